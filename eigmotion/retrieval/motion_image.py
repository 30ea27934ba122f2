"""The motion image: a whole clip of silhouettes pressed into one unit vector.

This is step 3 of the retrieval engine, and the one function both the database build
(masks rendered from the avatar by virtual cameras) and the query (masks cut out of a
video) go through, so that both sides see exactly the same preprocessing::

    masks (F, H, W) ──sample at sample_fps──▶ (F', H, W)
        ──align: image frame (one crop for the clip) or person frame (each frame on
          its body centre, scaled by the body height)──▶ (F', S, S) in [0, 1]
        ──|m_t − m_{t−step}|──▶ (F'−step, S, S) differences
        ──cut into ``phases`` consecutive parts holding equal shares of the
          motion (or of the time), each part:
          weighted sum (uniform or recency)──▶ one after-image (S, S)
          ──drop faint residue (residual_floor), optional mean-silhouette term──▶
          ──optional LoG or Sobel──▶
        ──side by side, raster scan──▶ x, ‖x‖ = 1, (phases·S·S,) float32

``S`` is :attr:`MotionImageConfig.size`.  The crop keeps the aspect ratio: the region
of interest is scaled uniformly into the square and padded with zeros.

Frames (``MotionImageConfig.frame``):

``"image"``
    One crop for the whole clip: the bounding box of every pixel the person covered
    (the support of the accumulated image plus the still body parts), widened by
    ``margin_frac`` and centred in the square.  A walk across the picture becomes a
    streak; the absolute path stays in the image.
``"person"``
    Each frame is first moved so that its body centre (the median row and column of
    its silhouette, robust to a swinging limb) lands on the square's centre, and the
    clip is scaled so that its body height (median over frames of the silhouette
    height) spans ``person_height_frac`` of the square.  A person walking across the
    image, or filmed from further away, gives the same image.  The scale is one per
    clip, not one per frame: a per-frame height would stretch a crouching body back
    to standing height and erase a sit-down.

Weighting (``MotionImageConfig.weighting``):

``"uniform"``
    Every difference weighs the same; a motion and its time reverse give the same
    image (the set of differences is the same).
``"recency"``
    Motion-history style: the ``j``-th of ``n`` differences weighs ``(j + 1) / n``, so
    the end of the motion is brighter than its start and "sit down" differs from
    "stand up".

Phases (``MotionImageConfig.phases``, ``phase_cuts``) cut the differences into
consecutive parts that each hold an equal share of the motion — the summed
differences — by default, so that a pause or a slow start moves no cut: people
do the same action at different paces (measured: 89 → 100 of 162 top-1 on the
holdout benchmark of new performers, ``docs/accuracy.md``).

The optional silhouette term (``silhouette_weight``) blends in the mean aligned
silhouette, weighted over time like the differences (so under "recency" it is
dominated by the pose the motion ends in).  The defaults — person frame, recency,
silhouette weight 0.5, Sobel, 32×32, two phases — are the best of the configurations
measured by nearest-neighbour retrieval over the motion library, on rendered masks
and on masks cut out of composed video, and (the phases) on the holdout benchmark of
new performers (``docs/motion-image.md``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from numbers import Integral, Real
from typing import ClassVar

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError, StillPersonError, VideoError
from eigmotion.imaging.media import FRAME_RATE_FPS, sample_indices
from eigmotion.segmentation.cut_bodies import continued_below
from eigmotion.validation import Interval, Options, validate, validate_params

FRAMES = ("image", "person")
WEIGHTINGS = ("uniform", "recency")
FILTERS = ("none", "log", "sobel")
PHASE_CUTS = ("motion", "time")

#: The ``min_change`` a query's silhouettes are held to (:class:`ClipMotionImages`):
#: share of the body's area per sampled frame.  Measured on masks the learned
#: segmenter cut out of the development set's clips (docs/motion-image.md, "A person
#: standing still"): their first frames held still, median 0.43% (123 of 140 under
#: it); the clips as filmed, 2.46% for the slowest action (a slow wave), median 20%.
STILL_CHANGE_SHARE = 0.013

#: Fraction of the silhouette mass trimmed at each end when measuring extents (the
#: image-frame crop, each frame's body height), so a stray speck far from the body
#: sets neither.  Measured: 5e-3 keeps retrieval on clean masks and lifts it on
#: masks cut out of video (see docs/motion-image.md).
_EXTENT_TRIM = 5e-3


@dataclass(frozen=True)
class MotionImageConfig:
    """Parameters of :func:`motion_image`; store it with every database built.

    Parameters
    ----------
    size : int
        Side of the square image, pixels; each phase has ``size * size`` elements.
        Valid range [8, 512].
    step : int
        Frame gap of the differences (1, 2 or 3 sampled frames apart).
    sample_fps : float
        Frame rate the clip is subsampled to before anything else, frames per
        second, in [1, 50].  Clips at 120 fps and at 30 fps of one motion then give
        the same image.  A clip slower than this is used as it is.
    frame : {"image", "person"}
        Plain image frame, or each silhouette aligned on its body centre and scaled
        by the body height first (see module docstring).
    weighting : {"uniform", "recency"}
        How differences are summed into the after-image (see module docstring).
    filter : {"none", "log", "sobel"}
        Optional blur-and-differentiate step that suppresses flat areas:
        the negated Laplacian of Gaussian (signed), or the Sobel gradient magnitude.
    log_sigma_px : float
        Gaussian sigma of the LoG filter, pixels of the output image, in [0.3, size/8].
    silhouette_weight : float
        Weight in [0, 1] of the mean aligned silhouette (weighted over time like the
        differences) blended into the after-image, each scaled to a maximum of 1
        first (0: differences only, as the patent; 1: the mean silhouette only).
    residual_floor : float
        Accumulated values below this fraction of the image's maximum are set to 0
        ("remove the remaining background": anti-aliasing flicker along still
        edges, one-off specks).  In [0, 0.5).
    margin_frac : float
        Image frame: free border added around the crop, as a fraction of its longer
        side, in [0, 0.45].
    person_height_frac : float
        Person frame: the body height as a fraction of ``size``, in [0.1, 1].
    min_motion_frac : float
        A clip whose mean difference mass is below this fraction of its mean
        silhouette area is rejected as "no motion", in [0, 1).
    phases : int
        The clip cut into this many consecutive parts of equal length, each made
        into its own ``size``×``size`` image the same way, side by side in the
        vector (1–4): the order of what happens, which one after-image blurs (a
        pick-up goes down then up, a sit-down only down).
    phase_cuts : {"motion", "time"}
        Where the phases are cut: ``"motion"``, where the differences summed from
        the start reach each equal share of their total — the same moments of the
        movement whatever its pace, however long a performer pauses or holds a
        pose; ``"time"``, at equal shares of the clip's duration.
    """

    size: int = 32
    step: int = 1
    sample_fps: float = 15.0
    frame: str = "person"
    weighting: str = "recency"
    filter: str = "sobel"
    log_sigma_px: float = 1.0
    silhouette_weight: float = 0.5
    residual_floor: float = 0.05
    margin_frac: float = 0.05
    person_height_frac: float = 0.6
    min_motion_frac: float = 0.002
    phases: int = 2
    phase_cuts: str = "motion"

    #: The valid values of each parameter (see :mod:`eigmotion.validation`);
    #: ``log_sigma_px``, whose upper bound is ``size / 8``, is checked after.
    _parameter_constraints: ClassVar[dict] = {
        "size": Interval(Integral, 8, 512),
        "step": Interval(Integral, 1, 3),
        "sample_fps": Interval(Real, 1.0, 50.0),
        "frame": Options(str, list(FRAMES)),
        "weighting": Options(str, list(WEIGHTINGS)),
        "filter": Options(str, list(FILTERS)),
        "silhouette_weight": Interval(Real, 0.0, 1.0),
        "residual_floor": Interval(Real, 0.0, 0.5, closed="left"),
        "margin_frac": Interval(Real, 0.0, 0.45),
        "person_height_frac": Interval(Real, 0.1, 1.0),
        "min_motion_frac": Interval(Real, 0.0, 1.0, closed="left"),
        "phases": Interval(Integral, 1, 4),
        "phase_cuts": Options(str, list(PHASE_CUTS)),
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints)
        validate("log_sigma_px", self.log_sigma_px, Interval(Real, 0.3, self.size / 8.0))
        # Normalise numeric types so that to_dict() round-trips exactly.
        object.__setattr__(self, "size", int(self.size))
        object.__setattr__(self, "step", int(self.step))
        object.__setattr__(self, "phases", int(self.phases))
        for name in (
            "sample_fps",
            "log_sigma_px",
            "silhouette_weight",
            "residual_floor",
            "margin_frac",
            "person_height_frac",
            "min_motion_frac",
        ):
            object.__setattr__(self, name, float(getattr(self, name)))

    @property
    def n_dims(self) -> int:
        """Length of a motion-image vector, ``phases * size * size``."""
        return self.phases * self.size * self.size

    def to_dict(self) -> dict:
        """Plain ``{name: int | float | str}`` for storing with a database."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> MotionImageConfig:
        """The inverse of :meth:`to_dict`; missing keys take their defaults, except
        ``phases`` and ``phase_cuts``: a configuration stored before they existed made
        one image (1), and cut phases by time.

        Raises
        ------
        InvalidParameterError
            On an unknown key or an invalid value.
        """
        if not isinstance(data, dict):
            raise InvalidParameterError(
                f"motion image config must be a dict, got {type(data).__name__}"
            )
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise InvalidParameterError(
                f"motion image config: unknown key(s) {unknown}; expected some of {sorted(known)}"
            )
        return cls(**{"phases": 1, "phase_cuts": "time", **data})


# -- public ------------------------------------------------------------------------------


def motion_image(
    masks: np.ndarray,
    config: MotionImageConfig = MotionImageConfig(),  # noqa: B008 - frozen, immutable
    clip_fps: float | None = None,
) -> np.ndarray:
    """One unit vector summarising the motion in a clip of silhouettes.

    Parameters
    ----------
    masks : (F, H, W) bool, uint8 or float
        Silhouettes, person > 0 (uint8 0/1 or 0/255; float in [0, 1]).  Needs at
        least ``config.step + 1`` frames after sampling.
    config : MotionImageConfig
    clip_fps : float, optional
        Frame rate of ``masks``, frames per second.  The clip is subsampled to
        ``config.sample_fps`` (nearest frame to each sample time).  ``None`` means the
        clip is already at the rate wanted and every frame is used.

    Returns
    -------
    (config.n_dims,) float32
        The raster-scanned (row-major) motion image with Euclidean norm 1.

    Raises
    ------
    InvalidParameterError
        ``masks`` of the wrong shape, type, or holding NaN/inf or negative values;
        a bad ``clip_fps``.
    VideoError
        Every mask empty ("no person"); :class:`~eigmotion.errors.StillPersonError`
        where nothing moved ("no motion").
    """
    return ClipMotionImages(masks, config, clip_fps).window(0, len(masks))


class ClipMotionImages:
    """Motion images of a clip and of windows of it, sharing the per-frame work.

    Each frame's silhouette is converted, and its mass profiles, body centre and body
    height measured, once; a window then only aligns and accumulates its frames.
    :meth:`window` equals :func:`motion_image` of the window's masks.

    Parameters
    ----------
    masks, config, clip_fps
        As for :func:`motion_image`, for the whole clip.
    hidden_below_px : int
        Rows of the person's body below the frames' bottom edge (feet out of the
        picture, :func:`eigmotion.segmentation.cut_bodies.hidden_rows_below`): every
        silhouette is continued down by as many copies of its bottom row first, so
        that the body's height and centre are measured on the whole body.
    min_change : float
        A window whose silhouettes, as given (before the person frame aligns them),
        change between its sampled frames by less than this share of the body's
        area per frame on average raises "no motion": a person standing still, whose
        masks only flicker along their edges (:data:`STILL_CHANGE_SHARE`).  In
        [0, 1); 0 tests nothing beyond ``config.min_motion_frac``.
    """

    def __init__(
        self,
        masks: np.ndarray,
        config: MotionImageConfig = MotionImageConfig(),  # noqa: B008 - frozen, immutable
        clip_fps: float | None = None,
        hidden_below_px: int = 0,
        min_change: float = 0.0,
    ):
        stack = continued_below(_check_masks(masks), int(hidden_below_px))
        if clip_fps is not None:
            validate("clip_fps", clip_fps, FRAME_RATE_FPS)
        validate("min_change", min_change, Interval(Real, 0.0, 1.0, closed="left"))
        self.config, self.clip_fps, self.min_change = config, clip_fps, float(min_change)
        if stack.dtype == np.bool_:
            # Masses of 0/1 pixels are whole numbers: counted, they are the float32 sums
            # to the bit; only the region a window resamples becomes float (_aligned).
            self._values = stack
            self._rows = np.count_nonzero(stack, axis=2).astype(np.float32)  # (F, H) per row
            self._cols = np.count_nonzero(stack, axis=1).astype(np.float32)  # (F, W) per column
        else:
            values = stack.astype(np.float32)  # one conversion; every later step reads it
            if stack.dtype == np.uint8 and stack.max() > 1:
                values *= 1.0 / 255.0
            self._values = values
            self._rows = values.sum(axis=2)  # (F, H) silhouette mass per row
            self._cols = values.sum(axis=1)  # (F, W) and per column
        self._occupied = self._rows.sum(axis=1) > 0.0
        # Body centre (row, col) and height per frame: the person frame and the rise.
        self._centres = np.stack(
            [_weighted_median(self._rows), _weighted_median(self._cols)], axis=1
        )
        self._heights = _trimmed_span(self._rows)

    def window(self, start: int, stop: int) -> np.ndarray:
        """The motion image of frames ``[start, stop)`` of the clip.

        Returns
        -------
        (config.n_dims,) float32
            Unit vector, as :func:`motion_image`.

        Raises
        ------
        VideoError
            As :func:`motion_image`: no person, too few frames, or no motion
            (:class:`~eigmotion.errors.StillPersonError`, also when the silhouettes
            change by less than ``min_change``).
        """
        kept = self._enough(self._sampled(start, stop))
        if self.min_change > 0.0:
            change = self._change(kept)
            if change < self.min_change:
                raise StillPersonError(
                    f"masks: no motion: the silhouettes change by {change:.2%} of the body's "
                    f"area per frame, under {self.min_change:.2%}: the person stands still, "
                    "or moves only where the camera cannot see it"
                )
        return _image_from_aligned(self._aligned(kept), self.config)

    def change(self, start: int, stop: int) -> float:
        """How much the silhouettes of frames ``[start, stop)`` change, as given.

        Returns
        -------
        float
            The pixels that differ between consecutive sampled frames (those the
            window keeps), on average, over the body's mean area: 0 for a body that
            does not move, 0.025–1.4 for the development set's actions (see
            :data:`STILL_CHANGE_SHARE`).

        Raises
        ------
        VideoError
            As :meth:`window`: no person, or too few frames with one.
        """
        return self._change(self._enough(self._sampled(start, stop)))

    def _change(self, frames: np.ndarray) -> float:
        """:meth:`change` of ``frames`` (at least two, each with a person)."""
        rows = self._rows[frames]
        y0, y1 = _support(rows.sum(axis=0))
        x0, x1 = _support(self._cols[frames].sum(axis=0))
        roi = self._values[frames, y0:y1, x0:x1]
        if roi.dtype == np.bool_:
            changed = float(np.count_nonzero(roi[1:] != roi[:-1]))
        else:
            changed = float(np.abs(np.diff(roi, axis=0)).sum())
        return changed / (len(frames) - 1) / (float(rows.sum()) / len(frames))

    def aligned(self, size: int) -> np.ndarray:
        """The whole clip's silhouettes as the motion image sees them, at another size.

        Parameters
        ----------
        size : int
            Side of the aligned square, pixels.

        Returns
        -------
        (F'', size, size) float32 in [0, 1]
            The frames the motion image samples, aligned in its frame (see
            :func:`align_frames`).

        Raises
        ------
        VideoError
            No person, or too few frames with one.
        """
        return self._aligned(self._enough(self._sampled(0, len(self._values))), size)

    def rise(self) -> np.ndarray:
        """How high the top of the body stands in each frame of :meth:`aligned`.

        The person frame centres every frame on its body, so a jump or a crouch keeps
        its shape but loses its height; this keeps it.  The top of the body is the
        body centre row less half the body height (both as the person frame measures
        them, robust to a raised arm); its rise is how far it lies above its median
        over the clip's frames, over the clip's median body height.

        Returns
        -------
        (F'',) float32
            Body heights, positive above the median (a jump rises, a sit-down sinks),
            for the frames of :meth:`aligned`; 0 for a frame without a person.
        """
        frames = self._kept(self._sampled(0, len(self._values)))
        occupied = self._occupied[frames]
        rise = np.zeros(len(frames), dtype=np.float32)
        if occupied.any():
            heights = self._heights[frames[occupied]]
            top = self._centres[frames[occupied], 0] - heights / 2.0
            rise[occupied] = (_median(top) - top) / max(_median(heights), 1.0)
        return rise

    def _sampled(self, start: int, stop: int) -> np.ndarray:
        """Indices of the frames in ``[start, stop)`` sampled at ``config.sample_fps``."""
        if self.clip_fps is None:
            return np.arange(start, stop)
        return start + sample_indices(stop - start, float(self.clip_fps), self.config.sample_fps)

    def _kept(self, frames: np.ndarray) -> np.ndarray:
        """The frames :meth:`_aligned` keeps: in the person frame, those with a person."""
        if self.config.frame == "person":
            return frames[self._occupied[frames]]
        return frames

    def _enough(self, frames: np.ndarray) -> np.ndarray:
        """:meth:`_kept` of ``frames``, or "no person" / "too few frames" raised."""
        if not self._occupied[frames].any():
            raise VideoError(
                f"masks: no person: all {len(frames)} silhouettes are empty; "
                "expected pixels > 0 where the person is"
            )
        kept = self._kept(frames)
        if len(kept) < self.config.step + 1:
            raise VideoError(
                f"masks: the person is in {len(kept)} of the {len(frames)} frame(s) sampled "
                f"at {self.config.sample_fps:g} fps; a motion image (step={self.config.step}) "
                f"needs at least {self.config.step + 1}"
            )
        return kept

    def _aligned(self, frames: np.ndarray, size: int | None = None) -> np.ndarray:
        """(F'', size, size) float32: the given frames (:meth:`_enough`'s) aligned (see
        :func:`align_frames`), at ``size`` pixels (default ``config.size``)."""
        config = self.config
        rows, cols = self._rows[frames], self._cols[frames]
        size = config.size if size is None else int(size)
        if config.frame == "image":
            # The crop: everything the person covered, less a sliver of stray mass.
            y0, y1 = _trim_1d(rows.sum(axis=0))
            x0, x1 = _trim_1d(cols.sum(axis=0))
            h, w = y1 - y0, x1 - x0
            scale = size / (max(h, w) * (1.0 + 2.0 * config.margin_frac))
            centres = np.tile([y0 + (h - 1) / 2.0, x0 + (w - 1) / 2.0], (len(frames), 1))
        else:
            # Each frame's centre is its own; the scale is the clip's.
            centres = self._centres[frames]
            heights = self._heights[frames]
            scale = config.person_height_frac * size / max(_median(heights), 1.0)
            y0, y1 = _support(rows.sum(axis=0))
            x0, x1 = _support(cols.sum(axis=0))
        # Only the region of interest is resampled: the rest is empty and costs time.
        roi = self._values[frames, y0:y1, x0:x1].astype(np.float32, copy=False)
        return _warp(roi, scale, centres - [y0, x0], size)


def align_frames(masks: np.ndarray, config: MotionImageConfig) -> np.ndarray:
    """Map every silhouette into the ``size``×``size`` square of the chosen frame.

    Parameters
    ----------
    masks : (F, H, W) bool, uint8 or float
        Silhouettes, already sampled in time.
    config : MotionImageConfig

    Returns
    -------
    (F'', size, size) float32 in [0, 1]
        Area-averaged silhouettes.  In the person frame, frames with an empty
        silhouette are dropped (they have no body centre), so ``F'' <= F``.

    Raises
    ------
    VideoError
        No person in any frame, or too few frames with a person.
    """
    images = ClipMotionImages(masks, config)
    return images._aligned(images._enough(np.arange(len(masks))))


def motion_image_picture(vector: np.ndarray, config: MotionImageConfig) -> np.ndarray:
    """A motion image as a picture to look at.

    Parameters
    ----------
    vector : (config.n_dims,) float
        A vector from :func:`motion_image`.
    config : MotionImageConfig
        The configuration it was made with.

    Returns
    -------
    (size, phases · size) uint8
        The phases side by side; non-negative images scaled so their maximum is 255,
        signed ones (LoG) mapped with 0 → 128 and the largest magnitude → 0 or 255.
    """
    v = np.asarray(vector)
    if v.ndim != 1 or v.shape[0] != config.n_dims:
        raise InvalidParameterError(
            f"vector must have shape ({config.n_dims},) for size={config.size}, "
            f"phases={config.phases}, got {v.shape}"
        )
    v = v.astype(np.float64)
    if not np.all(np.isfinite(v)):
        raise InvalidParameterError("vector holds NaN or inf")
    peak = float(np.abs(v).max())
    if peak == 0.0:
        return np.zeros((config.size, config.size), np.uint8)
    if v.min() < 0.0:
        out = 127.5 + 127.5 * v / peak
    else:
        out = 255.0 * v / peak
    picture = np.clip(np.rint(out), 0, 255).astype(np.uint8)
    return np.hstack(picture.reshape(config.phases, config.size, config.size))


# -- stages ------------------------------------------------------------------------------


def _check_masks(masks) -> np.ndarray:
    if not isinstance(masks, np.ndarray):
        masks = np.asarray(masks)
    if masks.ndim != 3 or min(masks.shape) < 1:
        raise InvalidParameterError(
            f"masks must have shape (F, H, W) with every side >= 1, got {masks.shape}"
        )
    if masks.dtype == bool or masks.dtype == np.uint8:
        return masks
    if not (np.issubdtype(masks.dtype, np.floating) or np.issubdtype(masks.dtype, np.integer)):
        raise InvalidParameterError(f"masks must be bool, uint8 or float, got dtype {masks.dtype}")
    if not np.all(np.isfinite(masks)):
        raise InvalidParameterError("masks hold NaN or inf; expected values in [0, 1]")
    lo, hi = float(masks.min()), float(masks.max())
    if lo < 0.0 or hi > 1.0:
        raise InvalidParameterError(
            f"masks must hold values in [0, 1] (or be bool/uint8), got range [{lo:g}, {hi:g}]"
        )
    return masks.astype(np.float32, copy=False)


def _image_from_aligned(aligned: np.ndarray, config: MotionImageConfig) -> np.ndarray:
    """(F, S, S) aligned silhouettes → (phases·S·S,) unit float32 motion image."""
    s = config.step
    diffs = np.abs(aligned[s:] - aligned[:-s])  # (n, S, S)
    n = diffs.shape[0]
    mean_area = float(aligned.sum()) / aligned.shape[0]
    motion = float(diffs.sum()) / n
    if motion <= config.min_motion_frac * mean_area or diffs.max() <= 0.0:
        raise StillPersonError(
            f"masks: no motion: the silhouettes barely change (mean change {motion:.3g} px "
            f"per difference vs a body of {mean_area:.3g} px at size {config.size}); "
            f"expected at least min_motion_frac={config.min_motion_frac:g} of the body"
        )
    # Phase p takes the differences [cuts[p], cuts[p+1]) and the frames they join.
    cuts = _phase_cuts(diffs, config)
    images = [
        _phase_image(diffs[a:b], aligned[a : b + s], config)
        for a, b in zip(cuts[:-1], cuts[1:], strict=True)
    ]
    vector = np.concatenate([image.reshape(-1) for image in images])
    norm = float(np.linalg.norm(vector))
    if norm <= 0.0:  # pragma: no cover - a non-zero image keeps energy under LoG/Sobel
        raise VideoError("masks: no motion left after filtering")
    return (vector / norm).astype(np.float32)


def _phase_cuts(diffs: np.ndarray, config: MotionImageConfig) -> np.ndarray:
    """(phases + 1,) int: the first difference of each phase, then ``len(diffs)``.

    By motion, phase ``p`` starts at the first difference where the mass summed so
    far reaches ``p / phases`` of the whole: differences of nothing (a pause, a held
    pose) move no cut, so a performer's pace does not change which part of the
    movement a phase shows.
    """
    n = len(diffs)
    if config.phase_cuts == "time":
        return np.linspace(0, n, config.phases + 1).round().astype(int)
    mass = diffs.reshape(n, -1).sum(axis=1, dtype=np.float64)
    reached = np.concatenate([[0.0], np.cumsum(mass)])  # (n + 1,) mass before each difference
    shares = np.linspace(0.0, reached[-1], config.phases + 1)
    cuts = np.searchsorted(reached, shares, side="left")
    cuts[0], cuts[-1] = 0, n
    return cuts


def _phase_image(diffs: np.ndarray, aligned: np.ndarray, config: MotionImageConfig):
    """(n, S, S) differences and the (n + step, S, S) frames they join → (S, S) float32
    image of one phase (all zeros when nothing moves in it)."""
    size = config.size
    if len(diffs) == 0:
        return np.zeros((size, size), np.float32)
    after = np.tensordot(_time_weights(len(diffs), config.weighting), diffs, axes=1)
    peak = float(after.max())
    if peak <= 0.0:
        return np.zeros((size, size), np.float32)
    after[after < config.residual_floor * peak] = 0.0
    image = after / peak
    if config.silhouette_weight > 0.0:
        # The silhouettes are averaged with the same kind of weights as the
        # differences, so under "recency" the pose the motion ends in dominates.
        weights = _time_weights(aligned.shape[0], config.weighting)
        mean_sil = np.tensordot(weights, aligned, axes=1)
        image = (1.0 - config.silhouette_weight) * image + config.silhouette_weight * (
            mean_sil / max(float(mean_sil.max()), 1e-12)
        )
    return _filter(image.astype(np.float32), config)


def _time_weights(n: int, weighting: str) -> np.ndarray:
    """(n,) float32 weights summing to 1: equal, or rising linearly as (j + 1) / n."""
    if weighting == "recency":
        weights = np.arange(1, n + 1, dtype=np.float32)
    else:
        weights = np.ones(n, dtype=np.float32)
    return weights / weights.sum()


def _filter(image: np.ndarray, config: MotionImageConfig) -> np.ndarray:
    if config.filter == "none":
        return image

    if config.filter == "log":
        blurred = cv2.GaussianBlur(
            image, (0, 0), config.log_sigma_px, borderType=cv2.BORDER_CONSTANT
        )
        return -cv2.Laplacian(blurred, cv2.CV_32F, ksize=3, borderType=cv2.BORDER_CONSTANT)
    gx = cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=3, borderType=cv2.BORDER_CONSTANT)
    gy = cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=3, borderType=cv2.BORDER_CONSTANT)
    # Not cv2.magnitude: its result depends on where the arrays lie in memory, so the
    # same clip would give a motion image differing in the last bits from run to run.
    return np.hypot(gx, gy)


def _support(mass: np.ndarray) -> tuple[int, int]:
    """[lo, hi) of the non-zero entries of a 1-D profile."""
    nonzero = np.flatnonzero(mass)
    return int(nonzero[0]), int(nonzero[-1]) + 1


def _trim_1d(mass: np.ndarray) -> tuple[int, int]:
    cum = np.cumsum(mass)
    cut = _EXTENT_TRIM * cum[-1]
    lo = int(np.searchsorted(cum, cut, side="right"))
    hi = int(np.searchsorted(cum, cum[-1] - cut, side="left")) + 1
    return lo, max(hi, lo + 1)


def _trimmed_span(profiles: np.ndarray) -> np.ndarray:
    """(F, n) mass profiles → (F,) extent of each, pixels, ignoring a sliver of mass."""
    cum = np.cumsum(profiles, axis=1)
    total = cum[:, -1:]
    cut = _EXTENT_TRIM * total
    lo = (cum <= cut).sum(axis=1)
    hi = (cum < total - cut).sum(axis=1) + 1
    return np.maximum(hi - lo, 1).astype(np.float64)


def _median(values: np.ndarray) -> float:
    """The median of (n,) values, n >= 1 (as ``np.median``, whose NaN check makes a new
    process load ``numpy.ma``: 7 ms of a cold query)."""
    n = len(values)
    part = np.partition(values, ((n - 1) // 2, n // 2))
    return 0.5 * float(part[(n - 1) // 2] + part[n // 2])


def _weighted_median(profiles: np.ndarray) -> np.ndarray:
    """(F, n) non-negative mass profiles → (F,) sub-pixel medians, pixel centres at 0..n-1."""
    cum = np.cumsum(profiles, axis=1)
    half = 0.5 * cum[:, -1]
    idx = np.minimum((cum < half[:, None]).sum(axis=1), profiles.shape[1] - 1)
    rows = np.arange(profiles.shape[0])
    mass = np.maximum(profiles[rows, idx], 1e-12)
    # Pixel idx spans [idx - 0.5, idx + 0.5]; interpolate where the mass reaches half.
    return idx + 0.5 - (cum[rows, idx] - half) / mass


def _warp(roi: np.ndarray, scale: float, centres: np.ndarray, size: int) -> np.ndarray:
    """Scale every frame by ``scale`` and put its centre (row, col) at the square's centre.

    Downscaling goes in two steps so thin limbs do not alias away: an exact box
    average by an integer factor, then bilinear resampling by the rest (>= 0.5).
    """
    factor = max(1, int(math.floor(1.0 / scale))) if scale < 1.0 else 1
    if factor > 1:
        roi = _box_downsample(roi, factor)
        centres = (centres + 0.5) / factor - 0.5
        scale *= factor
    out = np.empty((roi.shape[0], size, size), np.float32)
    mid = (size - 1) / 2.0
    matrix = np.array([[scale, 0.0, 0.0], [0.0, scale, 0.0]])
    for i, (cy, cx) in enumerate(centres):
        matrix[0, 2] = mid - scale * cx
        matrix[1, 2] = mid - scale * cy
        cv2.warpAffine(
            roi[i],
            matrix,
            (size, size),
            dst=out[i],
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=0.0,
        )
    return out


def _box_downsample(stack: np.ndarray, factor: int) -> np.ndarray:
    """(F, h, w) → (F, ceil(h/f), ceil(w/f)) block means (zero padding at the far edges)."""
    f, h, w = stack.shape
    hp, wp = -(-h // factor) * factor, -(-w // factor) * factor
    if (hp, wp) != (h, w):
        padded = np.zeros((f, hp, wp), np.float32)
        padded[:, :h, :w] = stack
        stack = padded
    out = np.zeros((f, hp // factor, wp // factor), np.float32)
    for dy in range(factor):  # factor² strided adds beat a reshape-mean by ~10×
        for dx in range(factor):
            out += stack[:, dy::factor, dx::factor]
    out *= 1.0 / (factor * factor)
    return out
