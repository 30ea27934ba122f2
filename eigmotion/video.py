"""The video front end: person silhouettes cut out of ordinary RGB video.

:func:`extract_silhouettes` turns frames into masks for :func:`~eigmotion.motion_image.
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
    1999) ──▶ not foreground ──▶ hysteresis: weak pixels (ΔE > low) kept when
    connected to strong ones (ΔE > high) ──▶ drop specks, close small gaps
    ──▶ the largest blob, plus big pieces above or below it (a head or legs cut
    off by camouflage) ──▶ fill holes that are small or differ from the
    background (not a shadow between the feet) ──▶ the rim the smoothing added
    is kept only where each pixel differs by itself ──▶ boundary pixels whose
    colour is nearer the background than the body (matting alpha < 0.5) dropped.

Thresholds follow the clip's noise level, the median ΔE over all pixels (most are
background): ``low = max(min_delta_e, low_factor × noise)``, ``high`` likewise.  A
lossy codec removes the fine grain but adds blocky errors, so the raw noise level is
never taken below :data:`RAW_PER_SMOOTHED_NOISE` times the smoothed one.

Background estimation when none is given (``SilhouetteConfig.background``):

``"median"``
    Per-pixel temporal median over up to ``max_background_frames`` frames spread over
    the clip, then refined once: the median again, over only the frames where the
    pixel was not (near) the person in a first segmentation and not darker than a
    shadow would make it.  Works while the person moves off every pixel for more
    than half of the clip, even when in view from the first frame: a walk across
    the picture, not a walk towards the camera or a wave on the spot (measured in
    ``docs/motion-image.md``).
``"mog2"``
    OpenCV's Gaussian-mixture subtractor (``BackgroundSubtractorMOG2``) run twice
    over the clip, its background image then used as above.  Kept for comparison:
    it measured worse (it keeps ghosts of a slowly moving person).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from .errors import InvalidParameterError, VideoError

BACKGROUND_METHODS = ("median", "mog2")

#: Gaussian sigma, pixels, of the smoothing before the shadow test.
SHADOW_SIGMA_PX = 1.0

#: Ratio of the raw to the smoothed median ΔE of sensor noise (white noise blurred
#: by the optics, smoothed with sigma 1 px; measured 2.7–2.8 on composed scenes).
RAW_PER_SMOOTHED_NOISE = 2.5

#: Frame rate assumed for an ``.npz`` of masks that stores none, frames per second.
DEFAULT_NPZ_FPS = 30.0


@dataclass(frozen=True)
class SilhouetteConfig:
    """Parameters of :func:`extract_silhouettes`.

    Parameters
    ----------
    background : {"median", "mog2"}
        How to estimate the background when none is given.
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
    work_max_side_px : int
        Frames (and the background) larger than this on their longer side are
        shrunk to it (area averaging) before segmentation, and the masks come back
        at that size, in [64, 4096].  The motion image is cropped and rescaled to
        32–64 pixels anyway, so segmenting full-resolution video only costs time.
    """

    background: str = "median"
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
    n, h, w = frames.shape[:3]
    if background is not None:
        background = np.asarray(background)
        if background.dtype != np.uint8 or background.ndim != 3 or background.shape[2] != 3:
            raise InvalidParameterError(
                f"background must be (H, W, 3) uint8 RGB, got {background.dtype} {background.shape}"
            )
        if background.shape[:2] != (h, w):
            raise VideoError(
                f"background is {background.shape[1]}×{background.shape[0]} pixels but the "
                f"frames are {w}×{h}; expected the same size"
            )
        frames, background = _shrink(frames, config), _shrink(background[None], config)[0]
        masks = _segment(frames, background, config)
    else:
        frames = _shrink(frames, config)
        masks = _segment(frames, estimate_background(frames, config), config)
        if config.background == "median":
            refined = estimate_background(frames, config, exclude=masks)
            masks = _segment(frames, refined, config)
    if not masks.any():
        raise VideoError(
            f"no person found in {n} frame(s): nothing that differs from the background "
            f"covers {config.min_person_frac:.2%} of the image"
        )
    return masks


def _shrink(frames: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
    """Frames (F, H, W, 3) shrunk to the working resolution (area averaging)."""
    import cv2

    h, w = frames.shape[1:3]
    factor = config.work_max_side_px / max(h, w)
    if factor >= 1.0:
        return frames
    size = (max(1, round(w * factor)), max(1, round(h * factor)))
    return np.stack([cv2.resize(f, size, interpolation=cv2.INTER_AREA) for f in frames])


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
        to the plain median.  Only used by the median method.

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
    plain = np.median(sample, axis=0)
    if exclude is None:
        return np.clip(np.rint(plain), 0, 255).astype(np.uint8)
    exclude = np.asarray(exclude, dtype=bool)
    if exclude.shape != frames.shape[:3]:
        raise InvalidParameterError(
            f"exclude must have shape {frames.shape[:3]} like the frames, got {exclude.shape}"
        )
    grow = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
    excluded = np.zeros(sample.shape[:3], bool)
    for i, k in enumerate(pick):
        if exclude[k].any():
            excluded[i] = cv2.dilate(exclude[k].astype(np.uint8), grow).astype(bool)
    # Cast shadows only darken: a floor pixel the shadow covers for most of the clip
    # would get a dark median.  Drop the samples darker than a shadow's upper ratio
    # of the pixel's bright level (its 80th luminance percentile), then take the median.
    luma = sample.astype(np.float32) @ np.float32([0.299, 0.587, 0.114])
    bright = _masked_quantile(luma[..., None], excluded, 0.8)[..., 0]
    excluded |= luma < config.shadow_ratio[1] * bright[None]
    refined = _masked_quantile(sample, excluded, 0.5)
    refined = np.where(np.isnan(refined), plain, refined)
    return np.clip(np.rint(refined), 0, 255).astype(np.uint8)


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
    (H, W, C) float32
        NaN where every frame is excluded.
    """
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


def load_clip_masks(
    path: str | Path,
    background_path: str | Path | None = None,
    config: SilhouetteConfig = SilhouetteConfig(),  # noqa: B008 - frozen, immutable
) -> tuple[np.ndarray, float]:
    """Silhouettes of the person in a clip on disk.

    Parameters
    ----------
    path : str or Path
        A video (``.mp4``, ``.avi``, ``.mov``, ``.mkv``), a GIF or a folder of frame
        images (read by :func:`eigmotion.media.read_frames`), or an ``.npz`` with key
        ``masks`` ``(F, H, W)`` (bool, or numbers: > 0 is the person) and optionally
        ``fps`` (a scalar, frames per second; :data:`DEFAULT_NPZ_FPS` if absent).
    background_path : str or Path, optional
        An image of the empty scene, same size as the frames (video input only).
    config : SilhouetteConfig

    Returns
    -------
    masks : (F, H, W) bool
    fps : float
        Frames per second.

    Raises
    ------
    VideoError
        Missing or unreadable file, zero frames, no person, background of another size.
    InvalidParameterError
        An ``.npz`` without ``masks`` or with masks of the wrong shape; a background
        given with an ``.npz`` of masks.
    """
    path = Path(path)
    if path.suffix.lower() == ".npz":
        if background_path is not None:
            raise InvalidParameterError(
                f"{path}: background_path applies to video input, not to stored masks"
            )
        return _load_npz_masks(path)
    from .media import read_frames

    frames, fps = read_frames(path)
    background = None if background_path is None else read_background(background_path)
    return extract_silhouettes(frames, background, config), fps


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


def _segment(frames: np.ndarray, background: np.ndarray, config: SilhouetteConfig) -> np.ndarray:
    """Masks of the person in every frame against one background image."""
    import cv2

    n, h, w = frames.shape[:3]
    bg_rgb = background.astype(np.float32)
    bg_lab = cv2.cvtColor(bg_rgb * (1.0 / 255.0), cv2.COLOR_RGB2Lab)
    # The shadow test compares lightly smoothed colours: video codecs halve the colour
    # resolution, which scatters the chromaticity of single pixels.
    bg_soft = cv2.GaussianBlur(bg_rgb, (0, 0), SHADOW_SIGMA_PX)
    bg_norm2 = np.maximum((bg_soft * bg_soft).sum(axis=2), 1.0)
    bg_bright = np.sqrt(bg_norm2)
    smooth = config.smooth_sigma_px > 0.0

    gains = _exposure_gains(frames, bg_rgb)
    raw = np.empty((n, h, w), np.float32)
    smoothed = np.empty((n, h, w), np.float32) if smooth else raw
    for i in range(n):
        rgb = frames[i].astype(np.float32) / gains[i]
        lab = cv2.cvtColor(np.clip(rgb, 0.0, 255.0) * (1.0 / 255.0), cv2.COLOR_RGB2Lab)
        diff = lab - bg_lab
        raw[i] = np.sqrt((diff * diff).sum(axis=2))
        if smooth:
            # Averaging the difference vector (not its length) cancels noise while a
            # consistent small offset (camouflaged clothing) survives.
            diff = cv2.GaussianBlur(diff, (0, 0), config.smooth_sigma_px)
            smoothed[i] = np.sqrt((diff * diff).sum(axis=2))
    raw_noise = _noise(raw)
    if smooth:
        smooth_noise = _noise(smoothed)
        # A lossy codec removes the fine grain (lowering the raw median) but leaves
        # blocky low-frequency errors (raising the smoothed one): the raw noise is
        # never taken below what the smoothed noise implies.
        raw_noise = max(raw_noise, RAW_PER_SMOOTHED_NOISE * smooth_noise)
        low, high = _thresholds(smooth_noise, config)
        low_raw, _ = _thresholds(raw_noise, config)
    else:
        low, high = low_raw, _ = _thresholds(raw_noise, config)
    sample = frames[:, ::4, ::4].astype(np.float32) / gains[:, None, None, :]
    rgb_noise = float(np.median(np.linalg.norm(sample - bg_rgb[::4, ::4], axis=-1)))

    scale = h / 240.0
    close_d = max(1, int(round(config.close_px * scale))) | 1
    closing = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (close_d, close_d))
    # Pixels deeper inside than the smoothing reaches are body even where camouflaged.
    reach = int(math.ceil(2.0 * config.smooth_sigma_px))
    inner = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
    min_area = config.min_person_frac * h * w
    speck = max(2, int(round(min_area * 0.05)))
    out = np.zeros((n, h, w), bool)
    for i in range(n):
        weak = smoothed[i] > low
        if not weak.any():
            continue
        rgb = frames[i].astype(np.float32) / gains[i]
        shadow = _shadow(rgb, bg_soft, bg_norm2, bg_bright, rgb_noise, config, cv2)
        weak &= ~shadow
        strong = weak & (smoothed[i] > high)
        mask = _hysteresis(weak, strong, speck, cv2)
        if close_d > 1:
            mask = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, closing).astype(bool)
        mask = _person_blob(mask, min_area, config.keep_piece_frac, cv2)
        if not mask.any():
            continue
        evidence = (smoothed[i], low, raw[i], low_raw)
        mask = _fill_holes(mask, evidence, shadow, reach, config.small_hole_frac, cv2)
        if smooth:  # the smoothing widened the mask: its rim must differ pixel by pixel
            interior = cv2.erode(mask.astype(np.uint8), inner).astype(bool)
            mask &= interior | ((raw[i] > low_raw) & ~shadow)
        out[i] = _refine_boundary(mask, rgb, bg_rgb, 4.0 * rgb_noise, cv2)
    return out


def _exposure_gains(frames: np.ndarray, bg_rgb: np.ndarray) -> np.ndarray:
    """(F, 3) float32: per frame and channel, the median ratio frame / background.

    Absorbs exposure and white-balance drift, and the colour bias of a lossy codec,
    between the frames and a background photographed apart from them.  The median
    over the image ignores the person as long as they cover less than half of it.
    """
    bg = bg_rgb[::2, ::2]
    usable = bg >= 16.0  # ratios of near-black pixels are noise
    gains = np.ones((frames.shape[0], 3), np.float32)
    for c in range(3):
        if usable[..., c].sum() < 16:
            continue
        ratios = frames[:, ::2, ::2, c][:, usable[..., c]] / bg[..., c][usable[..., c]]
        gains[:, c] = np.median(ratios, axis=1)
    return np.clip(gains, 0.5, 2.0)


def _shadow(rgb, bg_soft, bg_norm2, bg_bright, rgb_noise, config, cv2) -> np.ndarray:
    """(H, W) bool: pixels explained as the background in a cast shadow.

    Brightness distortion ``alpha`` (pixel ≈ alpha × background) within
    ``shadow_ratio`` and chromaticity distortion ``|pixel − alpha × background|``
    small relative to the background's brightness (Horprasert et al. 1999).
    """
    soft = cv2.GaussianBlur(rgb, (0, 0), SHADOW_SIGMA_PX)
    alpha = (soft * bg_soft).sum(axis=2) / bg_norm2
    chroma = np.sqrt(((soft - alpha[..., None] * bg_soft) ** 2).sum(axis=2))
    return (
        (alpha >= config.shadow_ratio[0])
        & (alpha <= config.shadow_ratio[1])
        & (chroma <= config.shadow_chroma * alpha * bg_bright + rgb_noise)
    )


def _noise(distances: np.ndarray) -> float:
    """The clip's noise level: the median ΔE over (a grid of) all pixels and frames."""
    return float(np.median(distances[:, ::2, ::2]))


def _thresholds(noise: float, config: SilhouetteConfig) -> tuple[float, float]:
    """(low, high) hysteresis thresholds, ΔE, for a noise level (median ΔE)."""
    low = max(config.min_delta_e, config.low_factor * noise)
    return low, max(2.0 * config.min_delta_e, config.high_factor * noise, low)


def _refine_boundary(
    mask: np.ndarray, rgb: np.ndarray, bg_rgb: np.ndarray, min_contrast: float, cv2
) -> np.ndarray:
    """Drop boundary pixels whose colour is nearer the background than the body.

    A blurred edge pixel mixes body and background colours; the low hysteresis
    threshold keeps pixels that are mostly background.  For each pixel on the mask's
    1-px rim, the local body colour F is the mean of the mask's core (2 px inside)
    nearby; the pixel's matting alpha along F − B decides, where F and B differ by at
    least ``min_contrast`` (RGB levels) so the decision is not noise.
    """
    m8 = mask.astype(np.uint8)
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    rim = mask & ~cv2.erode(m8, cross).astype(bool)
    core = cv2.erode(m8, cross, iterations=2).astype(np.float32)
    weight = cv2.blur(core, (7, 7))
    near_core = rim & (weight > 0.0)
    if not near_core.any():
        return mask
    body = cv2.blur(rgb * core[..., None], (7, 7))[near_core] / weight[near_core][:, None]
    back = bg_rgb[near_core]
    fb = body - back
    contrast2 = (fb * fb).sum(axis=1)
    alpha = ((rgb[near_core] - back) * fb).sum(axis=1) / np.maximum(contrast2, 1e-6)
    drop = (contrast2 >= min_contrast * min_contrast) & (alpha < 0.5)
    out = mask.copy()
    rows, cols = np.nonzero(near_core)
    out[rows[drop], cols[drop]] = False
    return out


def _hysteresis(weak: np.ndarray, strong: np.ndarray, speck: int, cv2) -> np.ndarray:
    """Weak pixels in 8-connected components that hold a strong pixel and are not specks."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(weak.astype(np.uint8), 8)
    keep = np.zeros(count, bool)
    keep[np.unique(labels[strong])] = True
    keep[0] = False
    keep &= stats[:, cv2.CC_STAT_AREA] >= speck
    return keep[labels]


def _person_blob(mask: np.ndarray, min_area: float, keep_frac: float, cv2) -> np.ndarray:
    """The largest blob, plus big pieces touching its grown bounding box."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), 8)
    if count <= 1:
        return np.zeros_like(mask)
    areas = stats[1:, cv2.CC_STAT_AREA]
    best = int(np.argmax(areas)) + 1
    if stats[best, cv2.CC_STAT_AREA] < min_area:
        return np.zeros_like(mask)
    x, y, bw, bh = (int(v) for v in stats[best, :4])
    # A piece cut off by camouflaged clothing (head, legs) lies above or below.
    gx, gy = 0.25 * bw, 0.5 * bh
    left, right = stats[:, 0], stats[:, 0] + stats[:, 2]
    top, bottom = stats[:, 1], stats[:, 1] + stats[:, 3]
    near = (right >= x - gx) & (left <= x + bw + gx) & (bottom >= y - gy) & (top <= y + bh + gy)
    keep = near & (stats[:, cv2.CC_STAT_AREA] >= keep_frac * stats[best, cv2.CC_STAT_AREA])
    keep[0] = False
    keep[best] = True
    return keep[labels]


def _fill_holes(
    mask: np.ndarray,
    evidence: tuple[np.ndarray, float, np.ndarray, float],
    shadow: np.ndarray,
    reach: int,
    small_frac: float,
    cv2,
) -> np.ndarray:
    """Fill the holes inside the person that are clothing, not background.

    A hole is filled when it is small, or when its pixels differ from the
    background — judged on the smoothed distance over the part of the hole more than
    ``reach`` pixels from its edge (the smoothing bleeds the body into narrow gaps),
    else on the raw distance — unless it touches the floor line of the body (its
    lowest 15 %) and is partly a cast shadow: the gap between the legs and the shadow
    they enclose.

    ``evidence`` is ``(smoothed, low_smoothed, raw, low_raw)``: (H, W) ΔE distances
    and their low thresholds.
    """
    smoothed, low_smoothed, raw, low_raw = evidence
    inverse = (~mask).astype(np.uint8)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(inverse, 4)
    if count <= 2:
        return mask
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    area = float(mask.sum())
    rows = np.flatnonzero(mask.any(axis=1))
    floor_line = rows[-1] - 0.15 * (rows[-1] - rows[0] + 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1, 2 * reach + 1))
    out = mask.copy()
    for label in range(1, count):
        if label in border:
            continue
        hole = labels == label
        if stats[label, cv2.CC_STAT_AREA] <= small_frac * area:
            out |= hole
            continue
        core = cv2.erode(hole.astype(np.uint8), kernel).astype(bool) if reach else hole
        if core.any():
            differs = float(np.median(smoothed[core])) > low_smoothed
        else:
            differs = float(np.median(raw[hole])) > low_raw
        bottom = stats[label, cv2.CC_STAT_TOP] + stats[label, cv2.CC_STAT_HEIGHT] - 1
        floor_shadow = bottom >= floor_line and float(shadow[hole].mean()) > 0.3
        if differs and not floor_shadow:
            out |= hole
    return out
