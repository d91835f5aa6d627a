"""Boxes from id masks and the merge of per-frame boxes into annotations."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.hyper.boxes import Link, mask_boxes, merge_frames, stretches


def test_mask_boxes_of_a_disc_and_a_rectangle() -> None:
    rows, cols = np.mgrid[0:60, 0:80]
    mask = np.zeros((60, 80), np.uint16)
    mask[10:21, 50:71] = 2                                    # rows 10..20, columns 50..70
    mask[(rows - 30) ** 2 + (cols - 20) ** 2 <= 100] = 7      # disc of radius 10 at row 30, column 20
    assert mask_boxes(mask) == {2: (50, 10, 70, 20), 7: (10, 20, 30, 40)}
    # negative control: the box of the disc is not its transposed box
    assert mask_boxes(mask.T)[7] == (20, 10, 40, 30) != mask_boxes(mask)[7]


def test_mask_boxes_refuses_a_colour_image() -> None:
    with pytest.raises(ValueError, match="integer"):
        mask_boxes(np.zeros((4, 4), np.float32))


def test_stretches_follow_the_render_frames() -> None:
    assert stretches([0, 1, 2, 3, 4, 5], [0, 1, 4, 5, 2]) == [(0, 2), (4, 5)]
    assert stretches([10, 12, 14], [10, 14]) == [(10, 10), (14, 14)]   # 12 is a render frame, missing
    assert stretches([10, 12, 14], [10, 12]) == [(10, 12)]


def test_an_object_that_leaves_and_comes_back_is_a_new_annotation() -> None:
    frames = [0, 1, 2, 3, 4]
    ball, box = 1, 2
    per_frame = {0: {ball: {"view": (0, 0, 1, 1)}, box: {"view": (5, 5, 6, 6), "h3d": (40, 40, 55, 55)}},
                 1: {ball: {"view": (1, 0, 2, 1)}, box: {"view": (5, 5, 6, 6)}},
                 2: {box: {"view": (5, 5, 6, 6)}},
                 3: {ball: {"view": (3, 0, 4, 1)}},
                 4: {ball: {"view": (4, 0, 5, 1)}}}
    scene = merge_frames(frames, per_frame, {ball: "ball", box: "box"}, {"ball": Link("https://b", "a ball")})
    got = [(a.ident, a.object_name, a.start, a.end, a.url, len(a.boxes)) for a in scene.annotations]
    assert got == [(1, "ball", 0, 1, "https://b", 2), (2, "box", 0, 2, "", 4), (3, "ball", 3, 4, "https://b", 2)]
    assert (scene.start, scene.end, scene.duration) == (0, 4, 5)
    assert [b.frame for b in scene.annotations[2].boxes] == [3, 4]
    assert [(b.frame, b.space) for b in scene.annotations[1].boxes][:2] == [(0, "view"), (0, "h3d")]
