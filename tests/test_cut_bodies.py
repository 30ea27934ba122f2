"""People whose feet are out of the picture (eigmotion.segmentation.cut_bodies)."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import pose_avatar, retarget
from eigmotion.imaging.cameras import virtual_rig
from eigmotion.mocap.library import find_motion
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.library_views import BuildConfig, hull_points
from eigmotion.retrieval.motion_image import ClipMotionImages, MotionImageConfig
from eigmotion.segmentation.cut_bodies import (
    ANKLE_PRESENCE,
    FEET,
    HIPS,
    KNEES,
    SHANK_PER_THIGH,
    continued_below,
    hidden_rows_below,
    restored_legs,
)
from eigmotion.synth.scene import stick_figure_masks

FEET_ROW = 110
#: The database of tests/test_continuous_pose.py (built once per session).
MOTIONS = ("kick_135_04", "wave_14_24")
CONFIG = BuildConfig(
    n_components=12, key_axes=3, key_sections=6, garments=((),), body_shapes=((None, 1.0),)
)


def waving(n_frames=40) -> np.ndarray:
    """A stick figure on the spot waving its arms, feet on row 110: (F, 120, 160) bool."""
    return stick_figure_masks(
        n_frames, 120, 160, body_height_px=90.0, feet_row_px=FEET_ROW, start_x_px=80.0,
        walk_speed_px_s=0.0, leg_swing_deg=0.0, arm_swing_deg=70.0, raise_arms_deg=60.0,
    )  # fmt: skip


def cosine_distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(1.0 - np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)))


def landmarks_with_feet(n_frames: int, feet_row: float, presence: float) -> np.ndarray:
    """(F, 33, 4): every landmark at mid-frame, the feet's on ``feet_row``."""
    landmarks = np.full((n_frames, 33, 4), 50.0)
    landmarks[:, :, 2:] = 0.9
    landmarks[:, FEET, 1] = feet_row
    landmarks[:, FEET, 3] = presence
    return landmarks


def test_a_body_cut_at_the_shins_continued_down_gives_the_whole_body_s_image():
    """Cut 30 rows above the feet, the person frame enlarges the rest and lifts it:
    another image; continued by those 30 rows, nearly the whole body's."""
    masks = waving()
    cut = masks[:, : FEET_ROW - 30]
    config = MotionImageConfig()
    whole = ClipMotionImages(masks, config, 30.0).window(0, len(masks))
    as_cut = ClipMotionImages(cut, config, 30.0).window(0, len(cut))
    continued = ClipMotionImages(cut, config, 30.0, hidden_below_px=31).window(0, len(cut))
    assert cosine_distance(whole, continued) < 0.25 * cosine_distance(whole, as_cut)


def test_hidden_rows_follow_the_feet_below_the_edge():
    masks = waving()[:, :80]  # every frame touches the bottom edge
    landmarks = landmarks_with_feet(len(masks), feet_row=55.0, presence=0.1)
    # landmarks in pixels of frames twice the masks' size: row 55 → 110 mask rows
    assert hidden_rows_below(masks, landmarks, landmark_scale=2.0) == 30


@pytest.mark.parametrize("presence", [ANKLE_PRESENCE, 0.9])
def test_feet_the_network_sees_are_in_the_picture(presence):
    masks = waving()[:, :80]
    landmarks = landmarks_with_feet(len(masks), feet_row=110.0, presence=presence)
    assert hidden_rows_below(masks, landmarks, 1.0) == 0


def test_a_body_that_ends_above_the_edge_is_whole():
    masks = waving()  # feet on row 110 of 120: nothing on the bottom row
    landmarks = landmarks_with_feet(len(masks), feet_row=150.0, presence=0.0)
    assert hidden_rows_below(masks, landmarks, 1.0) == 0


def test_without_landmarks_nothing_is_estimated():
    masks = waving()[:, :80]
    landmarks = np.full((len(masks), 33, 4), np.nan)
    assert hidden_rows_below(masks, landmarks, 1.0) == 0
    assert hidden_rows_below(np.zeros((3, 8, 8), bool), np.full((3, 33, 4), np.nan), 1.0) == 0


def test_a_wild_guess_adds_at_most_the_frame_s_height():
    masks = waving()[:, :80]
    landmarks = landmarks_with_feet(len(masks), feet_row=1e6, presence=0.0)
    assert hidden_rows_below(masks, landmarks, 1.0) == 80


def test_feet_guessed_too_far_below_the_knees_are_taken_up_to_the_legs_length():
    """Hips on row 40 and knees on 60 (a thigh of 20 rows): feet the network puts on
    row 120 lie at most SHANK_PER_THIGH thighs below the knees."""
    masks = waving()[:, :80]
    landmarks = landmarks_with_feet(len(masks), feet_row=120.0, presence=0.1)
    landmarks[:, HIPS, 1] = 40.0
    landmarks[:, KNEES, 1] = 60.0
    reach = 60.0 + SHANK_PER_THIGH * 20.0
    assert hidden_rows_below(masks, landmarks, 1.0) == int(np.ceil(reach - 80))
    # feet within the legs' reach stay where the network puts them
    landmarks[:, FEET, 1] = 82.0
    assert hidden_rows_below(masks, landmarks, 1.0) == 2
    # and a frame whose knees are not below its hips bounds nothing
    landmarks[:, FEET, 1] = 120.0
    landmarks[:, KNEES, 1] = 40.0
    assert hidden_rows_below(masks, landmarks, 1.0) == 40


def test_wrong_shapes_are_named():
    with pytest.raises(ValueError, match="landmarks"):
        hidden_rows_below(np.zeros((3, 8, 8), bool), np.zeros((2, 33, 4)), 1.0)


def standing_landmarks(n_frames: int) -> np.ndarray:
    """(F, 33, 4): the waving figure's hips on row 65, knees on 88, feet on 110, all at
    its centre column 80, seen and present."""
    landmarks = np.full((n_frames, 33, 4), 0.9)
    landmarks[:, :, 0] = 80.0
    landmarks[:, :, 1] = 40.0
    landmarks[:, HIPS, 1] = 65.0
    landmarks[:, (25, 26), 1] = 88.0
    landmarks[:, FEET, 1] = FEET_ROW
    return landmarks


def test_legs_lost_in_some_frames_come_back_from_a_frame_where_they_stand_the_same():
    """Light trousers lost below the thighs in frames 10-14: the legs of the nearest
    frame whose hips, knees and ankles lie where theirs do come back, the rest of the
    frame as it was."""
    whole = waving()
    masks = whole.copy()
    masks[10:15, 85:] = False
    restored = restored_legs(masks, standing_landmarks(len(masks)), 1.0)
    donors = {10: 9, 11: 9, 12: 9, 13: 15, 14: 15}  # the nearest whole frame (ties: earlier)
    expected = whole.copy()
    for frame, donor in donors.items():
        expected[frame, 65:] = masks[frame, 65:] | whole[donor, 65:]
    np.testing.assert_array_equal(restored, expected)
    assert restored[10:15, 85:].sum() > 0.9 * whole[10:15, 85:].sum()
    assert not masks[10:15, 85:].any()  # the caller's masks are left as they were


def test_legs_that_move_are_not_made_up():
    """Where no whole frame has the legs where the lost frame's landmarks put them (a
    jump, a kick), the frame stays as it is; so do frames without landmarks, and a clip
    whose legs are all whole comes back as it is."""
    masks = waving()
    masks[10:15, 85:] = False
    landmarks = standing_landmarks(len(masks))
    landmarks[10:15, (25, 26, 27, 28), 0] += 20.0  # knees and ankles 20 px aside
    np.testing.assert_array_equal(restored_legs(masks, landmarks, 1.0), masks)
    unseen = np.full((len(masks), 33, 4), np.nan)
    assert restored_legs(masks, unseen, 1.0) is masks
    whole = waving()
    assert restored_legs(whole, standing_landmarks(len(whole)), 1.0) is whole
    with pytest.raises(ValueError, match="landmarks"):
        restored_legs(masks, landmarks[:3], 1.0)


def test_continued_below_copies_the_bottom_row():
    masks = np.zeros((2, 4, 5), np.uint8)
    masks[:, 3, 1:3] = 1
    out = continued_below(masks, 3)
    assert out.shape == (2, 7, 5) and out.dtype == np.uint8
    assert (out[:, 3:] == masks[:, 3:4]).all() and (out[:, :4] == masks).all()
    assert continued_below(masks, 0) is masks


def test_a_query_cut_at_the_knees_is_nearer_its_motion_continued(ring6_database):
    """The avatar waving, filmed from between two of the database's cameras, its legs
    cut off by the frame's bottom edge: continued by the rows cut off, the clip lies
    nearer its motion in the database than as cut."""
    from eigmotion.imaging.silhouettes import render_masks

    body = load_default_avatar().with_shape(height_m=1.62, girth=1.15).decimated(4000)
    vertices = pose_avatar(body, retarget(find_motion("wave_14_24"), body))[::4]
    camera = virtual_rig([30.0], [10.0], 160, 120).fitted(hull_points(vertices), margin=0.08)[0]
    masks = render_masks(vertices, body.faces, camera)
    rows = np.flatnonzero(masks.any(axis=(0, 2)))
    cut_at = rows[0] + int(0.7 * (rows[-1] - rows[0]))  # about the knees
    cut, hidden = masks[:, :cut_at], int(rows[-1] + 1 - cut_at)
    with MotionDatabase.open(ring6_database(MOTIONS, CONFIG)) as db:
        whole = db.query_masks(masks, 30.0)
        as_cut = db.query_masks(cut, 30.0)
        continued = db.query_masks(cut, 30.0, hidden_below_px=hidden)
    assert whole.best.label == continued.best.label == "wave"
    assert continued.best.distance < as_cut.best.distance
    assert abs(continued.best.distance - whole.best.distance) < abs(
        as_cut.best.distance - whole.best.distance
    )
