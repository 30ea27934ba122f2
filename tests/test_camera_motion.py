"""How the camera moved (eigmotion.segmentation.camera_motion): a pan and a zoom of a
real scene image measured to the pixel, a still camera left alone, and the floor track
read in the first frame's pixels so that a camera that follows a standing person does
not make them travel."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.still_images import read_image_rgb
from eigmotion.retrieval.motion_cues import floor_cues
from eigmotion.segmentation import camera_motion as camera_motion_module
from eigmotion.segmentation.camera_motion import STILL_PX, camera_motion, stabilised

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "database" / "samples"
FPS = 15.0


def _filmed(
    shifts: np.ndarray, zooms: np.ndarray, person_x: np.ndarray, noise: float = 2.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A person (a dark box 64 px tall) standing at ``person_x`` (scene pixels) before the
    kick sample's empty scene, filmed by a 160 × 120 camera whose view is shifted by
    ``shifts`` (scene pixels, x) and zoomed by ``zooms`` about the frame's centre, with
    sensor noise.  Returns (frames (F, 120, 160, 3) uint8, person masks (F, 120, 160)
    bool, the true similarity from each frame's pixels to the first frame's (F, 2, 3))."""
    scene = cv2.resize(read_image_rgb(SAMPLES / "kick_background.png"), (160, 120))
    rng = np.random.default_rng(0)
    frames, masks, truth = [], [], []
    for dx, zoom, x in zip(shifts, zooms, person_x, strict=True):
        world = scene.copy()
        person = np.zeros(scene.shape[:2], np.uint8)
        person[40:104, int(x) - 8 : int(x) + 8] = 1
        world[person > 0] = (40, 30, 90)
        # camera: scene pixel p -> frame pixel zoom * (p - centre - [dx, 0]) + centre
        centre = np.array([80.0, 60.0])
        to_frame = np.c_[zoom * np.eye(2), centre - zoom * (centre + [dx, 0.0])]
        frame = cv2.warpAffine(world, to_frame, (160, 120), borderMode=cv2.BORDER_REFLECT)
        frame = np.clip(frame + rng.normal(0, noise, frame.shape), 0, 255).astype(np.uint8)
        frames.append(frame)
        masks.append(cv2.warpAffine(person, to_frame, (160, 120), flags=cv2.INTER_NEAREST) > 0)
        truth.append(to_frame)
    first = np.vstack([truth[0], [0, 0, 1]])
    to_first = [(first @ np.vstack([cv2.invertAffineTransform(t), [0, 0, 1]]))[:2] for t in truth]
    return np.stack(frames), np.stack(masks), np.stack(to_first)


def _corner_error_px(measured: np.ndarray, truth: np.ndarray) -> float:
    corners = np.array([[0.0, 0.0, 1.0], [160, 0, 1], [0, 120, 1], [160, 120, 1]])
    return float(np.abs(np.einsum("fij,cj->fci", measured - truth, corners)).max())


def test_a_pan_and_a_zoom_are_measured_on_the_scene():
    """The view sweeps 30 px and back while zooming in by 15 %: every frame's motion to
    the first is measured within half a pixel at the frame's corners."""
    n = 30
    t = np.arange(n) / (n - 1)
    frames, masks, truth = _filmed(30 * np.sin(np.pi * t), 1 + 0.15 * t, np.full(n, 80))
    measured = camera_motion(frames, masks)
    assert measured is not None and measured.shape == (n, 2, 3)
    np.testing.assert_allclose(measured[0], np.eye(2, 3))
    assert _corner_error_px(measured, truth) < 0.5


def test_a_still_camera_and_a_moving_person_read_as_still():
    n = 30
    walking = np.linspace(40, 120, n)  # the person crosses the frame: not the camera
    frames, masks, _ = _filmed(np.zeros(n), np.ones(n), walking)
    assert camera_motion(frames, masks) is None
    # the same frames with the camera turned by twice the still limit at the end:
    # measured, within a pixel
    frames, masks, truth = _filmed(np.linspace(0, 2 * STILL_PX, n), np.ones(n), walking)
    measured = camera_motion(frames, masks)
    assert measured is not None and _corner_error_px(measured, truth) < 1.0


def test_the_quick_look_at_every_fifth_frame_agrees_with_following_every_frame(monkeypatch):
    """A still camera is told by the frames it compares (every fifth and the last, with
    the first) as following every frame tells it; a pan, a frame whose scene cannot be
    measured (the lens covered) or a pan that starts after the last fifth frame sends it
    on to follow every frame."""
    n = 31
    walking = np.linspace(40, 120, n)
    still, still_masks, _ = _filmed(np.zeros(n), np.ones(n), walking)
    covered = still.copy()
    covered[10] = 0
    late_pan = np.r_[np.zeros(n - 3), [2.0, 4.0, 6.0]]
    panned, pan_masks, truth = _filmed(late_pan, np.ones(n), walking)

    def quick_look(frames, masks):
        looked = []
        original = camera_motion_module._still_at_checks

        def spy(*args):
            looked.append(original(*args))
            return looked[-1]

        monkeypatch.setattr(camera_motion_module, "_still_at_checks", spy)
        out = camera_motion(frames, masks)
        monkeypatch.setattr(camera_motion_module, "_still_at_checks", lambda *args: False)
        assert _same(out, camera_motion(frames, masks))  # as following every frame
        monkeypatch.setattr(camera_motion_module, "_still_at_checks", original)
        return looked[0], out

    assert quick_look(still, still_masks) == (True, None)
    assert quick_look(covered, still_masks) == (False, None)
    said_still, measured = quick_look(panned, pan_masks)
    assert not said_still and _corner_error_px(measured, truth) < 1.0


def _same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    return (a is None and b is None) or (a is not None and b is not None and np.array_equal(a, b))


def test_each_shot_is_measured_from_its_own_first_frame():
    n = 20
    frames, masks, _ = _filmed(np.linspace(0, 20, n), np.ones(n), np.full(n, 80))
    cut = np.concatenate([frames, frames[::-1]]), np.concatenate([masks, masks[::-1]])
    measured = camera_motion(*cut, shot_starts=np.array([0, n]))
    np.testing.assert_allclose(measured[n], np.eye(2, 3))
    assert measured[-1, 0, 2] == pytest.approx(-measured[n - 1, 0, 2], abs=0.5)


def test_bad_input_is_named():
    frames, masks, _ = _filmed(np.zeros(3), np.ones(3), np.full(3, 80))
    with pytest.raises(InvalidParameterError, match="masks must have the frames' shape"):
        camera_motion(frames, masks[:, :60])


def test_a_camera_following_a_standing_person_does_not_make_them_travel():
    """A person standing still while the camera pans 40 px and zooms in by 20 %: read as
    they are, the figure crosses the frame and grows (it travels, and its way bends);
    read in the first frame's pixels, it stands still."""
    n = 45
    t = np.arange(n) / (n - 1)
    frames, masks, truth = _filmed(40 * t**2, 1 + 0.2 * t, np.full(n, 80))
    measured = camera_motion(frames, masks)
    moving, _ = floor_cues(masks, FPS)
    still, turned = floor_cues(masks, FPS, measured)
    assert moving > 0.2 and still < 0.03 and turned is None
    assert floor_cues(masks, FPS, truth)[0] < 0.03


def test_the_silhouettes_stabilised_stand_still_where_the_person_does():
    """A person standing still, the camera panning 40 px and zooming in by 20 %: as
    filmed the silhouette moves and grows; carried by the measured motion onto a canvas
    that holds every frame's picture, it stays where the first frame had it."""
    n = 30
    t = np.arange(n) / (n - 1)
    frames, masks, _ = _filmed(40 * t, 1 + 0.2 * t, np.full(n, 80))
    still = stabilised(masks, camera_motion(frames, masks)) > 127
    assert still.shape[0] == n and still.shape[1] >= 120 and still.shape[2] >= 160 + 20

    def iou(a, b):
        return (a & b).sum() / (a | b).sum()

    assert iou(masks[0], masks[-1]) < 0.3
    assert min(iou(still[0], s) for s in still) > 0.85
    assert abs(int(still[-1].sum()) - int(still[0].sum())) < 0.1 * still[0].sum()
