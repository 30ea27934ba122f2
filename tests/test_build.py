"""The build's labels: sliding windows outside a motion's action get its filler label,
or are left out when it has none; the whole motion keeps its label."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from eigmotion.imaging.cameras import virtual_rig
from eigmotion.mocap.library import load_entry, read_manifest
from eigmotion.retrieval.library_views import (
    BuildConfig,
    render_views,
    window_bounds,
    window_labels,
)

CONFIG = BuildConfig(garments=((),), body_shapes=((None, 1.0),))


@pytest.fixture(scope="module")
def turn():
    """The walking turn: two steps, turn round (1.03-2.43 s), two steps back, stop."""
    item = load_entry(next(e for e in read_manifest() if e.name == "turn_walking_180"))
    assert (item.action, item.filler) == ((1.03, 2.43), "walk")
    return item


def test_a_window_shows_the_action_when_the_action_fills_half_of_it_or_of_the_window(turn):
    windows = [
        (0.0, turn.motion.duration_s),  # the whole motion
        (0.0, 1.5),  # 0.47 s of the turn
        (0.5, 2.0),  # 0.97 s
        (1.66, 3.16),  # 0.77 s
        (1.75, 3.25),  # 0.68 s: less than half of the 1.4 s turn
        (2.27, 3.77),  # 0.16 s
    ]
    assert window_labels(turn, windows) == ["turn", "walk", "turn", "turn", "walk", "walk"]
    standing = replace(turn, filler=None)
    assert window_labels(standing, windows) == ["turn", None, "turn", "turn", None, None]
    assert window_labels(replace(turn, action=None, filler=None), windows) == ["turn"] * 6


def test_an_action_shorter_than_a_window_needs_half_of_itself(turn):
    short = replace(turn, action=(1.0, 1.4))  # 0.4 s
    windows = [(0.0, 1.5), (1.2, 2.7), (1.21, 2.71), (-0.3, 1.2)]
    assert window_labels(short, windows) == ["turn", "turn", "walk", "turn"]


def test_every_action_keeps_a_window_of_its_own(turn):
    """With the build's windows (a step of a third of a window), any action span of a
    motion long enough for sliding windows gives at least one action window."""
    rng = np.random.default_rng(0)
    fps = CONFIG.render_fps
    for _ in range(500):
        n_frames = int(rng.integers(57, 200))
        duration = n_frames / fps
        start = rng.uniform(0.0, duration - 0.05)
        stop = rng.uniform(start + 0.04, duration)
        frames = window_bounds(n_frames, fps, CONFIG.window_s, CONFIG.window_step_s)
        labels = window_labels(replace(turn, action=(start, stop)), frames[1:] / fps)
        assert "turn" in labels, (n_frames, start, stop)


@pytest.fixture(scope="module")
def views(turn):
    """A real build's imaging of the walking turn, with and without its filler, on two
    views."""
    rig = virtual_rig([0.0, 90.0], [0.0], 64, 64)
    library = [turn, replace(turn, name="turn_standing", filler=None)]
    return list(render_views(library, rig, CONFIG, workers=1, progress=False))


def test_the_build_labels_windows_outside_the_action_with_the_filler(turn, views):
    with_filler = [v for v in views if v.motion_index == 0]
    assert [v.view_index for v in with_filler] == [0, 1]
    n_frames = turn.motion.n_frames
    for view in with_filler:
        assert len(view.labels) == len(view.windows) == len(view.vectors) == 7
        assert tuple(view.windows[0]) == (0, n_frames) and view.labels[0] == "turn"
        assert view.labels[1:] == ("walk", "turn", "turn", "turn", "walk", "walk")
        assert list(view.labels) == window_labels(turn, view.windows / turn.motion.fps)
        np.testing.assert_allclose(np.linalg.norm(view.vectors, axis=1), 1.0, atol=1e-5)


def test_the_build_leaves_out_windows_outside_an_action_without_filler(views):
    by_motion = {(v.motion_index, v.view_index): v for v in views}
    for view_index in (0, 1):
        kept, full = by_motion[(1, view_index)], by_motion[(0, view_index)]
        assert kept.labels == ("turn",) * 4
        # The same images as the turn's windows of the build with the filler.
        turn_rows = [i for i, label in enumerate(full.labels) if label == "turn"]
        np.testing.assert_array_equal(kept.windows, full.windows[turn_rows])
        np.testing.assert_array_equal(kept.vectors, full.vectors[turn_rows])


def test_view_images_of_stored_masks_equal_the_render(turn, views):
    """view_images, given the silhouettes a render makes, gives what the render gave."""
    from eigmotion.imaging.silhouettes import render_masks
    from eigmotion.retrieval.library_views import build_body, pose_for_views, view_images

    rig = virtual_rig([0.0, 90.0], [0.0], 64, 64)
    (shape, outfit) = CONFIG.bodies[0]
    body = build_body(shape, CONFIG.low_poly_faces, outfit)
    vertices, fitted = pose_for_views(turn.motion, body, rig, CONFIG.render_fps)
    masks = render_masks(vertices, body.faces, fitted[1])
    made = view_images(turn, masks, CONFIG)
    rendered = next(v for v in views if (v.motion_index, v.view_index) == (0, 1))
    assert made.labels == rendered.labels
    np.testing.assert_array_equal(made.windows, rendered.windows)
    np.testing.assert_array_equal(made.vectors, rendered.vectors)
