"""The body's heading, and the direction of travel as a prior on it.

Two views of a person from the front-left and front-right give nearly the same
silhouettes for the body facing the cameras and for the body turned by 180° with left
and right exchanged: the silhouettes alone cannot tell the heading.  A walking person
faces where they go, and where they go is known without any posture: the silhouettes'
centroids give the body centre on the floor plane in every frame
(:func:`~eigmotion.tracking.position.intersect_plane_lines`).  Its direction of
travel, where the body moves fast enough for the direction to mean something,
penalises the candidate postures that face away from it (:func:`heading_penalty`).

Headings are degrees about the vertical (world Y up): 0 = facing +Z, 90 = facing +X.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera
from eigmotion.tracking.position import intersect_plane_lines, mask_centroid

#: Joints whose left-to-right axes give the facing: (left, right) pairs of the
#: canonical skeleton (the default avatar's ``cmu_mb`` rig), hips and shoulders.
FACING_PAIRS = (("LeftUpLeg", "RightUpLeg"), ("LeftArm", "RightArm"))


def facing_deg(
    joint_positions: np.ndarray,
    joint_names: Sequence[str],
    pairs: Sequence[tuple[str, str]] = FACING_PAIRS,
) -> np.ndarray:
    """(N,) degrees in (-180, 180]: the way each posture's body faces.

    The body's left-to-right axis is the sum of ``left - right`` over ``pairs`` (hips
    and shoulders), projected on the floor; the body faces that axis turned by 90°
    about the vertical (a body facing +Z has its left on +X).

    Parameters
    ----------
    joint_positions : (N, J, 3) float
        Joint positions, metres, world Y up.
    joint_names : sequence of J str
    pairs : sequence of (str, str)
        (left, right) joint names; those present in ``joint_names`` are used.

    Raises
    ------
    InvalidParameterError
        None of ``pairs`` in ``joint_names``.
    """
    names = list(joint_names)
    found = [(names.index(a), names.index(b)) for a, b in pairs if a in names and b in names]
    if not found:
        raise InvalidParameterError(
            f"no left/right joint pair of {list(pairs)} among the joints; the heading "
            "cannot be measured"
        )
    positions = np.asarray(joint_positions, dtype=np.float64)
    across = sum(positions[:, a] - positions[:, b] for a, b in found)
    return np.rad2deg(np.arctan2(-across[:, 2], across[:, 0]))


def angle_difference_deg(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    """``|a - b|`` wrapped into [0, 180] degrees (elementwise)."""
    return np.abs((np.asarray(a, dtype=np.float64) - b + 180.0) % 360.0 - 180.0)


def rough_positions(
    cameras: Sequence[Camera],
    masks: Sequence[np.ndarray],
    frames: np.ndarray,
    height_m: float,
    min_silhouette_px: int,
) -> np.ndarray:
    """(F, 3) body-centre positions at ``frames`` from the silhouettes' centroids alone
    (no posture), world metres; NaN where fewer than two cameras see the person.

    Parameters
    ----------
    cameras : sequence of C Camera
    masks : sequence of C (F', H_c, W_c) bool
        Silhouettes per camera and frame.
    frames : (F,) int
    height_m : float
        Height of the body centre assumed, metres (the plane the rays are projected
        onto; for two cameras or more it hardly moves the answer).
    min_silhouette_px : int
        Smaller silhouettes count as the person not being in view.
    """
    out = np.full((len(frames), 3), np.nan)
    prior = None
    for i, f in enumerate(np.asarray(frames, dtype=np.int64)):
        views = [np.asarray(m[f]) for m in masks]
        seen = [c for c, v in enumerate(views) if v.sum() >= min_silhouette_px]
        if len(seen) < 2:
            continue
        prior = out[i] = intersect_plane_lines(
            [cameras[c] for c in seen],
            np.stack([mask_centroid(views[c]) for c in seen]),
            height_m,
            prior,
        )
    return out


def travel_headings(
    positions_m: np.ndarray,
    times_s: np.ndarray,
    window_s: float,
    min_speed_mps: float,
) -> np.ndarray:
    """(F,) degrees: the direction the body centre travels in at each frame, NaN where
    it moves slower than ``min_speed_mps`` or its position is unknown.

    The velocity at frame ``i`` is the horizontal displacement between the first and
    last known positions within ``times_s[i] ± window_s / 2``, over the time between
    them (a central difference, robust to the centroids' frame-to-frame jitter).

    Parameters
    ----------
    positions_m : (F, 3) float
        Body-centre positions, world metres, Y up (NaN rows: unknown).
    times_s : (F,) float
        Increasing times of the frames, seconds.
    window_s : float
        Length of the window the velocity is measured over, seconds (> 0).
    min_speed_mps : float
        Slower motion gives no direction (NaN), metres per second (≥ 0).
    """
    if not (np.isfinite(window_s) and window_s > 0):
        raise InvalidParameterError(f"window_s must be > 0, got {window_s!r}")
    positions = np.asarray(positions_m, dtype=np.float64)
    times = np.asarray(times_s, dtype=np.float64)
    if positions.shape != (len(times), 3):
        raise InvalidParameterError(
            f"positions of shape {positions.shape} for {len(times)} frame times"
        )
    known = np.flatnonzero(np.all(np.isfinite(positions), axis=1))
    out = np.full(len(times), np.nan)
    for i, t in enumerate(times):
        inside = known[np.abs(times[known] - t) <= window_s / 2 + 1e-9]
        if len(inside) < 2 or times[inside[-1]] <= times[inside[0]]:
            continue
        step = positions[inside[-1]] - positions[inside[0]]
        speed = np.hypot(step[0], step[2]) / (times[inside[-1]] - times[inside[0]])
        if speed >= min_speed_mps and speed > 0:
            out[i] = np.rad2deg(np.arctan2(step[0], step[2]))
    return out


def heading_penalty(
    headings_deg: np.ndarray,
    travel_deg: float,
    tolerance_deg: float,
    weight: float,
) -> np.ndarray:
    """(M,) the score taken off postures that face away from the direction of travel.

    ``weight × max(0, |heading − travel| − tolerance) / 90°``: nothing within the
    tolerance, ``weight`` per 90° beyond it (similarity units: one camera's score is
    at most 1).

    Parameters
    ----------
    headings_deg : (M,) float
        The postures' facing, degrees.
    travel_deg : float
        The direction of travel, degrees; NaN gives no penalty.
    tolerance_deg, weight : float
    """
    headings = np.asarray(headings_deg, dtype=np.float64)
    if not np.isfinite(travel_deg):
        return np.zeros(len(headings))
    excess = np.maximum(angle_difference_deg(headings, travel_deg) - tolerance_deg, 0.0)
    return weight * excess / 90.0
