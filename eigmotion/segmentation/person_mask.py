"""The second pass of the segmentation: the person's mask in a chunk's stacked frames.

From the per-pixel evidence (:mod:`eigmotion.segmentation.evidence`) and the pixels
taken as cast shadow: hysteresis (weak pixels kept when connected to strong ones),
specks dropped, small gaps closed, the person's components chosen per frame (the
largest blob, plus big pieces above or below it) (:func:`person_components`); then
holes that are clothing filled, the rim the smoothing added kept only where each pixel
differs by itself, and boundary pixels nearer the background's colour than the body's
dropped (:func:`person_mask`).
"""

from __future__ import annotations

import cv2
import numpy as np

from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.evidence import Evidence, Levels, Scene
from eigmotion.segmentation.kernels import (
    frame_boxes,
    labelled_components,
    refine_rim,
    seeded_components,
)


def person_components(
    evidence: Evidence, scene: Scene, levels: Levels, config: SilhouetteConfig,
    shadow: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The person's components in a chunk's stacked frames, ``shadow`` (S, W) bool
    being the pixels taken as cast shadow (never foreground).

    Returns
    -------
    labels : (S, W) int32
        Connected components of the foreground.
    boxes : (C, 5) int64
        Per component: area, x0, y0, x1, y1 (inclusive), rows counted from the end of
        the stack's first ``scene.sep`` rows (frame ``f`` from row ``f·tile``).
    keep : (C,) bool
        The components that are the person (:func:`_person_components`).
    """
    n, sep, tile = evidence.n, scene.sep, scene.tile
    # Hysteresis: weak pixels connected to strong ones, specks dropped.
    min_area = config.min_person_frac * scene.frame[0] * scene.frame[1]
    # The thresholds compared in float64, as Python numbers are.
    weak = (evidence.smoothed > np.float64(levels.low)) & ~shadow
    strong = weak & (evidence.smoothed > np.float64(levels.high))
    count, labels = cv2.connectedComponentsWithAlgorithm(
        weak.view(np.uint8), 8, cv2.CV_32S, cv2.CCL_GRANA
    )
    speck = max(2, int(round(min_area * 0.05)))
    mask = seeded_components(labels, count, strong, speck)
    if scene.close_d > 1:
        closing = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (scene.close_d, scene.close_d))
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, closing)
    count, labels, boxes = labelled_components(mask, 8)
    boxes[1:, [2, 4]] -= sep  # rows of the frames' view, frame f from row f·tile
    return labels, boxes, _person_components(boxes, tile, n, min_area, config.keep_piece_frac)


def person_mask(
    evidence: Evidence, scene: Scene, levels: Levels, config: SilhouetteConfig,
    shadow: np.ndarray, labels: np.ndarray, boxes: np.ndarray, keep: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The person (S, W) bool in a chunk's stacked frames from its components (as
    :func:`person_components` returns them): holes that are clothing
    filled, the rim the smoothing added kept only where it differs by itself, and the
    boundary refined."""
    sep = scene.sep
    person = np.take(keep, labels)
    reach = scene.reach
    _fill_holes(
        person[sep:], boxes[keep], (evidence.smoothed[sep:], levels.low, evidence.raw[sep:],
        levels.low_raw), shadow[sep:], scene.tile, reach, config.small_hole_frac,
    )  # fmt: skip
    person8 = person.view(np.uint8)
    if config.smooth_sigma_px > 0.0:
        # The smoothing widened the mask: its rim must differ pixel by pixel.
        inner = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
        interior = cv2.erode(person8, inner).view(bool)
        person &= interior | ((evidence.raw > levels.low_raw) & ~shadow)
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    inside = cv2.erode(person8, cross)
    core = cv2.erode(inside, cross)
    out = refine_rim(
        person8, inside, core, evidence.corrected, scene.rgb, sep, scene.tile,
        (4.0 * levels.rgb_noise) ** 2,
    )  # fmt: skip
    return out.view(bool)


def _person_components(
    boxes: np.ndarray, tile: int, n_frames: int, min_area: float, keep_frac: float
) -> np.ndarray:
    """Which components of the stacked frames are the person.

    In each frame: the largest component, when it covers at least ``min_area``
    pixels, plus pieces of at least ``keep_frac`` of its area touching its bounding
    box grown by 25 % sideways and 50 % up and down (a head or legs cut off by
    camouflaged clothing).

    Parameters
    ----------
    boxes : (C, 5) int64
        Per component (0 is the background): area, x0, y0, x1, y1 (inclusive) in the
        stack, frame ``f`` occupying rows ``[f·tile, f·tile + H)``.

    Returns
    -------
    (C,) bool
    """
    keep = np.zeros(len(boxes), bool)
    if len(boxes) <= 1:
        return keep
    area, x0, y0, x1, y1 = boxes[1:].T
    frame = y0 // tile
    order = np.lexsort((-area, frame))
    first = order[np.r_[True, frame[order][1:] != frame[order][:-1]]]
    best = np.full(n_frames, -1)
    best[frame[first]] = first
    mine = best[frame]  # each component's frame's largest component
    big = area[mine] >= min_area
    bw, bh = x1[mine] - x0[mine] + 1, y1[mine] - y0[mine] + 1
    gx, gy = 0.25 * bw, 0.5 * bh
    near = (
        (x1 + 1 >= x0[mine] - gx)
        & (x0 <= x0[mine] + bw + gx)
        & (y1 + 1 >= y0[mine] - gy)
        & (y0 <= y0[mine] + bh + gy)
    )
    keep[1:] = big & near & (area >= keep_frac * area[mine])
    keep[1:][first] = big[first]
    return keep


def _fill_holes(
    person: np.ndarray,
    person_boxes: np.ndarray,
    evidence: tuple[np.ndarray, float, np.ndarray, float],
    shadow: np.ndarray,
    tile: int,
    reach: int,
    small_frac: float,
) -> np.ndarray:
    """Fill the holes inside the person that are clothing, not background.

    A hole is filled when it is small (under ``small_frac`` of its frame's person),
    or when its pixels differ from the background — judged on the smoothed distance
    over the part of the hole more than ``reach`` pixels from its edge (the smoothing
    bleeds the body into narrow gaps), else on the raw distance — unless it touches
    the floor line of the body (its lowest 15 %) and is partly a cast shadow: the gap
    between the legs and the shadow they enclose.

    Holes lie inside the person's bounding box, so they are looked for only there:
    each frame's box, ringed with empty pixels, stacked into one small image.

    Parameters
    ----------
    person : (F·tile, W) bool
        The stacked masks, frame ``f`` from row ``f·tile``; filled in place.
    person_boxes : (K, 5) int64
        Area, x0, y0, x1, y1 of the person's components, in the stack.
    evidence : ((F, tile, W), float, (F, tile, W), float)
        Smoothed ΔE and its low threshold, raw ΔE and its low threshold.
    shadow : (F, tile, W) bool
    """
    if len(person_boxes) == 0:
        return person
    evidence = tuple(a.reshape(person.shape) if isinstance(a, np.ndarray) else a for a in evidence)
    shadow = shadow.reshape(person.shape)
    n = person.shape[0] // tile
    area, x0, y0, x1, y1 = per_frame_boxes(person_boxes, tile, n)
    frames = np.flatnonzero(area > 0)
    heights, widths = (y1 - y0 + 1)[frames], (x1 - x0 + 1)[frames]
    pad = reach + 1  # a hole's box grown by ``reach`` stays inside its crop
    crop_h, crop_w = heights.max() + 2 * pad, widths.max() + 2 * pad
    crops = np.zeros((len(frames), crop_h, crop_w), bool)
    for k, f in enumerate(frames):
        crops[k, pad : pad + heights[k], pad : pad + widths[k]] = person[
            y0[f] : y1[f] + 1, x0[f] : x1[f] + 1
        ]
    # The empty rings of all crops touch one another: one component, the outside.
    count, labels, boxes = labelled_components((~crops).reshape(-1, crop_w).view(np.uint8), 4)
    crop_of = boxes[:, 2] // crop_h
    hole = np.ones(count, bool)
    hole[[0, labels[0, 0]]] = False  # the person, the outside
    fill = hole & (boxes[:, 0] <= small_frac * area[frames[crop_of]])
    judge = hole & ~fill
    if judge.any():
        fill[judge] = _differing_holes(
            labels, judge, boxes, (frames, y0, y1, x0), (crop_h, pad), evidence, shadow, reach
        )[judge]
    filled = fill[labels].reshape(crops.shape)
    for k, f in enumerate(frames):
        person[y0[f] : y1[f] + 1, x0[f] : x1[f] + 1] |= filled[
            k, pad : pad + heights[k], pad : pad + widths[k]
        ]
    return person


def _differing_holes(
    labels: np.ndarray,
    judge: np.ndarray,
    boxes: np.ndarray,
    placement: tuple[np.ndarray, ...],
    crop: tuple[int, int],
    evidence: tuple[np.ndarray, float, np.ndarray, float],
    shadow: np.ndarray,
    reach: int,
) -> np.ndarray:
    """Which holes of :func:`_fill_holes`'s crops differ from the background.

    Parameters
    ----------
    labels : (K·crop_h, crop_w) int32
        The components of the stacked crops; ``judge`` (C,) bool marks the holes to
        judge, ``boxes`` (C, 5) their area and box in the crops' stack.
    placement : (frames, y0, y1, x0)
        The frame of each crop and each frame's person box in the frames' stack.
    crop : (crop_h, pad)
        Rows per crop and the empty ring around each box.
    evidence, shadow
        As for :func:`_fill_holes`, shaped like the frames' stack.

    Returns
    -------
    (C,) bool
        True for the holes to fill (meaningful where ``judge``).
    """
    smoothed, low_smoothed, raw, low_raw = evidence
    frames, y0, y1, x0 = placement
    crop_h, pad = crop
    judged = judge[labels]
    if reach:
        # A hole's part more than ``reach`` from its edge: eroding all judged holes at
        # once erodes each as on its own (person pixels separate any two of them).
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
        cores = cv2.erode(judged.view(np.uint8), kernel, borderValue=0).view(bool)
    else:
        cores = judged
    crop_w = labels.shape[1]
    at = np.flatnonzero(judged)
    label = labels.ravel()[at]
    k, within = np.divmod(at, crop_h * crop_w)
    cy, cx = np.divmod(within, crop_w)
    f = frames[k]
    rows, cols = y0[f] + cy - pad, x0[f] + cx - pad  # the pixels in the frames' stack
    in_core = cores.ravel()[at]
    count = len(judge)
    has_core = np.bincount(label, in_core, minlength=count) > 0
    # On its core where it has one, else on all of it (the smoothing blurs the body
    # into a narrow hole): the hole's median distance above the low threshold.
    use = np.where(has_core[label], in_core, True)
    values = np.where(has_core[label], smoothed[rows, cols], raw[rows, cols])
    differs = _grouped_medians(label[use], values[use], count) > np.where(
        has_core, low_smoothed, low_raw
    )
    # Not the gap between the legs and the shadow they enclose: a hole touching the
    # body's floor line (its lowest 15 %) that is partly a cast shadow.
    pixels = np.maximum(np.bincount(label, minlength=count), 1)
    shadowed = np.bincount(label, shadow[rows, cols], minlength=count) / pixels > 0.3
    crop_of = boxes[:, 2] // crop_h
    height = (y1 - y0 + 1)[frames[crop_of]]
    floor_line = crop_of * crop_h + pad + height - 1 - 0.15 * height
    return differs & ~((boxes[:, 4] >= floor_line) & shadowed)


def _grouped_medians(groups: np.ndarray, values: np.ndarray, count: int) -> np.ndarray:
    """(count,) median of ``values`` (N,) per group id in ``groups`` (N,) (NaN where
    a group is empty); the mean of the two middle values for an even count, as
    ``np.median``."""
    order = np.lexsort((values, groups))
    ordered = values[order]
    sizes = np.bincount(groups, minlength=count)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    out = np.full(count, np.nan, np.float64)
    some = sizes > 0
    lo = starts[some] + (sizes[some] - 1) // 2
    hi = starts[some] + sizes[some] // 2
    out[some] = 0.5 * (ordered[lo].astype(np.float64) + ordered[hi])
    return out


def per_frame_boxes(boxes: np.ndarray, tile: int, n_frames: int) -> tuple[np.ndarray, ...]:
    """Per frame of a stack, the union of its components' boxes.

    Parameters
    ----------
    boxes : (K, 5) int64
        Area, x0, y0, x1, y1 (inclusive) of components in the stack, frame ``f`` from
        row ``f·tile``.

    Returns
    -------
    area, x0, y0, x1, y1 : (F,) int64
        Total area (0: no component; the box is then meaningless) and the union box.
    """
    return tuple(frame_boxes(boxes, tile, n_frames).T)
