"""The segmentation's per-pixel loops, compiled by numba on first use.

:func:`compiled_kernels` imports numba and compiles the loops below (cached on disk);
until it is called, numba is not imported.  The loops are plain Python over NumPy
arrays, each documented with the shapes it reads and writes.
"""

from __future__ import annotations

from functools import lru_cache
from types import SimpleNamespace

import numpy as np


@lru_cache(maxsize=1)
def compiled_kernels():
    """The compiled per-pixel loops (numba is imported and they are compiled here)."""
    from numba import njit

    jit = njit(cache=True, nogil=True, fastmath=True)
    return SimpleNamespace(
        lab_differences=jit(_lab_differences),
        cast_shadows=jit(_cast_shadows),
        lengths=jit(_lengths),
        seeds=jit(_seeds),
        refine_rim=jit(_refine_rim),
        seeded_components=jit(_seeded_components),
        component_boxes=jit(_component_boxes),
        frame_boxes=jit(_frame_boxes),
        chosen=jit(_chosen),
        largest_cluster_means=jit(_largest_cluster_means),
    )


# The loops below run over flat (raveled, C-contiguous) arrays: numba compiles a 1-D
# loop over them several times faster than nested loops over 2-D or 3-D indices.


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


def _lab_differences(lab, bg_lab, diff, raw):  # pragma: no cover - JIT
    """``diff``: ``lab`` − ``bg_lab`` in CIE units, ``raw``: its length (ΔE).

    ``lab`` (F, M·3) and ``bg_lab`` (P·3,) are 8-bit L*a*b*; ``lab``, ``diff``
    (F, M·3) and ``raw`` (F, M), ``M >= P``, are stacked frames, whose first ``P``
    pixels are the frame's: only those are read and written.
    """
    n, p = lab.shape[0], bg_lab.shape[0] // 3
    l_scale = np.float32(100.0 / 255.0)
    for f in range(n):
        src, d, r = lab[f], diff[f], raw[f]
        for i in range(p):
            k = 3 * i
            dl = (np.float32(src[k]) - np.float32(bg_lab[k])) * l_scale
            da = np.float32(src[k + 1]) - np.float32(bg_lab[k + 1])
            db = np.float32(src[k + 2]) - np.float32(bg_lab[k + 2])
            d[k] = dl
            d[k + 1] = da
            d[k + 2] = db
            r[i] = np.sqrt(dl * dl + da * da + db * db)


def _cast_shadows(
    soft, bg_soft, inv_norm2, bg_bright, lo_ratio, hi_ratio, chroma_frac, rgb_noise, shadow
):  # pragma: no cover - JIT
    """``shadow`` (F, M): pixels explained as the background in a cast shadow.

    Brightness distortion ``alpha`` (``soft ≈ alpha × bg_soft``; ``soft`` (F, M·3)
    stacked frames, ``bg_soft`` (P·3,), ``inv_norm2 = 1 / |bg_soft|²`` (P,)) within
    ``[lo_ratio, hi_ratio]`` and chromaticity distortion ``|soft − alpha × bg_soft|``
    at most ``chroma_frac × alpha × bg_bright + rgb_noise`` (Horprasert et al. 1999).
    Only the first ``P`` pixels of each stacked frame are written.
    """
    n, p = soft.shape[0], inv_norm2.shape[0]
    for f in range(n):
        src, out = soft[f], shadow[f]
        for i in range(p):
            k = 3 * i
            r, g, b = np.float32(src[k]), np.float32(src[k + 1]), np.float32(src[k + 2])
            br, bg, bb = bg_soft[k], bg_soft[k + 1], bg_soft[k + 2]
            alpha = (r * br + g * bg + b * bb) * inv_norm2[i]
            cr, cg, cb = r - alpha * br, g - alpha * bg, b - alpha * bb
            limit = chroma_frac * alpha * bg_bright[i] + rgb_noise
            out[i] = (
                (alpha >= lo_ratio)
                & (alpha <= hi_ratio)
                & (cr * cr + cg * cg + cb * cb <= limit * limit)
            )


def _lengths(vectors, out):  # pragma: no cover - JIT
    """``out`` (P,): the length of each 3-vector of ``vectors`` (P·3,)."""
    for i in range(out.shape[0]):
        k = 3 * i
        a, b, c = vectors[k], vectors[k + 1], vectors[k + 2]
        out[i] = np.sqrt(a * a + b * b + c * c)


def _seeds(distance, shadow, low, high, weak, strong):  # pragma: no cover - JIT
    """Hysteresis seeds of one frame (all (P,)): ``weak`` (uint8 0/1) where
    ``distance > low`` and not a shadow, ``strong`` where also ``distance > high``.
    Returns whether any pixel is weak."""
    found = False
    for i in range(distance.shape[0]):
        d = distance[i]
        is_weak = (d > low) & (not shadow[i])
        weak[i] = is_weak
        strong[i] = is_weak & (d > high)
        found |= is_weak
    return found


def _seeded_components(labels, count, strong, min_area, out):  # pragma: no cover - JIT
    """``out`` (P,) uint8: 1 on components (``labels`` (P,) > 0) holding a ``strong``
    pixel and at least ``min_area`` pixels, 0 elsewhere."""
    area = np.zeros(count, np.int64)
    seeded = np.zeros(count, np.bool_)
    for i in range(labels.shape[0]):
        label = labels[i]
        if label:
            area[label] += 1
            seeded[label] |= strong[i]
    keep = seeded & (area >= min_area)
    keep[0] = False
    for i in range(labels.shape[0]):
        out[i] = keep[labels[i]]


def _component_boxes(labels, width, boxes):  # pragma: no cover - JIT
    """Per label > 0 of ``labels`` (P,) (rows of ``width`` pixels): ``boxes`` (C, 5)
    int64, zeros on entry, gets area, x0, y0, x1, y1 (inclusive); row 0 stays zero."""
    boxes[1:, 1] = width
    boxes[1:, 2] = labels.shape[0]
    for y in range(labels.shape[0] // width):
        row = y * width
        for x in range(width):
            label = labels[row + x]
            if label == 0:
                continue
            boxes[label, 0] += 1
            boxes[label, 1] = min(boxes[label, 1], x)
            boxes[label, 2] = min(boxes[label, 2], y)
            boxes[label, 3] = max(boxes[label, 3], x)
            boxes[label, 4] = max(boxes[label, 4], y)


def _frame_boxes(boxes, tile, out):  # pragma: no cover - JIT
    """``out`` (F, 5) int64: per frame (rows ``[f·tile, (f+1)·tile)``), the total area and
    the union box x0, y0, x1, y1 of the components ``boxes`` (K, 5) (area, x0, y0, x1,
    y1) that start in it; area 0, x0 = y0 = 0 and x1 = y1 = -1 where none does."""
    out[:, 0] = 0
    out[:, 1:3] = 0
    out[:, 3:] = -1
    for k in range(boxes.shape[0]):
        f = boxes[k, 2] // tile
        if out[f, 0] == 0:
            out[f, 1], out[f, 2] = boxes[k, 1], boxes[k, 2]
        out[f, 0] += boxes[k, 0]
        out[f, 1] = min(out[f, 1], boxes[k, 1])
        out[f, 2] = min(out[f, 2], boxes[k, 2])
        out[f, 3] = max(out[f, 3], boxes[k, 3])
        out[f, 4] = max(out[f, 4], boxes[k, 4])


def _chosen(labels, keep, out):  # pragma: no cover - JIT
    """``out[i] = keep[labels[i]]`` (``labels`` (P,) int32, ``keep`` (C,) and ``out``
    (P,) bool): the pixels of the components kept."""
    for i in range(labels.shape[0]):
        out[i] = keep[labels[i]]


def _refine_rim(mask, inside, core, rgb, bg, sep, tile, min_contrast2, out):  # pragma: no cover
    """Drop boundary pixels whose colour is nearer the background than the body.

    A blurred edge pixel mixes body and background colours; the low hysteresis
    threshold keeps pixels that are mostly background.  For each pixel on the mask's
    rim (``mask`` and not ``inside``, all (S, W) uint8 stacked frames), the local
    body colour F is the mean of ``rgb`` (S, W, 3) over the ``core`` pixels within
    3 px; ``out`` is cleared where the pixel's matting alpha along F − B is < 0.5 and
    F and B differ by at least ``sqrt(min_contrast2)`` RGB levels (so the decision is
    not noise).  ``bg`` (H, W, 3) is every frame's background; frames are ``tile``
    rows apart, the first from row ``sep``.
    """
    h, w = mask.shape
    for y in range(sep, h):
        by = (y - sep) % tile
        for x in range(w):
            if mask[y, x] == 0 or inside[y, x] != 0:
                continue
            total = 0
            f0 = f1 = f2 = np.float32(0.0)
            for yy in range(max(0, y - 3), min(h, y + 4)):
                for xx in range(max(0, x - 3), min(w, x + 4)):
                    if core[yy, xx] != 0:
                        total += 1
                        f0 += np.float32(rgb[yy, xx, 0])
                        f1 += np.float32(rgb[yy, xx, 1])
                        f2 += np.float32(rgb[yy, xx, 2])
            if total == 0:
                continue
            b0, b1, b2 = bg[by, x, 0], bg[by, x, 1], bg[by, x, 2]
            d0, d1, d2 = f0 / total - b0, f1 / total - b1, f2 / total - b2
            contrast2 = d0 * d0 + d1 * d1 + d2 * d2
            if contrast2 < min_contrast2:
                continue
            p0 = np.float32(rgb[y, x, 0]) - b0
            p1 = np.float32(rgb[y, x, 1]) - b1
            p2 = np.float32(rgb[y, x, 2]) - b2
            if (p0 * d0 + p1 * d1 + p2 * d2) < 0.5 * contrast2:
                out[y, x] = 0
