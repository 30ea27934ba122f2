"""Posture dictionary: posture vectors, d1 / d2, pruning, candidates, real mocap."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.canonical import CANONICAL_JOINTS, CANONICAL_PARENTS
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.rotations import axis_rotation
from eigmotion.tracking.body import avatar_bodies, proxy_bodies
from eigmotion.tracking.dictionary import (
    PostureDictionary,
    build_dictionary,
    dictionary_from_motion,
    select_candidates,
)
from eigmotion.tracking.postures import (
    d1_distance,
    d1_matrix,
    d2_distance,
    heading_deg,
    posture_vectors,
    projected_joints,
    prune_postures,
    wrap_deg,
    yaw_rotation,
)

J = len(CANONICAL_JOINTS)
ELBOW = CANONICAL_JOINTS.index("LeftForeArm")


@pytest.fixture(scope="module")
def walk(cmu_dir):
    """A short CMU walk (02_01, half a second at 120 fps)."""
    return read_amc(cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf").trim(0, 120)


@pytest.fixture(scope="module")
def walk_dictionary(walk):
    return build_dictionary([walk], threshold_deg=5.0, headings_deg=(0.0, 90.0, 180.0))


def identity_postures(n):
    return np.broadcast_to(np.eye(3), (n, J, 3, 3)).copy()


@pytest.mark.parametrize("angle", [-170.0, -30.0, 0.0, 45.0, 179.0])
def test_posture_vector_components(angle):
    rot = identity_postures(1)
    rot[0, 0] = yaw_rotation(angle) @ axis_rotation("X", 10.0)
    rot[0, ELBOW] = axis_rotation("X", 30.0)
    ids = list(range(1, J))
    v = posture_vectors(rot, ids)[0]
    assert v.shape == (4 + 3 * (J - 1),)
    assert v[0] == pytest.approx(angle)
    np.testing.assert_allclose(v[1:4], [10.0, 0, 0], atol=1e-9)
    k = 4 + 3 * ids.index(ELBOW)
    np.testing.assert_allclose(v[k : k + 3], [30.0, 0, 0], atol=1e-9)
    assert np.abs(np.delete(v, [0, 1, k])).max() < 1e-9


def test_d1_wraps_the_heading():
    a = np.zeros(7)
    b = np.zeros(7)
    a[0], b[0] = 179.0, -179.0
    assert d1_distance(a, b) == pytest.approx(2.0)
    b[5] = -12.5
    assert d1_distance(a, b) == pytest.approx(12.5)
    assert d1_matrix(np.stack([a, b]), np.stack([a, b])).shape == (2, 2)
    np.testing.assert_allclose(wrap_deg([181.0, -181.0, 540.0]), [-179.0, 179.0, 180.0])


def test_heading_of_turned_rest_pose():
    np.testing.assert_allclose(heading_deg(yaw_rotation([0.0, 90.0, -135.0])), [0, 90, -135])


def test_d2_is_a_projected_distance():
    """Moving a joint along a camera's optical axis changes nothing in that view."""
    a = np.zeros((1, 3, 3))
    b = a.copy()
    b[0, 2] = [0.0, 0.0, 0.4]  # 40 cm along world +Z
    looking_along_z = np.eye(3)[None]  # camera z = world z
    looking_along_x = np.array([[[0, 0, -1.0], [0, 1.0, 0], [1.0, 0, 0]]])
    pa = projected_joints(a, looking_along_z)
    pb = projected_joints(b, looking_along_z)
    assert d2_distance(pa, pb)[0] == pytest.approx(0.0)
    pa = projected_joints(a, looking_along_x)
    pb = projected_joints(b, looking_along_x)
    assert d2_distance(pa, pb)[0] == pytest.approx(0.4)
    both = np.concatenate([looking_along_z, looking_along_x])
    assert d2_distance(projected_joints(a, both), projected_joints(b, both))[0] == pytest.approx(
        0.4
    )


@pytest.mark.parametrize("threshold", [0.0, 2.0, 10.0])
def test_pruning_keeps_a_cover(threshold):
    rng = np.random.default_rng(0)
    vectors = np.cumsum(rng.normal(0, 1.0, size=(300, 10)), axis=0)
    kept = prune_postures(vectors, threshold)
    if threshold == 0:
        assert len(kept) == 300
        return
    # kept postures are pairwise at least the threshold apart ...
    d = d1_matrix(vectors[kept], vectors[kept])
    assert np.all(d[~np.eye(len(kept), dtype=bool)] >= threshold)
    # ... and every dropped one is within the threshold of a kept one
    assert np.all(d1_matrix(vectors, vectors[kept]).min(axis=1) < threshold + 1e-12)
    assert kept[0] == 0 and len(kept) < 300


def test_dictionary_from_real_mocap(walk, walk_dictionary):
    d = walk_dictionary
    assert d.joint_names == CANONICAL_JOINTS
    assert len(d) == 3 * d.n_base and 5 < d.n_base < walk.n_frames
    np.testing.assert_array_equal(d.parents, CANONICAL_PARENTS)
    # headings: each base posture appears turned by 0, 90 and 180 degrees
    base0 = np.flatnonzero(d.base_index == 0)
    turns = wrap_deg(d.vectors[base0, 0] - d.vectors[base0[0], 0])
    np.testing.assert_allclose(np.sort(np.abs(turns)), [0, 90, 180], atol=1e-6)
    # the root sits at the origin; the body centre is at hip height
    np.testing.assert_allclose(d.joint_positions[:, 0], 0.0, atol=1e-12)
    assert np.all((d.body_height_m > 0.8) & (d.body_height_m < 1.1))
    # neighbouring kept postures are at least the threshold apart (same heading)
    same = d.heading_offset_deg == 0.0
    dist = d1_matrix(d.vectors[same], d.vectors[same])
    assert np.all(dist[~np.eye(int(same.sum()), dtype=bool)] >= 5.0)


def test_joint_positions_match_forward_kinematics(walk_dictionary):
    d = walk_dictionary
    idx = np.array([0, 4, len(d) - 1])
    root = np.array([[0.5, 0.9, -1.0], [0.0, 1.0, 0.0], [2.0, 0.95, 1.0]])
    motion = d.to_motion(idx, root, 1 / 25)
    pose = forward_kinematics(motion, ground=False)
    np.testing.assert_allclose(pose.positions, d.joints_at(idx, root), atol=1e-6)


def test_save_and_load(tmp_path, walk_dictionary):
    path = walk_dictionary.save(tmp_path / "dict.npz")
    again = PostureDictionary.load(path)
    assert again.joint_names == walk_dictionary.joint_names
    assert again.vector_joints == walk_dictionary.vector_joints
    np.testing.assert_array_equal(again.vectors, walk_dictionary.vectors)
    np.testing.assert_array_equal(again.base_index, walk_dictionary.base_index)
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(InvalidParameterError, match="junk.npz"):
        PostureDictionary.load(tmp_path / "junk.npz")
    with pytest.raises(InvalidParameterError, match="not found"):
        PostureDictionary.load(tmp_path / "none.npz")


@pytest.mark.parametrize("max_candidates", [1, 5, 40])
def test_candidates_are_near_and_sorted(walk_dictionary, max_candidates):
    d = walk_dictionary
    views = yaw_rotation([0.0, 60.0])
    prev = 3
    cands, closeness = select_candidates(d, prev, views, 20.0, 0.25, max_candidates)
    assert cands[0] == prev and closeness[0] == 0.0
    assert len(cands) <= max_candidates
    assert np.all(np.diff(closeness) >= 0) and np.all(closeness < 1)
    d1 = d1_distance(d.vectors[cands], d.vectors[prev])
    proj = projected_joints(d.joint_positions[cands], views)
    d2 = d2_distance(proj, projected_joints(d.joint_positions[prev][None], views))
    assert np.all(d1 < 20.0) and np.all(d2 < 0.25)
    np.testing.assert_allclose(closeness, np.maximum(d1 / 20.0, d2 / 0.25))
    # nothing left out is nearer than the last one kept
    every, every_close = select_candidates(d, prev, views, 20.0, 0.25, len(d))
    assert set(cands) <= set(every)
    if len(every) > len(cands):
        assert every_close[len(cands)] >= closeness[-1]
    # turned copies (90 degrees away) are never candidates ...
    assert np.all(np.abs(wrap_deg(d.vectors[every, 0] - d.vectors[prev, 0])) < 20.0)
    # ... unless the heading has its own, wider threshold
    wide, wide_close = select_candidates(d, prev, views, 20.0, 10.0, len(d), max_heading_deg=100.0)
    turned = np.abs(wrap_deg(d.vectors[wide, 0] - d.vectors[prev, 0]))
    assert np.any(turned > 80.0) and np.all(turned < 100.0)
    assert np.all(wide_close < 1.0) and wide[0] == prev


def test_bodies_follow_the_dictionary(walk_dictionary):
    d = walk_dictionary
    bodies = avatar_bodies(d)
    assert len(bodies) == len(d) and 1500 < bodies.n_vertices < 3000
    idx = np.flatnonzero(d.base_index == 2)  # one posture at three headings
    where = np.array([1.0, 0.93, -2.0])
    verts = bodies.vertices(idx, where)
    # the turned copies are the same mesh turned about the root
    rel = verts - where
    np.testing.assert_allclose(
        rel[1], rel[0] @ yaw_rotation(d.heading_offset_deg[idx[1]]).T, atol=1e-5
    )
    # the body surrounds its joints and stands on the floor
    joints = bodies.joints(idx, where)
    lo, hi = verts.min(axis=1), verts.max(axis=1)
    assert np.all(joints >= lo[:, None] - 1e-6) and np.all(joints <= hi[:, None] + 1e-6)
    assert np.all(np.abs(lo[:, 1] - (where[1] - d.body_height_m[idx])) < 0.12)
    corners = bodies.box_corners(idx, where)
    assert np.all(verts.min(axis=1) >= corners.min(axis=1) - 1e-5)


def test_proxy_bodies(walk_dictionary):
    bodies = proxy_bodies(walk_dictionary)
    assert len(bodies) == len(walk_dictionary)
    verts = bodies.vertices(np.arange(3), np.zeros(3))
    assert verts.shape[0] == 3 and np.all(np.isfinite(verts))


def test_one_motion_in_order(walk):
    d = dictionary_from_motion(walk.trim(0, 20))
    assert len(d) == 20
    np.testing.assert_array_equal(d.source_frame, np.arange(20))


def test_errors(walk):
    with pytest.raises(InvalidParameterError, match="no motions"):
        build_dictionary([])
    with pytest.raises(InvalidParameterError, match="exclude_joints"):
        build_dictionary([walk.trim(0, 5)], exclude_joints=("Tail",))
    with pytest.raises(InvalidParameterError, match="threshold_deg"):
        prune_postures(np.zeros((3, 4)), -1.0)
    with pytest.raises(InvalidParameterError, match="local_rotations"):
        posture_vectors(np.zeros((3, 3)), [1])
