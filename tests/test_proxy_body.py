"""Capsule proxy bodies for skeletons without a skinned mesh."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mesh_helpers import winding_numbers

from eigmotion.body.proxy_body import MIN_BONE_M, capsule_mesh, proxy_body
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.canonical import canonical_skeleton
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.motion import Motion, Skeleton, standard_channels

CMU = Path(__file__).resolve().parents[1] / "database" / "motions" / "cmu"


def quadruped() -> Skeleton:
    """A four-legged creature with a tail (no human names), centimetres."""
    names = ["pelvis", "tail1", "tail2", "spine", "neck", "skull"]
    parents = [-1, 0, 1, 0, 3, 4]
    offsets = [[0, 60, 0], [0, 5, -15], [0, -5, -25], [0, 5, 50], [0, 15, 15], [0, 5, 15]]
    for side, x in (("l", 12), ("r", -12)):
        for part, root in (("hind", 0), ("fore", 3)):
            base = len(names)
            names += [f"{side}{part}_hip", f"{side}{part}_knee", f"{side}{part}_paw"]
            parents += [root, base, base + 1]
            offsets += [[x, -5, 0], [0, -25, 5], [0, -25, -5]]
    n = len(names)
    ends = {2: [0, 0, -20], 5: [0, 0, 12]}
    ends.update({j: [0, -5, 5] for j, name in enumerate(names) if name.endswith("_paw")})
    return Skeleton(tuple(names), parents, offsets, standard_channels(n), ends)


def random_motion(skeleton: Skeleton, seed: int, n_frames: int = 12) -> Motion:
    rng = np.random.default_rng(seed)
    values = rng.uniform(-45, 45, (n_frames, skeleton.n_channels))
    values[:, :3] = rng.uniform(-0.2, 0.2, (n_frames, 3))
    return Motion(skeleton, values, 1 / 30, None, f"random{seed}")


def expected_capsules(skeleton: Skeleton, unit_m: float) -> int:
    bones = [np.linalg.norm(o) * unit_m for o in skeleton.offsets[1:]]
    ends = [np.linalg.norm(e) * unit_m for e in skeleton.end_sites.values()]
    return sum(length > MIN_BONE_M for length in bones + ends)


SKELETONS = {
    "canonical": lambda: random_motion(canonical_skeleton(), 0),
    "cmu_asf": lambda: read_amc(CMU / "amc" / "02_01.amc", CMU / "asf" / "02.asf").trim(0, 60),
    "quadruped": lambda: random_motion(quadruped(), 1).replace(length_unit_m=0.01),
}


@pytest.mark.parametrize("which", sorted(SKELETONS))
def test_one_capsule_per_bone_enclosing_every_joint(which):
    motion = SKELETONS[which]()
    pose = forward_kinematics(motion)
    body = proxy_body(pose)
    unit = motion.length_unit_m or 1.0
    assert body.n_capsules == expected_capsules(motion.skeleton, unit)
    n_f = motion.n_frames
    assert body.vertices.shape[0] == n_f and body.vertices.dtype == np.float32
    assert body.faces.dtype == np.int32 and body.faces.max() < body.vertices.shape[1]
    for f in (0, n_f // 2, n_f - 1):
        inside = winding_numbers(pose.all_points()[f], body.vertices[f], body.faces)
        assert np.all(inside > 0.5), np.flatnonzero(inside <= 0.5)


def test_capsules_are_rigid_and_follow_their_bones():
    motion = SKELETONS["cmu_asf"]()
    pose = forward_kinematics(motion)
    body = proxy_body(pose)
    owner = body.vertex_bone()
    points = pose.all_points()
    for b, (head, tail) in enumerate(body.bones):
        v = body.vertices[:, owner == b].astype(np.float64)
        a, c = points[:, head][:, None], points[:, tail][:, None]
        axis = c - a
        t = np.clip(np.sum((v - a) * axis, -1) / np.sum(axis * axis, -1), 0, 1)
        dist = np.linalg.norm(v - a - t[..., None] * axis, axis=-1)
        # Every vertex within its capsule's radii of the bone segment, every frame.
        assert dist.max() <= body.radii_m[b].max() + 1e-5
        assert dist.min() >= body.radii_m[b].min() * np.cos(np.pi / 12) - 1e-5


def test_capsule_mesh_is_closed():
    vertices, faces = capsule_mesh(0.3, 0.05, 0.03, n_sides=10, n_cap=3)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), 1)
    counts = np.unique(edges, axis=0, return_counts=True)[1]
    assert np.all(counts == 2)
    assert len(vertices) - len(counts) + len(faces) == 2  # a sphere's Euler characteristic
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() > 0  # outward faces
    assert vertices[:, 1].min() == pytest.approx(-0.05) and vertices[:, 1].max() == pytest.approx(
        0.33
    )


def test_given_radii_are_used():
    pose = forward_kinematics(SKELETONS["quadruped"]())
    n_b = proxy_body(pose).n_capsules
    thin = proxy_body(pose, radii_m=np.full(n_b, 0.02))
    thick = proxy_body(pose, radii_m=np.tile([0.06, 0.03], (n_b, 1)))
    np.testing.assert_allclose(thin.radii_m, 0.02)
    np.testing.assert_allclose(thick.radii_m[:, 1], 0.03)
    np.testing.assert_array_equal(thin.faces, thick.faces)  # fixed topology
    spread = [np.ptp(m.vertices[0], axis=0).sum() for m in (thin, thick)]
    assert spread[1] > spread[0]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"radius_ratio": 0.0}, "radius_ratio"),
        ({"taper": 3.0}, "taper"),
        ({"radii_m": np.ones(3)}, "radii_m"),
        ({"radii_m": -np.ones((25, 2))}, "radii_m"),
    ],
)
def test_bad_parameters_are_named(kwargs, match):
    pose = forward_kinematics(SKELETONS["quadruped"]())
    with pytest.raises(InvalidParameterError, match=match):
        proxy_body(pose, **kwargs)
