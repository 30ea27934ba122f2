"""The video front end: person silhouettes cut out of ordinary RGB video.

:func:`extract_silhouettes` turns frames into masks for :func:`~eigmotion.retrieval.motion_image.
motion_image`; :func:`load_clip_masks` does the same from a file (a video, a folder of
frames, or masks already made and stored as ``.npz``).

Per frame, against a background image (given, or estimated from the clip)::

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
never taken below :data:`RAW_PER_SMOOTHED_NOISE` times the smoothed one.

Each stage runs over chunks of :data:`CHUNK_FRAMES` frames, not frame by frame: the
frames of a chunk are stacked one above the other in a single image, each with empty
separator rows above and below it wider than any filter reaches, so a colour
conversion, a blur, a connected-component labelling or a morphology is one OpenCV call
and the per-pixel tests are compiled loops (numba) over the stack; holes are looked for
only inside each frame's person box.  The chunks are worked on by one thread per CPU,
and a video read by :func:`load_clip_masks` with a background is segmented chunk by
chunk while it is still being decoded.

Background estimation when none is given (``SilhouetteConfig.background``):

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
    person (:mod:`eigmotion.segmentation.background`); then the median over the frames where the
    pixel was neither near the moving person nor on the still body — or, where the
    person moved, where its colour is the scene's rather than the person's (the body
    uncovered); pixels never uncovered are inpainted (``cv2.inpaint``, Telea).
``"mog2"``
    OpenCV's Gaussian-mixture subtractor (``BackgroundSubtractorMOG2``) run twice
    over the clip, its background image then used as above.  Kept for comparison:
    it measured worse (it keeps ghosts of a slowly moving person).
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields, replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError, VideoError

BACKGROUND_METHODS = ("median", "grabcut", "mog2")

#: Gaussian sigma, pixels, of the smoothing before the shadow test.
SHADOW_SIGMA_PX = 1.0

#: How far beside the person's box (a share of its height, each side) the shadow test
#: is taken back over the upper body (``SilhouetteConfig.upper_body_frac``).
UPPER_BODY_SIDE_FRAC = 0.15

#: Ratio of the raw to the smoothed median ΔE of sensor noise (white noise blurred
#: by the optics, smoothed with sigma 1 px; measured 2.7–2.8 on composed scenes).
RAW_PER_SMOOTHED_NOISE = 2.5

#: The most the frames may differ from the empty scene over half of the picture: the
#: median ΔE (smoothed as the segmentation smooths it) above which no person can be
#: told from the scene.  Frames and the image of the same empty view differ by 1.0–1.4
#: on the holdout clips (38 of them, with their sensor noise and video codec), by
#: 20–73 when the image is another clip's scene.
MAX_SCENE_DIFFERENCE = 12.0

#: Pixels per frame and channel whose median ratio to the background is the exposure gain.
GAIN_SAMPLES = 512

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

#: Frame rate assumed for an ``.npz`` of masks that stores none, frames per second.
DEFAULT_NPZ_FPS = 30.0

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


@dataclass(frozen=True)
class SilhouetteConfig:
    """Parameters of :func:`extract_silhouettes`.

    Parameters
    ----------
    background : {"median", "grabcut", "mog2"}
        How to estimate the background when none is given (see the module's notes).
    max_background_frames : int
        Frames (spread evenly over the clip) the median uses, in [3, 1000].
    low_factor, high_factor : float
        Hysteresis thresholds as multiples of the clip's noise level (median ΔE),
        ``1 <= low_factor <= high_factor <= 100``.
    min_delta_e : float
        Lower bound of the low threshold, ΔE (CIE76) units, in [0.5, 50]; the high
        threshold is at least twice this.
    shadow_ratio : (float, float)
        Range of brightness ratio (pixel / background) taken as a cast shadow,
        ``0 < lo < hi <= 1``.
    shadow_chroma : float
        Largest chromaticity distortion of a shadow pixel, as a fraction of the
        background's brightness, in [0, 0.5].
    smooth_sigma_px : float
        Gaussian sigma, pixels, applied to the colour difference (the L*a*b* vector
        frame − background) before its length is taken, in [0, 5]; 0: none.
    close_px : int
        Diameter of the closing that bridges small gaps, pixels at 240 rows (scaled
        with the image height), in [0, 31].
    min_person_frac : float
        Smallest person, as a fraction of the image area, in (0, 0.5]; a frame whose
        largest blob is smaller has an empty mask.
    keep_piece_frac : float
        Blobs at least this fraction of the largest one, and touching its bounding box
        grown by 25 % sideways and 50 % up and down, are kept too (a head or limb cut
        off by camouflaged clothing), in [0, 1].
    small_hole_frac : float
        Holes inside the person smaller than this fraction of its area are always
        filled; bigger ones only when they differ from the background, in [0, 1].
    upper_body_frac : float
        Cast shadows lie on the floor: beside the top ``upper_body_frac`` of the
        person's height (its box in a first segmentation) the shadow test is taken
        back and the frame segmented again, so that clothing darker than the wall
        behind it, with the wall's hue, stays body; in [0, 1], 0 turns it off.
        Used against a given background image only (see :func:`extract_silhouettes`).
    work_max_side_px : int
        Frames (and the background) larger than this on their longer side are
        shrunk by the smallest whole factor that brings them to it (area averaging)
        before segmentation, and the masks come back at that size, in [64, 4096].
        The motion image is cropped and rescaled to 32–64 pixels anyway, so
        segmenting full-resolution video only costs time.
    """

    background: str = "grabcut"
    max_background_frames: int = 60
    low_factor: float = 3.0
    high_factor: float = 7.0
    min_delta_e: float = 4.0
    shadow_ratio: tuple[float, float] = (0.35, 0.92)
    shadow_chroma: float = 0.10
    smooth_sigma_px: float = 1.0
    close_px: int = 5
    min_person_frac: float = 0.002
    keep_piece_frac: float = 0.05
    small_hole_frac: float = 0.01
    upper_body_frac: float = 0.6
    work_max_side_px: int = 4096

    def __post_init__(self):
        if self.background not in BACKGROUND_METHODS:
            raise InvalidParameterError(
                f"background must be one of {list(BACKGROUND_METHODS)}, got {self.background!r}"
            )
        _check_int("max_background_frames", self.max_background_frames, 3, 1000)
        _check_real("low_factor", self.low_factor, 1.0, 100.0)
        _check_real("high_factor", self.high_factor, self.low_factor, 100.0)
        _check_real("min_delta_e", self.min_delta_e, 0.5, 50.0)
        ratio = tuple(self.shadow_ratio)
        if (
            len(ratio) != 2
            or not all(isinstance(r, int | float) and math.isfinite(r) for r in ratio)
            or not 0.0 < ratio[0] < ratio[1] <= 1.0
        ):
            raise InvalidParameterError(
                f"shadow_ratio must be (lo, hi) with 0 < lo < hi <= 1, got {self.shadow_ratio!r}"
            )
        object.__setattr__(self, "shadow_ratio", (float(ratio[0]), float(ratio[1])))
        _check_real("shadow_chroma", self.shadow_chroma, 0.0, 0.5)
        _check_real("smooth_sigma_px", self.smooth_sigma_px, 0.0, 5.0)
        _check_int("close_px", self.close_px, 0, 31)
        _check_real("min_person_frac", self.min_person_frac, 1e-6, 0.5)
        _check_real("keep_piece_frac", self.keep_piece_frac, 0.0, 1.0)
        _check_real("small_hole_frac", self.small_hole_frac, 0.0, 1.0)
        _check_real("upper_body_frac", self.upper_body_frac, 0.0, 1.0)
        _check_int("work_max_side_px", self.work_max_side_px, 64, 4096)

    def to_dict(self) -> dict:
        """Plain data (the shadow ratio as a list)."""
        out = asdict(self)
        out["shadow_ratio"] = list(self.shadow_ratio)
        return out

    @classmethod
    def from_dict(cls, data: dict) -> SilhouetteConfig:
        """The inverse of :meth:`to_dict`; missing keys take their defaults."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InvalidParameterError(
                f"silhouette config: unknown key(s) {unknown}; expected some of {sorted(known)}"
            )
        data = dict(data)
        if "shadow_ratio" in data:
            data["shadow_ratio"] = tuple(data["shadow_ratio"])
        return cls(**data)


def _check_int(name: str, value, lo: int, hi: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lo <= value <= hi:
        raise InvalidParameterError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


def _check_real(name: str, value, lo: float, hi: float) -> None:
    ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool)
    if not (ok and math.isfinite(value) and lo <= value <= hi):
        raise InvalidParameterError(f"{name} must be a number in [{lo:g}, {hi:g}], got {value!r}")


# -- public ------------------------------------------------------------------------------


def extract_silhouettes(
    frames: np.ndarray,
    background: np.ndarray | None = None,
    config: SilhouetteConfig = SilhouetteConfig(),  # noqa: B008 - frozen, immutable
) -> np.ndarray:
    """Cut the person out of every frame.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB video frames.
    background : (H, W, 3) uint8, optional
        The empty scene, RGB, same size as the frames.  Estimated from the clip when
        not given (see ``config.background``).
    config : SilhouetteConfig

    Returns
    -------
    (F, H', W') bool
        The person in each frame; all False where none was found in that frame.
        ``H', W'`` are ``H, W`` shrunk so that the longer side is at most
        ``config.work_max_side_px`` (the same aspect ratio).

    Raises
    ------
    InvalidParameterError
        ``frames`` or ``background`` of the wrong type or number of dimensions.
    VideoError
        Zero frames; a background of another size than the frames (both sizes named);
        no person in any frame.
    """
    frames = _check_frames(frames)
    if background is None:
        # Beside a body that stays in place, an estimated background holds what the
        # body hid, inpainted: darker-than-scene pixels there are estimation residue
        # more often than clothing, so the shadow test stands everywhere.
        config = replace(config, upper_body_frac=0.0)
        frames = _shrink(frames, config)
        with opencv_in_calling_threads():  # the estimate's steps run on the workers too
            masks = _segment(_chunks(frames), estimate_background(frames, config), config)
            if config.background == "median":
                refined = estimate_background(frames, config, exclude=masks)
                masks = _segment(_chunks(frames), refined, config)
    else:
        background = _check_background(background)
        masks = _segment(_same_size(_chunks(frames), background), background, config)
    return _person_found(masks, config, estimated=background is None)


def _check_background(background) -> np.ndarray:
    background = np.asarray(background)
    if background.dtype != np.uint8 or background.ndim != 3 or background.shape[2] != 3:
        raise InvalidParameterError(
            f"background must be (H, W, 3) uint8 RGB, got {background.dtype} {background.shape}"
        )
    return background


def _same_size(chunks: Iterable[np.ndarray], background: np.ndarray) -> Iterator[np.ndarray]:
    """The chunks, each checked to be frames of the background's size."""
    for chunk in chunks:
        chunk = _check_frames(chunk)
        _check_size(chunk.shape[1:3], background)
        yield chunk


def _check_size(frame_size: tuple[int, int], background: np.ndarray) -> None:
    """VideoError unless ``frame_size`` (H, W) is the background's."""
    h, w = background.shape[:2]
    if tuple(frame_size) != (h, w):
        raise VideoError(
            f"background is {w}×{h} pixels but the frames are "
            f"{frame_size[1]}×{frame_size[0]}; expected the same size"
        )


def _chunks(frames: np.ndarray) -> Iterator[np.ndarray]:
    """(F, H, W, 3) frames, :data:`CHUNK_FRAMES` at a time."""
    for start in range(0, len(frames), CHUNK_FRAMES):
        yield frames[start : start + CHUNK_FRAMES]


def _person_found(
    masks: np.ndarray, config: SilhouetteConfig, estimated: bool = False
) -> np.ndarray:
    """``masks``, unless no frame shows a person (VideoError; with ``estimated``, the
    background was estimated from the clip, and the error says what that needs)."""
    if not masks.any():
        why = (
            " (no image of the empty scene was given, so it was estimated from the clip: "
            "a person shows only by moving; give an image of the empty scene)"
            if estimated
            else ""
        )
        raise VideoError(
            f"no person found in {len(masks)} frame(s): nothing that differs from the "
            f"background covers {config.min_person_frac:.2%} of the image{why}"
        )
    return masks


def _shrink(frames: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
    """Frames (F, H, W, 3) shrunk by the smallest whole factor that brings the longer
    side to at most ``config.work_max_side_px`` (area averaging over factor × factor
    blocks; the last rows and columns that do not fill a block are dropped)."""
    import cv2

    h, w = frames.shape[1:3]
    factor = math.ceil(max(h, w) / config.work_max_side_px)
    if factor <= 1:
        return frames
    n, rows, cols = frames.shape[0], h // factor, w // factor
    # Whole blocks never straddle two frames: one resize of the frames stacked.
    stacked = np.ascontiguousarray(frames[:, : rows * factor, : cols * factor])
    stacked = stacked.reshape(n * rows * factor, cols * factor, 3)
    small = cv2.resize(stacked, (cols, n * rows), interpolation=cv2.INTER_AREA)
    return small.reshape(n, rows, cols, 3)


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
    import cv2

    frames = _check_frames(frames)
    n = frames.shape[0]
    if config.background == "mog2":
        subtractor = cv2.createBackgroundSubtractorMOG2(
            history=max(n, 2), varThreshold=16.0, detectShadows=False
        )
        for _ in range(2):  # a second pass settles the mixture on the longest-held colours
            for frame in frames:
                subtractor.apply(cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
        return cv2.cvtColor(subtractor.getBackgroundImage(), cv2.COLOR_BGR2RGB)
    pick = np.unique(np.linspace(0, n - 1, min(n, config.max_background_frames)).round())
    pick = pick.astype(np.int64)
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
    import cv2

    from eigmotion.segmentation.background import find_still_body

    image = _to_uint8(commonest)
    if first_masks is None:
        first_masks = _segment(_chunks(sample), image, config)
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
    grid = _grid_step(h, w)
    on_grid = sample[:, ::grid, ::grid].astype(np.int16)
    step = np.abs(np.diff(on_grid, axis=0)).max(axis=-1) if f > 1 else np.zeros(1)
    radius = np.int32(max(MIN_COLOUR_LEVELS, math.floor(COLOUR_PER_NOISE * np.median(step))))
    out = np.empty((h * w, 3), np.float32)
    pixels = np.ascontiguousarray(sample).reshape(f, h * w, 3)
    kernel = _kernels().largest_cluster_means
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
    import cv2

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


@dataclass(frozen=True)
class ClipMasks:
    """The person's silhouettes in a clip on disk.

    Attributes
    ----------
    masks : (F', H, W) bool
        One per frame taken.
    frame_indices : (F',) int64
        Index in the clip of each mask's frame, increasing.
    n_frames : int
        Frames in the whole clip.
    fps : float
        The rate the masks are spaced at, frames/s: the clip's rate when every frame
        was taken, else the sample rate asked for.
    clip_fps : float
        The clip's frame rate, frames/s.
    """

    masks: np.ndarray
    frame_indices: np.ndarray
    n_frames: int
    fps: float
    clip_fps: float


def load_clip_masks(
    path: str | Path,
    background_path: str | Path | None = None,
    config: SilhouetteConfig = SilhouetteConfig(),  # noqa: B008 - frozen, immutable
    sample_fps: float | None = None,
    progress: bool = False,
) -> ClipMasks:
    """Silhouettes of the person in a clip on disk.

    Parameters
    ----------
    path : str or Path
        A video (``.mp4``, ``.avi``, ``.mov``, ``.mkv``), a GIF or a folder of frame
        images (read by :func:`eigmotion.imaging.media.read_frames`), or an ``.npz`` with key
        ``masks`` ``(F, H, W)`` (bool, or numbers: > 0 is the person) and optionally
        ``fps`` (a scalar, frames per second; :data:`DEFAULT_NPZ_FPS` if absent).
    background_path : str or Path, optional
        An image of the empty scene, same size as the frames (video input only).
    config : SilhouetteConfig
    sample_fps : float, optional
        Take only the frames nearest to this rate (frames/s; see
        :func:`eigmotion.imaging.media.sample_indices`): the motion image samples the clip at
        its own rate anyway, and frames it skips need no silhouette.  Every frame when
        ``None``.
    progress : bool
        A bar on stderr of a long video's frames as they are read
        (:class:`eigmotion.imaging.media.FrameSampleStream`).

    Returns
    -------
    ClipMasks

    Raises
    ------
    VideoError
        Missing or unreadable file, zero frames, no person, background of another size.
    InvalidParameterError
        An ``.npz`` without ``masks`` or with masks of the wrong shape; a background
        given with an ``.npz`` of masks; a bad ``sample_fps``.
    """
    from eigmotion.imaging.media import FrameSampleStream, sample_indices

    path = Path(path)
    if path.suffix.lower() == ".npz":
        if background_path is not None:
            raise InvalidParameterError(
                f"{path}: background_path applies to video input, not to stored masks"
            )
        if sample_fps is not None:
            _check_real("sample_fps", sample_fps, 1e-3, 1e4)
        masks, clip_fps = _load_npz_masks(path)
        rate = clip_fps if sample_fps is None else sample_fps
        indices = sample_indices(len(masks), clip_fps, rate)
        return ClipMasks(masks[indices], indices, len(masks), min(rate, clip_fps), clip_fps)

    def to_working_size(frame: np.ndarray) -> np.ndarray:
        """Each frame shrunk as soon as it is decoded (as the segmentation would shrink
        it): a long clip in high definition is held at the working size only."""
        if background is not None:
            _check_size(frame.shape[:2], background)
        return _shrink(frame[None], config)[0]

    stream = FrameSampleStream(path, sample_fps, progress=progress, transform=to_working_size)
    try:  # read while the video starts decoding
        background = None if background_path is None else read_background(background_path)
    except BaseException:
        stream.close()
        raise
    if background is None:  # estimated from the whole clip
        frames = np.concatenate(list(stream.chunks(CHUNK_FRAMES)))
        masks = extract_silhouettes(frames, None, config)
    else:  # segmented as it is decoded
        small = _shrink(background[None], config)[0]
        masks = _person_found(_segment(stream.chunks(CHUNK_FRAMES), small, config), config)
    return ClipMasks(masks, stream.frame_indices, stream.n_frames, stream.fps, stream.clip_fps)


def read_background(path: str | Path) -> np.ndarray:
    """Read an image of the empty scene.

    Parameters
    ----------
    path : str or Path
        Any still image OpenCV reads (``.png``, ``.jpg``, …).

    Returns
    -------
    (H, W, 3) uint8
        RGB.
    """
    import cv2

    path = Path(path)
    if not path.is_file():
        raise VideoError(f"{path}: background image not found")
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise VideoError(f"{path}: not a readable image")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


# -- stages ------------------------------------------------------------------------------


def _check_frames(frames) -> np.ndarray:
    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3:
        raise InvalidParameterError(
            f"frames must have shape (F, H, W, 3) (RGB), got {frames.shape}"
        )
    if frames.dtype != np.uint8:
        raise InvalidParameterError(f"frames must be uint8, got dtype {frames.dtype}")
    if frames.shape[0] == 0:
        raise VideoError("the clip has zero frames")
    if frames.shape[1] < 8 or frames.shape[2] < 8:
        raise InvalidParameterError(
            f"frames must be at least 8×8 pixels, got {frames.shape[2]}×{frames.shape[1]}"
        )
    return frames


def _load_npz_masks(path: Path) -> tuple[np.ndarray, float]:
    if not path.is_file():
        raise VideoError(f"{path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as data:
            if "masks" not in data:
                raise InvalidParameterError(f"{path}: no array 'masks'; found {sorted(data.files)}")
            masks = np.asarray(data["masks"])
            fps = float(data["fps"]) if "fps" in data else DEFAULT_NPZ_FPS
    except (OSError, ValueError) as exc:
        if isinstance(exc, InvalidParameterError):
            raise
        raise VideoError(f"{path}: not a readable .npz ({exc})") from None
    if masks.ndim != 3:
        raise InvalidParameterError(f"{path}: masks must have shape (F, H, W), got {masks.shape}")
    if masks.shape[0] == 0:
        raise VideoError(f"{path}: the clip has zero frames")
    if not (math.isfinite(fps) and fps > 0):
        raise InvalidParameterError(f"{path}: fps must be > 0 frames/s, got {fps!r}")
    if masks.dtype != bool:
        if not (np.issubdtype(masks.dtype, np.number)) or not np.all(np.isfinite(masks)):
            raise InvalidParameterError(f"{path}: masks must be bool or finite numbers")
        masks = masks > 0
    if not masks.any():
        raise VideoError(f"{path}: no person: every mask is empty")
    return masks, fps


def _segment(
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
    every stage is one OpenCV call or one compiled loop over the stack, and a frame's
    mask does not depend on the chunk it is in.  Two passes over the chunks, in
    worker threads (OpenCV and the compiled loops release the GIL): the per-pixel
    evidence (:func:`_evidence`), then — with the clip's noise level, taken over all
    of its frames — the masks (:func:`_chunk_masks`).
    """
    workers = worker_threads()
    # The first L*a*b* conversion in a process builds OpenCV's tables (about 0.2 s,
    # the GIL released): the scene is prepared on a worker while this thread imports
    # numba and loads the compiled loops (the GIL held), before any worker calls them.
    scene_job = workers.submit(_scene, background, config)
    _kernels()
    scene = scene_job.result()
    with opencv_in_calling_threads():
        pending = [workers.submit(_evidence, chunk, scene, config) for chunk in chunks]
        evidence = [job.result() for job in pending]
        levels = _levels(evidence, config)
        masks = list(
            workers.map(lambda chunk: _chunk_masks(chunk, scene, levels, config), evidence)
        )
    return np.concatenate(masks)


_opencv_scopes = 0  # calls inside opencv_in_calling_threads, across threads
_opencv_threads_before = 0  # OpenCV's thread count when the first of them entered
_opencv_scope_lock = threading.Lock()


@contextmanager
def opencv_in_calling_threads() -> Iterator[None]:
    """OpenCV's own thread pool turned off for the duration: each OpenCV call runs on
    the thread that makes it.

    The worker threads (:func:`worker_threads`) already run OpenCV calls side by side
    on every core; OpenCV's pool on top of them only contends for the same cores (its
    threads wait for work by spinning).  Six chunks of a 3 s clip's frames took 20.1
    and 19.1 ms for the two passes on two workers with the pool, 17.8 and 14.7 ms
    without it (``docs/database.md``, "Query time").  Nested and concurrent uses
    count: the pool's size is put back when the last of them ends.
    """
    import cv2

    global _opencv_scopes, _opencv_threads_before
    with _opencv_scope_lock:
        if _opencv_scopes == 0:
            _opencv_threads_before = cv2.getNumThreads()
            cv2.setNumThreads(1)
        _opencv_scopes += 1
    try:
        yield
    finally:
        with _opencv_scope_lock:
            _opencv_scopes -= 1
            if _opencv_scopes == 0:
                cv2.setNumThreads(_opencv_threads_before)


@lru_cache(maxsize=1)
def worker_threads() -> ThreadPoolExecutor:
    """The threads, one per CPU, that chunks of frames are segmented on and a query's
    independent steps run on (work that releases the GIL: OpenCV, compiled loops).
    A task running on them must not wait for another task it submits to them."""
    return ThreadPoolExecutor(max_workers=os.cpu_count() or 1, thread_name_prefix="eigmotion-seg")


def worker_shares(length: int) -> list[tuple[int, int]]:
    """Bounds ``[lo, hi)`` that split ``length`` items into one share per worker thread
    (:func:`worker_threads`), in order; empty shares are left out."""
    bounds = np.linspace(0, length, (os.cpu_count() or 1) + 1).astype(np.int64)
    return [(int(lo), int(hi)) for lo, hi in zip(bounds[:-1], bounds[1:], strict=True) if hi > lo]


# A forked child has none of its parent's threads: it starts a pool of its own.
os.register_at_fork(after_in_child=worker_threads.cache_clear)


@dataclass(frozen=True)
class _Scene:
    """The background and the stack layout, prepared once for all chunks of a clip.

    ``rgb`` (H, W, 3) float32 and ``lab`` (H, W, 3) uint8 are the background
    shrunk to the working size; ``soft`` (H, W, 3) float32 its lightly smoothed
    colours for the shadow test, ``bright`` (H, W) their length and ``inv_norm2``
    (H, W) one over its square; ``gain_pixels`` what :func:`_gain_pixels` picks.  A
    stack of ``k`` frames has ``sep + k·tile`` rows: ``sep`` empty rows, then per
    frame its ``H`` rows and ``sep`` empty ones.  ``frame`` is the (H, W) of a whole
    frame at the working size: a scene cropped to a person region
    (:func:`_cropped_scene`) keeps the whole frame's (the smallest person is a share
    of its area).
    """

    rgb: np.ndarray
    lab: np.ndarray
    soft: np.ndarray
    bright: np.ndarray
    inv_norm2: np.ndarray
    sep: int
    tile: int
    close_d: int
    reach: int
    gain_pixels: list
    frame: tuple[int, int]

    @property
    def shape(self) -> tuple[int, int]:
        return self.rgb.shape[:2]


def _scene(background: np.ndarray, config: SilhouetteConfig) -> _Scene:
    import cv2

    background = _shrink(background[None], config)[0]
    h = background.shape[0]
    # The shadow test compares lightly smoothed colours: video codecs halve the colour
    # resolution, which scatters the chromaticity of single pixels.
    soft = cv2.GaussianBlur(background, _gaussian_size(SHADOW_SIGMA_PX), SHADOW_SIGMA_PX)
    soft = soft.astype(np.float32)
    norm2 = np.maximum(np.einsum("ijk,ijk->ij", soft, soft), 1.0)
    close_d = max(1, int(round(config.close_px * h / 240.0))) | 1
    # Pixels deeper inside than the smoothing reaches are body even where camouflaged.
    reach = int(math.ceil(2.0 * config.smooth_sigma_px))
    # Separator rows: more than any blur, closing, erosion or the boundary
    # refinement's 7×7 window reaches from one frame into the next.
    sep = max(
        close_d, 2 * reach + 1, _gaussian_size(config.smooth_sigma_px)[0],
        _gaussian_size(SHADOW_SIGMA_PX)[0], 7,
    ) + 1  # fmt: skip
    rgb = background.astype(np.float32)
    return _Scene(
        rgb, _lab(background[None])[0], soft, np.sqrt(norm2), 1.0 / norm2, sep, h + sep,
        close_d, reach, _gain_pixels(rgb), background.shape[:2],
    )  # fmt: skip


@dataclass(frozen=True)
class _Evidence:
    """The per-pixel evidence of one chunk of ``n`` frames, stacked (see :class:`_Scene`).

    ``corrected`` (S, W, 3) uint8: the frames with their exposure gains undone;
    ``soft`` (S, W, 3) uint8: those lightly smoothed; ``raw`` (S, W) float32: ΔE to
    the background; ``smoothed`` (S, W) float32: the length of the smoothed L*a*b*
    difference (``raw`` when ``smooth_sigma_px`` is 0); ``rgb_d2``, ``raw_grid``,
    ``smoothed_grid``: squared RGB distance, ``raw`` and ``smoothed`` on a grid of
    about 1,000 pixels per frame, for the clip's noise levels.
    """

    n: int
    corrected: np.ndarray
    soft: np.ndarray
    raw: np.ndarray
    smoothed: np.ndarray
    rgb_d2: np.ndarray
    raw_grid: np.ndarray
    smoothed_grid: np.ndarray


def _frames_of(stack: np.ndarray, scene: _Scene, n: int) -> np.ndarray:
    """(n, tile, W, ...) view of a stack's frames, each followed by its separator."""
    return stack[scene.sep :].reshape(n, scene.tile, *stack.shape[1:])


def _evidence(chunk: np.ndarray, scene: _Scene, config: SilhouetteConfig) -> _Evidence:
    """The first pass over a chunk (k, H, W, 3) uint8 of frames: per pixel, the
    colour difference to the background, smoothed and not, and the smoothed colours."""
    import cv2

    kernels = _kernels()
    frames = _shrink(chunk, config)
    n, h, w = frames.shape[:3]
    rows = scene.sep + n * scene.tile
    gains = _exposure_gains(frames, scene)
    corrected = np.zeros((rows, w, 3), np.uint8)
    stacked = _frames_of(corrected, scene, n)
    if np.all(np.abs(gains - 1.0) < 0.5 / 255.0):
        stacked[:, :h] = frames  # no level would change
    else:
        for frame, table, out in zip(frames, _gain_tables(gains), stacked, strict=True):
            cv2.LUT(frame, table, dst=out[:h])
    grid = _grid_step(h, w)
    sample = stacked[:, :h:grid, ::grid].astype(np.float32) - scene.rgb[::grid, ::grid]
    rgb_d2 = np.einsum("...c,...c->...", sample, sample).ravel()

    diff = np.zeros((rows, w, 3), np.float32)
    raw = np.zeros((rows, w), np.float32)
    lab = cv2.cvtColor(corrected, cv2.COLOR_RGB2Lab)
    kernels.lab_differences(
        _frames_of(lab, scene, n).reshape(n, -1), scene.lab.ravel(),
        _frames_of(diff, scene, n).reshape(n, -1), _frames_of(raw, scene, n).reshape(n, -1),
    )  # fmt: skip
    if config.smooth_sigma_px > 0.0:
        # Averaging the difference vector (not its length) cancels noise while a
        # consistent small offset (camouflaged clothing) survives.
        size = _gaussian_size(config.smooth_sigma_px)
        cv2.GaussianBlur(diff, size, config.smooth_sigma_px, dst=diff)
        smoothed = np.empty((rows, w), np.float32)
        kernels.lengths(diff.ravel(), smoothed.ravel())
        smoothed[: scene.sep] = 0.0  # the blur spilled into the separators
        _frames_of(smoothed, scene, n)[:, h:] = 0.0
    else:
        smoothed = raw
    soft = cv2.GaussianBlur(corrected, _gaussian_size(SHADOW_SIGMA_PX), SHADOW_SIGMA_PX)
    step = _grid_step(h, w)
    return _Evidence(
        n, corrected, soft, raw, smoothed, rgb_d2,
        _frames_of(raw, scene, n)[:, :h:step, ::step].ravel(),
        _frames_of(smoothed, scene, n)[:, :h:step, ::step].ravel(),
    )  # fmt: skip


@dataclass(frozen=True)
class _Levels:
    """The clip's noise levels and hysteresis thresholds (ΔE; ``rgb_noise`` in RGB levels)."""

    rgb_noise: float
    low: float
    high: float
    low_raw: float


def _levels(evidence: list[_Evidence], config: SilhouetteConfig) -> _Levels:
    """Noise levels of the whole clip: medians over the grids of all its chunks.

    Raises
    ------
    VideoError
        The frames differ from the background over most of the picture (a median
        above :data:`MAX_SCENE_DIFFERENCE`): no threshold could tell the person from it.
    """
    smoothed = config.smooth_sigma_px > 0.0

    def median_of(grid: str) -> np.float32:
        return _median(np.concatenate([getattr(e, grid) for e in evidence]))

    # The three medians beside one another (NumPy's partition releases the GIL).
    smooth_job = worker_threads().submit(median_of, "smoothed_grid") if smoothed else None
    raw_job = worker_threads().submit(median_of, "raw_grid")
    rgb_noise = float(np.sqrt(median_of("rgb_d2")))
    raw_noise = float(raw_job.result())
    smooth_noise = float(smooth_job.result()) if smoothed else raw_noise
    if not smooth_noise <= MAX_SCENE_DIFFERENCE:
        raise VideoError(
            f"the frames differ from the empty scene over most of the picture (median "
            f"colour difference {smooth_noise:.0f} ΔE; frames of the same empty view "
            f"differ from it by about 1–3): a background image of another scene or view, "
            f"a moving camera, or a person who fills most of the frame"
        )
    if smoothed:
        # A lossy codec removes the fine grain (lowering the raw median) but leaves
        # blocky low-frequency errors (raising the smoothed one): the raw noise is
        # never taken below what the smoothed noise implies.
        raw_noise = max(raw_noise, RAW_PER_SMOOTHED_NOISE * smooth_noise)
        low, high = _thresholds(smooth_noise, config)
        low_raw, _ = _thresholds(raw_noise, config)
    else:
        low, high = low_raw, _ = _thresholds(raw_noise, config)
    return _Levels(rgb_noise, low, high, low_raw)


def _chunk_masks(
    evidence: _Evidence, scene: _Scene, levels: _Levels, config: SilhouetteConfig
) -> np.ndarray:
    """The second pass over a chunk: its masks (n, H, W) bool from its evidence.

    Only the chunk's person region is segmented (:func:`_person_region`), the masks
    being the same as over the whole frames: nothing outside it can seed a person.
    Where what lies beyond the region could change them (:func:`_region_masks`), or
    the region is most of the frame (:data:`MAX_REGION_FRAC`), the whole frames are
    segmented.
    """
    kernels = _kernels()
    n, (h, w) = evidence.n, scene.shape
    shadow = np.zeros(evidence.raw.shape, np.bool_)
    kernels.cast_shadows(
        _frames_of(evidence.soft, scene, n).reshape(n, -1), scene.soft.ravel(),
        scene.inv_norm2.ravel(), scene.bright.ravel(), *np.float32(config.shadow_ratio),
        np.float32(config.shadow_chroma), np.float32(levels.rgb_noise),
        _frames_of(shadow, scene, n).reshape(n, -1),
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
    evidence: _Evidence, scene: _Scene, levels: _Levels, config: SilhouetteConfig,
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
    labels, boxes, keep = _person_components_given_shadow(evidence, scene, levels, config, shadow)
    if config.upper_body_frac > 0.0:
        beside = _beside_upper_body(boxes[keep], scene, n, config.upper_body_frac)
        if _across_inner_edge(beside, scene, region):
            return None
        if _clear_upper_body_shadow(beside, shadow, scene, n):
            labels, boxes, keep = _person_components_given_shadow(
                evidence, scene, levels, config, shadow
            )
    if _near_inner_edge(boxes[1:], scene, region):
        return None
    person = _person_mask(evidence, scene, levels, config, shadow, labels, boxes, keep)
    return _frames_of(person, scene, n)[:, :h].copy()


def _guard_px(scene: _Scene) -> int:
    """How near, pixels, a component may come to an edge of a person region before
    what lies beyond could change the masks: more than the closing, the hole test's
    erosion and the boundary refinement's 7×7 window reach."""
    return max(scene.close_d, 2 * scene.reach + 1, 7) + 1


def _person_region(
    evidence: _Evidence, scene: _Scene, levels: _Levels, shadow: np.ndarray
) -> tuple[int, int, int, int] | None:
    """The part of a chunk's frames that can hold the person: (y0, y1, x0, x1), pixels.

    Every component of a mask holds a seed: a pixel whose smoothed difference exceeds
    the high threshold and that is not in a cast shadow (``shadow`` (S, W) bool, as
    the stack; :func:`_seeds`).  The region is the box of the chunk's seeds, grown on
    each side by :data:`REGION_MARGIN_FRAC` of its longer side (at least twice
    :func:`_guard_px`), clipped to the frame.  None when there is no seed.
    """
    n, (h, w) = evidence.n, scene.shape
    seeds = _frames_of(evidence.smoothed, scene, n)[:, :h] > levels.high
    seeds &= ~_frames_of(shadow, scene, n)[:, :h]
    rows, cols = np.flatnonzero(seeds.any(axis=(0, 2))), np.flatnonzero(seeds.any(axis=(0, 1)))
    if rows.size == 0:
        return None
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    grow = max(2 * _guard_px(scene), math.ceil(REGION_MARGIN_FRAC * max(y1 - y0, x1 - x0)))
    return max(0, y0 - grow), min(h, y1 + grow), max(0, x0 - grow), min(w, x1 + grow)


def _near_inner_edge(boxes: np.ndarray, scene: _Scene, region: tuple[int, int, int, int]) -> bool:
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
    beside: tuple[np.ndarray, ...], scene: _Scene, region: tuple[int, int, int, int]
) -> bool:
    """Whether a box of :func:`_beside_upper_body` reaches across the left or right
    edge of ``region`` (y0, y1, x0, x1) where that is not the whole frame's."""
    _, _, _, left, right = beside
    if len(left) == 0:
        return False
    x0, x1, frame_w = region[2], region[3], scene.frame[1]
    return bool((x0 > 0 and left.min() < 0) or (x1 < frame_w and right.max() > scene.shape[1]))


def _cropped_scene(scene: _Scene, region: tuple[int, int, int, int]) -> _Scene:
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
    evidence: _Evidence, scene: _Scene, part: _Scene, region: tuple[int, int, int, int]
) -> _Evidence:
    """A chunk's evidence over the ``region`` (y0, y1, x0, x1) of its frames, stacked
    as the cropped scene ``part`` stacks them (the grids, first-pass only, left out)."""
    n = evidence.n

    def crop(stack: np.ndarray) -> np.ndarray:
        return _cropped_stack(stack, scene, part, region, n)

    empty = np.zeros(0, np.float32)
    return _Evidence(
        n, crop(evidence.corrected), crop(evidence.soft), crop(evidence.raw),
        crop(evidence.smoothed), empty, empty, empty,
    )  # fmt: skip


def _cropped_stack(
    stack: np.ndarray, scene: _Scene, part: _Scene, region: tuple[int, int, int, int], n: int
) -> np.ndarray:
    """The ``region`` (y0, y1, x0, x1) of each of the ``n`` frames of ``stack`` (S, W, ...),
    stacked as the cropped scene ``part`` stacks them (empty separator rows)."""
    y0, y1, x0, x1 = region
    out = np.zeros((part.sep + n * part.tile, x1 - x0, *stack.shape[2:]), stack.dtype)
    _frames_of(out, part, n)[:, : y1 - y0] = _frames_of(stack, scene, n)[:, y0:y1, x0:x1]
    return out


def _beside_upper_body(
    person_boxes: np.ndarray, scene: _Scene, n: int, upper_frac: float
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
    area, x0, y0, x1, y1 = _per_frame_boxes(person_boxes, scene.tile, n)
    frames = np.flatnonzero(area > 0)
    height = (y1 - y0 + 1)[frames]
    top = y0[frames] - frames * scene.tile
    side = np.rint(UPPER_BODY_SIDE_FRAC * height).astype(np.int64)
    bottom = top + np.rint(upper_frac * height).astype(np.int64)
    return frames, top, bottom, x0[frames] - side, x1[frames] + side + 1


def _clear_upper_body_shadow(
    beside: tuple[np.ndarray, ...], shadow: np.ndarray, scene: _Scene, n: int
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
    shadows = _frames_of(shadow, scene, n)[:, : scene.shape[0]]
    cleared = False
    for f, top, bottom, left, right in zip(*beside, strict=True):
        region = shadows[f, top:bottom, max(0, left) : right]
        if region.any():
            region[:] = False
            cleared = True
    return cleared


def _person_components_given_shadow(
    evidence: _Evidence, scene: _Scene, levels: _Levels, config: SilhouetteConfig,
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
    import cv2

    kernels = _kernels()
    n, w, sep, tile = evidence.n, scene.shape[1], scene.sep, scene.tile
    rows = sep + n * tile
    # Hysteresis: weak pixels connected to strong ones, specks dropped.
    min_area = config.min_person_frac * scene.frame[0] * scene.frame[1]
    weak = np.empty((rows, w), np.uint8)
    strong = np.empty((rows, w), np.bool_)
    kernels.seeds(
        evidence.smoothed.ravel(), shadow.ravel(), levels.low, levels.high, weak.ravel(),
        strong.ravel(),
    )  # fmt: skip
    count, labels = cv2.connectedComponentsWithAlgorithm(weak, 8, cv2.CV_32S, cv2.CCL_GRANA)
    mask = np.empty((rows, w), np.uint8)
    speck = max(2, int(round(min_area * 0.05)))
    kernels.seeded_components(labels.ravel(), count, strong.ravel(), speck, mask.ravel())
    if scene.close_d > 1:
        closing = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (scene.close_d, scene.close_d))
        mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, closing)
    count, labels = cv2.connectedComponentsWithAlgorithm(mask, 8, cv2.CV_32S, cv2.CCL_GRANA)
    boxes = np.zeros((count, 5), np.int64)
    kernels.component_boxes(labels.ravel(), w, boxes)
    boxes[1:, [2, 4]] -= sep  # rows of the frames' view, frame f from row f·tile
    return labels, boxes, _person_components(boxes, tile, n, min_area, config.keep_piece_frac)


def _person_mask(
    evidence: _Evidence, scene: _Scene, levels: _Levels, config: SilhouetteConfig,
    shadow: np.ndarray, labels: np.ndarray, boxes: np.ndarray, keep: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The person (S, W) bool in a chunk's stacked frames from its components (as
    :func:`_person_components_given_shadow` returns them): holes that are clothing
    filled, the rim the smoothing added kept only where it differs by itself, and the
    boundary refined."""
    import cv2

    kernels = _kernels()
    sep = scene.sep
    person = np.empty(labels.shape, np.bool_)
    kernels.chosen(labels.ravel(), keep, person.ravel())
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
    out = person8.copy()
    kernels.refine_rim(
        person8, inside, core, evidence.corrected, scene.rgb, sep, scene.tile,
        np.float32((4.0 * levels.rgb_noise) ** 2), out,
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
    import cv2

    if len(person_boxes) == 0:
        return person
    evidence = tuple(a.reshape(person.shape) if isinstance(a, np.ndarray) else a for a in evidence)
    shadow = shadow.reshape(person.shape)
    n = person.shape[0] // tile
    area, x0, y0, x1, y1 = _per_frame_boxes(person_boxes, tile, n)
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
    count, labels = cv2.connectedComponentsWithAlgorithm(
        (~crops).reshape(-1, crop_w).view(np.uint8), 4, cv2.CV_32S, cv2.CCL_GRANA
    )
    boxes = np.zeros((count, 5), np.int64)
    _kernels().component_boxes(labels.ravel(), crop_w, boxes)
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
    import cv2

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


def _per_frame_boxes(boxes: np.ndarray, tile: int, n_frames: int) -> tuple[np.ndarray, ...]:
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
    out = np.empty((n_frames, 5), np.int64)
    _kernels().frame_boxes(np.ascontiguousarray(boxes), tile, out)
    return tuple(out.T)


def _lab(frames: np.ndarray) -> np.ndarray:
    """(F, H, W, 3) uint8 RGB → uint8 L*a*b* (OpenCV's 8-bit scaling: L×255/100, a+128, b+128).

    One conversion over the whole clip (the frames stacked into one image); the 8-bit
    rounding (mean ΔE 0.5) is far below the thresholds.
    """
    import cv2

    n, h, w = frames.shape[:3]
    stacked = np.ascontiguousarray(frames).reshape(n * h, w, 3)
    return cv2.cvtColor(stacked, cv2.COLOR_RGB2Lab).reshape(n, h, w, 3)


def _gaussian_size(sigma_px: float) -> tuple[int, int]:
    """Kernel size of a Gaussian blur cut at 2 sigma (OpenCV's default cuts at 3–4)."""
    half = max(1, math.ceil(2.0 * sigma_px))
    return (2 * half + 1, 2 * half + 1)


def _grid_step(h: int, w: int) -> int:
    """Stride, pixels, of the grid the clip-wide statistics sample: about 1,000 per frame."""
    return max(1, int(math.sqrt(h * w / 1000.0)))


def _gain_tables(gains: np.ndarray) -> np.ndarray:
    """(F, 1, 256, 3) uint8 lookup tables (``cv2.LUT``): per frame, level → level / gain
    of each channel, rounded."""
    levels = np.arange(256, dtype=np.float32)
    tables = levels[None, :, None] / gains[:, None, :]
    return np.clip(np.rint(tables), 0, 255).astype(np.uint8)[:, None]


@lru_cache(maxsize=1)
def _kernels():
    """The compiled per-pixel loops (numba is imported and they are compiled here)."""
    from types import SimpleNamespace

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


def _gain_pixels(bg_rgb: np.ndarray) -> list[tuple[np.ndarray, np.ndarray] | None]:
    """Per channel, the pixels whose median ratio frame / background is the exposure gain.

    Up to :data:`GAIN_SAMPLES` flat pixel indices, spread evenly over the pixels where
    the background (H, W, 3) float32 is not near black (their ratios are noise), and
    the background's values there; None for a channel with fewer than 16 such pixels.
    """
    bg = bg_rgb.reshape(-1, 3)
    picks: list[tuple[np.ndarray, np.ndarray] | None] = []
    for c in range(3):
        usable = np.flatnonzero(bg[:, c] >= 16.0)
        if len(usable) < 16:
            picks.append(None)
            continue
        spread = np.linspace(0, len(usable) - 1, min(len(usable), GAIN_SAMPLES))
        picked = usable[spread.astype(np.int64)]
        picks.append((picked, bg[picked, c]))
    return picks


def _exposure_gains(frames: np.ndarray, scene: _Scene) -> np.ndarray:
    """(F, 3) float32: per frame and channel, the median ratio frame / background.

    Absorbs exposure and white-balance drift, and the colour bias of a lossy codec,
    between the frames and a background photographed apart from them.  The median
    over (a spread of) the image's pixels ignores the person as long as they cover
    less than half of it.
    """
    pixels = frames.reshape(frames.shape[0], -1, 3)
    gains = np.ones((frames.shape[0], 3), np.float32)
    for c, pick in enumerate(scene.gain_pixels):
        if pick is not None:
            picked, bg = pick
            gains[:, c] = _median(pixels[:, picked, c] / bg)
    return np.clip(gains, 0.5, 2.0)


def _median(values: np.ndarray) -> np.ndarray:
    """Median along the last axis (as ``np.median``, several times faster on short rows)."""
    n = values.shape[-1]
    lo, hi = (n - 1) // 2, n // 2
    part = np.partition(values, (lo, hi), axis=-1)
    return 0.5 * (part[..., lo] + part[..., hi])


def _thresholds(noise: float, config: SilhouetteConfig) -> tuple[float, float]:
    """(low, high) hysteresis thresholds, ΔE, for a noise level (median ΔE)."""
    low = max(config.min_delta_e, config.low_factor * noise)
    return low, max(2.0 * config.min_delta_e, config.high_factor * noise, low)


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
