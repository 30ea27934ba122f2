"""The core motion type: channels ↔ local transforms, trimming, resampling, FK."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.canonical import canonical_skeleton
from eigmotion.errors import InvalidParameterError
from eigmotion.kinematics import detect_length_unit, forward_kinematics
from eigmotion.motion import Motion, Skeleton
from eigmotion.rotations import align_vectors, euler_to_matrix, rotation_between


def _random_motion(rng, n_frames=12, order="ZXY") -> Motion:
    sk = canonical_skeleton(order)
    values = rng.uniform(-60, 60, size=(n_frames, sk.n_channels))
    values[:, :3] = rng.uniform(-0.5, 0.5, size=(n_frames, 3))
    return Motion(sk, values, 1 / 30, 1.0, "random")


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "YZX", "ZYX"])
def test_channels_round_trip_through_local_transforms(rng, order):
    m = _random_motion(rng, order=order)
    again = m.with_local_transforms(m.local_rotations(), m.local_translations())
    np.testing.assert_allclose(again.local_rotations(), m.local_rotations(), atol=1e-9)
    np.testing.assert_allclose(again.values[:, :3], m.values[:, :3], atol=1e-12)


def test_euler_convention_is_intrinsic_in_listed_order():
    r = euler_to_matrix(np.array([30.0, 40.0, 50.0]), "ZXY")
    rz = euler_to_matrix(np.array([30.0, 0, 0]), "ZXY")
    rx = euler_to_matrix(np.array([0, 40.0, 0]), "ZXY")
    ry = euler_to_matrix(np.array([0, 0, 50.0]), "ZXY")
    np.testing.assert_allclose(r, rz @ rx @ ry, atol=1e-12)


def test_rotation_helpers(rng):
    a, b = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    r = rotation_between(a, b)
    got = np.einsum("nab,nb->na", r, a / np.linalg.norm(a, axis=1, keepdims=True))
    np.testing.assert_allclose(got, b / np.linalg.norm(b, axis=1, keepdims=True), atol=1e-9)
    np.testing.assert_allclose(rotation_between(a[0], -a[0]) @ a[0], -a[0], atol=1e-9)
    true = euler_to_matrix(np.array([10.0, 70.0, -20.0]), "XYZ")
    np.testing.assert_allclose(align_vectors(a[:5], a[:5] @ true.T), true, atol=1e-9)


def test_trim_and_resample(rng):
    m = _random_motion(rng, n_frames=31)
    assert m.trim(5, 15).n_frames == 10
    with pytest.raises(InvalidParameterError, match="empty"):
        m.trim(20, 10)
    r = m.resample(60)
    assert r.n_frames == 61 and r.fps == pytest.approx(60)
    np.testing.assert_allclose(r.local_rotations()[::2], m.local_rotations(), atol=1e-9)
    np.testing.assert_allclose(r.local_translations()[::2], m.local_translations(), atol=1e-12)


def test_fk_bone_lengths_constant_and_grounded(rng):
    m = _random_motion(rng)
    pose = forward_kinematics(m)
    lengths = pose.bone_lengths()
    np.testing.assert_allclose(lengths, np.broadcast_to(lengths[0], lengths.shape), atol=1e-9)
    assert pose.all_points()[..., 1].min() == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("unit", [1.0, 0.01, 0.0254, 0.0254 / 0.45])
def test_length_unit_detection(unit):
    sk = canonical_skeleton().scaled(1.0 / unit)
    assert detect_length_unit(sk) == pytest.approx(unit)


def test_bad_skeleton_and_values_are_named():
    with pytest.raises(InvalidParameterError, match="parents-first"):
        Skeleton(("a", "b"), [1, -1], np.zeros((2, 3)), ((), ()))
    sk = canonical_skeleton()
    with pytest.raises(InvalidParameterError, match="shape"):
        Motion(sk, np.zeros((3, 5)), 1 / 30)
    bad = np.zeros((3, sk.n_channels))
    bad[1, 4] = np.nan
    with pytest.raises(InvalidParameterError, match="frame 1"):
        Motion(sk, bad, 1 / 30)
