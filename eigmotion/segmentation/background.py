"""The empty scene estimated from a clip in which a person moves.

:func:`estimate_background` gives the image a clip's frames are segmented against when
no image of the empty scene is given (``SilhouetteConfig.background``):

``"median"``
    Per-pixel temporal median over up to ``max_background_frames`` frames spread over
    the clip, then refined once: the median again, over only the frames where the
    pixel was not (near) the person in a first segmentation and not darker than a
    shadow would make it.  Works while the person moves off every pixel for more
    than half of the clip, even when in view from the first frame: a walk across
    the picture, not a walk towards the camera or a wave on the spot (measured in
    ``docs/motion-image.md``).
``"grabcut"`` (the default)
    Each pixel's commonest colour first, not its median: the mean of the largest
    cluster of its samples, those within a few times the clip's noise of one another
    (:func:`_commonest_colours`).  The scene behind a person is one steady colour,
    the person passing over it many, so the scene wins even where the person covers
    the pixel in more than half of the frames (someone who stands on a spot for half
    the clip and then steps aside), where a median takes the person.  A person who
    stays in place still leaves their still body in that image, and a first
    segmentation against it finds only what moves.  The still body is found in the
    image by ``cv2.grabCut``, seeded by colour models of the scene and of the moving
    person (:func:`find_still_body`, below); then the median over the frames where the
    pixel was neither near the moving person nor on the still body — or, where the
    person moved, where its colour is the scene's rather than the person's (the body
    uncovered); pixels never uncovered are inpainted (``cv2.inpaint``, Telea).
``"mog2"``
    OpenCV's Gaussian-mixture subtractor (``BackgroundSubtractorMOG2``) run twice
    over the clip, its background image then used as above.  Kept for comparison:
    it measured worse (it keeps ghosts of a slowly moving person).

The person's still body in the image of a clip's commonest colours: a person who stays
in place (waving, lifting, covering the head) covers the same pixels for most of the
clip, so each pixel's commonest colour over the clip is their body's, and a
segmentation against that image finds only what moves.  :func:`find_still_body` finds
that body in the image, for the estimate to replace it with the scene::

    first masks (the person against the image: what moves) ──▶ their union,
    closed, its rows and columns filled: the envelope the person moved in ──▶ colour
    models, smoothed 3-D RGB histograms: the scene's from a ring of the image
    around the envelope, the person's from the first masks' pixels in the frames ──▶
    their log likelihood ratio on the image seeds cv2.grabCut inside the
    envelope (outside it: certainly scene) ──▶ its pieces that come near the moving
    person in at least half of the frames, kept whole (a person crossing the picture
    leaves no still body), less what is more the colour of the scene right around them
    than the person's ──▶ plus still limbs: pieces of certainly personal colour above
    or below them, within reach of the envelope (legs below waving arms) ──▶ the still
    body.

The same colour models then judge, frame by frame, which pixels of the envelope show
the scene (:meth:`StillBody.person_log_ratio`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.evidence import check_frames, grid_step
from eigmotion.segmentation.kernels import compiled_cluster_means
from eigmotion.segmentation.subtraction import frame_chunks, segment_chunks
from eigmotion.segmentation.workers import worker_shares, worker_threads

#: Radius, pixels, of the inpainting that fills the scene behind a still body never
#: uncovered (background method "grabcut").
INPAINT_RADIUS_PX = 3

#: Two samples of a pixel are one colour in :func:`_commonest_colours` when no RGB
#: channel differs by more than this many times the clip's frame-to-frame noise (the
#: median, over a grid of pixels, of the largest channel difference between consecutive
#: samples),
#: and never less than :data:`MIN_COLOUR_LEVELS` levels.  Measured on the holdout
#: clips without their background images (``docs/accuracy.md``): 3, 5, 6, 8, 12 and 20
#: levels gave top-1 148, 146, 143, 142, 131 and 131 of 220 (the median: 129); their
#: noise is 1–2 levels.
COLOUR_PER_NOISE = 2.5
MIN_COLOUR_LEVELS = 3

#: Bins per RGB channel of the colour histograms (a power of two).
HISTOGRAM_BINS = 16

#: Gaussian sigma, bins, the histograms are smoothed with (colours between samples).
HISTOGRAM_SIGMA_BINS = 0.7

#: Pseudo-count added to every histogram bin, samples.
HISTOGRAM_PRIOR = 0.1

#: Person/scene log likelihood ratio above which a pixel of the image seeds grabCut as
#: probably the person, and above which it is certainly the person.
PROBABLE_LOG_RATIO = 0.0
CERTAIN_LOG_RATIO = 2.0

#: grabCut iterations (colour models re-fitted, graph cut again), and the margin of
#: scene, pixels, around the envelope's box that takes part in the cut.
GRABCUT_ITERATIONS = 3
GRABCUT_MARGIN_PX = 8

#: Radii as fractions of the height the person moved over: the closing and the growth
#: that turn the union of the first masks into the envelope, and the width of the
#: ring around it whose colours are the scene's.
CLOSE_PER_HEIGHT = 0.045
GROW_PER_HEIGHT = 0.02
RING_PER_HEIGHT = 0.25

#: Fewest ring pixels for a scene colour model; with fewer, every pixel outside the
#: envelope is used.
MIN_RING_PIXELS = 64

#: A still body lies within this distance of the moving person (a fraction of the
#: height the person moved over) in at least this fraction of the frames.
NEAR_PER_HEIGHT = 0.25
MIN_NEAR_FRAC = 0.5

#: Width of the band around the still body whose colours are the scene right around
#: it, as a fraction of the height the person moved over.
AROUND_PER_HEIGHT = 0.1

#: How far beyond the envelope a still limb may reach, as a fraction of the height the
#: person moved over, and its smallest area, as a fraction of the still body's.
REACH_PER_HEIGHT = 0.6
MIN_LIMB_FRAC = 0.05


def estimate_background(
    frames: np.ndarray,
    config: SilhouetteConfig = SilhouetteConfig(),  # noqa: B008 - frozen, immutable
    exclude: np.ndarray | None = None,
) -> np.ndarray:
    """The empty scene, estimated from a clip in which a person moves.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB frames.
    config : SilhouetteConfig
        ``background`` picks the method, ``max_background_frames`` bounds the work.
    exclude : (F, H, W) bool, optional
        Pixels known to be the person (e.g. a first segmentation); grown by a few
        pixels and left out of the per-pixel median, as are samples darker than
        ``config.shadow_ratio[1]`` times the pixel's bright level (its 80th luminance
        percentile: a lingering cast shadow).  Pixels excluded in every frame fall back
        to the plain median.  The grabcut method takes them as its first segmentation
        (made against each pixel's commonest colour when not given); mog2 ignores them.

    Returns
    -------
    (H, W, 3) uint8
    """
    frames = check_frames(frames)
    n = frames.shape[0]
    if config.background == "mog2":
        subtractor = cv2.createBackgroundSubtractorMOG2(
            history=max(n, 2), varThreshold=16.0, detectShadows=False
        )
        for _ in range(2):  # a second pass settles the mixture on the longest-held colours
            for frame in frames:
                subtractor.apply(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
        return cv2.cvtColor(subtractor.getBackgroundImage(), cv2.COLOR_BGR2RGB)
    pick = sampled_frames(n, config)
    sample = frames[pick]
    if exclude is not None:
        exclude = np.asarray(exclude, dtype=bool)
        if exclude.shape != frames.shape[:3]:
            raise InvalidParameterError(
                f"exclude must have shape {frames.shape[:3]} like the frames, got {exclude.shape}"
            )
        exclude = exclude[pick]
    if config.background == "grabcut":
        return _without_still_body(sample, _commonest_colours(sample), exclude, config)
    plain = np.median(sample, axis=0)
    if exclude is None:
        return _to_uint8(plain)
    refined = _median_of_scene(sample, _grown(exclude), config)
    return _to_uint8(np.where(np.isnan(refined), plain, refined))


def sampled_frames(n: int, config: SilhouetteConfig) -> np.ndarray:
    """(S,) int64: the frames of ``n`` a scene is estimated from, at most
    ``config.max_background_frames`` spread evenly over the clip."""
    pick = np.unique(np.linspace(0, n - 1, min(n, config.max_background_frames)).round())
    return pick.astype(np.int64)


#: A pixel counts as seen by :func:`seen_scene` where at least this share of the
#: sampled frames shows it without the person...
SEEN_SHARE = 0.25

#: ... and at least this many of them.
MIN_SEEN_FRAMES = 3


@dataclass(frozen=True)
class SeenScene:
    """The empty scene as a clip shows it, where the person is not
    (:func:`seen_scene`).

    ``image`` (H, W, 3) uint8 RGB: each pixel's median over the sampled frames in which
    the person is not there (a cast shadow's darker samples left out), the plain median
    where no frame shows it; ``seen`` (H, W) bool: where at least
    :data:`SEEN_SHARE` of the sampled frames, and :data:`MIN_SEEN_FRAMES`, show it.
    """

    image: np.ndarray
    seen: np.ndarray


def seen_scene(
    frames: np.ndarray,
    person: np.ndarray,
    config: SilhouetteConfig = SilhouetteConfig(),  # noqa: B008 - frozen, immutable
) -> SeenScene:
    """The scene a clip shows around a person already cut out of its frames.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB frames.
    person : (F, H, W) bool
        The person in each frame (grown by 3 pixels here, their blurred rim).
    config : SilhouetteConfig
        ``max_background_frames`` frames, spread evenly over the clip, are sampled.

    Returns
    -------
    SeenScene
    """
    frames = check_frames(frames)
    person = np.asarray(person, dtype=bool)
    if person.shape != frames.shape[:3]:
        raise InvalidParameterError(
            f"person must have shape {frames.shape[:3]} like the frames, got {person.shape}"
        )
    pick = sampled_frames(frames.shape[0], config)
    sample, excluded = frames[pick], _grown(person[pick])
    scene = _median_of_scene(sample, excluded, config)
    never = np.isnan(scene[..., 0])
    if never.any():
        scene[never] = np.median(sample[:, never], axis=0)
    image = _to_uint8(scene)
    shown = (~excluded).sum(axis=0)
    return SeenScene(image, shown >= max(MIN_SEEN_FRAMES, SEEN_SHARE * len(pick)))


def _without_still_body(
    sample: np.ndarray,
    commonest: np.ndarray,
    first_masks: np.ndarray | None,
    config: SilhouetteConfig,
) -> np.ndarray:
    """The grabcut method of :func:`estimate_background`.

    Parameters
    ----------
    sample : (F, H, W, 3) uint8
        The frames the background is estimated from.
    commonest : (H, W, 3) float32
        Their per-pixel commonest colour (:func:`_commonest_colours`).
    first_masks : (F, H, W) bool or None
        The person in each sample frame; segmented against ``commonest`` when None.

    Returns
    -------
    (H, W, 3) uint8
    """
    image = _to_uint8(commonest)
    if first_masks is None:
        first_masks = segment_chunks(frame_chunks(sample), image, config)
    body = find_still_body(image, sample, first_masks)
    # A sample shows the scene where the person was not near it and the commonest
    # colours show no still body; and, where the person moved, wherever its colour is
    # more the scene's than the person's (the still body uncovered).
    scene = ~_grown(first_masks)
    if body is not None:
        scene &= ~body.mask
        scene[:, body.envelope] |= body.person_log_ratio(sample[:, body.envelope]) < 0.0
    background = _median_of_scene(sample, ~scene, config)
    never = np.isnan(background[..., 0])
    background = _to_uint8(np.where(np.isnan(background), commonest, background))
    if never.any():
        background = cv2.inpaint(
            background, never.astype(np.uint8), INPAINT_RADIUS_PX, cv2.INPAINT_TELEA
        )
    return background


def _commonest_colours(sample: np.ndarray) -> np.ndarray:
    """Each pixel's commonest colour over a clip's frames, (H, W, 3) float32.

    Two samples of a pixel are one colour when no channel differs by more than the
    radius (:data:`COLOUR_PER_NOISE` times the clip's frame-to-frame noise, at least
    :data:`MIN_COLOUR_LEVELS`); the commonest colour is the mean of the sample that
    has the most samples of its colour (the first such, in frame order) and of those
    samples.

    Parameters
    ----------
    sample : (F, H, W, 3) uint8
        RGB frames.
    """
    f, h, w, _ = sample.shape
    # The noise on a grid of about 1,000 pixels per frame pair, as the segmentation's.
    grid = grid_step(h, w)
    on_grid = sample[:, ::grid, ::grid].astype(np.int16)
    step = np.abs(np.diff(on_grid, axis=0)).max(axis=-1) if f > 1 else np.zeros(1)
    radius = np.int32(max(MIN_COLOUR_LEVELS, math.floor(COLOUR_PER_NOISE * np.median(step))))
    out = np.empty((h * w, 3), np.float32)
    pixels = np.ascontiguousarray(sample).reshape(f, h * w, 3)
    kernel = compiled_cluster_means()
    workers = worker_threads()
    jobs = [
        workers.submit(kernel, pixels[:, lo:hi], radius, out[lo:hi])
        for lo, hi in worker_shares(h * w)
    ]
    for job in jobs:
        job.result()
    return out.reshape(h, w, 3)


def _grown(masks: np.ndarray) -> np.ndarray:
    """(F, H, W) bool masks, each grown by 3 pixels (the person's blurred rim)."""
    grow = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
    out = np.zeros(masks.shape, bool)
    for i, mask in enumerate(masks):
        if mask.any():
            out[i] = cv2.dilate(mask.astype(np.uint8), grow).astype(bool)
    return out


def _median_of_scene(
    sample: np.ndarray, excluded: np.ndarray, config: SilhouetteConfig
) -> np.ndarray:
    """Per-pixel median (H, W, 3) float32 of the samples (F, H, W, 3) not ``excluded``
    (F, H, W) nor in a cast shadow; NaN where no sample is left."""
    # Cast shadows only darken: a floor pixel the shadow covers for most of the clip
    # would get a dark median.  Drop the samples darker than a shadow's upper ratio
    # of the pixel's bright level (its 80th luminance percentile), then take the median.
    luma = sample.astype(np.float32) @ np.float32([0.299, 0.587, 0.114])
    bright = _masked_quantile(luma[..., None], excluded, 0.8)[..., 0]
    excluded = excluded | (luma < config.shadow_ratio[1] * bright[None])
    return _masked_quantile(sample, excluded, 0.5)


def _to_uint8(image: np.ndarray) -> np.ndarray:
    """Rounded and clipped to 0–255, uint8."""
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def _masked_quantile(sample: np.ndarray, excluded: np.ndarray, q: float) -> np.ndarray:
    """Per-pixel quantile over the frames where the pixel is not excluded.

    Parameters
    ----------
    sample : (F, H, W, C) uint8 or float
    excluded : (F, H, W) bool
    q : float
        Quantile in [0, 1], linear interpolation between order statistics.

    Returns
    -------
    (H, W, C) float64
        NaN where every frame is excluded.

    The rows are split between the worker threads (NumPy's sort releases the GIL).
    """
    parts = [
        worker_threads().submit(_masked_quantile_rows, sample[:, lo:hi], excluded[:, lo:hi], q)
        for lo, hi in worker_shares(sample.shape[1])
    ]
    return np.concatenate([part.result() for part in parts])


def _masked_quantile_rows(sample: np.ndarray, excluded: np.ndarray, q: float) -> np.ndarray:
    """:func:`_masked_quantile` of some of the rows."""
    # Excluded values sort after every real one; a sort along time then gives the
    # quantile inside each pixel's valid prefix (10x faster than nanmedian).
    values = sample.astype(np.float32)
    values[excluded] = np.inf
    values.sort(axis=0)
    valid = (~excluded).sum(axis=0)[None, ..., None]  # (1, H, W, 1)
    position = q * np.maximum(valid - 1, 0)
    lo_index = np.floor(position).astype(np.int64)
    hi_index = np.minimum(lo_index + 1, np.maximum(valid - 1, 0))
    lo = np.take_along_axis(values, lo_index, axis=0)[0]
    hi = np.take_along_axis(values, hi_index, axis=0)[0]
    frac = (position - lo_index)[0]
    with np.errstate(invalid="ignore"):  # inf - inf where every frame is excluded
        out = lo + frac * (hi - lo)
    out[valid[0, ..., 0] == 0] = np.nan
    return out


@dataclass(frozen=True, eq=False)
class StillBody:
    """The person as the commonest colours show them, and the colour models that found it.

    Attributes
    ----------
    mask : (H, W) bool
        Pixels of the commonest colours' image that show the person.
    envelope : (H, W) bool
        Where the person moved: the union of the first masks, closed, every row and
        then every column filled from its first pixel to its last, and grown by a few
        pixels.
    person_histogram, scene_histogram : (B, B, B) float32
        Colour probabilities over RGB bins (``B`` = :data:`HISTOGRAM_BINS`), each
        summing to 1.
    """

    mask: np.ndarray
    envelope: np.ndarray
    person_histogram: np.ndarray
    scene_histogram: np.ndarray

    def person_log_ratio(self, rgb: np.ndarray) -> np.ndarray:
        """Log likelihood ratio, person against scene, of each colour.

        Parameters
        ----------
        rgb : (..., 3) uint8

        Returns
        -------
        (...) float32
            > 0: more likely the person's colour than the scene's.
        """
        return _log_ratio(self.person_histogram, self.scene_histogram, rgb)


def find_still_body(
    commonest: np.ndarray, frames: np.ndarray, first_masks: np.ndarray
) -> StillBody | None:
    """The person's still body in the image of a clip's commonest colours.

    Parameters
    ----------
    commonest : (H, W, 3) uint8
        Each pixel's commonest colour over ``frames``, RGB.
    frames : (F, H, W, 3) uint8
        The frames, RGB.
    first_masks : (F, H, W) bool
        The person in each frame as a segmentation against ``commonest`` finds them
        (what moves).

    Returns
    -------
    StillBody or None
        None when the first masks are empty or the envelope leaves no scene around it.
        ``mask`` is empty when the person left no still body (they crossed the
        picture).
    """
    motion = first_masks.any(axis=0)
    if not motion.any():
        return None
    rows = np.flatnonzero(motion.any(axis=1))
    height = rows[-1] - rows[0] + 1
    envelope = _envelope(motion, height)
    ring = cv2.dilate(envelope.astype(np.uint8), _disk(RING_PER_HEIGHT * height)) > 0
    ring &= ~envelope
    if ring.sum() < MIN_RING_PIXELS:
        ring = ~envelope
        if ring.sum() < MIN_RING_PIXELS:
            return None
    # The first masks' rims mix the person's colour with the scene's.
    core = np.stack([cv2.erode(m.astype(np.uint8), _disk(1)) for m in first_masks]) > 0
    person = _histogram(frames[core] if core.any() else frames[first_masks])
    scene = _histogram(commonest[ring])
    log_ratio = _log_ratio(person, scene, commonest)
    near = _near_most_frames(first_masks, height)  # counted on the workers meanwhile
    mask = _pieces_reaching(_grabcut(commonest, envelope, log_ratio), near())
    if mask.any():
        mask &= ~_like_surroundings(commonest, mask, person, height)
    if mask.any():
        mask |= _still_limbs(mask, envelope, log_ratio, height)
    return StillBody(mask, envelope, person, scene)


def _envelope(motion: np.ndarray, height: int) -> np.ndarray:
    """The union of the first masks (H, W) bool, closed, its spans filled, grown.

    A still body between moving parts lies in the envelope even where the gap between
    them is open on one side: the torso between two waving arms, open below.
    """
    close = _disk(CLOSE_PER_HEIGHT * height)
    closed = cv2.morphologyEx(motion.astype(np.uint8), cv2.MORPH_CLOSE, close) > 0
    filled = _spans_filled(_spans_filled(closed, axis=1), axis=0)
    return cv2.dilate(filled.astype(np.uint8), _disk(GROW_PER_HEIGHT * height)) > 0


def _spans_filled(mask: np.ndarray, axis: int) -> np.ndarray:
    """(H, W) bool: ``mask`` with every row (``axis=1``) or column (``axis=0``) filled
    from its first pixel to its last (holes included)."""
    before = np.logical_or.accumulate(mask, axis=axis)
    after = np.flip(np.logical_or.accumulate(np.flip(mask, axis=axis), axis=axis), axis=axis)
    return before & after


def _grabcut(image: np.ndarray, envelope: np.ndarray, log_ratio: np.ndarray) -> np.ndarray:
    """The person in the image (H, W) bool: grabCut inside the envelope, seeded
    by the colour models' log ratio; the scene outside the envelope."""
    seeds = np.full(envelope.shape, cv2.GC_BGD, np.uint8)
    seeds[envelope] = np.where(
        log_ratio[envelope] > PROBABLE_LOG_RATIO, cv2.GC_PR_FGD, cv2.GC_PR_BGD
    )
    seeds[envelope & (log_ratio > CERTAIN_LOG_RATIO)] = cv2.GC_FGD
    person_seed = (seeds == cv2.GC_FGD) | (seeds == cv2.GC_PR_FGD)
    if not person_seed.any():
        return person_seed
    # Only the envelope's box, and a margin of scene around it, takes part in the cut.
    h, w = envelope.shape
    rows, cols = np.flatnonzero(envelope.any(axis=1)), np.flatnonzero(envelope.any(axis=0))
    box = (
        slice(max(0, rows[0] - GRABCUT_MARGIN_PX), min(h, rows[-1] + 1 + GRABCUT_MARGIN_PX)),
        slice(max(0, cols[0] - GRABCUT_MARGIN_PX), min(w, cols[-1] + 1 + GRABCUT_MARGIN_PX)),
    )
    labels = np.ascontiguousarray(seeds[box])
    if not ((labels == cv2.GC_BGD) | (labels == cv2.GC_PR_BGD)).any():
        return person_seed
    bgr = np.ascontiguousarray(image[box][..., ::-1])
    models = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)  # grabCut starts its colour models with k-means: the same clip, the same cut
    cv2.grabCut(bgr, labels, None, *models, GRABCUT_ITERATIONS, cv2.GC_INIT_WITH_MASK)
    out = np.zeros(envelope.shape, bool)
    out[box] = (labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)
    return out


def _near_most_frames(first_masks: np.ndarray, height: int) -> Callable[[], np.ndarray]:
    """The pixels near the moving person in at least :data:`MIN_NEAR_FRAC` of the
    frames that show them.  A still body is part of the person in every frame; a
    person who crosses the picture is near any one place only for a while.

    The frames are counted on the worker threads
    (:func:`eigmotion.segmentation.workers.worker_threads`;
    the dilations release the GIL), in one share per thread.  The call returns at once;
    calling what it returns waits for the counts and gives the pixels, (H, W) bool.
    """
    near = _disk(NEAR_PER_HEIGHT * height)
    reach = near.shape[0] // 2
    shown = [mask for mask in first_masks if mask.any()]

    def count_near(masks: list[np.ndarray]) -> np.ndarray:
        count = np.zeros(first_masks.shape[1:], np.int32)
        for mask in masks:
            # Nothing beyond reach of the mask's box is near it: the mask is dilated
            # within that box only, with the same result.
            rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
            box = (
                slice(max(0, rows[0] - reach), rows[-1] + 1 + reach),
                slice(max(0, cols[0] - reach), cols[-1] + 1 + reach),
            )
            count[box] += cv2.dilate(np.ascontiguousarray(mask[box]).view(np.uint8), near)
        return count

    shares = len(worker_shares(len(shown)))  # frames taken in turn: one share per thread
    parts = [worker_threads().submit(count_near, shown[i::shares]) for i in range(shares)]

    def pixels() -> np.ndarray:
        count = sum(part.result() for part in parts)  # integers: the same in any order
        return count >= MIN_NEAR_FRAC * len(shown)

    return pixels


def _pieces_reaching(cut: np.ndarray, near: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pieces (8-connected) of ``cut`` that reach into ``near``, whole.

    The nearness is measured in the height the person moved over, which is the arms'
    when only the arms move: the torso below them lies beyond that reach, but is
    joined to shoulders within it."""
    _, labels = cv2.connectedComponents(cut.astype(np.uint8), connectivity=8)
    reached = np.unique(labels[cut & near])
    return np.isin(labels, reached[reached > 0])


def _like_surroundings(
    image: np.ndarray, body: np.ndarray, person: np.ndarray, height: int
) -> np.ndarray:
    """(H, W) bool: pixels of ``body`` whose colour is more the scene's right around it
    than the person's: a stretch of a stripe, say, that continues beyond the body found."""
    around = cv2.dilate(body.astype(np.uint8), _disk(AROUND_PER_HEIGHT * height)) > 0
    around &= ~body
    if around.sum() < MIN_RING_PIXELS:
        return np.zeros_like(body)
    local = _histogram(image[around])
    return body & (_log_ratio(person, local, image) < 0.0)


def _still_limbs(
    body: np.ndarray, envelope: np.ndarray, log_ratio: np.ndarray, height: int
) -> np.ndarray:
    """Still parts beyond where the person moved (legs below waving arms), (H, W) bool.

    Pieces of certainly personal colour within reach of the envelope, at least
    :data:`MIN_LIMB_FRAC` of the body's area, above or below it (overlapping its
    columns): camouflaged clothing may part them from the body.
    """
    reach = cv2.dilate(envelope.astype(np.uint8), _disk(REACH_PER_HEIGHT * height)) > 0
    certain = (reach & ~body & (log_ratio > CERTAIN_LOG_RATIO)).astype(np.uint8)
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(certain, connectivity=8)
    cols = np.flatnonzero(body.any(axis=0))
    left = stats[:, cv2.CC_STAT_LEFT]
    right = left + stats[:, cv2.CC_STAT_WIDTH] - 1
    keep = (
        (stats[:, cv2.CC_STAT_AREA] >= MIN_LIMB_FRAC * body.sum())
        & (left <= cols[-1])
        & (right >= cols[0])
    )
    keep[0] = False
    return keep[pieces]


def _histogram(pixels: np.ndarray) -> np.ndarray:
    """(B, B, B) float32 colour probabilities of (N, 3) uint8 RGB pixels, smoothed."""
    # scipy.ndimage is imported here, not with the module: it would add about a third to
    # the import time of every query (eigmotion.retrieval.database imports this module),
    # and only a clip without an image of the empty scene needs it.
    from scipy.ndimage import gaussian_filter

    bins = HISTOGRAM_BINS
    index = _bin_index(pixels.reshape(-1, 3))
    counts = np.bincount(index, minlength=bins**3).astype(np.float32).reshape(bins, bins, bins)
    counts = gaussian_filter(counts, HISTOGRAM_SIGMA_BINS, mode="constant") + HISTOGRAM_PRIOR
    return counts / counts.sum()


def _log_ratio(person: np.ndarray, scene: np.ndarray, rgb: np.ndarray) -> np.ndarray:
    """Log likelihood ratio (...) float32, person against scene histogram, of each
    colour of ``rgb`` (..., 3) uint8."""
    index = _bin_index(rgb)
    return np.log(person.ravel()[index]) - np.log(scene.ravel()[index])


def _bin_index(rgb: np.ndarray) -> np.ndarray:
    """Flat histogram bin (...) int64 of each colour of ``rgb`` (..., 3) uint8."""
    q = rgb.astype(np.int64) >> (8 - int(np.log2(HISTOGRAM_BINS)))
    return (q[..., 0] * HISTOGRAM_BINS + q[..., 1]) * HISTOGRAM_BINS + q[..., 2]


def _disk(radius: float) -> np.ndarray:
    """Elliptic structuring element of the given radius (pixels, at least 1)."""
    r = max(1, int(round(radius)))
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
