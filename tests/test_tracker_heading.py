"""The direction-of-travel prior on the heading, and the body scale measured from the
top of the silhouettes: unit checks, then real tracking of rendered two-camera views
from the front, where the silhouettes alone cannot tell front from back."""

from __future__ import annotations

import numpy as np
import pytest
from test_tracker_tracking import stage_clip

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.garments import dress
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.amc import read_amc
from eigmotion.tracking.body import avatar_bodies
from eigmotion.tracking.dictionary import build_dictionary
from eigmotion.tracking.heading import (
    angle_difference_deg,
    facing_deg,
    heading_penalty,
    travel_headings,
)
from eigmotion.tracking.tracker import SilhouetteTracker, TrackerConfig

NAMES = ("Hips", "LeftUpLeg", "RightUpLeg", "LeftArm", "RightArm")
NAMES_ALL = tuple(load_default_avatar().joint_names)


def body_facing(heading_deg: float) -> np.ndarray:
    """(1, 5, 3) joints of NAMES for a body facing ``heading_deg`` (left on +X at 0)."""
    a = np.deg2rad(heading_deg)
    left = np.array([np.cos(a), 0.0, -np.sin(a)])  # +X turned by the heading about +Y
    joints = np.array([[0, 0.9, 0], 0.1 * left + [0, 0.9, 0], -0.1 * left + [0, 0.9, 0],
                       0.18 * left + [0, 1.4, 0], -0.18 * left + [0, 1.4, 0]])  # fmt: skip
    return joints[None]


@pytest.mark.parametrize("heading", [0.0, 90.0, -90.0, 135.0, 180.0])
def test_facing_of_a_turned_body(heading):
    got = facing_deg(body_facing(heading), NAMES)[0]
    assert angle_difference_deg(got, heading) < 1e-6


def test_facing_needs_a_left_right_pair():
    with pytest.raises(InvalidParameterError, match="left/right joint pair"):
        facing_deg(np.zeros((1, 2, 3)), ("Hips", "Head"))


def test_travel_headings():
    times = np.arange(20) / 10.0
    along_x = np.c_[times * 1.0, np.full(20, 0.9), np.zeros(20)]  # 1 m/s along +X
    assert np.allclose(travel_headings(along_x, times, 0.5, 0.3), 90.0)
    towards_minus_z = np.c_[np.zeros(20), np.full(20, 0.9), -0.5 * times]
    got = travel_headings(towards_minus_z, times, 0.5, 0.3)
    assert np.allclose(angle_difference_deg(got, 180.0), 0.0)
    # too slow: no direction; unknown positions are skipped, not read as zeros
    assert np.all(np.isnan(travel_headings(0.2 * along_x, times, 0.5, 0.3)))
    holes = along_x.copy()
    holes[5:8] = np.nan
    got = travel_headings(holes, times, 0.5, 0.3)
    assert np.allclose(got[np.isfinite(got)], 90.0) and np.isfinite(got).sum() >= 17
    with pytest.raises(InvalidParameterError, match="window_s"):
        travel_headings(along_x, times, 0.0, 0.3)
    with pytest.raises(InvalidParameterError, match="positions of shape"):
        travel_headings(along_x[:5], times, 0.5, 0.3)


def test_heading_penalty():
    headings = np.array([0.0, 50.0, 60.0, 150.0, -120.0, 180.0])
    got = heading_penalty(headings, 0.0, 60.0, 1.0)
    assert np.allclose(got, [0.0, 0.0, 0.0, 1.0, 60 / 90, 120 / 90])
    assert np.all(heading_penalty(headings, float("nan"), 60.0, 1.0) == 0.0)


@pytest.mark.parametrize(
    "bad",
    [
        {"travel_tolerance_deg": -1.0},
        {"travel_tolerance_deg": 200.0},
        {"travel_weight": -0.5},
        {"travel_window_s": 0.0},
        {"travel_min_speed_mps": float("nan")},
        {"scale_from_top": "yes"},
    ],
)
def test_bad_settings(bad):
    with pytest.raises(InvalidParameterError, match=next(iter(bad))):
        TrackerConfig(**bad)


def front_cameras(width=320, height=240):
    """Two cameras 1.5 m high at ±60° from the walking direction (+Z), both in front."""
    K = intrinsics(width, height, 45.0)
    target = np.array([0.0, 0.9, 0.6])
    cams = []
    for name, azimuth in (("left_front", 60.0), ("right_front", -60.0)):
        a = np.deg2rad(azimuth)
        eye = target + [6.0 * np.sin(a), 0.6, 6.0 * np.cos(a)]
        cams.append(look_at(eye, target, K, width, height, name=name))
    return cams


@pytest.fixture(scope="module")
def front_walk(cmu_dir):
    """Dictionary of walk 02_01 turned to every 15°; walk 02_02 by another body in a
    long coat (it hides the legs, whose shape tells front from back), walking towards
    both cameras (+Z)."""

    def read(trial):
        return read_amc(cmu_dir / "amc" / f"{trial}.amc", cmu_dir / "asf" / f"{trial[:2]}.asf")

    dictionary = build_dictionary(
        [read("02_01")], threshold_deg=5.0, headings_deg=tuple(np.arange(-180.0, 180.0, 15.0)),
        face_forward=True,
    )  # fmt: skip
    bodies = avatar_bodies(dictionary)
    subject = dress(load_default_avatar(), ["long_coat"]).with_shape(height_m=1.58, girth=1.2)
    rot, pos = stage_clip(read("02_02").trim(0, 300).resample(25), subject, 0.0, (0.0, -1.0))
    cams = front_cameras()
    masks = [render_masks(subject.skin(rot, pos), subject.faces, cam) for cam in cams]
    scale = subject.height_m / load_default_avatar().height_m
    return dictionary, bodies, cams, masks, pos, scale


def mpjpe_mm(result, truth):
    return 1000 * float(np.linalg.norm(result.joint_positions_m - truth, axis=-1).mean())


def heading_errors(result, truth, names):
    est = facing_deg(result.joint_positions_m, names)
    return angle_difference_deg(est, facing_deg(truth, names))


def test_travel_prior_keeps_the_heading(front_walk):
    dictionary, bodies, cams, masks, truth, _ = front_walk
    tracker = SilhouetteTracker(dictionary, cams, bodies)
    frames = np.arange(len(truth))
    travel = tracker.travel_directions(masks, frames, 1 / 25)
    moving = np.isfinite(travel)
    assert moving.mean() > 0.8  # a walk at about 1 m/s
    true_facing = facing_deg(truth, dictionary.joint_names)
    assert np.median(angle_difference_deg(travel[moving], true_facing[moving])) < 15.0
    result = tracker.track(masks, frame_time_s=1 / 25)
    errors = heading_errors(result, truth, dictionary.joint_names)
    assert np.all(errors < 90.0), errors.round()
    # without the prior the coat's silhouettes let the body face the wrong way
    off = SilhouetteTracker(dictionary, cams, bodies, TrackerConfig(travel_tolerance_deg=None))
    assert np.all(np.isnan(off.travel_directions(masks, frames, 1 / 25)))
    unguided = off.track(masks, frame_time_s=1 / 25)
    flipped = heading_errors(unguided, truth, dictionary.joint_names)
    assert np.sum(flipped > 90.0) >= 5, flipped.round()
    assert mpjpe_mm(result, truth) < 0.6 * mpjpe_mm(unguided, truth)


def test_travel_penalty_reaches_the_scores(front_walk):
    dictionary, bodies, cams, masks, truth, _ = front_walk
    tracker = SilhouetteTracker(dictionary, cams, bodies)
    facing = tracker.facing_deg
    towards = np.flatnonzero(angle_difference_deg(facing, 0.0) < 10)[:5]
    away = np.flatnonzero(angle_difference_deg(facing, 180.0) < 10)[:5]
    tracker.travel_deg_ = 0.0
    assert np.all(tracker.travel_penalty(towards) == 0.0)
    assert np.all(tracker.travel_penalty(away) > 1.0)
    # a step told the person walks the other way turns the estimate round
    first = tracker.step([m[10] for m in masks], travel_deg=0.0)
    tracker.reset()
    flipped = tracker.step([m[10] for m in masks], travel_deg=180.0)
    assert angle_difference_deg(facing[first.entry], facing_deg(truth[10:11], NAMES_ALL)[0]) < 60
    assert angle_difference_deg(facing[flipped.entry], 180.0) <= 60 + 15


def test_body_scale_from_the_top_ignores_lost_feet(front_walk):
    """Background subtraction often loses the feet against the floor: the height
    measured from the top of the silhouette down to where the estimate stands keeps
    the body's size; the silhouette's own extent shrinks it."""
    dictionary, bodies, cams, masks, _, scale = front_walk
    cut = []
    for m in masks:
        m = m.copy()
        for f in range(len(m)):
            rows = np.flatnonzero(m[f].any(axis=1))
            m[f, rows[-1] - (rows[-1] - rows[0]) // 8 :] = False  # the lowest 1/8 lost
        cut.append(m)
    n = 12
    scales = {}
    for top in (True, False):
        tracker = SilhouetteTracker(dictionary, cams, bodies, TrackerConfig(scale_from_top=top))
        for f in range(n):
            tracker.step([m[f] for m in cut])
        scales[top] = tracker.body_scale_
    assert abs(scales[True] - scale) < 0.04, (scales, scale)
    assert scales[False] < scale - 0.06, (scales, scale)
