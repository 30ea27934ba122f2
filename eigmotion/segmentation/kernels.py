"""The segmentation's per-pixel steps, as whole-array NumPy and OpenCV operations.

Each step reads the frames of a chunk stacked one above the other
(:class:`~eigmotion.segmentation.evidence.Scene`) and works on all of them at once:
no loop over pixels in Python, and nothing compiled at run time, so a query's first
segmentation costs what every later one does.  The arithmetic is float32 where the
inputs are (the colour differences, the shadow test) and float64 where a sum of
several terms decides (the matting test of :func:`refine_rim`).

Only the background estimate's per-pixel clustering (:func:`compiled_cluster_means`,
for a clip without an image of the empty scene) is a loop compiled by numba, on first
use and cached on disk: numba is imported only when it is called.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np


@lru_cache(maxsize=1)
def compiled_cluster_means():
    """:func:`_largest_cluster_means` compiled (numba is imported and it is compiled or
    loaded from its disk cache here)."""
    from numba import njit

    return njit(cache=True, nogil=True, fastmath=True)(_largest_cluster_means)


def lab_differences(lab: np.ndarray, bg_lab: np.ndarray, diff: np.ndarray, raw: np.ndarray):
    """The colour difference of frames to the background in CIE units, and its length.

    Parameters
    ----------
    lab : (F, H, W, 3) uint8
        The frames in 8-bit L*a*b* (OpenCV's scaling: L×255/100, a+128, b+128).
    bg_lab : (H, W, 3) uint8
        The background, likewise.
    diff : (F, H, W, 3) float32
        Written: ``lab − bg_lab`` with L* in its own units (×100/255), a* and b*.
    raw : (F, H, W) float32
        Written: the length of ``diff`` (ΔE).
    """
    for frame, out, length in zip(lab, diff, raw, strict=True):
        difference = cv2.subtract(frame, bg_lab, dtype=cv2.CV_32F)
        cv2.transform(difference, _LAB_UNITS, dst=out)
        vector_lengths(out, length)


#: :func:`cv2.transform`'s matrix from 8-bit L*a*b* differences to CIE units.
_LAB_UNITS = np.diag(np.float32([100.0 / 255.0, 1.0, 1.0]))


def vector_lengths(vectors: np.ndarray, out: np.ndarray) -> None:
    """``out`` (H, W): the length of each 3-vector of ``vectors`` (H, W, 3) float32
    (also (F, H, W, 3) and (F, H, W), frame by frame)."""
    if vectors.ndim == 4:
        for frame, length in zip(vectors, out, strict=True):
            vector_lengths(frame, length)
        return
    squares = cv2.multiply(vectors, vectors)
    cv2.sqrt(cv2.transform(squares, _SUM_OF_THREE), dst=out)


#: :func:`cv2.transform`'s matrix that sums the three channels of a pixel.
_SUM_OF_THREE = np.ones((1, 3), np.float32)

#: :func:`cv2.LUT`'s table of the squares of the 256 levels.
_SQUARES = np.square(np.arange(256, dtype=np.float32))[None]


def cast_shadows(
    soft: np.ndarray, bg_soft: np.ndarray, inv_norm2: np.ndarray, bg_bright: np.ndarray,
    ratio: tuple[float, float], chroma_frac: float, rgb_noise: float, sep: int, tile: int,
) -> np.ndarray:  # fmt: skip
    """The pixels explained as the background in a cast shadow (Horprasert et al. 1999).

    Brightness distortion ``alpha`` (``soft ≈ alpha × bg_soft``) within ``ratio``
    (lo, hi) and chromaticity distortion ``|soft − alpha × bg_soft|`` at most
    ``chroma_frac × alpha × bg_bright + rgb_noise``, in float32.

    The test is taken only where it can pass: with ``alpha`` the projection of the
    colour on the background's, ``|soft|² = alpha² |bg_soft|² + |soft − alpha ×
    bg_soft|²``, so a shadow has ``|soft|² <= (hi |bg_soft|)² + (chroma_frac × hi ×
    |bg_soft| + rgb_noise)²`` — which most of the scene, as bright as the background,
    is not (the bound is taken with a margin far above float32's rounding).

    Parameters
    ----------
    soft : (S, W, 3) uint8
        The frames' lightly smoothed colours, RGB levels, stacked: frames ``tile``
        rows apart, the first from row ``sep``, each ``H`` rows and empty rows below.
    bg_soft : (H, W, 3) float32
        The background's.
    inv_norm2, bg_bright : (H, W) float32
        ``1 / max(|bg_soft|², 1)`` and its inverse square root.
    ratio : (float, float)
        Darkening factors a shadow may have, (lo, hi), ``0 <= lo <= hi``.
    chroma_frac, rgb_noise : float
        Allowed chromaticity distortion: a share of the brightness (>= 0) and RGB
        levels (>= 0).
    sep, tile : int

    Returns
    -------
    (S, W) bool
        False in the empty rows.
    """
    f32 = np.float32
    lo, hi = f32(ratio[0]), f32(ratio[1])
    h = bg_soft.shape[0]
    n = (soft.shape[0] - sep) // tile
    # The bound on |soft|², where |bg_soft| is the brightness (elsewhere, a black
    # background, every pixel is tested).
    bright = np.sqrt(np.einsum("ijk,ijk->ij", bg_soft, bg_soft))
    bound = np.square(hi * bright) + np.square(f32(chroma_frac) * hi * bright + f32(rgb_noise))
    bound = bound * f32(1.001) + f32(1.0)
    bound[bright < f32(1.0)] = np.inf
    norm2 = cv2.transform(cv2.LUT(soft, _SQUARES), _SUM_OF_THREE)
    candidates = np.zeros(soft.shape[:2], bool)
    frames = candidates[sep:].reshape(n, tile, -1)[:, :h]
    np.less_equal(norm2[sep:].reshape(n, tile, -1)[:, :h], bound, out=frames)
    ys, xs = np.nonzero(candidates)
    rows = (ys - sep) % tile
    shadow = np.zeros(soft.shape[:2], bool)
    shadow[ys, xs] = _shadow_test(
        soft[ys, xs], bg_soft[rows, xs], inv_norm2[rows, xs], bg_bright[rows, xs], (lo, hi),
        f32(chroma_frac), f32(rgb_noise),
    )  # fmt: skip
    return shadow


def _shadow_test(soft, bg_soft, inv_norm2, bg_bright, ratio, chroma_frac, rgb_noise):
    """:func:`cast_shadows`'s test of pixels (P, 3) uint8 against their background's
    (P, 3), (P,) and (P,) float32: (P,) bool."""
    r, g, b = (soft[:, c].astype(np.float32) for c in range(3))
    br, bg, bb = bg_soft[:, 0], bg_soft[:, 1], bg_soft[:, 2]
    alpha = (r * br + g * bg + b * bb) * inv_norm2
    cr, cg, cb = r - alpha * br, g - alpha * bg, b - alpha * bb
    limit = chroma_frac * alpha * bg_bright + rgb_noise
    return (
        (alpha >= ratio[0]) & (alpha <= ratio[1]) & (cr * cr + cg * cg + cb * cb <= limit * limit)
    )


def labelled_components(mask: np.ndarray, connectivity: int) -> tuple[int, np.ndarray, np.ndarray]:
    """Connected components of ``mask`` (H, W) uint8 (non-zero: in a component).

    Returns
    -------
    count : int
        Labels, the background's 0 included.
    labels : (H, W) int32
    boxes : (count, 5) int64
        Per label: area, x0, y0, x1, y1 (inclusive); row 0 (the background) zeros.
    """
    count, labels, stats, _ = cv2.connectedComponentsWithStatsWithAlgorithm(
        mask, connectivity, cv2.CV_32S, cv2.CCL_GRANA
    )
    boxes = np.zeros((count, 5), np.int64)
    left, top = stats[1:, cv2.CC_STAT_LEFT], stats[1:, cv2.CC_STAT_TOP]
    boxes[1:, 0] = stats[1:, cv2.CC_STAT_AREA]
    boxes[1:, 1], boxes[1:, 2] = left, top
    boxes[1:, 3] = left + stats[1:, cv2.CC_STAT_WIDTH] - 1
    boxes[1:, 4] = top + stats[1:, cv2.CC_STAT_HEIGHT] - 1
    return count, labels, boxes


def seeded_components(
    labels: np.ndarray, count: int, strong: np.ndarray, min_area: int
) -> np.ndarray:
    """(H, W) uint8: 1 on the components of ``labels`` (H, W) int32 (> 0, ``count``
    labels with the background's) that hold a ``strong`` (H, W) bool pixel and at
    least ``min_area`` pixels, 0 elsewhere."""
    area = np.bincount(labels.ravel(), minlength=count)
    seeded = np.bincount(labels[strong], minlength=count) > 0
    keep = seeded & (area >= min_area)
    keep[0] = False
    return np.take(keep.view(np.uint8), labels)


def frame_boxes(boxes: np.ndarray, tile: int, n_frames: int) -> np.ndarray:
    """(F, 5) int64: per frame of a stack (rows ``[f·tile, (f+1)·tile)``), the total
    area and the union box x0, y0, x1, y1 of the components ``boxes`` (K, 5) (area,
    x0, y0, x1, y1) that start in it; area 0, x0 = y0 = 0 and x1 = y1 = -1 where none
    does."""
    out = np.zeros((n_frames, 5), np.int64)
    out[:, 3:] = -1
    if len(boxes) == 0:
        return out
    frame = boxes[:, 2] // tile
    out[:, 0] = np.bincount(frame, weights=boxes[:, 0], minlength=n_frames).astype(np.int64)
    big = np.iinfo(np.int64).max
    lows = np.full((n_frames, 2), big, np.int64)
    np.minimum.at(lows, frame, boxes[:, 1:3])
    np.maximum.at(out[:, 3:], frame, boxes[:, 3:5])
    found = np.zeros(n_frames, bool)
    found[frame] = True
    out[found, 1:3] = lows[found]
    return out


#: Half-width, pixels, of the window :func:`refine_rim` takes the body's colour over.
RIM_REACH_PX = 3


def refine_rim(
    mask: np.ndarray, inside: np.ndarray, core: np.ndarray, rgb: np.ndarray,
    bg: np.ndarray, sep: int, tile: int, min_contrast2: float,
) -> np.ndarray:  # fmt: skip
    """Drop boundary pixels whose colour is nearer the background than the body.

    A blurred edge pixel mixes body and background colours; the low hysteresis
    threshold keeps pixels that are mostly background.  For each pixel on the mask's
    rim (``mask`` and not ``inside``), the local body colour F is the mean of ``rgb``
    over the ``core`` pixels within :data:`RIM_REACH_PX` (a square window, cut at the
    stack's edges); the pixel is dropped where its matting alpha along F − B is < 0.5
    and F and B differ by at least ``sqrt(min_contrast2)`` RGB levels (so the decision
    is not noise).

    Parameters
    ----------
    mask, inside, core : (S, W) uint8
        Stacked frames: frames are ``tile`` rows apart, the first from row ``sep``.
    rgb : (S, W, 3) uint8
        The frames' colours.
    bg : (H, W, 3) float32
        Every frame's background.
    sep, tile : int
    min_contrast2 : float
        Squared RGB levels.

    Returns
    -------
    (S, W) uint8
        ``mask`` with the dropped pixels cleared.
    """
    out = mask.copy()
    points = cv2.findNonZero(cv2.bitwise_and(mask, cv2.bitwise_not(inside)))
    if points is None:
        return out
    xs, ys = points.reshape(-1, 2).T
    # Window sums from integral images, exact in integers; the window is cut at the
    # stack's edges.
    h, w = mask.shape
    y0, y1 = np.maximum(ys - RIM_REACH_PX, 0), np.minimum(ys + RIM_REACH_PX + 1, h)
    x0, x1 = np.maximum(xs - RIM_REACH_PX, 0), np.minimum(xs + RIM_REACH_PX + 1, w)

    def window_sums(image: np.ndarray) -> np.ndarray:
        total = cv2.integral(image, sdepth=cv2.CV_32S)
        return total[y1, x1] - total[y0, x1] - total[y1, x0] + total[y0, x0]

    count = window_sums(core)
    sums = window_sums(cv2.bitwise_and(rgb, rgb, mask=core))
    some = count > 0
    ys, xs, count, sums = ys[some], xs[some], count[some], sums[some]
    background = bg[(ys - sep) % tile, xs]
    body = sums / count[:, None].astype(np.float64) - background
    contrast2 = np.einsum("ij,ij->i", body, body)
    pixel = rgb[ys, xs].astype(np.float32) - background
    along = np.einsum("ij,ij->i", pixel.astype(np.float64), body)
    drop = (contrast2 >= np.float64(np.float32(min_contrast2))) & (along < 0.5 * contrast2)
    out[ys[drop], xs[drop]] = 0
    return out


def _largest_cluster_means(values, radius, out):  # pragma: no cover - JIT
    """``out`` (P, 3) float32: per pixel of ``values`` (F, P, 3) uint8, the mean of the
    sample with the most samples within ``radius`` in every channel, and of those.

    A pixel whose samples all lie within ``radius`` of one another in every channel
    (most of the scene) is one cluster: its mean, without comparing every pair."""
    n_frames, n_pixels = values.shape[0], values.shape[1]
    counts = np.empty(n_frames, np.int32)
    channels = np.empty((3, n_frames), np.int32)
    red, green, blue = channels[0], channels[1], channels[2]
    for p in range(n_pixels):
        spread = 0
        for c in range(3):
            lo = hi = np.int32(values[0, p, c])
            for i in range(n_frames):
                value = np.int32(values[i, p, c])
                lo, hi = min(lo, value), max(hi, value)
                channels[c, i] = value
            spread = max(spread, hi - lo)
        best = 0
        if spread > radius:
            # Every sample against every one (itself included), without branches, over
            # channels laid out apart: the compiler vectorises the inner loop.
            for i in range(n_frames):
                ri, gi, bi = red[i], green[i], blue[i]
                count = 0
                for j in range(n_frames):
                    count += (
                        (abs(red[j] - ri) <= radius)
                        & (abs(green[j] - gi) <= radius)
                        & (abs(blue[j] - bi) <= radius)
                    )
                counts[i] = count
            for i in range(1, n_frames):
                if counts[i] > counts[best]:
                    best = i
        rb, gb, bb = red[best], green[best], blue[best]
        r = g = b = members = 0  # integer sums: exact in any order
        for j in range(n_frames):
            member = (
                (abs(red[j] - rb) <= radius)
                & (abs(green[j] - gb) <= radius)
                & (abs(blue[j] - bb) <= radius)
            )
            r += member * red[j]
            g += member * green[j]
            b += member * blue[j]
            members += member
        out[p, 0], out[p, 1], out[p, 2] = r / members, g / members, b / members
