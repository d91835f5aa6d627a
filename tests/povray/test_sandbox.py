"""Tests of povh3d.sandbox: what a scene may read and write, with the real POV-Ray.

Each denial has a negative control with ``POVH3D_SANDBOX=off``: there the same
scene reads or writes the file although the job's ``povray.conf`` says
``restricted``, which shows both that the test can fail and that POV-Ray
3.7.0.10 does not enforce its own I/O security (the reason for the sandbox).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from povh3d.povray import sandbox
from povh3d.errors import ConfigError, PovrayError
from povh3d.image.io import read_png
from povh3d.povray.process import JobResult, PovrayJob, run_jobs
from povh3d.engine.quality import RenderSettings
from tests.support.arrays import square_array

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { orthographic location <0, 0, -1> look_at 0 right x up y }
"""
PLANE = "plane {{ z, 0 pigment {{ {} }} finish {{ ambient 1 diffuse 0 }} }}\n"


def run(script: str, workdir: Path, **job: object) -> list[np.ndarray]:
    images: list[np.ndarray] = []

    def keep(result: JobResult) -> None:
        images.extend(read_png(path) for path in result.images)

    run_jobs([PovrayJob("probe", script, 2, 2, **job)], processes=1, on_result=keep,
             workdir=workdir)
    return images


@pytest.fixture
def outside(tmp_path: Path) -> Path:
    """A folder no job may touch, holding a secret include file."""
    folder = tmp_path / "outside"
    folder.mkdir()
    (folder / "secret.inc").write_text("#declare Secret = rgb <0, 1, 0>;\n")
    return folder


@pytest.fixture
def unconfined(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(sandbox.ENV_VAR, "off")


def test_this_kernel_has_landlock() -> None:
    # The tests below rely on it; CI's machines have it (ABI 7 on Linux 6.18).
    assert sandbox.landlock_abi() >= 1, "the kernel has no Landlock: POV-Ray runs unconfined"
    assert sandbox.describe().startswith("landlock ABI")


def test_reading_etc_passwd_fails_with_a_clear_error(workdir: Path) -> None:
    script = HEAD + '#fopen F "/etc/passwd" read\n' + PLANE.format("rgb 1")
    with pytest.raises(PovrayError) as caught:
        run(script, workdir)
    message = str(caught.value)
    assert "Cannot open user file /etc/passwd (read)" in message
    assert "read only its own files" in message  # the hint names the sandbox
    assert list(workdir.iterdir()) == []


def test_including_a_file_outside_the_job_fails(workdir: Path, outside: Path) -> None:
    script = HEAD + f'#include "{outside}/secret.inc"\n' + PLANE.format("Secret")
    with pytest.raises(PovrayError, match="Cannot open include file .*secret.inc"):
        run(script, workdir)


def test_negative_control_unconfined_povray_reads_outside(workdir: Path, outside: Path,
                                                          unconfined: None) -> None:
    # The job's povray.conf says "restricted"; POV-Ray 3.7.0.10 reads it anyway.
    script = HEAD + f'#include "{outside}/secret.inc"\n' + PLANE.format("Secret")
    image, = run(script, workdir)
    assert tuple(image[0, 0]) == (0, 255, 0)


@pytest.mark.parametrize("confined", [True, False], ids=["sandbox", "control-off"])
def test_writing_outside_the_job_folder(workdir: Path, outside: Path, confined: bool,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    if not confined:
        monkeypatch.setenv(sandbox.ENV_VAR, "off")
    target = outside / "written.txt"
    script = HEAD + f'#fopen F "{target}" write\n#write (F, "x")\n#fclose F\n' + PLANE.format("rgb 1")
    if confined:
        with pytest.raises(PovrayError, match=r"Cannot open user file .*written.txt\s*\(write\)"):
            run(script, workdir)
        assert not target.exists()
    else:
        run(script, workdir)
        assert target.read_text() == "x"


def test_allowed_job_folder_writes_system_includes_and_fonts(workdir: Path) -> None:
    # Writing in its own folder, POV-Ray's include files and fonts: all allowed.
    script = HEAD + """#include "colors.inc"
#fopen F "scratch.txt" write
#write (F, "\\"kept\\"")
#fclose F
#fopen F "scratch.txt" read
#read (F, Word)
#fclose F
#if (strcmp(Word, "kept") != 0) #error "read back something else" #end
text { ttf "timrom.ttf" "A" 1, 0 pigment { Red } scale 0.01 translate 5*z }
""" + PLANE.format("Blue")
    image, = run(script, workdir)
    assert tuple(image[0, 0]) == (0, 0, 255)


def test_read_files_allow_listed_and_not(workdir: Path, tmp_path: Path) -> None:
    scene = tmp_path / "scene"
    scene.mkdir()
    (scene / "listed.inc").write_text("#declare C = rgb <1, 0, 0>;\n")
    (scene / "other.inc").write_text("#declare C = rgb <0, 0, 1>;\n")
    listed = (str(scene / "listed.inc"),)
    image, = run(HEAD + '#include "listed.inc"\n' + PLANE.format("C"), workdir,
                 include_dirs=(str(scene),), read_files=listed)
    assert tuple(image[0, 0]) == (255, 0, 0)
    with pytest.raises(PovrayError, match="other.inc"):
        run(HEAD + '#include "other.inc"\n' + PLANE.format("C"), workdir,
            include_dirs=(str(scene),), read_files=listed)
    # Without an allow-list the include folders are readable as a whole.
    image, = run(HEAD + '#include "other.inc"\n' + PLANE.format("C"), workdir,
                 include_dirs=(str(scene),))
    assert tuple(image[0, 0]) == (0, 0, 255)


def test_render_of_a_scene_naming_etc_passwd(tmp_path: Path) -> None:
    # scene.py lists /etc/passwd among the scene's files (it exists and is
    # named); the sandbox still allows only the scene's own folders.
    from tests.support.render import render

    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "colour.inc").write_text("#declare C = rgb <0.2, 0.4, 0.6>;\n")
    path = folder / "peek.pov"
    path.write_text('#version 3.7;\n#include "colour.inc"\n#fopen F "/etc/passwd" read\n'
                    'plane { z, 1 pigment { C } finish { emission 1 diffuse 0 } }\n')
    out = tmp_path / "out.png"
    with pytest.raises(PovrayError, match="/etc/passwd"):
        render(path, square_array(2, 2, 2, 2), out, settings=RenderSettings(quality="draft"))
    assert not out.exists() and not out.with_suffix(".json").exists()
    path.write_text(path.read_text().replace('#fopen F "/etc/passwd" read\n', ""))
    render(path, square_array(2, 2, 2, 2), out, settings=RenderSettings(quality="draft"))
    assert out.exists()  # its own include is allowed


def test_files_within() -> None:
    files = ["/etc/passwd", "/a/b/c.inc", "/a/bc/d.inc", "/x/y.png"]
    assert sandbox.files_within(files, ["/a/b", "/x"]) == ("/a/b/c.inc", "/x/y.png")


def test_policy_and_mode_are_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ConfigError, match="absolute"):
        sandbox.Policy(("relative/dir",), ())
    monkeypatch.setenv(sandbox.ENV_VAR, "maybe")
    with pytest.raises(ConfigError, match="POVH3D_SANDBOX"):
        sandbox.sandbox_mode()
    monkeypatch.setenv(sandbox.ENV_VAR, "off")
    assert sandbox.build_ruleset(sandbox.Policy(("/usr",), ())) is None


def test_system_paths_leave_out_etc() -> None:
    paths = sandbox.system_read_paths("/usr/bin/povray")
    assert "/usr" in paths and "/etc/povray" in paths
    assert "/etc" not in paths and not any(p.startswith(("/home", "/root", "/tmp")) for p in paths)
    assert all(os.path.isabs(p) for p in paths)


def test_sidecar_records_the_sandbox(tmp_path: Path) -> None:
    from tests.support.render import render

    scene = tmp_path / "s.pov"
    scene.write_text("#version 3.7;\nplane { z, 1 pigment { rgb 1 } }\n")
    record = render(scene, square_array(2, 2, 2, 2), tmp_path / "o.png",
                    settings=RenderSettings(quality="draft"))
    assert record["sandbox"].startswith("landlock ABI")
