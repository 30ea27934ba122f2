"""Motion generation: variable-speed playback of a reference sequence."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.tracking.dictionary import posture_sequence
from eigmotion.tracking.generation import (
    VariableSpeedPlayback,
    playback_motion,
    smooth_headings_deg,
    variable_speed_playback,
)
from eigmotion.tracking.postures import heading_deg, posture_vectors


def ramp_reference(n=100, dims=5):
    """Reference postures that change steadily: frame i has every component = i."""
    return np.repeat(np.arange(n, dtype=float)[:, None], dims, axis=1)


@settings(max_examples=80, deadline=None)
@given(
    window=st.integers(1, 15),
    estimates=st.lists(st.floats(-20, 140, allow_nan=False), min_size=1, max_size=60),
    start=st.integers(0, 99),
)
def test_playback_never_jumps_more_than_the_window(window, estimates, start):
    ref = ramp_reference()
    est = np.repeat(np.asarray(estimates)[:, None], 5, axis=1)
    frames = variable_speed_playback(ref, est, start, 3.0, window)
    steps = np.diff(np.concatenate([[start], frames]))
    assert np.all(steps >= 0) and np.all(steps <= window)
    assert np.all((frames >= 0) & (frames < len(ref)))


def test_holds_the_start_until_reached_then_follows():
    ref = ramp_reference()
    est = np.array([50, 40, 11, 12, 20, 30, 30, 29, 90, 99], dtype=float)
    frames = variable_speed_playback(
        ref, np.repeat(est[:, None], 5, axis=1), start_frame=10, start_threshold_deg=3.0,
        window_frames=8,
    )  # fmt: skip
    # 50 and 40 are far from the start posture (10): hold it
    assert frames[:2].tolist() == [10, 10]
    # 11 is within 3 of it: start and follow, at most 8 frames per step, never back
    assert frames[2:].tolist() == [11, 12, 20, 28, 30, 30, 38, 46]


def test_heading_is_ignored_unless_asked():
    ref = ramp_reference(20)
    est = ref[5].copy()
    est[0] = 170.0  # another heading
    playback = VariableSpeedPlayback(ref, 0, 100.0, 10)
    assert playback.step(est) == 5
    strict = VariableSpeedPlayback(ref, 0, 100.0, 10, compare_heading=True)
    assert strict.step(est) == 0  # 170° away: nothing within d1 100° of the estimate


def test_playback_motion_on_real_mocap(cmu_dir):
    walk = read_amc(cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf").trim(0, 90)
    seq = posture_sequence(walk)
    names = seq.joint_names
    ids = [i for i in range(1, len(names)) if "Finger" not in names[i]]
    ref = posture_vectors(seq.local_rotations(), ids)
    # estimates: the reference at half speed, played as if walking towards +X
    est = ref[np.arange(0, 90, 2)[:20]]
    frames = variable_speed_playback(ref, est, 0, 15.0, 6)
    assert np.all(np.abs(frames - np.arange(0, 40, 2)) <= 1)
    where = np.column_stack([np.linspace(0, 1, 20), np.zeros(20), np.full(20, 2.0)])
    motion = playback_motion(seq, frames, where, 1 / 25, headings_deg=np.full(20, 90.0))
    pose = forward_kinematics(motion, ground=False)
    np.testing.assert_allclose(pose.positions[:, 0, [0, 2]], where[:, [0, 2]], atol=1e-6)
    np.testing.assert_allclose(pose.positions[:, 0, 1], seq.root_positions[frames, 1], atol=1e-6)
    np.testing.assert_allclose(heading_deg(pose.rotations[:, 0]), 90.0, atol=1e-6)
    assert motion.frame_time_s == pytest.approx(1 / 25)


def test_smooth_headings_cross_the_wrap():
    h = np.array([170.0, 178.0, -176.0, -170.0, -160.0])
    out = smooth_headings_deg(h, 3)
    assert np.all(np.abs(out) <= 180.0)
    assert np.abs(((out - h + 180) % 360) - 180).max() < 10.0


def test_errors():
    ref = ramp_reference(10)
    with pytest.raises(InvalidParameterError, match="start_frame"):
        VariableSpeedPlayback(ref, 10)
    with pytest.raises(InvalidParameterError, match="window_frames"):
        VariableSpeedPlayback(ref, 0, window_frames=0)
    with pytest.raises(InvalidParameterError, match="start_threshold_deg"):
        VariableSpeedPlayback(ref, 0, start_threshold_deg=0.0)
    with pytest.raises(InvalidParameterError, match="estimate_vector"):
        VariableSpeedPlayback(ref).step(np.zeros(3))
    with pytest.raises(InvalidParameterError, match="reference_vectors"):
        VariableSpeedPlayback(np.zeros((0, 4)))
