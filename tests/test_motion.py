"""The core motion type: channels ↔ local transforms, trimming, resampling, FK."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.canonical import canonical_skeleton
from eigmotion.mocap.kinematics import detect_length_unit, forward_kinematics
from eigmotion.mocap.mirror import mirror_motion
from eigmotion.mocap.motion import Motion, Skeleton
from eigmotion.mocap.naming import mirror_partners
from eigmotion.mocap.rotations import align_vectors, euler_to_matrix, rotation_between


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


def test_the_query_path_imports_no_scipy_rotations():
    import subprocess
    import sys

    # scipy.spatial costs a query that writes no motion about 0.14 s to import.
    code = "import sys, eigmotion.retrieval.database; print('scipy.spatial' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


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


# -- mirror images ----------------------------------------------------------------------


def test_mirrored_twice_is_the_original(rng):
    m = _random_motion(rng, n_frames=20)
    twice = mirror_motion(mirror_motion(m))
    np.testing.assert_allclose(
        forward_kinematics(twice, ground=False).positions,
        forward_kinematics(m, ground=False).positions,
        atol=1e-9,
    )
    np.testing.assert_allclose(twice.skeleton.offsets, m.skeleton.offsets, atol=1e-15)


def test_mirrored_is_a_reflection_with_the_sides_swapped(rng):
    m = _random_motion(rng, n_frames=20)
    before = forward_kinematics(m, ground=False)
    after = forward_kinematics(mirror_motion(m), ground=False)
    partner = list(mirror_partners(m.skeleton))
    swapped = after.positions[:, partner]
    # Distances between joints and heights are kept, the first root position too ...
    d_before = np.linalg.norm(before.positions[:, :, None] - before.positions[:, None], axis=-1)
    d_after = np.linalg.norm(swapped[:, :, None] - swapped[:, None], axis=-1)
    np.testing.assert_allclose(d_after, d_before, atol=1e-9)
    np.testing.assert_allclose(swapped[..., 1], before.positions[..., 1], atol=1e-9)
    np.testing.assert_allclose(after.positions[0, 0], before.positions[0, 0], atol=1e-12)

    # ... and handedness flips: a reflection, not a turn.
    def handedness(pose, joints):
        hips, a, b, c = (pose.positions[:, pose.names.index(j)] for j in ("Hips", *joints))
        return np.sign(np.einsum("fi,fi->f", np.cross(a - hips, b - hips), c - hips))

    joints = ("LeftUpLeg", "Head", "LeftHand")
    mirrored_joints = ("RightUpLeg", "Head", "RightHand")
    np.testing.assert_array_equal(handedness(after, mirrored_joints), -handedness(before, joints))


def test_mirrored_keeps_the_channels_and_timing(rng):
    m = _random_motion(rng)
    mirror = mirror_motion(m)
    assert mirror.skeleton.names == m.skeleton.names
    assert mirror.skeleton.channels == m.skeleton.channels
    assert (mirror.n_frames, mirror.frame_time_s, mirror.length_unit_m, mirror.name) == (
        m.n_frames,
        m.frame_time_s,
        m.length_unit_m,
        m.name,
    )


def test_mirroring_needs_sides_along_x(rng):
    m = _random_motion(rng)
    sk = m.skeleton
    plain = Skeleton(
        tuple(f"j{i}" for i in range(sk.n_joints)),
        sk.parents,
        sk.offsets,
        sk.channels,
        sk.end_sites,
    )
    with pytest.raises(InvalidParameterError, match="no joint name says its side"):
        mirror_motion(m.replace(skeleton=plain))
    # Facing +X at rest: left and right lie apart along z.
    quarter = euler_to_matrix(np.array([0.0, 90.0, 0.0]), "XYZ")
    turned = Skeleton(sk.names, sk.parents, sk.offsets @ quarter.T, sk.channels, sk.end_sites)
    with pytest.raises(InvalidParameterError, match="along x"):
        mirror_motion(m.replace(skeleton=turned))
