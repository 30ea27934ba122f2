"""Body joints in 3D from the pose network's 2D landmarks in two or more calibrated views.

The front end that cuts the person out (``--segmenter auto``: learned or fused) runs
MediaPipe's pose landmark network on every frame of every camera; its 33 landmarks
per frame (x, y in frame pixels, visibility, presence) are triangulated here, joint by
joint, with the calibrated cameras:

1. A view's landmark takes part only where its visibility and presence are both at
   least :attr:`TriangulationConfig.min_confidence`.
2. Each joint seen by two views or more is triangulated by the direct linear
   transform, each view's two equations weighted by its visibility.
3. The network mixes up the person's left and right, in one view and not the other
   (on the development set in 13-54 % of the frames of a view).  Left/right pairs
   come in two groups (legs: hips, knees, ankles; arms: shoulders, elbows, wrists);
   per group, every assignment of the views (each as labelled or with left and right
   exchanged) is a state of a path over the clip: a frame's state costs its
   reprojection residual plus its distance to the silhouette tracker's estimate, a
   change of state the jump of the group's top joints (hips, shoulders) from the
   frame before, and the cheapest path is kept (:func:`triangulate_clip`).  The
   residual tells which views disagree; the tracker and the jumps tell which side is
   the person's left.
4. A joint whose reprojection residual (the largest over its views) exceeds
   :attr:`TriangulationConfig.max_residual_frac` of the image's longer side is not
   trusted; with three views or more, the view farthest off is dropped first and the
   joint triangulated again.

Joints are returned in the order of :data:`KEYPOINT_JOINTS` (the names of the
tracker's canonical skeleton), world metres, NaN where not trusted.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import product
from numbers import Real
from typing import ClassVar

import numpy as np

from eigmotion.imaging.cameras import Camera
from eigmotion.validation import Interval, validate_params

#: Skeleton joint -> the pose network's landmark (MediaPipe's order; left and right
#: are the person's); ``Head`` is the midpoint of the two ears.
KEYPOINT_LANDMARKS: dict[str, tuple[int, ...]] = {
    "LeftUpLeg": (23,),
    "RightUpLeg": (24,),
    "LeftLeg": (25,),
    "RightLeg": (26,),
    "LeftFoot": (27,),
    "RightFoot": (28,),
    "LeftArm": (11,),
    "RightArm": (12,),
    "LeftForeArm": (13,),
    "RightForeArm": (14,),
    "LeftHand": (15,),
    "RightHand": (16,),
    "Head": (7, 8),
}

#: The joints triangulated, in the order of :func:`triangulate_clip`'s output.
KEYPOINT_JOINTS = tuple(KEYPOINT_LANDMARKS)

#: Left/right groups: (left joint, right joint) pairs, the first pair the group's top.
SIDE_GROUPS: tuple[tuple[tuple[str, str], ...], ...] = (
    (("LeftUpLeg", "RightUpLeg"), ("LeftLeg", "RightLeg"), ("LeftFoot", "RightFoot")),
    (("LeftArm", "RightArm"), ("LeftForeArm", "RightForeArm"), ("LeftHand", "RightHand")),
)

_INDEX = {name: k for k, name in enumerate(KEYPOINT_JOINTS)}


@dataclass(frozen=True)
class TriangulationConfig:
    """When a view's landmark and a triangulated joint are trusted.

    Parameters
    ----------
    min_confidence : float
        A view's landmark takes part when its visibility and presence are both at
        least this (probabilities).
    max_residual_frac : float
        A joint is not trusted when its reprojection residual in some view exceeds
        this fraction of that image's longer side.
    track_weight : float
        Weight of the distance to the tracker's estimate, against the jump between
        frames, when deciding which side is the person's left.
    """

    min_confidence: float = 0.5
    max_residual_frac: float = 0.03
    track_weight: float = 0.5

    _parameter_constraints: ClassVar[dict] = {
        "min_confidence": Interval(Real, 0.0, 1.0, noun="a probability"),
        "max_residual_frac": Interval(Real, 0.0, 1.0, closed="right", noun="a fraction"),
        "track_weight": Interval(Real, 0.0, None, noun="a weight"),
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints)


def projection_matrix(camera: Camera) -> np.ndarray:
    """(3, 4) ``K [R | t]`` of a camera: world metres to homogeneous pixels."""
    return camera.K @ np.hstack([camera.R, camera.t.reshape(3, 1)])


def triangulate_points(
    projections: np.ndarray, pixels: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """Points from their pixels in several views, by the weighted direct linear transform.

    Parameters
    ----------
    projections : (V, 3, 4) float
        Each view's projection matrix (:func:`projection_matrix`).
    pixels : (N, V, 2) float
        Each point's (u, v) in each view, pixels (the cameras' convention: the first
        pixel's centre at 0).
    weights : (N, V) float, or broadcast to it
        Each view's weight per point; 0 leaves the view out.

    Returns
    -------
    (N, 3) float64
        World points, metres; NaN where fewer than two views have weight.
    """
    projections = np.asarray(projections, dtype=np.float64)
    pixels = np.asarray(pixels, dtype=np.float64)
    weights = np.broadcast_to(np.asarray(weights, dtype=np.float64), pixels.shape[:2])
    weights = np.where(np.isfinite(weights), weights, 0.0)
    pixels = np.where(np.isfinite(pixels), pixels, 0.0)
    u, v = pixels[..., 0:1], pixels[..., 1:2]
    rows_u = u * projections[None, :, 2] - projections[None, :, 0]  # (N, V, 4)
    rows_v = v * projections[None, :, 2] - projections[None, :, 1]
    w = weights[..., None]
    a = np.concatenate([rows_u * w, rows_v * w], axis=1)  # (N, 2V, 4)
    a /= np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-12)
    _, _, vt = np.linalg.svd(a)
    h = vt[:, -1]
    with np.errstate(divide="ignore", invalid="ignore"):
        points = h[:, :3] / h[:, 3:4]
    points[(weights > 0).sum(axis=1) < 2] = np.nan
    return points


def reprojection_residuals(
    projections: np.ndarray, points: np.ndarray, pixels: np.ndarray
) -> np.ndarray:
    """(N, V) distance in pixels between each point's projection and its pixels."""
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1)
    projected = np.einsum("vij,nj->nvi", projections, homogeneous)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = projected[..., :2] / projected[..., 2:3]
    return np.linalg.norm(uv - pixels, axis=-1)


def _view_arrays(
    landmarks: Sequence[np.ndarray], min_confidence: float
) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (F, K, V, 2) (cameras' convention) and weights (F, K, V) of every view's
    landmarks (F, 33, 4) for :data:`KEYPOINT_JOINTS`: the mean of a joint's landmarks,
    its weight the least visibility of them, 0 below ``min_confidence``."""
    pixels, weights = [], []
    for marks in landmarks:
        marks = np.asarray(marks, dtype=np.float64)
        groups = [list(ids) for ids in KEYPOINT_LANDMARKS.values()]
        px = np.stack([marks[:, ids, :2].mean(axis=1) for ids in groups], 1)
        vis = np.stack([marks[:, ids, 2].min(axis=1) for ids in groups], 1)
        pres = np.stack([marks[:, ids, 3].min(axis=1) for ids in groups], 1)
        with np.errstate(invalid="ignore"):
            ok = (np.minimum(vis, pres) >= min_confidence) & np.isfinite(px).all(axis=-1)
        pixels.append(px - 0.5)  # continuous (0 at the first pixel's edge) -> centres at 0
        weights.append(np.where(ok, vis, 0.0))
    return np.stack(pixels, axis=2), np.stack(weights, axis=2)


def _exchange(values: np.ndarray, group: int, axis: int = 1) -> np.ndarray:
    """``values`` with the left and right joints (along ``axis``) of a side group
    exchanged."""
    out = values.copy()
    for left, right in SIDE_GROUPS[group]:
        a, b = _INDEX[left], _INDEX[right]
        index_a = (slice(None),) * axis + (a,)
        index_b = (slice(None),) * axis + (b,)
        out[index_a], out[index_b] = values[index_b], values[index_a]
    return out


def _group_rows(group: int) -> list[int]:
    return [_INDEX[name] for pair in SIDE_GROUPS[group] for name in pair]


@dataclass(frozen=True, eq=False)
class TriangulatedJoints:
    """Joints triangulated per frame.

    Attributes
    ----------
    positions_m : (F, K, 3) float64
        :data:`KEYPOINT_JOINTS` per frame, world metres, NaN where not trusted.
    residuals_px : (F, K) float64
        Largest reprojection residual over the views used, pixels (NaN where fewer
        than two views saw the joint).
    exchanged : (F, V, G) bool
        Per frame, view and side group: the view's left and right were exchanged.
    """

    positions_m: np.ndarray
    residuals_px: np.ndarray
    exchanged: np.ndarray

    @property
    def trusted(self) -> np.ndarray:
        """(F, K) bool: the joint was triangulated and trusted."""
        return np.isfinite(self.positions_m).all(axis=-1)


def _triangulate_many(projections, pixels, weights):
    """Points (F, R, 3) and residuals (F, R, V) of pixels (F, R, V, 2), weights (F, R, V)."""
    f, r, v = weights.shape
    points = triangulate_points(projections, pixels.reshape(f * r, v, 2), weights.reshape(f * r, v))
    residuals = reprojection_residuals(projections, points, pixels.reshape(f * r, v, 2))
    return points.reshape(f, r, 3), residuals.reshape(f, r, v)


def _viterbi(unary: np.ndarray, tops: np.ndarray) -> np.ndarray:
    """(F,) the cheapest path through states (unary: (S, F) costs), each change of
    state costing how far the top joints ``tops`` (S, F, 2, 3) would jump (metres,
    from the last frame where the state's were found)."""
    n_states, n = unary.shape
    cost = unary[:, 0].copy()
    back = np.zeros((n, n_states), np.int64)
    last = tops[:, 0]
    for f in range(1, n):
        jump = np.linalg.norm(tops[None, :, f] - last[:, None], axis=-1).mean(axis=-1)
        total = cost[:, None] + np.nan_to_num(jump, nan=0.0)
        back[f] = np.argmin(total, axis=0)
        cost = total[back[f], np.arange(n_states)] + unary[:, f]
        seen = np.isfinite(tops[:, f]).all(axis=(-1, -2))
        last = np.where(seen[:, None, None], tops[:, f], last[back[f]])
    path = np.empty(n, np.int64)
    state = int(np.argmin(cost))
    for f in range(n - 1, -1, -1):
        path[f] = state
        state = back[f, state]
    return path


def triangulate_clip(
    cameras: Sequence[Camera],
    landmarks: Sequence[np.ndarray],
    tracked: np.ndarray,
    config: TriangulationConfig = TriangulationConfig(),  # noqa: B008 - frozen
) -> TriangulatedJoints:
    """Every frame's :data:`KEYPOINT_JOINTS` from the views' landmarks (the module's
    steps 1–4).

    Per side group, every assignment of the views (each as labelled or exchanged) is a
    state; a frame's state costs its reprojection residual (each joint's largest,
    over the residual limit, capped at 1; 1 for a joint it leaves untriangulated) plus
    ``track_weight`` times the distance of its joints to the tracker's (metres); a
    change of state between frames costs how far the group's top joints (hips,
    shoulders) jump.  The cheapest path over the clip is kept (Viterbi).

    Parameters
    ----------
    cameras : sequence of Camera
        V ≥ 2.
    landmarks : sequence of (F, 33, 4) float
        Per camera, the frames' landmarks (x, y in frame pixels, continuous;
        visibility; presence); NaN where the network saw no one.
    tracked : (F, K, 3) float
        The tracker's estimate of :data:`KEYPOINT_JOINTS` in the same frames, metres.
    config : TriangulationConfig
    """
    projections = np.stack([projection_matrix(c) for c in cameras])
    limits = np.array([config.max_residual_frac * max(c.width, c.height) for c in cameras])
    pixels, weights = _view_arrays(landmarks, config.min_confidence)
    n, _, n_views = weights.shape
    exchanged = np.zeros((n, n_views, len(SIDE_GROUPS)), bool)
    tracked = np.asarray(tracked, dtype=np.float64)
    if n == 0:
        return TriangulatedJoints(
            np.zeros((0, len(KEYPOINT_JOINTS), 3)), np.zeros((0, len(KEYPOINT_JOINTS))), exchanged
        )
    for g in range(len(SIDE_GROUPS)):
        rows = _group_rows(g)
        states = list(product((False, True), repeat=n_views))
        unary = np.zeros((len(states), n))
        tops = np.zeros((len(states), n, 2, 3))
        for s, flips in enumerate(states):
            px, wt = pixels.copy(), weights.copy()
            for v in np.flatnonzero(flips):
                px[:, :, v] = _exchange(pixels[:, :, v], g)
                wt[:, :, v] = _exchange(weights[:, :, v], g)
            points, residual = _triangulate_many(projections, px[:, rows], wt[:, rows])
            found = np.isfinite(points).all(axis=-1)
            off = np.where(wt[:, rows] > 0, np.minimum(residual / limits, 1.0), 0.0).max(axis=-1)
            gap = np.where(found, np.linalg.norm(points - tracked[:, rows], axis=-1), 0.0)
            gap = np.nan_to_num(gap).sum(axis=1) / np.maximum(found.sum(axis=1), 1)
            unary[s] = np.where(found, off, 1.0).sum(axis=1) + config.track_weight * gap
            tops[s] = points[:, :2]
        path = _viterbi(unary, tops)
        for v in range(n_views):
            chosen = np.array([states[s][v] for s in path], bool)
            exchanged[:, v, g] = chosen
            pixels[chosen, :, v] = _exchange(pixels[chosen, :, v], g)
            weights[chosen, :, v] = _exchange(weights[chosen, :, v], g)
    points, residuals = _triangulate_many(projections, pixels, weights)
    for _ in range(n_views - 2):  # drop the view farthest off, where more remain
        off = np.where(weights > 0, residuals / limits, -1.0)
        bad = off.max(axis=-1) > 1.0
        if not bad.any():
            break
        worst = np.argmax(off, axis=-1)
        f, k = np.nonzero(bad)
        weights[f, k, worst[f, k]] = 0.0
        points, residuals = _triangulate_many(projections, pixels, weights)
    used = weights > 0
    off = np.where(used, residuals / limits, 0.0).max(axis=-1)
    largest = np.where(used.sum(axis=-1) >= 2, np.where(used, residuals, 0.0).max(axis=-1), np.nan)
    points[~(off <= 1.0) | ~np.isfinite(largest)] = np.nan
    return TriangulatedJoints(points, largest, exchanged)
