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
from povh3d.image.io import read_image
from povh3d.povray.process import JobResult, PovrayJob, run_jobs, shared_libraries
from povh3d.renderer.methods.quality import RenderSettings
from tests.support.arrays import square_array

HEAD = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { orthographic location <0, 0, -1> look_at 0 right x up y }
"""
PLANE = "plane {{ z, 0 pigment {{ {} }} finish {{ ambient 1 diffuse 0 }} }}\n"


def run(script: str, workdir: Path, **job: object) -> list[np.ndarray]:
    images: list[np.ndarray] = []

    def keep(result: JobResult) -> None:
        images.extend(read_image(path) for path in result.images)

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


@pytest.mark.povray
def test_reading_etc_passwd_fails_with_a_clear_error(workdir: Path) -> None:
    script = HEAD + '#fopen F "/etc/passwd" read\n' + PLANE.format("rgb 1")
    with pytest.raises(PovrayError) as caught:
        run(script, workdir)
    message = str(caught.value)
    assert "Cannot open user file /etc/passwd (read)" in message
    assert "read only its own files" in message  # the hint names the sandbox
    assert list(workdir.iterdir()) == []


@pytest.mark.povray
def test_including_a_file_outside_the_job_fails(workdir: Path, outside: Path) -> None:
    script = HEAD + f'#include "{outside}/secret.inc"\n' + PLANE.format("Secret")
    with pytest.raises(PovrayError, match="Cannot open include file .*secret.inc"):
        run(script, workdir)


@pytest.mark.povray
def test_negative_control_unconfined_povray_reads_outside(workdir: Path, outside: Path,
                                                          unconfined: None) -> None:
    # The job's povray.conf says "restricted"; POV-Ray 3.7.0.10 reads it anyway.
    script = HEAD + f'#include "{outside}/secret.inc"\n' + PLANE.format("Secret")
    image, = run(script, workdir)
    assert tuple(image[0, 0]) == (0, 255, 0)


@pytest.mark.povray
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


@pytest.mark.povray
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


@pytest.mark.povray
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


@pytest.mark.povray
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


# Where POVH3D_POVRAY may point, and the files that lie around it: a wrapper script in a
# user's bin folder, a wrapper in an /opt-like prefix (for /opt/povray/povray the old rule,
# dirname(dirname(binary)), allowed all of /), a copy of the program in a prefix of its own.
def _wrapper(path: Path) -> None:
    path.write_text('#!/bin/sh\nexec /usr/bin/povray "$@"\n')
    path.chmod(0o755)


def _copy(path: Path) -> None:
    path.write_bytes(Path("/usr/bin/povray").read_bytes())
    path.chmod(0o755)


PLACES = {"home-wrapper": ("home/bin/povray", _wrapper, ("home/secret.txt", "home/bin/secret.txt")),
          "opt-wrapper": ("opt/povray/povray", _wrapper, ("opt/secret.txt", "opt/povray/secret.txt")),
          "prefix-copy": ("prefix/bin/povray", _copy, ("prefix/secret.txt", "prefix/bin/secret.txt"))}


def _computed_read(path: Path) -> str:
    """A scene that reads `path` through a name it computes (no literal names the file)."""
    text = str(path)
    cut = len(text) // 2
    return (HEAD + f'#fopen F concat("{text[:cut]}", "{text[cut:]}") read\n#read (F, Word)\n#fclose F\n'
            '#if (strcmp(Word, "sesame") != 0) #error "read something else" #end\n' + PLANE.format("Green")
            ).replace("Green", "rgb <0, 1, 0>")


@pytest.mark.povray
@pytest.mark.parametrize("secret", [0, 1], ids=["in-prefix", "beside-binary"])
@pytest.mark.parametrize("place", sorted(PLACES))
@pytest.mark.parametrize("confined", [True, False], ids=["sandbox", "control-off"])
def test_the_binary_location_does_not_widen_the_sandbox(tmp_path: Path, workdir: Path, place: str,
                                                        secret: int, confined: bool,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    where, make, secrets = PLACES[place]
    binary = tmp_path / where
    binary.parent.mkdir(parents=True)
    make(binary)
    target = tmp_path / secrets[secret]
    target.write_text('"sesame"\n')
    monkeypatch.setenv("POVH3D_POVRAY", str(binary))
    if not confined:
        monkeypatch.setenv(sandbox.ENV_VAR, "off")
    if confined:
        with pytest.raises(PovrayError, match=r"Cannot open user file .*secret\.txt \(read\)"):
            run(_computed_read(target), workdir)
        assert not any(p.startswith(str(tmp_path)) and os.path.isdir(p)
                       for p in sandbox.system_read_paths(str(binary), shared_libraries))
    else:  # the wrapper or copy runs, and the scene does read the file when nothing stops it
        image, = run(_computed_read(target), workdir)
        assert tuple(image[0, 0]) == (0, 255, 0)


@pytest.mark.povray
@pytest.mark.parametrize("place", sorted(PLACES))
def test_a_moved_binary_still_reads_the_scene_and_its_own_includes(tmp_path: Path, workdir: Path,
                                                                   place: str,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    where, make, _ = PLACES[place]
    binary = tmp_path / where
    binary.parent.mkdir(parents=True)
    make(binary)
    monkeypatch.setenv("POVH3D_POVRAY", str(binary))
    scene = tmp_path / "scene"
    scene.mkdir()
    (scene / "word.txt").write_text('"sesame"\n')
    script = _computed_read(scene / "word.txt").replace(HEAD, HEAD + '#include "colors.inc"\n'
                                                        'text { ttf "timrom.ttf" "A" 1, 0 scale 0.01 '
                                                        'translate 5*z }\n')
    image, = run(script, workdir, include_dirs=(str(scene),))
    assert tuple(image[0, 0]) == (0, 255, 0)


def test_system_paths_never_hold_a_home_or_the_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home" / "bin").mkdir(parents=True)
    _wrapper(tmp_path / "home" / "bin" / "povray")
    paths = sandbox.system_read_paths(str(tmp_path / "home" / "bin" / "povray"))
    assert str(tmp_path / "home" / "bin" / "povray") in paths  # the program itself, a file
    assert not any(p in ("/", str(tmp_path), str(tmp_path / "home"), str(tmp_path / "home" / "bin"))
                   for p in paths)
    # A povray.ini whose Library_Path is / or the home is not followed.
    ini = tmp_path / "home" / "etc" / "povray" / "3.7" / "povray.ini"
    ini.parent.mkdir(parents=True)
    ini.write_text(f'Library_Path="/"\nLibrary_Path={tmp_path / "home"}\n+L/opt\n'
                   f'Library_Path="{tmp_path / "home" / "etc"}" ; fine\n')
    paths = sandbox.system_read_paths(str(tmp_path / "home" / "bin" / "povray"))
    assert "/" not in paths and str(tmp_path / "home") not in paths and "/opt" not in paths
    assert str(tmp_path / "home" / "etc") in paths  # negative control: the parser reads entries
    assert "/usr/share/povray-3.7/include" in sandbox.system_read_paths("/usr/bin/povray")


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


@pytest.mark.povray
def test_sidecar_records_the_sandbox(tmp_path: Path) -> None:
    from tests.support.render import render

    scene = tmp_path / "s.pov"
    scene.write_text("#version 3.7;\nplane { z, 1 pigment { rgb 1 } }\n")
    record = render(scene, square_array(2, 2, 2, 2), tmp_path / "o.png",
                    settings=RenderSettings(quality="draft"))
    assert record["sandbox"].startswith("landlock ABI")
