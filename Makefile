# povh3d: `make render` renders the bundled sample, `make test` runs the tests.
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

.PHONY: help render test soak bench povray opengl venv clean

help: ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-8s %s\n", $$1, $$2}'

povray: ## install POV-Ray 3.7 with apt when it is missing
	@command -v povray >/dev/null || { echo "installing POV-Ray (apt-get install povray)"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq povray >/dev/null; }
	@povray --version 2>&1 | grep -m1 'POV-Ray'

opengl: ## install Mesa's off-screen OpenGL (EGL) with apt when it is missing: 'povh3d layout' draws with it
	@$$(command -v ldconfig || echo /sbin/ldconfig) -p | grep -qE 'libEGL_mesa\.so\.0|libOSMesa\.so' || { echo "installing Mesa EGL (apt-get install libegl1 libegl-mesa0)"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq libegl1 libegl-mesa0 >/dev/null; }

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

test: povray opengl venv ## run the test suite (POV-Ray tests included)
	$(BIN)/python -m pytest -q

soak: povray venv ## 200 random kills over renders, view writes and cache writes, each output checked (minutes)
	$(BIN)/python -m pytest -q -s -m soak tests/app/test_soak.py

bench: povray venv ## measure whole commands against whole-process 2D POV-Ray renders, then the breakdowns and every other benchmark (docs/benchmarks.md)
	$(BIN)/python benchmarks/bench_command.py
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
	$(BIN)/python benchmarks/bench_frame.py
	$(BIN)/python benchmarks/bench_moire.py
	$(BIN)/python benchmarks/bench_volume_media.py
	$(BIN)/python benchmarks/bench_volume.py

clean: ## remove outputs (not the cache)
	rm -rf out
