# povh3d: `make render` renders the bundled sample, `make test` runs the tests,
# `make test-fast` the ones that start no POV-Ray (the edit loop).
# Both set up what they need: POV-Ray (apt) and a .venv with povh3d installed.
SHELL := bash
.SHELLFLAGS := -eu -o pipefail -c
.DELETE_ON_ERROR:
.DEFAULT_GOAL := help
MAKEFLAGS += --no-builtin-rules

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
PRESET ?= demo
QUALITY ?= normal
# The fast subset is NumPy work: one test process a core.
CORES := $(shell nproc)
# make test: three test processes a core, at most 16: a POV-Ray run idles about 0.7 s at start-up
# and 0.3 s a frame (POV-Ray 3.7's front end polls), so one process a core leaves the cores idle.
WORKERS ?= $(shell n=$$(( 3 * $$(nproc) )); [ $$n -gt 16 ] && n=16; echo $$n)

.PHONY: help render lint test test-fast soak fuzz bench gallery povray povray-examples opengl browser venv clean

help: ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-10s %s\n", $$1, $$2}'

povray: ## install POV-Ray 3.7 with apt when it is missing
	@command -v povray >/dev/null || { echo "installing POV-Ray (apt-get install povray)"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq povray >/dev/null; }
	@povray --version 2>&1 | grep -m1 'POV-Ray'

povray-examples: povray ## install POV-Ray's sample scenes (Debian's povray-examples) with apt when they are missing
	@test -d /usr/share/doc/povray/examples || { echo "installing POV-Ray's sample scenes (apt-get install povray-examples)"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq povray-examples >/dev/null; }

opengl: ## install Mesa's off-screen OpenGL (EGL) with apt when it is missing: 'povh3d layout' draws with it
	@$$(command -v ldconfig || echo /sbin/ldconfig) -p | grep -qE 'libEGL_mesa\.so\.0|libOSMesa\.so' || { echo "installing Mesa EGL (apt-get install libegl1 libegl-mesa0)"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq libegl1 libegl-mesa0 >/dev/null; }

browser: ## install Chromium and its driver with apt when missing: the viewer page's tests drive it headless
	@command -v chromium >/dev/null && command -v chromedriver >/dev/null || { echo "installing Chromium (apt-get install chromium chromium-driver)"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq chromium chromium-driver >/dev/null; }

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[test]'
	touch $@

venv: $(BIN)/.installed ## create .venv with povh3d installed

render: povray venv ## render the bundled sample to out/sample-h3d.png (PRESET=demo)
	mkdir -p out
	$(BIN)/povh3d render sample_models/sample.pov --preset $(PRESET) --quality $(QUALITY) \
	  -o out/sample-h3d.png --views-dir out/views

# Ruff (syntax, imports, names: [tool.ruff]) and mypy ([tool.mypy]: the package, default strictness)
# on the source; make test runs it first, so CI fails on either.
lint: venv ## ruff and the type checker (mypy), both configured in pyproject.toml
	$(BIN)/ruff check povh3d tests benchmarks
	$(BIN)/mypy

# WORKERS pytest processes (pytest-xdist) taking tests one by one, but a module with a module-wide
# fixture whole (tests/conftest.py groups it, so its fixture renders once); pytest's exit status
# is make's (5: no test ran).
test: lint povray povray-examples opengl browser venv ## ruff and mypy (make lint), then the whole test suite, POV-Ray renders included (WORKERS processes, 3 a core)
	$(BIN)/python -m pytest -q -n $(WORKERS) --dist loadgroup

test-fast: browser venv ## the tests that start no POV-Ray and no slow sweep, in under a minute (pytest --fast)
	$(BIN)/python -m pytest -q -n $(CORES) --dist loadgroup --fast

soak: povray venv ## 200 random kills over renders, view writes and cache writes, each output checked (minutes)
	$(BIN)/python -m pytest -q -s -m soak tests/renderer/test_soak.py

# make test runs 100 + 100 + 6 of these cases; the counts below make the 2,000 (docs/reliability.md).
fuzz: povray venv ## 2,000 hostile cases: 1,200 command lines, 700 damaged sidecars, views folders and calibrations, 100 command lines as processes (minutes)
	POVH3D_FUZZ_LINES=1200 POVH3D_FUZZ_DAMAGED=700 POVH3D_FUZZ_PROCESSES=100 \
	  $(BIN)/python -m pytest -q -s tests/cli/test_fuzz.py

bench: povray venv ## measure whole commands against whole-process 2D POV-Ray renders, then the breakdowns and every other benchmark (docs/benchmarks.md)
	$(BIN)/python benchmarks/bench_command.py
	$(BIN)/python benchmarks/bench_scenes.py
	$(BIN)/python benchmarks/bench_scenes.py --gallery
	$(BIN)/python benchmarks/bench_startup.py
	$(BIN)/python benchmarks/bench_speed.py
	$(BIN)/python benchmarks/bench_render.py
	$(BIN)/python benchmarks/bench_quality.py
	$(BIN)/python benchmarks/bench_mapping.py
	$(BIN)/python benchmarks/bench_dask.py 2> >(grep -v -E 'distributed|^ |Traceback|CommClosed' >&2)
	$(BIN)/python benchmarks/bench_single_stage.py
	$(BIN)/python benchmarks/bench_skip.py
	$(BIN)/python benchmarks/bench_mesh.py
	$(BIN)/python benchmarks/bench_large.py
	$(BIN)/python benchmarks/bench_calibrate.py
	$(BIN)/python benchmarks/bench_subpixel.py
	$(BIN)/python benchmarks/bench_placement.py
	$(BIN)/python benchmarks/bench_moire.py
	$(BIN)/python benchmarks/bench_volume_media.py
	$(BIN)/python benchmarks/bench_volume.py
	$(BIN)/python benchmarks/bench_objects.py
	$(BIN)/python benchmarks/bench_startup_signals.py

gallery: povray-examples venv ## render every POV-Ray sample scene with a camera at low priority, outcomes into docs/benchmarks.md (GALLERY_ARGS='--resume', '--scenes advanced/* --limit 10')
	nice -n 19 $(BIN)/python benchmarks/gallery.py $(GALLERY_ARGS)

clean: ## remove outputs (not the cache)
	rm -rf out
