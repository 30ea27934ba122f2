"""The paper's silhouette similarity (its equation 4) and the per-camera view.

For camera ``c`` and candidate posture ``m``, with ``S1`` the candidate silhouette
shifted by ``(x, y)``, ``S2`` the observed silhouette and ``R`` the rectangle enclosing
all candidates' silhouettes::

    s_c(m) = max over (x, y) in D of
             A(S1 ∩ S2) / A(S1)  -  A(R ∩ S2 \\ S1) / A(R \\ S1)

the density of observed pixels inside the candidate minus their density in the rest of
the rectangle; ``s(m) = sum_c s_c(m)``.  Each term lies in [-1, 1].  The shift search
absorbs the error of the estimated 3D position.

All counts are taken inside ``R``: the arrays given to :func:`similarity` and
:func:`score_masks` ARE the rectangle.  A candidate pixel shifted out of it counts in
``A(S1)`` but in no other area.  The observed silhouette may be fractional (a block
average of the full-resolution mask when the rectangle is sampled at a reduced
resolution); areas are then sums of weights.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera

#: Score of a candidate whose silhouette is empty (the lowest possible).
EMPTY_SCORE = -1.0


def similarity(
    observed: np.ndarray, candidate: np.ndarray, shift_radius_px: int = 0
) -> tuple[float, tuple[int, int]]:
    """The similarity of one candidate silhouette in one view (equation 4 of the paper).

    Parameters
    ----------
    observed : (H, W) bool or float
        Observed silhouette over the rectangle ``R`` (weights in [0, 1]).
    candidate : (H, W) bool
        Candidate silhouette over the same rectangle, unshifted.
    shift_radius_px : int
        The shift neighbourhood ``D``: every ``(dx, dy)`` with ``|dx|, |dy| <= r``.

    Returns
    -------
    score : float
        In [-1, 1]; :data:`EMPTY_SCORE` for an empty candidate.
    shift : (int, int)
        The best ``(dx, dy)``, pixels (ties: the first in row-major order of dy, dx).
    """
    observed = np.asarray(observed)
    candidate = np.asarray(candidate)
    if observed.ndim != 2 or observed.shape != candidate.shape:
        raise InvalidParameterError(
            f"observed {observed.shape} and candidate {candidate.shape} must be equal (H, W)"
        )
    scores, shifts = score_masks(observed, candidate[None], shift_radius_px)
    return float(scores[0]), (int(shifts[0, 0]), int(shifts[0, 1]))


def score_masks(
    observed: np.ndarray, candidates: np.ndarray, shift_radius_px: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Similarity of many candidate silhouettes against one observed silhouette.

    Parameters
    ----------
    observed : (H, W) bool or float
        Observed silhouette over the rectangle ``R``.
    candidates : (M, H, W) bool
        Candidate silhouettes over the same rectangle.
    shift_radius_px : int
        Half-width of the square shift neighbourhood ``D``, pixels, ≥ 0.

    Returns
    -------
    scores : (M,) float64
        Per candidate, the best score over the shifts.
    shifts : (M, 2) int64
        The best ``(dx, dy)`` per candidate, pixels.
    """
    r = int(shift_radius_px)
    if r < 0 or r != shift_radius_px:
        raise InvalidParameterError(
            f"shift_radius_px must be an integer >= 0, got {shift_radius_px!r}"
        )
    obs = np.asarray(observed, dtype=np.float32)
    cands = np.asarray(candidates, dtype=bool)
    if cands.ndim != 3 or cands.shape[1:] != obs.shape:
        raise InvalidParameterError(
            f"candidates must be (M, {obs.shape[0]}, {obs.shape[1]}), got {cands.shape}"
        )
    scores = np.full(len(cands), EMPTY_SCORE)
    shifts = np.zeros((len(cands), 2), dtype=np.int64)
    if len(cands):
        _score_kernel()(np.pad(obs, r), cands, r, float(obs.sum(dtype=np.float64)), scores, shifts)
    return scores, shifts


@lru_cache(maxsize=1)
def _score_kernel():
    """The compiled :func:`_score_candidates` (numba is imported and it is compiled
    here, once)."""
    from numba import njit

    return njit(cache=True, nogil=True)(_score_candidates)


def _score_candidates(padded, cands, r, obs_total, scores, shifts):  # pragma: no cover - JIT
    """Fill ``scores`` (M,) and ``shifts`` (M, 2) (``(dx, dy)``) of the candidates
    ``cands`` (M, H, W) bool against the observed silhouette ``padded`` (H + 2r,
    W + 2r) float32 (zero rows and columns ``r`` wide around it; ``obs_total`` its
    sum); empty candidates are left as they are.

    Per candidate, its pixels are listed once; for every shift in row-major order of
    ``(dy, dx)`` the observed weights under them and, where the shifted candidate may
    leave ``R``, how many of them stay inside are summed in float64, in the pixels'
    order (block averages of 2 × 2 pixels are quarters: those sums are exact), and
    the first best score is kept.
    """
    n, h, w = cands.shape
    area_r = float(h * w)
    side = 2 * r + 1
    ys = np.empty(h * w, np.int64)
    xs = np.empty(h * w, np.int64)
    for i in range(n):
        count = 0
        y0, y1, x0, x1 = h, -1, w, -1
        for y in range(h):
            for x in range(w):
                if cands[i, y, x]:
                    ys[count], xs[count] = y, x
                    count += 1
                    y0, y1 = min(y0, y), max(y1, y)
                    x0, x1 = min(x0, x), max(x1, x)
        if count == 0:
            continue
        stays = y0 - r >= 0 and x0 - r >= 0 and y1 + r < h and x1 + r < w
        best, best_shift = -np.inf, 0
        for shift in range(side * side):
            dy, dx = shift // side - r, shift % side - r
            inside = 0.0
            in_r = 0
            for k in range(count):
                yy, xx = ys[k] + dy, xs[k] + dx
                inside += padded[yy + r, xx + r]
                if not stays and 0 <= yy < h and 0 <= xx < w:
                    in_r += 1
            outside_area = area_r - (count if stays else in_r)
            outside = (obs_total - inside) / outside_area if outside_area > 0 else 0.0
            s = inside / count - outside
            if s > best:
                best, best_shift = s, shift
        scores[i] = best
        shifts[i, 0] = best_shift % side - r
        shifts[i, 1] = best_shift // side - r


@dataclass(frozen=True, eq=False)
class ViewWindow:
    """The rectangle ``R(c)`` of one camera, sampled at a reduced resolution.

    Parameters
    ----------
    camera : Camera
        The full-resolution camera.
    x0, y0 : int
        Top-left full-resolution pixel of the rectangle.
    width_px, height_px : int
        Size of the rectangle in full-resolution pixels (multiples of ``downsample``).
    downsample : int
        Full-resolution pixels per window pixel along each axis.
    """

    camera: Camera
    x0: int
    y0: int
    width_px: int
    height_px: int
    downsample: int

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of the reduced-resolution window."""
        return self.height_px // self.downsample, self.width_px // self.downsample

    def window_camera(self, scale: float = 1.0, center_px: np.ndarray | None = None) -> Camera:
        """A camera whose image is the window (at the reduced resolution).

        Window pixel ``(i, j)`` covers full-resolution pixels ``x0 + n i … x0 + n i +
        n - 1`` (``n = downsample``); its centre is their mean.  ``scale`` magnifies the
        image about the full-resolution point ``center_px`` (u, v) — a 2D scale of the
        candidate silhouette, for a single camera whose distance is unknown.
        """
        n = float(self.downsample)
        K = self.camera.K.copy()
        if scale != 1.0:
            c = np.asarray(center_px, dtype=np.float64).reshape(2)
            K[0, 0] *= scale
            K[1, 1] *= scale
            K[0, 2] = c[0] + scale * (K[0, 2] - c[0])
            K[1, 2] = c[1] + scale * (K[1, 2] - c[1])
        # full-res u → window j:  j = (u - x0 - (n - 1) / 2) / n
        K[0] = K[0] / n
        K[1] = K[1] / n
        K[0, 2] -= (self.x0 + (n - 1) / 2.0) / n
        K[1, 2] -= (self.y0 + (n - 1) / 2.0) / n
        rows, cols = self.shape
        return Camera(K, self.camera.R, self.camera.t, cols, rows, self.camera.name)

    def crop(self, mask: np.ndarray) -> np.ndarray:
        """(rows, cols) float32: the full-resolution mask averaged over window pixels.

        Parts of the window outside the image count as background.
        """
        mask = np.asarray(mask)
        h, w = mask.shape
        full = np.zeros((self.height_px, self.width_px), dtype=np.float32)
        ya, yb = max(self.y0, 0), min(self.y0 + self.height_px, h)
        xa, xb = max(self.x0, 0), min(self.x0 + self.width_px, w)
        if ya < yb and xa < xb:
            full[ya - self.y0 : yb - self.y0, xa - self.x0 : xb - self.x0] = mask[ya:yb, xa:xb]
        n = self.downsample
        if n == 1:
            return full
        rows, cols = self.shape
        return full.reshape(rows, n, cols, n).mean(axis=(1, 3))

    def to_full_px(self, window_px: np.ndarray) -> np.ndarray:
        """Window pixel coordinates (..., 2) (u, v) → full-resolution pixels."""
        n = self.downsample
        p = np.asarray(window_px, dtype=np.float64)
        return p * n + (n - 1) / 2.0 + np.array([self.x0, self.y0])


def view_window(
    camera: Camera, corners_px: np.ndarray, margin_px: int, downsample: int
) -> ViewWindow:
    """The rectangle ``R(c)`` enclosing projected points, grown by a margin.

    Parameters
    ----------
    camera : Camera
    corners_px : (N, 2) float
        Projected points the rectangle must hold (e.g. the corners of the candidates'
        bounding boxes), full-resolution pixels.
    margin_px : int
        Extra pixels on every side (the shift radius, so shifted candidates stay in).
    downsample : int
        ≥ 1; the rectangle's size is rounded up to a multiple of it.

    Returns
    -------
    ViewWindow
        Clipped to the image (grown back to a multiple of ``downsample``).
    """
    pts = np.asarray(corners_px, dtype=np.float64).reshape(-1, 2)
    n = int(downsample)
    x0 = int(np.floor(pts[:, 0].min())) - margin_px
    x1 = int(np.ceil(pts[:, 0].max())) + margin_px + 1
    y0 = int(np.floor(pts[:, 1].min())) - margin_px
    y1 = int(np.ceil(pts[:, 1].max())) + margin_px + 1
    x0, y0 = max(x0, 0), max(y0, 0)
    x1, y1 = min(x1, camera.width), min(y1, camera.height)
    if x1 <= x0 or y1 <= y0:
        raise InvalidParameterError(
            f"camera {camera.name!r}: the candidates project outside the image"
        )
    width = -(-(x1 - x0) // n) * n
    height = -(-(y1 - y0) // n) * n
    return ViewWindow(camera, x0, y0, width, height, n)
