"""Two-bone inverse kinematics for the limbs of authored motions.

:func:`two_bone_ik` places the middle and end joints of a limb (hip, knee, ankle;
shoulder, elbow, wrist) so that the end reaches a target, the limb bending the way it
is bent; :func:`solve_limb` applies it to one limb of a keyframed motion over all
frames, its targets interpolated between the keys.  Metres, world frame Y up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.kinematics import rest_points
from eigmotion.mocap.motion import Skeleton
from eigmotion.mocap.rotations import euler_to_matrix
from eigmotion.synth.keyframes import pchip_interpolate, unwrap_rotvecs


def unit_vectors(v: np.ndarray) -> np.ndarray:
    """Vectors (..., 3) scaled to length 1 along the last axis; zero vectors stay zero."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _orthogonal(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Component of v (F, 3) orthogonal to unit ``axis`` (F, 3)."""
    return v - np.sum(v * axis, axis=-1, keepdims=True) * axis


@dataclass(frozen=True)
class _Geometry:
    mid: np.ndarray  # (F, 3) new middle joint
    end: np.ndarray  # (F, 3) new end joint
    normal_old: np.ndarray  # (F, 3) unit normal of the current limb plane
    normal: np.ndarray  # (F, 3) unit normal of the new limb plane


def _ik(a, b, c, t, fallback) -> _Geometry:
    l1 = np.linalg.norm(b - a, axis=-1)
    l2 = np.linalg.norm(c - b, axis=-1)
    if np.any(l1 <= 0) or np.any(l2 <= 0):
        raise InvalidParameterError("two-bone IK: a bone of zero length cannot bend")
    axis_old = unit_vectors(c - a)
    pole_old = _orthogonal(b - a, axis_old)
    fb = _orthogonal(fallback, axis_old)
    # Nearly straight: the bend direction of the pose is noise, use the fallback.
    straight = np.linalg.norm(pole_old, axis=-1) < 0.02 * l1
    pole_old[straight] = fb[straight]
    pole_old = unit_vectors(pole_old)
    to_target = t - a
    dist = np.linalg.norm(to_target, axis=-1)
    u = unit_vectors(np.where(dist[:, None] > 1e-9, to_target, c - a))
    pole = _orthogonal(pole_old, u)
    flat = np.linalg.norm(pole, axis=-1) < 1e-6
    pole[flat] = _orthogonal(fallback, u)[flat]
    pole = unit_vectors(pole)
    reach = np.clip(dist, np.abs(l1 - l2) + 1e-9, (l1 + l2) * (1 - 1e-9))
    cos_a = np.clip((l1**2 + reach**2 - l2**2) / (2 * l1 * reach), -1.0, 1.0)
    sin_a = np.sqrt(1.0 - cos_a**2)
    mid = a + l1[:, None] * (cos_a[:, None] * u + sin_a[:, None] * pole)
    end = a + reach[:, None] * u
    return _Geometry(
        mid, end, unit_vectors(np.cross(pole_old, axis_old)), unit_vectors(np.cross(pole, u))
    )


def frame_change(u_old, n_old, u_new, n_new):
    """(F, 3, 3) rotation taking (u_old, n_old) to (u_new, n_new); n ⟂ u assumed."""

    def frame(u, n):
        e1 = unit_vectors(u)
        e2 = unit_vectors(_orthogonal(n, e1))
        return np.stack([e1, e2, np.cross(e1, e2)], axis=-1)

    return frame(u_new, n_new) @ np.swapaxes(frame(u_old, n_old), -1, -2)


def _rest_pole(skeleton: Skeleton, a: int, b: int, c: int) -> np.ndarray:
    """(3,) unit direction from the rest a→c line to the rest middle joint b (+Z if straight)."""
    pts = rest_points(skeleton)
    axis = unit_vectors(pts[c] - pts[a])
    off = pts[b] - pts[a]
    off = off - np.dot(off, axis) * axis
    n = np.linalg.norm(off)
    return off / n if n > 1e-6 else np.array([0.0, 0.0, 1.0])


def solve_limb(
    skeleton, end, per_key, order, key_times, times, key_r, key_p, glob_r, glob_p, local
) -> None:
    """Move one two-bone limb to its interpolated targets; updates ``local`` in place."""
    c = skeleton.index(end)
    b = int(skeleton.parents[c])
    a = int(skeleton.parents[b])
    frame_name = next(t.relative_to for t in per_key if t is not None)
    f = None if frame_name is None else skeleton.index(frame_name)
    perm = ["XYZ".index(x) for x in order]

    def in_frame(rot, pos, k):
        # Key k's own end pose, expressed in the target frame.
        if f is None:
            return pos[k, c], rot[k, c]
        r_f = rot[k, f]
        return r_f.T @ (pos[k, c] - pos[k, f]), r_f.T @ rot[k, c]

    pos_k = np.zeros((len(per_key), 3))
    rot_k = np.zeros((len(per_key), 3))
    use_rotation = any(t is not None and t.rotation_deg is not None for t in per_key)
    for k, target in enumerate(per_key):
        fk_pos, fk_rot = in_frame(key_r, key_p, k)
        pos_k[k] = fk_pos if target is None else target.position_m
        if target is not None and target.rotation_deg is not None:
            m = euler_to_matrix(np.asarray(target.rotation_deg)[perm], order)
        else:
            m = fk_rot
        rot_k[k] = Rotation.from_matrix(m).as_rotvec()
    tgt = pchip_interpolate(key_times, pos_k, times)
    if f is not None:
        tgt = glob_p[:, f] + np.einsum("fab,fb->fa", glob_r[:, f], tgt)
    # A straight limb bends the way it is bent at rest, turned with its upper bone.
    fallback = glob_r[:, a] @ _rest_pole(skeleton, a, b, c)
    geo = _ik(glob_p[:, a], glob_p[:, b], glob_p[:, c], tgt, fallback)
    q_a = frame_change(
        glob_p[:, b] - glob_p[:, a], geo.normal_old, geo.mid - glob_p[:, a], geo.normal
    )
    carried = np.einsum("fab,fb->fa", q_a, glob_p[:, c] - glob_p[:, b])
    q_b = frame_change(carried, geo.normal, geo.end - geo.mid, geo.normal)
    parent_a = int(skeleton.parents[a])
    g_a = q_a @ glob_r[:, a]
    g_b = q_b @ q_a @ glob_r[:, b]
    g_pa = glob_r[:, parent_a] if parent_a >= 0 else np.eye(3)
    local[:, a] = np.swapaxes(g_pa, -1, -2) @ g_a
    local[:, b] = np.swapaxes(g_a, -1, -2) @ g_b
    if use_rotation:
        rv = pchip_interpolate(key_times, unwrap_rotvecs(rot_k), times)
        g_c = Rotation.from_rotvec(rv).as_matrix()
        if f is not None:
            g_c = glob_r[:, f] @ g_c
        local[:, c] = np.swapaxes(g_b, -1, -2) @ g_c


def two_bone_ik(
    root_m: np.ndarray,
    mid_m: np.ndarray,
    end_m: np.ndarray,
    target_m: np.ndarray,
    pole_hint: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Analytic two-bone IK: new middle and end joint positions reaching ``target_m``.

    The bone lengths are those of the current pose; the middle joint bends the way it
    is bent now (towards ``pole_hint`` when the limb is nearly straight); a target out of
    reach is approached along the root→target line.

    Parameters
    ----------
    root_m, mid_m, end_m : (F, 3) float
        Current positions of the limb's joints (e.g. hip, knee, ankle), metres.
    target_m : (F, 3) float
        Wanted end positions, metres.
    pole_hint : (F, 3) or (3,) float, optional
        Direction the middle joint bends towards when the limb is straight; default +Z.

    Returns
    -------
    mid : (F, 3) float64
        New middle joint positions, metres.
    end : (F, 3) float64
        New end positions (the target, or as near as the limb reaches), metres.
    """
    a, b, c, t = (
        np.atleast_2d(np.asarray(x, dtype=np.float64)) for x in (root_m, mid_m, end_m, target_m)
    )
    hint = [0.0, 0.0, 1.0] if pole_hint is None else pole_hint
    hint = np.broadcast_to(np.asarray(hint, dtype=np.float64), a.shape).copy()
    geo = _ik(a, b, c, t, hint)
    return geo.mid, geo.end
