"""Variable-speed playback: reference frames chosen for every clip frame.

The path through a (clip frame, reference frame) score matrix that never goes back
and steps at most ``max_step`` frames (:func:`monotone_path`, dynamic programming),
the prior on the playback's speed (:func:`speed_costs`), the chosen path smoothed
(:func:`smooth_path`) and a motion sampled at fractional frames
(:func:`sample_motion`).  Used by :mod:`eigmotion.pose.continuous_pose`.
"""

from __future__ import annotations

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.motion import Motion
from eigmotion.mocap.rotations import slerp_matrices


def monotone_path(
    scores: np.ndarray, max_step: int, step_costs: np.ndarray | None = None
) -> np.ndarray:
    """The best non-decreasing path through a score matrix (variable-speed playback).

    Parameters
    ----------
    scores : (F, R) float
        Score of showing reference frame ``r`` at clip frame ``f`` (higher is better;
        ``-inf``: not allowed).
    max_step : int
        Largest step ``r[f + 1] - r[f]``, ≥ 1.
    step_costs : (max_step + 1,) float, optional
        Cost subtracted for each step of ``k`` frames (a prior on the speed); default
        none.

    Returns
    -------
    (F,) int64
        ``r[f]``, non-decreasing, steps at most ``max_step``, maximising
        ``sum_f scores[f, r[f]] - sum_f step_costs[r[f + 1] - r[f]]`` (ties: the
        smaller step).
    """
    scores = np.asarray(scores, dtype=np.float64)
    if scores.ndim != 2 or scores.shape[0] == 0 or scores.shape[1] == 0:
        raise InvalidParameterError(f"scores must be a non-empty (F, R) array, got {scores.shape}")
    if int(max_step) != max_step or max_step < 1:
        raise InvalidParameterError(f"max_step must be an integer >= 1, got {max_step!r}")
    max_step = int(max_step)
    if step_costs is None:
        costs = np.zeros(max_step + 1)
    else:
        costs = np.asarray(step_costs, dtype=np.float64).reshape(-1)
        if costs.shape != (max_step + 1,) or not np.all(np.isfinite(costs)):
            raise InvalidParameterError(
                f"step_costs must be {max_step + 1} finite numbers, got shape {costs.shape}"
            )
    n_f, n_r = scores.shape
    total = scores[0].copy()
    back = np.zeros((n_f, n_r), dtype=np.int64)
    idx = np.arange(n_r)
    for f in range(1, n_f):
        best = total - costs[0]
        arg = idx.copy()
        for k in range(1, min(max_step, n_r - 1) + 1):
            shifted = np.full(n_r, -np.inf)
            shifted[k:] = total[:-k] - costs[k]
            better = shifted > best
            best[better] = shifted[better]
            arg[better] = idx[better] - k
        total = best + scores[f]
        back[f] = arg
    if not np.isfinite(total).any():
        raise InvalidParameterError("no path through the allowed reference frames")
    path = np.empty(n_f, dtype=np.int64)
    path[-1] = int(np.argmax(total))
    for f in range(n_f - 1, 0, -1):
        path[f - 1] = back[f, path[f]]
    return path


def speed_costs(max_step: int, unit_step: float, weight: float) -> np.ndarray:
    """(max_step + 1,) float64: ``weight * |k / unit_step - 1|`` for steps ``k``.

    The playback's prior: the person moves at the reference's speed (a step of
    ``unit_step`` reference frames per clip frame), and every departure from it costs
    in proportion.
    """
    k = np.arange(int(max_step) + 1, dtype=np.float64)
    return float(weight) * np.abs(k / float(unit_step) - 1.0)


def smooth_path(path: np.ndarray, width: int) -> np.ndarray:
    """(F,) float64 moving average (edges held), still non-decreasing."""
    path = np.asarray(path, dtype=np.float64)
    if width <= 1 or len(path) < 2:
        return path
    kernel = np.ones(width) / width
    padded = np.pad(path, (width // 2, width - 1 - width // 2), mode="edge")
    return np.convolve(padded, kernel, mode="valid")


def sample_motion(motion: Motion, frames: np.ndarray, frame_time_s: float) -> Motion:
    """The motion at fractional frames (slerp rotations, lerp translations)."""
    frames = np.clip(np.asarray(frames, dtype=np.float64), 0, motion.n_frames - 1)
    i0 = np.floor(frames).astype(np.int64)
    i1 = np.minimum(i0 + 1, motion.n_frames - 1)
    w = frames - i0
    rot = motion.local_rotations()
    trans = motion.local_translations()
    j = motion.skeleton.n_joints
    r = slerp_matrices(
        rot[i0].reshape(-1, 3, 3), rot[i1].reshape(-1, 3, 3), np.repeat(w, j)
    ).reshape(len(frames), j, 3, 3)
    t = trans[i0] * (1 - w)[:, None, None] + trans[i1] * w[:, None, None]
    return motion.with_local_transforms(r, t, frame_time_s=frame_time_s)
