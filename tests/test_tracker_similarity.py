"""The paper's silhouette similarity (equation 4) on tiny masks counted by hand."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.tracking.similarity import EMPTY_SCORE, score_masks, similarity, view_window


def grid(rows: list[str]) -> np.ndarray:
    """A mask from strings: '#' is True."""
    return np.array([[c == "#" for c in row] for row in rows])


def test_hand_computed_case_without_shift():
    observed = grid(
        [
            "......",
            ".###..",
            ".###..",
            "...#..",
        ]
    )
    candidate = grid(
        [
            "......",
            "..##..",
            "..##..",
            "..##..",
        ]
    )
    # A(S1) = 6, A(S1 ∩ S2) = 5 (rows 1-2 cols 2-3, and (3, 3)); observed outside the
    # candidate: (1, 1), (2, 1) = 2; R has 24 pixels, 18 outside the candidate.
    score, shift = similarity(observed, candidate)
    assert shift == (0, 0)
    assert score == pytest.approx(5 / 6 - 2 / 18)


def test_shift_finds_the_offset():
    observed = grid(
        [
            ".......",
            ".......",
            "....##.",
            "....##.",
            ".......",
        ]
    )
    candidate = grid(
        [
            ".......",
            "..##...",
            "..##...",
            ".......",
            ".......",
        ]
    )
    score0, _ = similarity(observed, candidate, 0)
    # unshifted: no overlap, all 4 observed pixels lie outside: 0 - 4 / 31
    assert score0 == pytest.approx(-4 / 31)
    score, shift = similarity(observed, candidate, 2)
    assert shift == (2, 1)
    assert score == pytest.approx(1.0)


def test_shift_beyond_the_rectangle_counts_only_inside():
    """A candidate pushed past the border of R keeps its area A(S1), but only the
    part inside R takes from the area of R outside it."""
    observed = grid(["##..", "##..", "...."])
    candidate = grid(["....", ".##.", ".##."])
    score, shift = similarity(observed, candidate, 1)
    # best shift (-1, -1): candidate covers rows 0-1, cols 0-1 = the observed exactly
    assert shift == (-1, -1)
    assert score == pytest.approx(1.0)
    # with shift (+1, +1) the candidate leaves R: its in-R area is 2 of 4
    scores, _ = score_masks(observed.astype(float), candidate[None], 0)
    # unshifted: overlap 1, observed outside 3, R outside 12 - 4 = 8
    assert scores[0] == pytest.approx(1 / 4 - 3 / 8)


def test_empty_candidate_scores_lowest_and_fractional_observed():
    obs = np.full((3, 3), 0.5)
    scores, shifts = score_masks(obs, np.zeros((2, 3, 3), bool), 1)
    assert np.all(scores == EMPTY_SCORE) and np.all(shifts == 0)
    cand = np.zeros((3, 3), bool)
    cand[1, 1] = True
    score, _ = similarity(obs, cand)
    assert score == pytest.approx(0.5 - 0.5)


@pytest.mark.parametrize("radius", [0, 1, 3])
def test_batch_equals_single_and_brute_force(radius):
    rng = np.random.default_rng(radius)
    obs = rng.random((12, 10)) < 0.4
    cands = rng.random((5, 12, 10)) < 0.3
    scores, shifts = score_masks(obs, cands, radius)
    for i in range(5):
        s, sh = similarity(obs, cands[i], radius)
        assert s == pytest.approx(scores[i]) and sh == tuple(shifts[i])
        # brute force over shifts with np.roll-free shifting
        best = -np.inf
        area = cands[i].sum()
        for dy in range(-radius, radius + 1):
            for dx in range(-radius, radius + 1):
                moved = np.zeros((12 + 2 * radius, 10 + 2 * radius), bool)
                moved[radius + dy : radius + dy + 12, radius + dx : radius + dx + 10] = cands[i]
                inside = moved[radius : radius + 12, radius : radius + 10]
                val = (inside & obs).sum() / area - (obs & ~inside).sum() / (120 - inside.sum())
                best = max(best, val)
        assert scores[i] == pytest.approx(best)


def test_errors():
    with pytest.raises(InvalidParameterError, match="equal"):
        similarity(np.zeros((3, 3)), np.zeros((3, 4), bool))
    with pytest.raises(InvalidParameterError, match="shift_radius_px"):
        score_masks(np.zeros((3, 3)), np.zeros((1, 3, 3), bool), -1)
    with pytest.raises(InvalidParameterError, match="candidates"):
        score_masks(np.zeros((3, 3)), np.zeros((3, 3), bool), 0)


@pytest.mark.parametrize("downsample", [1, 2, 3])
def test_window_camera_renders_the_crop(downsample):
    """A silhouette rendered through the window camera equals the full-resolution
    render cropped and block-averaged (to within edge pixels)."""
    cam = look_at([0.5, 1.5, -4], [0, 0.9, 0], intrinsics(160, 120, 45), 160, 120)
    box = np.array([[x, y, z] for x in (-0.3, 0.2) for y in (0.1, 1.7) for z in (-0.15, 0.1)])
    faces = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    )  # fmt: skip
    full = render_masks(box[None], faces, cam)[0]
    px, _ = cam.project(box)
    window = view_window(cam, px, 3, downsample)
    assert window.width_px % downsample == 0 and window.height_px % downsample == 0
    small = render_masks(box[None], faces, window.window_camera())[0]
    coverage = window.crop(full)
    assert small.shape == coverage.shape
    # Window pixels whose block is fully covered (or empty) at full resolution agree;
    # only blocks on the outline may differ.
    assert np.all(small[coverage == 1.0]) and not np.any(small[coverage == 0.0])
    assert coverage.sum() > 20
    np.testing.assert_allclose(
        window.to_full_px(np.zeros(2)), np.array([window.x0, window.y0]) + (downsample - 1) / 2
    )
