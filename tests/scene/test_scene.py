"""What the walk over a scene finds about the files it names with non-ASCII characters:
the names POV-Ray 3.7 will ask for (it reads strings as ASCII), the files behind them,
and their place in the digest."""

from __future__ import annotations

import pytest

from povh3d.errors import InputError
from povh3d.scene.scene import load_scene, pov_ascii_names


def _latin1(text: str) -> str:
    """How the walk sees a UTF-8 string of a scene: one character per byte."""
    return text.encode("utf-8").decode("latin-1")


def test_pov_ascii_names_replace_bytes_or_characters():
    # "è" is 2 bytes in UTF-8, "€" 3: POV-Ray's default charset makes a space of each byte,
    # charset utf8 one of each character.
    assert pov_ascii_names(_latin1("pièce.inc")) == ["pi  ce.inc", "pi ce.inc"]
    assert pov_ascii_names(_latin1("modèles/€.png")) == ["mod  les/   .png", "mod les/ .png"]
    assert pov_ascii_names("caf\xe9.inc") == ["caf .inc"]  # a Latin-1 file name: not UTF-8, one byte
    assert pov_ascii_names(_latin1("/home/é/x.inc")) == [] and pov_ascii_names(_latin1("../é.inc")) == []


def test_files_named_with_non_ascii_characters_are_found_and_linked(tmp_path):
    (tmp_path / "modèles").mkdir()
    part = tmp_path / "modèles" / "pièce.inc"
    part.write_text("sphere { 0, 1 }\n")
    texture = tmp_path / "tex é.png"
    texture.write_bytes(b"not really a png")
    scene = tmp_path / "s.pov"
    scene.write_text('#include "modèles/pièce.inc"\nplane { z, 1 pigment { image_map { png "tex é.png" } } }\n')
    found = load_scene(scene)
    assert set(found.files) == {scene, part, texture}
    assert dict(found.ascii_names) == {"mod  les/pi  ce.inc": part, "mod les/pi ce.inc": part,
                                       "tex   .png": texture, "tex  .png": texture}
    before = found.digest
    part.write_text("sphere { 0, 2 }\n")  # an edit of the non-ASCII include changes the key
    assert load_scene(scene).digest != before


def test_two_files_behind_one_ascii_name_are_refused(tmp_path):
    for name in ("pièce.inc", "piéce.inc"):  # è and é: two bytes each, both "pi  ce.inc" to POV-Ray
        (tmp_path / name).write_text("// part\n")
    scene = tmp_path / "s.pov"
    scene.write_text('#include "pièce.inc"\n#include "piéce.inc"\n')
    with pytest.raises(InputError, match="rename one of them with ASCII characters only"):
        load_scene(scene)


def test_ascii_scenes_have_no_links(tmp_path):
    (tmp_path / "part.inc").write_text("sphere { 0, 1 }\n")
    scene = tmp_path / "s.pov"
    scene.write_text('#include "part.inc"\n#declare T = "Déjà vu";  // a non-ASCII string, no file\n')
    assert load_scene(scene).ascii_names == ()
