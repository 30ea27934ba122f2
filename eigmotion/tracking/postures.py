"""Postures as vectors, and the posture distances d1 and d2 (the paper's section 2.2).

A posture is the set of joint rotations of the canonical skeleton (the avatar's): each
joint's rotation relative to its parent, relative to the rest pose (joint frames are
world-aligned at rest, see :mod:`eigmotion.mocap.motion`).  For comparisons a posture is
written as one vector ``r`` in degrees:

* ``r[0]`` — the heading: the yaw of the body's forward axis (+Z at rest) about +Y,
  in (-180, 180];
* ``r[1:4]`` — the rest of the root's rotation (its tilt, the root rotation with the
  heading taken out) as a rotation vector (axis × angle);
* then, per joint of :attr:`eigmotion.tracking.dictionary.PostureDictionary.vector_joints`,
  the rotation vector of its local rotation.

The paper's posture difference (its equation 1) is ``d1(a, b) = max_i |r_ai - r_bi|``,
degrees, with the heading difference wrapped into [0, 180].  Rotation vectors are
continuous for rotations below 180°, which joint rotations relative to the rest pose
stay within for human motion; the heading is the one angle that goes all the way
round, hence its separate, wrapped component.

The paper's second distance (its equation 2), ``d2(a, b)``, is the largest distance
between matching joints of the two postures (root at the origin) after a parallel
projection onto a camera's image plane, metres; over several cameras, the largest.

World frame: metres, Y up, the body at rest facing +Z, its left towards +X.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from eigmotion.errors import InvalidParameterError


def yaw_rotation(angle_deg: np.ndarray) -> np.ndarray:
    """Rotations about +Y; ``angle_deg`` (...,) → (..., 3, 3) float64."""
    a = np.deg2rad(np.asarray(angle_deg, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    out[..., 0, 0] = c
    out[..., 0, 2] = s
    out[..., 1, 1] = 1.0
    out[..., 2, 0] = -s
    out[..., 2, 2] = c
    return out


def heading_deg(root_rotations: np.ndarray) -> np.ndarray:
    """Heading of the body, degrees in (-180, 180].

    Parameters
    ----------
    root_rotations : (..., 3, 3) float
        World rotations of the root relative to its rest orientation.

    Returns
    -------
    (...,) float64
        Angle about +Y from +Z towards +X of the rotated forward axis (+Z).
    """
    r = np.asarray(root_rotations, dtype=np.float64)
    return np.rad2deg(np.arctan2(r[..., 0, 2], r[..., 2, 2]))


def wrap_deg(angle_deg: np.ndarray) -> np.ndarray:
    """Angles wrapped into (-180, 180], degrees."""
    a = np.asarray(angle_deg, dtype=np.float64)
    return 180.0 - np.mod(180.0 - a, 360.0)


def posture_vectors(local_rotations: np.ndarray, joint_ids: Sequence[int]) -> np.ndarray:
    """Posture vectors ``r`` (see the module docstring) of stacked postures.

    Parameters
    ----------
    local_rotations : (N, J, 3, 3) float
        Joint rotations relative to the parent joint (the root's: to the world),
        relative to the rest pose; joint 0 is the root.
    joint_ids : sequence of int
        Non-root joints whose rotations enter the vector, in order.

    Returns
    -------
    (N, 4 + 3 * len(joint_ids)) float64, degrees.
    """
    rot = np.asarray(local_rotations, dtype=np.float64)
    if rot.ndim != 4 or rot.shape[2:] != (3, 3):
        raise InvalidParameterError(f"local_rotations must be (N, J, 3, 3), got {rot.shape}")
    n = rot.shape[0]
    joint_ids = np.asarray(joint_ids, dtype=np.int64)
    if np.any(joint_ids <= 0) or np.any(joint_ids >= rot.shape[1]):
        raise InvalidParameterError(f"joint_ids must lie in [1, {rot.shape[1]}), got {joint_ids}")
    yaw = heading_deg(rot[:, 0])
    tilt = np.einsum("nba,nbc->nac", yaw_rotation(yaw), rot[:, 0])  # Ry(-yaw) @ root
    out = np.empty((n, 4 + 3 * len(joint_ids)))
    out[:, 0] = yaw
    out[:, 1:4] = np.rad2deg(Rotation.from_matrix(tilt).as_rotvec())
    if len(joint_ids):
        rv = Rotation.from_matrix(rot[:, joint_ids].reshape(-1, 3, 3)).as_rotvec()
        out[:, 4:] = np.rad2deg(rv).reshape(n, -1)
    return out


def d1_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The paper's posture difference d1, degrees, broadcasting over leading axes.

    Parameters
    ----------
    a, b : (..., D) float
        Posture vectors (:func:`posture_vectors`); the heading ``[..., 0]`` is compared
        modulo 360°.

    Returns
    -------
    (...,) float64
        ``max_i |a_i - b_i|``, degrees.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    heading = np.abs(wrap_deg(a[..., 0] - b[..., 0]))
    rest = np.abs(a[..., 1:] - b[..., 1:]).max(axis=-1, initial=0.0)
    return np.maximum(heading, rest)


def d1_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(M, K) float64: d1 between every row of ``a`` (M, D) and of ``b`` (K, D), degrees."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return d1_distance(a[:, None, :], b[None, :, :])


def projected_joints(joint_positions: np.ndarray, view_rotations: np.ndarray) -> np.ndarray:
    """Parallel projection of root-relative joints onto each camera's image plane.

    Parameters
    ----------
    joint_positions : (N, J, 3) float
        Joint positions relative to the root, world axes, metres.
    view_rotations : (C, 3, 3) float
        World → camera rotations ``R`` of the cameras.

    Returns
    -------
    (N, C, J, 2) float64
        Camera x (right) and y (down) coordinates, metres.
    """
    p = np.asarray(joint_positions, dtype=np.float64)
    r = np.asarray(view_rotations, dtype=np.float64).reshape(-1, 3, 3)[:, :2]
    n, j = p.shape[0], p.shape[1]
    flat = p.reshape(-1, 3) @ r.reshape(-1, 3).T  # (N J, C 2)
    return flat.reshape(n, j, len(r), 2).transpose(0, 2, 1, 3)


def d2_distance(projected_a: np.ndarray, projected_b: np.ndarray) -> np.ndarray:
    """The paper's d2, metres: the largest projected joint distance over joints and cameras.

    Parameters
    ----------
    projected_a, projected_b : (..., C, J, 2) float
        From :func:`projected_joints`, broadcasting over leading axes.

    Returns
    -------
    (...,) float64
    """
    diff = np.asarray(projected_a) - np.asarray(projected_b)
    return np.sqrt(np.max(np.sum(diff * diff, axis=-1), axis=(-2, -1)))


def prune_postures(vectors: np.ndarray, threshold_deg: float) -> np.ndarray:
    """Indices of postures kept after dropping near-duplicates (d1 below a threshold).

    Greedy in the given order: a posture is kept unless a posture already kept is
    within ``threshold_deg`` of it (d1 < threshold).

    Parameters
    ----------
    vectors : (N, D) float
        Posture vectors, degrees.
    threshold_deg : float
        ≥ 0; 0 keeps every posture.

    Returns
    -------
    (K,) int64, increasing.
    """
    vectors = np.asarray(vectors, dtype=np.float64)
    if not (np.isfinite(threshold_deg) and threshold_deg >= 0):
        raise InvalidParameterError(f"threshold_deg must be >= 0, got {threshold_deg!r}")
    n = len(vectors)
    if threshold_deg == 0 or n == 0:
        return np.arange(n, dtype=np.int64)
    kept = np.empty((n, vectors.shape[1]))
    ids = []
    for i in range(n):
        if ids and d1_distance(kept[: len(ids)], vectors[i]).min() < threshold_deg:
            continue
        kept[len(ids)] = vectors[i]
        ids.append(i)
    return np.asarray(ids, dtype=np.int64)


def chain_rotations(local_rotations: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """World rotations (N, J, 3, 3) from local ones (N, J, 3, 3) along a joint tree."""
    local_rotations = np.asarray(local_rotations, dtype=np.float64)
    out = np.empty_like(local_rotations)
    for j, p in enumerate(parents):
        out[:, j] = local_rotations[:, j] if p < 0 else out[:, p] @ local_rotations[:, j]
    return out


def relative_joint_positions(
    world_rotations: np.ndarray, rest_joints: np.ndarray, parents: np.ndarray
) -> np.ndarray:
    """(N, J, 3) joint positions with the root at the origin, metres.

    Parameters
    ----------
    world_rotations : (N, J, 3, 3) float
        World rotation of each joint relative to its rest orientation.
    rest_joints : (J, 3) float
        Rest joint positions, metres (bone lengths come from these).
    parents : (J,) int
    """
    rest_joints = np.asarray(rest_joints, dtype=np.float64)
    out = np.zeros(world_rotations.shape[:2] + (3,))
    for j, p in enumerate(parents):
        if p >= 0:
            out[:, j] = out[:, p] + world_rotations[:, p] @ (rest_joints[j] - rest_joints[p])
    return out


def mean_heading_deg(root_rotations: np.ndarray) -> float:
    """Circular mean of the heading over frames, degrees."""
    h = np.deg2rad(heading_deg(root_rotations))
    return float(np.rad2deg(np.arctan2(np.sin(h).mean(), np.cos(h).mean())))
