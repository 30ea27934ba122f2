"""The first pass of the segmentation: per-pixel evidence of a person in stacked frames.

The frames of a chunk are stacked one above the other in a single image, each with
empty separator rows above and below it wider than any filter reaches (the layout a
:class:`Scene` holds), so that a colour conversion or a blur is one OpenCV call and the
per-pixel tests are whole-array operations over the stack.  Per chunk (:func:`chunk_evidence`):
the exposure gains undone, the colour difference to the empty scene in CIE L*a*b*, raw
and smoothed, and the lightly smoothed colours the shadow test reads; over the whole
clip (:func:`clip_levels`): its noise levels and the hysteresis thresholds that follow
from them.
"""

from __future__ import annotations

import math
from concurrent.futures import Future
from dataclasses import dataclass

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError, SceneMismatchError, VideoError
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.kernels import lab_differences, vector_lengths
from eigmotion.segmentation.workers import worker_threads

#: Gaussian sigma, pixels, of the smoothing before the shadow test.
SHADOW_SIGMA_PX = 1.0

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


def check_frames(frames) -> np.ndarray:
    """``frames`` as an array, checked to be (F, H, W, 3) uint8 RGB with ``F >= 1`` and
    ``H, W >= 8`` (InvalidParameterError; VideoError for zero frames)."""
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


def shrink(frames: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
    """Frames (F, H, W, 3) shrunk by the smallest whole factor that brings the longer
    side to at most ``config.work_max_side_px`` (area averaging over factor × factor
    blocks; the last rows and columns that do not fill a block are dropped)."""
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


@dataclass(frozen=True)
class Scene:
    """The background and the stack layout, prepared once for all chunks of a clip.

    ``rgb`` (H, W, 3) float32 and ``lab`` (H, W, 3) uint8 are the background
    shrunk to the working size; ``soft`` (H, W, 3) float32 its lightly smoothed
    colours for the shadow test, ``bright`` (H, W) their length and ``inv_norm2``
    (H, W) one over its square; ``gain_pixels`` what :func:`_gain_pixels` picks.  A
    stack of ``k`` frames has ``sep + k·tile`` rows: ``sep`` empty rows, then per
    frame its ``H`` rows and ``sep`` empty ones.  ``frame`` is the (H, W) of a whole
    frame at the working size: a scene cropped to a person region (in
    :mod:`eigmotion.segmentation.subtraction`) keeps the whole frame's (the smallest
    person is a share of its area).
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


def prepare_scene(background: np.ndarray, config: SilhouetteConfig) -> Scene:
    background = shrink(background[None], config)[0]
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
    return Scene(
        rgb, lab_frames(background[None])[0], soft, np.sqrt(norm2), 1.0 / norm2, sep, h + sep,
        close_d, reach, _gain_pixels(rgb), background.shape[:2],
    )  # fmt: skip


@dataclass(frozen=True)
class Evidence:
    """The per-pixel evidence of one chunk of ``n`` frames, stacked (see :class:`Scene`).

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


def frames_of(stack: np.ndarray, scene: Scene, n: int) -> np.ndarray:
    """(n, tile, W, ...) view of a stack's frames, each followed by its separator."""
    return stack[scene.sep :].reshape(n, scene.tile, *stack.shape[1:])


def chunk_evidence(chunk: np.ndarray, scene: Scene, config: SilhouetteConfig) -> Evidence:
    """The first pass over a chunk (k, H, W, 3) uint8 of frames: per pixel, the
    colour difference to the background, smoothed and not, and the smoothed colours."""
    frames = shrink(chunk, config)
    n, h, w = frames.shape[:3]
    rows = scene.sep + n * scene.tile
    gains = _exposure_gains(frames, scene)
    corrected = np.zeros((rows, w, 3), np.uint8)
    stacked = frames_of(corrected, scene, n)
    if np.all(np.abs(gains - 1.0) < 0.5 / 255.0):
        stacked[:, :h] = frames  # no level would change
    else:
        for frame, table, out in zip(frames, _gain_tables(gains), stacked, strict=True):
            cv2.LUT(frame, table, dst=out[:h])
    grid = grid_step(h, w)
    sample = stacked[:, :h:grid, ::grid].astype(np.float32) - scene.rgb[::grid, ::grid]
    rgb_d2 = np.einsum("...c,...c->...", sample, sample).ravel()

    diff = np.zeros((rows, w, 3), np.float32)
    raw = np.zeros((rows, w), np.float32)
    lab = cv2.cvtColor(corrected, cv2.COLOR_RGB2Lab)
    lab_differences(
        frames_of(lab, scene, n)[:, :h], scene.lab, frames_of(diff, scene, n)[:, :h],
        frames_of(raw, scene, n)[:, :h],
    )  # fmt: skip
    if config.smooth_sigma_px > 0.0:
        # Averaging the difference vector (not its length) cancels noise while a
        # consistent small offset (camouflaged clothing) survives.
        size = _gaussian_size(config.smooth_sigma_px)
        cv2.GaussianBlur(diff, size, config.smooth_sigma_px, dst=diff)
        smoothed = np.empty((rows, w), np.float32)
        vector_lengths(diff, smoothed)
        smoothed[: scene.sep] = 0.0  # the blur spilled into the separators
        frames_of(smoothed, scene, n)[:, h:] = 0.0
    else:
        smoothed = raw
    soft = cv2.GaussianBlur(corrected, _gaussian_size(SHADOW_SIGMA_PX), SHADOW_SIGMA_PX)
    step = grid_step(h, w)
    return Evidence(
        n, corrected, soft, raw, smoothed, rgb_d2,
        frames_of(raw, scene, n)[:, :h:step, ::step].ravel(),
        frames_of(smoothed, scene, n)[:, :h:step, ::step].ravel(),
    )  # fmt: skip


@dataclass(frozen=True)
class Levels:
    """The clip's noise levels and hysteresis thresholds (ΔE; ``rgb_noise`` in RGB levels)."""

    rgb_noise: float
    low: float
    high: float
    low_raw: float


def clip_levels(evidence: list[Evidence], config: SilhouetteConfig) -> Levels:
    """Noise levels of the whole clip: medians over the grids of all its chunks.

    Raises
    ------
    SceneMismatchError
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
        raise SceneMismatchError(
            f"the frames differ from the empty scene over most of the picture (median "
            f"colour difference {smooth_noise:.0f} ΔE; frames of the same empty view "
            f"differ from it by about 1–3): a background image of another scene or view, "
            f"a moving camera, or a person who fills most of the frame",
            smooth_noise,
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
    return Levels(rgb_noise, low, high, low_raw)


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


def _exposure_gains(frames: np.ndarray, scene: Scene) -> np.ndarray:
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


def _gain_tables(gains: np.ndarray) -> np.ndarray:
    """(F, 1, 256, 3) uint8 lookup tables (``cv2.LUT``): per frame, level → level / gain
    of each channel, rounded."""
    levels = np.arange(256, dtype=np.float32)
    tables = levels[None, :, None] / gains[:, None, :]
    return np.clip(np.rint(tables), 0, 255).astype(np.uint8)[:, None]


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


def lab_frames(frames: np.ndarray) -> np.ndarray:
    """(F, H, W, 3) uint8 RGB → uint8 L*a*b* (OpenCV's 8-bit scaling: L×255/100, a+128, b+128).

    One conversion over the whole clip (the frames stacked into one image); the 8-bit
    rounding (mean ΔE 0.5) is far below the thresholds.
    """
    n, h, w = frames.shape[:3]
    stacked = np.ascontiguousarray(frames).reshape(n * h, w, 3)
    return cv2.cvtColor(stacked, cv2.COLOR_RGB2Lab).reshape(n, h, w, 3)


def start_colour_tables() -> Future:
    """Have OpenCV build its 8-bit L*a*b* tables now, on a worker thread.

    The first RGB → L*a*b* conversion in a process builds them (about 70 ms on an idle
    machine, the GIL released); started before the database is opened or the video
    decoded, they are built while that work goes on, on another core.
    """
    return worker_threads().submit(lab_frames, np.zeros((1, 1, 1, 3), np.uint8))


def _gaussian_size(sigma_px: float) -> tuple[int, int]:
    """Kernel size of a Gaussian blur cut at 2 sigma (OpenCV's default cuts at 3–4)."""
    half = max(1, math.ceil(2.0 * sigma_px))
    return (2 * half + 1, 2 * half + 1)


def grid_step(h: int, w: int) -> int:
    """Stride, pixels, of the grid the clip-wide statistics sample: about 1,000 per frame."""
    return max(1, int(math.sqrt(h * w / 1000.0)))
