"""Forward kinematics: a :class:`~eigmotion.mocap.motion.Motion` → world joint positions.

World frame: metres, Y up, the floor at y = 0 (the lowest joint or end site over
the whole clip touches it).  The horizontal root path is kept as recorded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.motion import Motion, Skeleton

#: Length units a motion file may be in, metres per unit.  ``cmu_asf`` is the CMU
#: ASF default (``:units length 0.45``: a length L is L / 0.45 inches).
LENGTH_UNITS_M = {
    "m": 1.0,
    "dm": 0.1,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    "foot": 0.3048,
    "cmu_asf": 0.0254 / 0.45,
}

#: Height of a typical adult, metres; unit detection picks the unit that brings the
#: rest-pose skeleton nearest to it (on a log scale).
TYPICAL_HEIGHT_M = 1.7

_Z_UP_TO_Y_UP = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])


@dataclass(frozen=True, eq=False)
class Pose:
    """World-space joints of a posed skeleton over frames.

    Attributes
    ----------
    names : tuple of str
        Joint names, as in the skeleton.
    parents : (J,) int
    positions : (F, J, 3) float64
        Joint positions, metres, Y up, floor at y = 0.
    rotations : (F, J, 3, 3) float64
        Joint world rotations (joint frame → world), relative to the rest pose.
    end_site_joints : (E,) int
        The joint that carries each end site.
    end_sites : (F, E, 3) float64
        End site positions, metres.
    frame_time_s : float
    """

    names: tuple[str, ...]
    parents: np.ndarray
    positions: np.ndarray
    rotations: np.ndarray
    end_site_joints: np.ndarray
    end_sites: np.ndarray
    frame_time_s: float

    @property
    def n_frames(self) -> int:
        return self.positions.shape[0]

    def all_points(self) -> np.ndarray:
        """(F, J + E, 3): joints followed by end sites."""
        return np.concatenate([self.positions, self.end_sites], axis=1)

    def bone_lengths(self) -> np.ndarray:
        """(F, J - 1) float: distance from each non-root joint to its parent, metres."""
        child = np.arange(1, len(self.names))
        return np.linalg.norm(
            self.positions[:, child] - self.positions[:, self.parents[child]], axis=-1
        )


def rest_points(skeleton: Skeleton) -> np.ndarray:
    """(J + E, 3): rest-pose joint then end-site positions in the skeleton's units."""
    pos = np.zeros((skeleton.n_joints, 3))
    for j in range(1, skeleton.n_joints):
        pos[j] = pos[skeleton.parents[j]] + skeleton.offsets[j]
    ends = [pos[j] + off for j, off in sorted(skeleton.end_sites.items())]
    return np.concatenate([pos, np.reshape(ends, (-1, 3))], axis=0)


def detect_length_unit(skeleton: Skeleton, up_axis: str = "y") -> float:
    """Guess metres per length unit from the rest-pose height.

    Parameters
    ----------
    skeleton : Skeleton
    up_axis : {"y", "z"}

    Returns
    -------
    float
        One of :data:`LENGTH_UNITS_M`, the one that makes the skeleton's rest height
        nearest to :data:`TYPICAL_HEIGHT_M`.
    """
    pts = rest_points(skeleton)
    axis = {"y": 1, "z": 2}[_check_up(up_axis)]
    height = float(np.ptp(pts[:, axis]))
    if not height > 0:
        raise InvalidParameterError(
            "cannot detect the length unit: the rest pose has zero height; pass length_unit_m"
        )
    scales = np.array(list(LENGTH_UNITS_M.values()))
    best = np.argmin(np.abs(np.log(height * scales / TYPICAL_HEIGHT_M)))
    return float(scales[best])


def _check_up(up_axis: str) -> str:
    if up_axis not in ("y", "z"):
        raise InvalidParameterError(f"up_axis must be 'y' or 'z', got {up_axis!r}")
    return up_axis


def forward_kinematics(
    motion: Motion,
    length_unit_m: float | None = None,
    up_axis: str = "y",
    ground: bool = True,
) -> Pose:
    """World joint positions and rotations per frame.

    Parameters
    ----------
    motion : Motion
    length_unit_m : float, optional
        Metres per unit; default ``motion.length_unit_m`` or, when that is unknown,
        :func:`detect_length_unit`.
    up_axis : {"y", "z"}
        The file's up axis; Z-up data is turned to Y up.
    ground : bool
        Shift vertically so the lowest joint or end site over the clip is at y = 0.

    Returns
    -------
    Pose
    """
    sk = motion.skeleton
    up_axis = _check_up(up_axis)
    unit = length_unit_m or motion.length_unit_m or detect_length_unit(sk, up_axis)
    local_r = motion.local_rotations()
    local_t = motion.local_translations() * unit
    n_frames, n_joints = motion.n_frames, sk.n_joints
    glob_r = np.empty_like(local_r)
    glob_t = np.empty_like(local_t)
    for j in range(n_joints):
        p = sk.parents[j]
        if p < 0:
            glob_r[:, j] = local_r[:, j]
            glob_t[:, j] = local_t[:, j]
        else:
            glob_r[:, j] = glob_r[:, p] @ local_r[:, j]
            glob_t[:, j] = glob_t[:, p] + np.einsum("fab,fb->fa", glob_r[:, p], local_t[:, j])
    end_joints = np.array(sorted(sk.end_sites), dtype=np.int64)
    if len(end_joints):
        offs = np.stack([sk.end_sites[j] for j in end_joints]) * unit
        ends = glob_t[:, end_joints] + np.einsum("feab,eb->fea", glob_r[:, end_joints], offs)
    else:
        ends = np.zeros((n_frames, 0, 3))
    if up_axis == "z":
        glob_t = glob_t @ _Z_UP_TO_Y_UP.T
        ends = ends @ _Z_UP_TO_Y_UP.T
        glob_r = _Z_UP_TO_Y_UP @ glob_r @ _Z_UP_TO_Y_UP.T
    if ground:
        floor = min(glob_t[..., 1].min(), ends[..., 1].min() if ends.size else np.inf)
        glob_t = glob_t - [0.0, floor, 0.0]
        ends = ends - [0.0, floor, 0.0]
    return Pose(sk.names, sk.parents, glob_t, glob_r, end_joints, ends, motion.frame_time_s)
