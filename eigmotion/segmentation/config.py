"""The parameters of the person's segmentation out of video (:class:`SilhouetteConfig`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from numbers import Integral, Real
from typing import ClassVar

from eigmotion.errors import InvalidParameterError
from eigmotion.validation import Interval, Options, validate, validate_params

#: How the empty scene may be estimated from a clip
#: (:func:`eigmotion.segmentation.background.estimate_background`).
BACKGROUND_METHODS = ("median", "grabcut", "mog2")


@dataclass(frozen=True)
class SilhouetteConfig:
    """Parameters of :func:`~eigmotion.segmentation.video.extract_silhouettes`.

    Parameters
    ----------
    background : {"median", "grabcut", "mog2"}
        How to estimate the background when none is given (see
        :mod:`eigmotion.segmentation.background`).
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
        Used against a given background image only (see
        :func:`~eigmotion.segmentation.video.extract_silhouettes`).
    work_max_side_px : int
        Frames (and the background) larger than this on their longer side are
        shrunk by the smallest whole factor that brings them to it (area averaging)
        before segmentation, and the masks come back at that size, in [64, 4096].
        The motion image is cropped and rescaled to 32–64 pixels anyway, so
        segmenting full-resolution video only costs time.
    work_min_side_px : int
        Frames smaller than this on their longer side are enlarged by the smallest
        whole factor that brings them to it (bicubic) as they are decoded, before the
        person networks see them; the masks come back at the enlarged frame's working
        size (shrunk as ``work_max_side_px`` says).  The learned and fused front ends
        only (background subtraction alone segments the frames as they are), in
        [0, 4096]; 0 never enlarges.
    drop_seen_scene : bool
        The learned front end without an image of the empty scene takes out of its
        masks the pieces that show the scene as the clip itself shows it where the
        person is not (a stool the person sits on;
        :func:`~eigmotion.segmentation.fused.without_seen_scene`).
    brighten_dim : bool
        The learned and fused front ends show the person networks a dim clip
        brightened (:func:`~eigmotion.segmentation.learned.brightened`); the rest of
        the cut sees the frames as they are.
    measure_camera : bool
        Without an image of the empty scene, measure how the camera moved
        (:func:`~eigmotion.segmentation.camera_motion.camera_motion`) for the floor track
        and the motion image; off where nothing reads it (the silhouettes of every
        frame cut for a 3D answer).
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
    work_min_side_px: int = 0
    drop_seen_scene: bool = True
    brighten_dim: bool = True
    measure_camera: bool = True

    #: The valid values of each parameter (see :mod:`eigmotion.validation`); the
    #: high factor's lower bound and the shadow ratio's order are checked after.
    _parameter_constraints: ClassVar[dict] = {
        "background": Options(str, list(BACKGROUND_METHODS)),
        "max_background_frames": Interval(Integral, 3, 1000),
        "low_factor": Interval(Real, 1.0, 100.0),
        "min_delta_e": Interval(Real, 0.5, 50.0),
        "shadow_chroma": Interval(Real, 0.0, 0.5),
        "smooth_sigma_px": Interval(Real, 0.0, 5.0),
        "close_px": Interval(Integral, 0, 31),
        "min_person_frac": Interval(Real, 1e-6, 0.5),
        "keep_piece_frac": Interval(Real, 0.0, 1.0),
        "small_hole_frac": Interval(Real, 0.0, 1.0),
        "upper_body_frac": Interval(Real, 0.0, 1.0),
        "work_max_side_px": Interval(Integral, 64, 4096),
        "work_min_side_px": Interval(Integral, 0, 4096),
        "drop_seen_scene": Options(bool, [True, False]),
        "brighten_dim": Options(bool, [True, False]),
        "measure_camera": Options(bool, [True, False]),
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints)
        validate("high_factor", self.high_factor, Interval(Real, self.low_factor, 100.0))
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
