"""Key poses of authored motions and their interpolation between keys.

A :class:`Key` gives joint rotations (Euler degrees ``(x, y, z)`` relative to rest),
a root offset and IK :class:`Target` s at one time; :func:`eigmotion.synth.authoring.animate`
completes and interpolates them with monotone piecewise-cubic Hermite splines
(:func:`pchip_interpolate`), rotations as rotation vectors made continuous by
:func:`unwrap_rotvecs`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.spatial.transform import Rotation

from eigmotion.errors import InvalidParameterError


@dataclass(frozen=True)
class Target:
    """Where the end joint of a two-bone limb must be, in a key.

    Parameters
    ----------
    position_m : (3,) float
        Position of the end joint (ankle, wrist), metres, in the frame of
        ``relative_to``: the world when ``None``, else that joint's frame (origin at the
        joint, axes parallel to the world at rest and turning with the joint).
    relative_to : str, optional
        A joint outside every IK limb (e.g. ``"Spine"``, ``"Head"``); the same for all
        keys that give a target to this limb.
    rotation_deg : (3,) float, optional
        Orientation of the end joint relative to its rest orientation, Euler degrees
        ``(x, y, z)`` in the key order, in the same frame as ``position_m``: ``(0, 0, 0)``
        keeps a foot flat on the floor.  ``None``: the end joint keeps the rotation
        relative to its parent that the keys give it.
    """

    position_m: tuple[float, float, float]
    relative_to: str | None = None
    rotation_deg: tuple[float, float, float] | None = None

    def __post_init__(self):
        pos = np.asarray(self.position_m, dtype=np.float64)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise InvalidParameterError(
                f"Target position_m must be 3 finite numbers (metres), got {self.position_m!r}"
            )
        object.__setattr__(self, "position_m", tuple(float(v) for v in pos))
        if self.rotation_deg is not None:
            rot = np.asarray(self.rotation_deg, dtype=np.float64)
            if rot.shape != (3,) or not np.all(np.isfinite(rot)):
                raise InvalidParameterError(
                    f"Target rotation_deg must be 3 finite angles (degrees), "
                    f"got {self.rotation_deg!r}"
                )
            object.__setattr__(self, "rotation_deg", tuple(float(v) for v in rot))


@dataclass(frozen=True)
class Key:
    """One key pose.

    Parameters
    ----------
    time_s : float
        Time of the key, seconds.
    rotations_deg : mapping of str to (3,) float
        Joint name → rotation relative to rest, Euler degrees ``(x, y, z)``.  The root
        joint's rotation turns the whole body.  Joints not named keep the previous key's
        rotation (rest in the first key).
    root_offset_m : (3,) float, optional
        Displacement of the root from where it is when standing at the origin, metres.
        Not given: the previous key's (zero in the first key).
    targets : mapping of str to Target or None
        End joint of a two-bone limb (``"LeftFoot"``, ``"RightHand"`` …) → its target;
        ``None`` releases a limb.  Limbs not named keep the previous key's target.
    """

    time_s: float
    rotations_deg: Mapping[str, Sequence[float]] = field(default_factory=dict)
    root_offset_m: Sequence[float] | None = None
    targets: Mapping[str, Target | None] = field(default_factory=dict)

    def __post_init__(self):
        if not np.isfinite(self.time_s):
            raise InvalidParameterError(f"Key time_s must be finite, got {self.time_s!r}")
        rots = {}
        for joint, angles in dict(self.rotations_deg).items():
            a = np.asarray(angles, dtype=np.float64)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise InvalidParameterError(
                    f"key at {self.time_s} s: rotation of {joint!r} must be 3 finite angles "
                    f"(x, y, z degrees), got {angles!r}"
                )
            rots[joint] = tuple(float(v) for v in a)
        object.__setattr__(self, "rotations_deg", rots)
        if self.root_offset_m is not None:
            off = np.asarray(self.root_offset_m, dtype=np.float64)
            if off.shape != (3,) or not np.all(np.isfinite(off)):
                raise InvalidParameterError(
                    f"key at {self.time_s} s: root_offset_m must be 3 finite numbers (metres), "
                    f"got {self.root_offset_m!r}"
                )
            object.__setattr__(self, "root_offset_m", tuple(float(v) for v in off))
        targets = dict(self.targets)
        for joint, target in targets.items():
            if target is not None and not isinstance(target, Target):
                raise InvalidParameterError(
                    f"key at {self.time_s} s: target of {joint!r} must be a Target or None, "
                    f"got {type(target).__name__}"
                )
        object.__setattr__(self, "targets", targets)


def pchip_interpolate(key_times: np.ndarray, values: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Monotone cubic interpolation along axis 0 (values (K, ...) → (F, ...))."""
    return PchipInterpolator(key_times, values, axis=0)(times)


def interpolate_rotations(key_times, rot_k, times) -> np.ndarray:
    """(F, J, 3, 3) local rotations from per-key rotation vectors (K, J, 3)."""
    rv = pchip_interpolate(key_times, rot_k, times)
    return Rotation.from_rotvec(rv.reshape(-1, 3)).as_matrix().reshape(*rv.shape[:2], 3, 3)


def unwrap_rotvecs(rv: np.ndarray) -> np.ndarray:
    """Rotation vectors made continuous along the first axis, for interpolation.

    Parameters
    ----------
    rv : (K, ..., 3) float
        Rotation vectors, radians, in key order.

    Returns
    -------
    (K, ..., 3) float64
        Each vector replaced by its equivalent (the same rotation, 2π longer or shorter)
        nearest the previous one, so that interpolating them takes the short way round.
    """
    rv = np.array(rv, dtype=np.float64)
    for i in range(1, len(rv)):
        cur = rv[i]
        angle = np.linalg.norm(cur, axis=-1, keepdims=True)
        alt = cur - 2 * np.pi * cur / np.where(angle > 0, angle, 1.0)
        flip = np.linalg.norm(alt - rv[i - 1], axis=-1) < np.linalg.norm(cur - rv[i - 1], axis=-1)
        rv[i] = np.where(flip[..., None], alt, cur)
    return rv
