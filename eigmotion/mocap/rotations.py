"""Rotation helpers over stacks of 3×3 matrices.

Conventions: rotation matrices act on column vectors (``v' = R @ v``); Euler angle
orders are written as BVH writes channels, e.g. ``"ZXY"`` means
``R = Rz(a) @ Rx(b) @ Ry(c)`` (intrinsic rotations, first listed is outermost).
Conversions go through :class:`scipy.spatial.transform.Rotation`, whose uppercase
sequences are exactly this intrinsic convention.
"""

from __future__ import annotations

import warnings

import numpy as np

from eigmotion.errors import InvalidParameterError

_AXES = {"X", "Y", "Z"}


def _rotation_class():
    """:class:`scipy.spatial.transform.Rotation`, imported on first use: importing
    ``scipy.spatial`` takes about 0.14 s, which a query that writes no motion never
    needs (``tests/test_motion.py`` checks that the query path does not import it)."""
    from scipy.spatial.transform import Rotation

    return Rotation


def check_euler_order(order: str) -> str:
    """Return ``order`` upper-cased if it names three distinct axes, else raise."""
    order = order.upper()
    if len(order) != 3 or set(order) != _AXES:
        raise InvalidParameterError(
            f"Euler order {order!r} must be a permutation of 'XYZ' (e.g. 'ZXY')"
        )
    return order


def euler_to_matrix(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Euler angles in degrees → rotation matrices.

    Parameters
    ----------
    angles_deg : (..., 3) float
        Angles in degrees, in the order given by ``order``.
    order : str
        Intrinsic axis order, e.g. ``"ZXY"``.

    Returns
    -------
    (..., 3, 3) float64
    """
    angles_deg = np.asarray(angles_deg, dtype=np.float64)
    shape = angles_deg.shape[:-1]
    rot = _rotation_class().from_euler(
        check_euler_order(order), angles_deg.reshape(-1, 3), degrees=True
    )
    return rot.as_matrix().reshape(*shape, 3, 3)


def matrix_to_euler(matrices: np.ndarray, order: str) -> np.ndarray:
    """Rotation matrices → Euler angles in degrees (inverse of :func:`euler_to_matrix`).

    Parameters
    ----------
    matrices : (..., 3, 3) float
    order : str

    Returns
    -------
    (..., 3) float64, degrees.
    """
    matrices = np.asarray(matrices, dtype=np.float64)
    shape = matrices.shape[:-2]
    rot = _rotation_class().from_matrix(matrices.reshape(-1, 3, 3))
    with np.errstate(all="ignore"):
        with warnings.catch_warnings():
            # Gimbal lock is exact and harmless here: scipy picks one of the
            # equivalent angle sets and says so.
            warnings.simplefilter("ignore", UserWarning)
            angles = rot.as_euler(check_euler_order(order), degrees=True)
    return angles.reshape(*shape, 3)


def axis_rotation(axis: str, angle_deg: np.ndarray) -> np.ndarray:
    """Rotation about one principal axis; ``angle_deg`` (...,) → (..., 3, 3)."""
    angle = np.deg2rad(np.asarray(angle_deg, dtype=np.float64))
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    i = "XYZ".index(axis.upper())
    j, k = (i + 1) % 3, (i + 2) % 3
    out[..., i, i] = 1.0
    out[..., j, j] = c
    out[..., k, k] = c
    out[..., j, k] = -s
    out[..., k, j] = s
    return out


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest rotation taking direction ``a`` to direction ``b``.

    Parameters
    ----------
    a, b : (..., 3) float
        Non-zero vectors (need not be unit length).

    Returns
    -------
    (..., 3, 3) float64
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)
    shape = a.shape[:-1]
    out = np.broadcast_to(np.eye(3), shape + (3, 3)).copy()
    vx = np.zeros(shape + (3, 3))
    vx[..., 0, 1], vx[..., 0, 2] = -v[..., 2], v[..., 1]
    vx[..., 1, 0], vx[..., 1, 2] = v[..., 2], -v[..., 0]
    vx[..., 2, 0], vx[..., 2, 1] = -v[..., 1], v[..., 0]
    regular = c > -1.0 + 1e-9
    factor = np.where(regular, 1.0 / np.where(regular, 1.0 + c, 1.0), 0.0)
    out = out + vx + (vx @ vx) * factor[..., None, None]
    if np.any(~regular):
        # Opposite vectors: turn 180° about any axis orthogonal to a.
        a_opp = a[~regular]
        helper = np.where(np.abs(a_opp[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
        axis = np.cross(a_opp, helper)
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        out[~regular] = 2.0 * axis[:, :, None] * axis[:, None, :] - np.eye(3)
    return out


def align_vectors(source: np.ndarray, target: np.ndarray, weights: np.ndarray | None = None):
    """Rotation ``R`` minimising ``sum w |R @ source_i - target_i|²`` (Kabsch).

    Parameters
    ----------
    source, target : (N, 3) float
        N >= 1 paired vectors.  With one pair (or collinear pairs) the smallest
        rotation between them is returned.
    weights : (N,) float, optional

    Returns
    -------
    (3, 3) float64
    """
    source = np.asarray(source, dtype=np.float64).reshape(-1, 3)
    target = np.asarray(target, dtype=np.float64).reshape(-1, 3)
    if len(source) == 1:
        return rotation_between(source[0], target[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        rot, _ = _rotation_class().align_vectors(target, source, weights=weights)
    return rot.as_matrix()


def similarity_align(points: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``points`` moved by the similarity (rotation, uniform scale, translation) that
    brings them closest to ``target`` in the least-squares sense (Umeyama).

    Parameters
    ----------
    points, target : (N, 3) float

    Returns
    -------
    (N, 3) float64
    """
    mean_p, mean_t = points.mean(0), target.mean(0)
    a, b = points - mean_p, target - mean_t
    u, s, vt = np.linalg.svd(a.T @ b)
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rotation = u @ d @ vt
    denominator = (a**2).sum()
    scale = (s * np.diag(d)).sum() / denominator if denominator > 0 else 1.0
    return scale * a @ rotation + mean_t


def slerp_matrices(r0: np.ndarray, r1: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical interpolation between matching stacks of rotations.

    Parameters
    ----------
    r0, r1 : (N, 3, 3) float
    t : (N,) float in [0, 1]

    Returns
    -------
    (N, 3, 3) float64
    """
    rotation = _rotation_class()
    q0 = rotation.from_matrix(r0)
    rel = q0.inv() * rotation.from_matrix(r1)
    step = rotation.from_rotvec(rel.as_rotvec() * np.asarray(t, dtype=np.float64)[:, None])
    return (q0 * step).as_matrix()
