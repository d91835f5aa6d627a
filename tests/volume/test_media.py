"""The direct volume render against a NumPy ray-march of the same emission-absorption integral.

An asymmetric analytic volume (an off-centre Gaussian blob on a gradient, voxels
1 x 1.2 x 2 mm), turned by an orientation preset and ``rotate`` and scaled onto a
small square array, is rendered by POV-Ray through ``multi-ortho`` (point-sampled),
and 400 random pixels are compared in linear light with ``tests/support/raymarch.py``
along the conventions' rays.  POV-Ray's sampling is first order in the step
(docs/volume-rendering.md), so a finer step must come closer; a volume moved by
half a voxel or mirrored must fail.
"""

from pathlib import Path

import numpy as np
import pytest

from povh3d.renderer.content.volume_media import media_stage
from povh3d.volume.media import sampling_for, sub_intervals, uniform_scale
from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.errors import ConfigError, InputError
from povh3d.image.colour import to_linear
from povh3d.scene.features import strip_comments
from povh3d.scene.scene import load_scene
from povh3d.volume.grid import Volume
from povh3d.volume.orient import display_box, volume_to_display, world_to_display
from povh3d.volume.transfer import Transfer

from tests.support.arrays import square_array
from tests.support.raymarch import march, square_pixel_rays

ARRAY = square_array(lx=24, ly=16, nx=6, ny=6, s=0.1, f=1.5)
BACKGROUND = (0.2, 0.3, 0.1)  # not black: the transmittance shows too
SPACING = (1.0, 1.2, 2.0)
ORIGIN = (-10.0, 5.0, 30.0)
TRANSFER = Transfer("test", "absolute", np.array([0.0, 200, 600, 1400]),
                    np.array([[0, 0, 0], [0.2, 0.6, 1.0], [1.0, 0.5, 0.2], [1, 1, 1.0]]),
                    np.array([0.0, 0.05, 0.3, 0.6]))
LABELS = Transfer("tissues", "labels", np.array([1.0, 2, 5]),
                  np.array([[0.2, 0.6, 1.0], [1.0, 0.5, 0.2], [1, 1, 1.0]]), np.array([0.05, 0.3, 0.6]))


def blob() -> Volume:
    i, j, k = np.meshgrid(*[np.arange(n) for n in (24, 20, 12)], indexing="ij")
    r2 = ((i - 9) / 5.0) ** 2 + ((j - 11) / 4.0) ** 2 + ((k - 5) / 3.0) ** 2
    return Volume((1000 * np.exp(-r2 / 2) + 20 * i).astype(np.float32), SPACING, origin=ORIGIN)


def tissues() -> Volume:
    """Nested ellipsoids (labels 1, 2), a half core (5) and a corner of label 3, which the transfer omits."""
    i, j, k = np.meshgrid(*[np.arange(n) for n in (20, 16, 10)], indexing="ij")
    r2 = ((i - 9) / 6.0) ** 2 + ((j - 8) / 5.0) ** 2 + ((k - 4) / 3.5) ** 2
    lab = (r2 < 1).astype(int) + (r2 < 0.5) + 3 * ((r2 < 0.3) & (i > 9)) + 3 * (i + j < 6)
    return Volume(lab.astype(np.uint8), SPACING, origin=ORIGIN)


def placement(volume: Volume, orientation: str, rotate) -> np.ndarray:
    turn = volume_to_display(orientation, rotate)
    lo, hi = display_box(volume.corners(), turn)
    return world_to_display(turn, -(lo + hi) / 2, 0.8 * ARRAY.panel.size_mm[1] / max(hi - lo))


def render(tmp_path: Path, volume: Volume, w2d: np.ndarray, transfer, **options) -> np.ndarray:
    stage, _ = media_stage(volume, w2d, ARRAY, transfer=transfer, folder=tmp_path / "stage",
                           background=BACKGROUND, **options)
    result = run_method("multi-ortho", load_scene(stage), ARRAY,
                        RenderSettings(quality="draft", use_cache=False, bit_depth=16))
    return to_linear(result.h3d)


def compare(image: np.ndarray, volume: Volume, w2d: np.ndarray, transfer) -> float:
    """PSNR (dB, linear light) of 400 random pixels against the ray-march."""
    rng = np.random.default_rng(0)
    rows, cols = rng.integers(0, image.shape[0], 400), rng.integers(0, image.shape[1], 400)
    centres, directions = square_pixel_rays(ARRAY, cols, rows)
    expected = march(volume, w2d, transfer, centres - 100 * directions, directions,
                     background=BACKGROUND, step=0.005)
    assert np.ptp(expected) > 0.3, "test set-up: the volume must be visible"
    return float(10 * np.log10(1 / np.mean((image[rows, cols] - expected) ** 2)))


@pytest.fixture(scope="module")
def blob_renders(tmp_path_factory):
    volume, w2d = blob(), placement(blob(), "coronal", (20, 30, 0))
    folder = tmp_path_factory.mktemp("media")
    return volume, w2d, {(step, bits): render(folder / f"{step}-{bits}", volume, w2d, TRANSFER, step=step, bits=bits)
                         for step, bits in ((1.0, 16), (0.25, 16), (1.0, 8))}


@pytest.mark.povray
def test_media_matches_the_ray_march(blob_renders):
    volume, w2d, images = blob_renders
    coarse, fine = compare(images[1.0, 16], volume, w2d, TRANSFER), compare(images[0.25, 16], volume, w2d, TRANSFER)
    assert coarse >= 35.0, f"default step: {coarse:.1f} dB"
    assert fine >= 45.0, f"a quarter-voxel step: {fine:.1f} dB"
    assert fine > coarse + 6, "POV-Ray's media sampling must converge to the integral as the step shrinks"
    assert compare(images[1.0, 8], volume, w2d, TRANSFER) >= 35.0, "8-bit df3"


@pytest.mark.povray
@pytest.mark.parametrize("wrong", ["half-voxel", "mirrored"])
def test_a_misplaced_volume_fails_the_same_check(blob_renders, wrong):
    volume, w2d, images = blob_renders
    moved = (Volume(volume.values, SPACING, origin=(ORIGIN[0] + 0.5 * SPACING[0], *ORIGIN[1:]))
             if wrong == "half-voxel" else Volume(volume.values[::-1].copy(), SPACING, origin=ORIGIN))
    assert compare(images[0.25, 16], moved, w2d, TRANSFER) < 45.0


@pytest.mark.povray
def test_label_volume_nearest_voxel(tmp_path):
    volume = tissues()
    w2d = placement(volume, "axial", (10, -25, 5))
    image = render(tmp_path, volume, w2d, LABELS, step=0.25, bits=8)
    assert compare(image, volume, w2d, LABELS) >= 45.0


def test_sampling_counts():
    # POV-Ray holds at most 256 intervals: a long chord takes more samples per interval instead.
    volume = Volume(np.zeros((500, 470, 136), dtype=np.uint8), (1.0, 1.0, 1.5))
    intervals, samples = sampling_for(volume, 1.0)
    assert intervals <= 250
    assert intervals * sub_intervals(samples) >= np.linalg.norm([500, 470, 204])
    assert sampling_for(blob(), 1.0) == (21, 2)  # sqrt(24^2 + 24^2 + 24^2) = 41.6 sub-intervals


def test_record_and_files(tmp_path):
    volume = blob()
    stage, record = media_stage(volume, placement(volume, "sagittal", None), ARRAY, transfer="ct-soft", bits=8,
                                folder=tmp_path)
    text = stage.read_text()
    assert "camera" not in strip_comments(text) and "hollow" in text and "interpolate 1" in text
    df3 = Path(record["df3"]["path"])
    assert df3.parent == tmp_path and df3.stat().st_size == 6 + 26 * 22 * 14
    assert record["df3"]["window"] == [-600.0, 3000.0] and record["transfer"]["name"] == "ct-soft"
    assert f'"{df3.name}"' in text
    # The same volume again writes nothing new.
    assert media_stage(volume, placement(volume, "sagittal", None), ARRAY, transfer="ct-soft", bits=8,
                       folder=tmp_path)[0] == stage
    assert len(list(tmp_path.iterdir())) == 2


def test_bad_input_writes_nothing(tmp_path):
    volume, folder = blob(), tmp_path / "out"
    w2d = placement(volume, "coronal", None)
    with pytest.raises(InputError, match="neither a preset"):
        media_stage(volume, w2d, ARRAY, transfer=str(tmp_path / "missing.tf"), folder=folder)
    with pytest.raises(ConfigError, match="df3_bits must be 8 or 16"):
        media_stage(volume, w2d, ARRAY, bits=12, folder=folder)
    squash = w2d @ np.diag([1.0, 2.0, 1.0, 1.0])
    with pytest.raises(ConfigError, match="uniform scale"):
        media_stage(volume, squash, ARRAY, folder=folder)
    with pytest.raises(ConfigError, match="media step"):
        media_stage(volume, w2d, ARRAY, step=0, folder=folder)
    big = Volume(np.full((3, 3, 3), 300, dtype=np.uint16), SPACING)
    with pytest.raises(ConfigError, match="df3_bits 16"):
        media_stage(big, w2d, ARRAY, transfer=LABELS, bits=8, folder=folder)
    assert not folder.exists() or not any(folder.iterdir())


def test_uniform_scale_of_a_mirror():
    assert uniform_scale(world_to_display(volume_to_display("axial"), (1, 2, 3), 0.25)) == pytest.approx(0.25)


def test_auto_transfer_draws_a_segmentation_as_labels(tmp_path):
    volume = tissues()
    stage, record = media_stage(volume, placement(volume, "coronal", None), ARRAY, transfer="auto", bits=8,
                                folder=tmp_path)
    assert record["transfer"]["name"] == "labels" and "interpolate 0" in stage.read_text()
    assert record["transfer"]["points"][0][0] == 1.0  # label 0, the background, is not drawn


def test_relative_transfer_window(tmp_path):
    volume = blob()
    _, record = media_stage(volume, placement(volume, "coronal", None), ARRAY, transfer="mri", folder=tmp_path)
    lo, hi = record["df3"]["window"]
    assert lo == pytest.approx(float(volume.values.min()))
    assert hi == pytest.approx(float(np.percentile(volume.values, 99.5)), rel=1e-6)
    # 0.8 of the panel height (9.6 mm) spans the box's largest side (24 mm): 0.32 mm per 1 mm voxel.
    assert record["voxels_per_lens"] == pytest.approx(0.6 / (0.8 * 9.6 / 24), rel=1e-3)
