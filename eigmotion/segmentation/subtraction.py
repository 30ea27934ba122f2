"""Background subtraction: the person's masks in a clip's frames against one image of
the empty scene.

Per frame, against the background image (given, or estimated from the clip by
:mod:`eigmotion.segmentation.background`)::

    exposure gain per channel (median frame / background ratio: auto-exposure,
    white balance, a codec's colour bias) ──▶ colour difference in CIE L*a*b*,
    smoothed (Gaussian, ``smooth_sigma_px``) before its length ΔE is taken, so
    a small but consistent offset — clothing close to the background colour —
    rises above the noise ──▶ cast-shadow test on lightly smoothed RGB: darker
    than the background by a factor in ``shadow_ratio`` with the same
    chromaticity (brightness and chromaticity distortion, Horprasert et al.
    1999) ──▶ not foreground, except beside the upper body when the background
    is given, where a second pass takes the test back (``upper_body_frac``)
    ──▶ hysteresis: weak pixels (ΔE > low) kept when connected to strong ones
    (ΔE > high) ──▶ drop specks, close small gaps ──▶ the largest blob, plus
    big pieces above or below it (a head or legs cut off by camouflage) ──▶ fill
    holes that are small or differ from the background (not a shadow between
    the feet) ──▶ the rim the smoothing added is kept only where each pixel
    differs by itself ──▶ boundary pixels whose colour is nearer the background
    than the body (matting alpha < 0.5) dropped.

Thresholds follow the clip's noise level, the median ΔE over all pixels (most are
background): ``low = max(min_delta_e, low_factor × noise)``, ``high`` likewise.  A
lossy codec removes the fine grain but adds blocky errors, so the raw noise level is
never taken below :data:`~eigmotion.segmentation.evidence.RAW_PER_SMOOTHED_NOISE`
times the smoothed one.

Each stage runs over chunks of :data:`CHUNK_FRAMES` frames, not frame by frame: the
frames of a chunk are stacked one above the other in a single image, each with empty
separator rows above and below it wider than any filter reaches, so a colour
conversion, a blur, a connected-component labelling or a morphology is one OpenCV call
and the per-pixel tests are whole-array NumPy and OpenCV operations
(:mod:`eigmotion.segmentation.kernels`) over the stack; holes are looked for only inside
each frame's person box.  The chunks are worked on by one thread per CPU
(:mod:`eigmotion.segmentation.workers`), and a video read by
:func:`eigmotion.segmentation.video.load_clip_masks` with a background is segmented
chunk by chunk while it is still being decoded.

The first pass over a chunk is :mod:`eigmotion.segmentation.evidence`, the making of
the masks :mod:`eigmotion.segmentation.person_mask`; this module runs the two passes
and segments only the part of the frames that can hold the person.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.evidence import (
    Evidence,
    Levels,
    Scene,
    chunk_evidence,
    clip_levels,
    frames_of,
    prepare_scene,
)
from eigmotion.segmentation.kernels import cast_shadows
from eigmotion.segmentation.person_mask import per_frame_boxes, person_components, person_mask
from eigmotion.segmentation.workers import opencv_in_calling_threads, worker_threads

#: Frames segmented together, stacked in one image: the unit of work of the worker
#: threads and of the pipeline with a video's decoding.  The masks do not depend on it.
CHUNK_FRAMES = 8

#: The second pass segments only a chunk's person region: the box of the pixels that
#: could seed a person, grown by this share of its longer side on each side (weak
#: pixels reach out from the seeds: camouflaged legs below a torso) …
REGION_MARGIN_FRAC = 0.25
#: … unless that region covers more than this share of the frame (the whole frame is
#: then as quick).
MAX_REGION_FRAC = 0.6

#: How far beside the person's box (a share of its height, each side) the shadow test
#: is taken back over the upper body (``SilhouetteConfig.upper_body_frac``).
UPPER_BODY_SIDE_FRAC = 0.15


def frame_chunks(frames: np.ndarray) -> Iterator[np.ndarray]:
    """(F, H, W, 3) frames, :data:`CHUNK_FRAMES` at a time."""
    for start in range(0, len(frames), CHUNK_FRAMES):
        yield frames[start : start + CHUNK_FRAMES]


def segment_chunks(
    chunks: Iterable[np.ndarray], background: np.ndarray, config: SilhouetteConfig
) -> np.ndarray:
    """Masks of the person in every frame against one background image.

    Parameters
    ----------
    chunks : iterable of (k, H, W, 3) uint8
        The clip's RGB frames, a few at a time (:data:`CHUNK_FRAMES`), in order;
        each chunk is handed to a worker thread as soon as it comes, so a clip being
        decoded is segmented while the rest of it is decoded.
    background : (H, W, 3) uint8
        The empty scene, RGB.  Frames and background are shrunk as
        ``config.work_max_side_px`` asks.

    Returns
    -------
    (F, H', W') bool

    The frames of a chunk are stacked one above the other in a single image, each
    with empty separator rows above and below it, wider than any filter reaches:
    every stage is one OpenCV call or one whole-array operation over the stack, and a frame's
    mask does not depend on the chunk it is in.  Two passes over the chunks, in
    worker threads (OpenCV and NumPy release the GIL): the per-pixel
    evidence (:func:`~eigmotion.segmentation.evidence.chunk_evidence`), then — with
    the clip's noise level, taken over all of its frames — the masks
    (:func:`_chunk_masks`).
    """
    return subtract_scene(chunks, background, config, plain_scene=False).masks


@dataclass(frozen=True)
class Subtraction:
    """What subtracting the empty scene found in a clip's frames, at the working size.

    ``masks`` (F, H, W) bool: the person (:func:`segment_chunks`) in every chunk that
    holds a wanted frame, all False in the other chunks; ``plain_scene`` (F, H, W) bool
    or None: the pixels whose smoothed colour difference to the empty scene stays under
    the clip's low threshold — no evidence of anything but the scene there, not even a
    weak one (shadows are not counted: the shadow test also takes dark hair and clothes
    before a lighter scene); ``wanted`` (F,) bool: the frames whose masks were asked for
    (every frame unless :func:`subtract_scene` was given ``frames_wanted``).
    """

    masks: np.ndarray
    plain_scene: np.ndarray | None
    wanted: np.ndarray


def subtract_scene(
    chunks: Iterable[np.ndarray],
    background: np.ndarray,
    config: SilhouetteConfig,
    plain_scene: bool = True,
    frames_wanted: Callable[[np.ndarray], np.ndarray] | None = None,
) -> Subtraction:
    """:func:`segment_chunks`, and with ``plain_scene`` where the frames show the
    empty scene as it is (:class:`Subtraction`).

    ``frames_wanted``, given the plain scene (F, H, W) bool, says which frames' masks
    are wanted, (F,) bool: the second pass skips the chunks that hold none of them
    (their masks all False).  The masks it makes are the same as when every chunk is
    segmented: a chunk's masks depend on its own evidence and the clip's levels only.
    """
    workers = worker_threads()
    scene = prepare_scene(background, config)
    with opencv_in_calling_threads():
        pending = [workers.submit(chunk_evidence, chunk, scene, config) for chunk in chunks]
        evidence = [job.result() for job in pending]
        levels = clip_levels(evidence, config)
        plain = None
        if plain_scene or frames_wanted is not None:
            h = scene.shape[0]
            plain = np.concatenate(
                [frames_of(e.smoothed, scene, e.n)[:, :h] < levels.low for e in evidence]
            )
        n_frames = sum(e.n for e in evidence)
        wanted = np.ones(n_frames, bool) if frames_wanted is None else frames_wanted(plain)
        ends = np.cumsum([e.n for e in evidence])

        def masks_of(chunk: int) -> np.ndarray:
            e, end = evidence[chunk], ends[chunk]
            if not wanted[end - e.n : end].any():
                return np.zeros((e.n, *scene.shape), bool)
            return _chunk_masks(e, scene, levels, config)

        masks = list(workers.map(masks_of, range(len(evidence))))
    return Subtraction(np.concatenate(masks), plain, np.asarray(wanted, bool))


def _chunk_masks(
    evidence: Evidence, scene: Scene, levels: Levels, config: SilhouetteConfig
) -> np.ndarray:
    """The second pass over a chunk: its masks (n, H, W) bool from its evidence.

    Only the chunk's person region is segmented (:func:`_person_region`), the masks
    being the same as over the whole frames: nothing outside it can seed a person.
    Where what lies beyond the region could change them (:func:`_region_masks`), or
    the region is most of the frame (:data:`MAX_REGION_FRAC`), the whole frames are
    segmented.
    """
    n, (h, w) = evidence.n, scene.shape
    shadow = cast_shadows(
        evidence.soft, scene.soft, scene.inv_norm2, scene.bright, config.shadow_ratio,
        config.shadow_chroma, levels.rgb_noise, scene.sep, scene.tile,
    )  # fmt: skip
    region = _person_region(evidence, scene, levels, shadow)
    if region is None:  # no pixel strong enough to seed a person
        return np.zeros((n, h, w), bool)
    y0, y1, x0, x1 = region
    if (y1 - y0) * (x1 - x0) <= MAX_REGION_FRAC * h * w:
        part = _cropped_scene(scene, region)
        masks = _region_masks(
            _cropped_evidence(evidence, scene, part, region), part, levels, config,
            _cropped_stack(shadow, scene, part, region, n), region,
        )  # fmt: skip
        if masks is not None:
            out = np.zeros((n, h, w), bool)
            out[:, y0:y1, x0:x1] = masks
            return out
    return _region_masks(evidence, scene, levels, config, shadow, (0, h, 0, w))


def _region_masks(
    evidence: Evidence, scene: Scene, levels: Levels, config: SilhouetteConfig,
    shadow: np.ndarray, region: tuple[int, int, int, int],
) -> np.ndarray | None:  # fmt: skip
    """The masks (n, H', W') bool of a chunk's frames, or of the region of them that
    ``evidence``, ``scene`` and ``shadow`` (S, W') bool, the cast-shadow pixels, were
    cropped to (``region`` (y0, y1, x0, x1) of the whole frame, ``scene.frame``).

    The person's components are found, and found again when
    :func:`_clear_upper_body_shadow` takes the shadow test back anywhere beside them
    (``shadow`` is changed); then they are made into the masks (holes filled, the rim
    refined) once.

    None when what lies beyond an edge of the region that is not the frame's could
    change the masks: a component within :func:`_guard_px` of it, or the upper body's
    shadow test taken back across it.
    """
    n, h = evidence.n, scene.shape[0]
    labels, boxes, keep = person_components(evidence, scene, levels, config, shadow)
    if config.upper_body_frac > 0.0:
        beside = _beside_upper_body(boxes[keep], scene, n, config.upper_body_frac)
        if _across_inner_edge(beside, scene, region):
            return None
        if _clear_upper_body_shadow(beside, shadow, scene, n):
            labels, boxes, keep = person_components(evidence, scene, levels, config, shadow)
    if _near_inner_edge(boxes[1:], scene, region):
        return None
    person = person_mask(evidence, scene, levels, config, shadow, labels, boxes, keep)
    return frames_of(person, scene, n)[:, :h].copy()


def _guard_px(scene: Scene) -> int:
    """How near, pixels, a component may come to an edge of a person region before
    what lies beyond could change the masks: more than the closing, the hole test's
    erosion and the boundary refinement's 7×7 window reach."""
    return max(scene.close_d, 2 * scene.reach + 1, 7) + 1


def _person_region(
    evidence: Evidence, scene: Scene, levels: Levels, shadow: np.ndarray
) -> tuple[int, int, int, int] | None:
    """The part of a chunk's frames that can hold the person: (y0, y1, x0, x1), pixels.

    Every component of a mask holds a seed: a pixel whose smoothed difference exceeds
    the high threshold and that is not in a cast shadow (``shadow`` (S, W) bool, as
    the stack; :func:`eigmotion.segmentation.person_mask.person_components`).  The region is the box
    of the chunk's seeds, grown on each side by :data:`REGION_MARGIN_FRAC` of its
    longer side (at least twice :func:`_guard_px`), clipped to the frame.  None when
    there is no seed.
    """
    n, (h, w) = evidence.n, scene.shape
    seeds = frames_of(evidence.smoothed, scene, n)[:, :h] > levels.high
    seeds &= ~frames_of(shadow, scene, n)[:, :h]
    rows, cols = np.flatnonzero(seeds.any(axis=(0, 2))), np.flatnonzero(seeds.any(axis=(0, 1)))
    if rows.size == 0:
        return None
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    grow = max(2 * _guard_px(scene), math.ceil(REGION_MARGIN_FRAC * max(y1 - y0, x1 - x0)))
    return max(0, y0 - grow), min(h, y1 + grow), max(0, x0 - grow), min(w, x1 + grow)


def _near_inner_edge(boxes: np.ndarray, scene: Scene, region: tuple[int, int, int, int]) -> bool:
    """Whether any component's box comes within :func:`_guard_px` of an edge of
    ``region`` (y0, y1, x0, x1) that is not an edge of the whole frame.

    Parameters
    ----------
    boxes : (K, 5) int64
        Area, x0, y0, x1, y1 of the components in the stack of the region's frames,
        less its first ``scene.sep`` rows (frame ``f`` from row ``f·tile``).
    """
    if len(boxes) == 0:
        return False
    y0, y1, x0, x1 = region
    (h, w), (frame_h, frame_w), guard = scene.shape, scene.frame, _guard_px(scene)
    top = boxes[:, 2] % scene.tile
    bottom = top + boxes[:, 4] - boxes[:, 2]
    return bool(
        (x0 > 0 and np.any(boxes[:, 1] < guard))
        or (x1 < frame_w and np.any(boxes[:, 3] >= w - guard))
        or (y0 > 0 and np.any(top < guard))
        or (y1 < frame_h and np.any(bottom >= h - guard))
    )


def _across_inner_edge(
    beside: tuple[np.ndarray, ...], scene: Scene, region: tuple[int, int, int, int]
) -> bool:
    """Whether a box of :func:`_beside_upper_body` reaches across the left or right
    edge of ``region`` (y0, y1, x0, x1) where that is not the whole frame's."""
    _, _, _, left, right = beside
    if len(left) == 0:
        return False
    x0, x1, frame_w = region[2], region[3], scene.frame[1]
    return bool((x0 > 0 and left.min() < 0) or (x1 < frame_w and right.max() > scene.shape[1]))


def _cropped_scene(scene: Scene, region: tuple[int, int, int, int]) -> Scene:
    """The scene of the ``region`` (y0, y1, x0, x1) of its frames, stacked the same way
    (the exposure gains' pixels are the first pass's and are left out)."""
    y0, y1, x0, x1 = region

    def crop(image: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(image[y0:y1, x0:x1])

    return replace(
        scene, rgb=crop(scene.rgb), lab=crop(scene.lab), soft=crop(scene.soft),
        bright=crop(scene.bright), inv_norm2=crop(scene.inv_norm2), tile=y1 - y0 + scene.sep,
        gain_pixels=[],
    )  # fmt: skip


def _cropped_evidence(
    evidence: Evidence, scene: Scene, part: Scene, region: tuple[int, int, int, int]
) -> Evidence:
    """A chunk's evidence over the ``region`` (y0, y1, x0, x1) of its frames, stacked
    as the cropped scene ``part`` stacks them (the grids, first-pass only, left out)."""
    n = evidence.n

    def crop(stack: np.ndarray) -> np.ndarray:
        return _cropped_stack(stack, scene, part, region, n)

    empty = np.zeros(0, np.float32)
    return Evidence(
        n, crop(evidence.corrected), crop(evidence.soft), crop(evidence.raw),
        crop(evidence.smoothed), empty, empty, empty,
    )  # fmt: skip


def _cropped_stack(
    stack: np.ndarray, scene: Scene, part: Scene, region: tuple[int, int, int, int], n: int
) -> np.ndarray:
    """The ``region`` (y0, y1, x0, x1) of each of the ``n`` frames of ``stack`` (S, W, ...),
    stacked as the cropped scene ``part`` stacks them (empty separator rows)."""
    y0, y1, x0, x1 = region
    out = np.zeros((part.sep + n * part.tile, x1 - x0, *stack.shape[2:]), stack.dtype)
    frames_of(out, part, n)[:, : y1 - y0] = frames_of(stack, scene, n)[:, y0:y1, x0:x1]
    return out


def _beside_upper_body(
    person_boxes: np.ndarray, scene: Scene, n: int, upper_frac: float
) -> tuple[np.ndarray, ...]:
    """Where a cast shadow cannot be: beside the upper body, per frame with a person.

    The top ``upper_frac`` of the box of the person's components, in its columns
    widened by :data:`UPPER_BODY_SIDE_FRAC` of its height on each side.

    Parameters
    ----------
    person_boxes : (K, 5) int64
        Area, x0, y0, x1, y1 of the person's components in the stack less its first
        ``scene.sep`` rows (frame ``f`` from row ``f·tile``).
    n : int
        Frames in the stack.
    upper_frac : float
        Share of the box height, from its top, in (0, 1].

    Returns
    -------
    frames, top, bottom, left, right : (P,) int64
        The frames with a person and their boxes: rows ``[top, bottom)`` of the frame,
        columns ``[left, right)``, not clipped to the frame.
    """
    area, x0, y0, x1, y1 = per_frame_boxes(person_boxes, scene.tile, n)
    frames = np.flatnonzero(area > 0)
    height = (y1 - y0 + 1)[frames]
    top = y0[frames] - frames * scene.tile
    side = np.rint(UPPER_BODY_SIDE_FRAC * height).astype(np.int64)
    bottom = top + np.rint(upper_frac * height).astype(np.int64)
    return frames, top, bottom, x0[frames] - side, x1[frames] + side + 1


def _clear_upper_body_shadow(
    beside: tuple[np.ndarray, ...], shadow: np.ndarray, scene: Scene, n: int
) -> bool:
    """Take back the shadow test where a cast shadow cannot be: beside the upper body.

    A cast shadow lies on the floor, around and behind the feet; clothing darker
    than the wall behind it with the wall's hue passes the same test.  ``shadow``
    (S, W) bool, the stacked frames' shadow pixels, is cleared in place over the
    boxes ``beside`` (:func:`_beside_upper_body`) of its ``n`` frames.

    Returns
    -------
    bool
        Whether any shadow pixel was cleared.
    """
    shadows = frames_of(shadow, scene, n)[:, : scene.shape[0]]
    cleared = False
    for f, top, bottom, left, right in zip(*beside, strict=True):
        region = shadows[f, top:bottom, max(0, left) : right]
        if region.any():
            region[:] = False
            cleared = True
    return cleared
