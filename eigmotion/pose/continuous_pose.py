"""Continuous pose: the retrieved motion aligned to a single-camera clip frame by frame.

Retrieval answers a clip with a basic motion, the window of it that matched and the
view (azimuth, elevation) of the virtual camera that saw it like the clip's camera
sees the person.  The linear replay (:mod:`eigmotion.pose.replay`) stretches that window
over the clip; a person who speeds up or slows down is then out of step.  Here the
tracker's machinery aligns the motion to the clip instead (MISSION, "How the two
meet"):

1. **Dictionary.** The matched window and ``margin_s`` around it, on the avatar, at
   ``reference_fps``: entry ``i`` is reference frame ``i``
   (:func:`eigmotion.tracking.dictionary_from_sequences`, no pruning), posed on the
   low-poly body (:func:`eigmotion.tracking.avatar_bodies`).
2. **Virtual camera.** One camera at the matched view, aimed at the reference as the
   database build aimed its rig; its image is the clip's.  The person's apparent size
   and place are unknown: the camera's intrinsics are fitted so that the box around
   the reference's silhouettes over the matched window covers the box around the
   clip's silhouettes (a 2D scale and translation).
3. **Similarity.** A candidate (clip frame, reference frame) is the body in that
   reference posture, moved (not scaled) along the camera's axis until its silhouette
   has the clip frame's area and parallel to the image until the two centroids
   coincide, rendered inside the rectangle around the candidates and the observed
   silhouette, and scored with the tracker's similarity
   (:func:`eigmotion.tracking.score_masks`) maximised over small shifts and over 2D
   scales (``scales``) about the centroid.  Size and place thus come from each frame's
   silhouette: another performer does not follow the reference's path, and walking
   towards the camera changes the apparent size several tens of per cent.
4. **Variable-speed playback, solved for the whole clip.** Reference frames are chosen
   for all clip frames at once, maximising the summed similarity under the playback's
   rule: never back, at most ``max_speed`` times the clip's speed per frame (dynamic
   programming over (clip frame, reference frame)), with a small cost for playing at
   another speed than the reference's (``speed_weight``: a walk repeats itself, and a
   silhouette hardly tells the left leg from the right, so without it the playback
   may hold a posture for a step and catch up a cycle later).  A coarse pass (clip
   at ``coarse_fps``, every reference frame at ``coarse_reference_fps``) gives the
   path; the view is refined on it, first the azimuth then the elevation (the rig's
   cameras are tens of degrees apart; a clip filmed between them fits best a little
   off the matched view); a fine pass searches ``band_s`` around the coarse path at
   full rate.
5. **Output.** The chosen reference frames, lightly smoothed (still never back), are
   sampled from the reference (slerp) at the clip's frame rate, and the motion is
   turned so that the clip's camera stands at azimuth 0, as in :mod:`eigmotion.pose.replay`.

Why not :meth:`eigmotion.tracking.SilhouetteTracker.step`: it places the body where
the ray through the silhouette's centroid meets the plane of the body centre's height;
a level camera (elevation 0°, most rig views) looks along that plane, so the place is
undetermined.  Here size and place come from each silhouette, and the whole clip is
known, so the playback is solved over all frames rather than greedily.

6. **Keypoints** (``cue``, :func:`eigmotion.pose.clip_pose.clip_pose`).  With the
   clip's frames, the pose landmark network's 3D posture moves each frame's trunk and
   limbs toward it (the world cue), or its 2D keypoints refine each frame's heading and
   limbs first (the keypoints cue; :mod:`eigmotion.pose.keypoint_fit`); the skeleton,
   joint set and axes stay.

Steps 1 to 3 live in :mod:`eigmotion.pose.silhouette_scoring`, the playback's path
and the output's sampling in :mod:`eigmotion.pose.playback`; this module searches
(coarse pass, view, fine pass) and assembles the answer.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from numbers import Integral, Real
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from eigmotion.body.avatar import Avatar, load_default_avatar
from eigmotion.body.retarget import pose_avatar, retarget
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.motion import Motion
from eigmotion.pose.keypoints import CUES
from eigmotion.pose.playback import monotone_path, sample_motion, smooth_path, speed_costs
from eigmotion.pose.replay import Replay, turn_about_vertical
from eigmotion.pose.silhouette_scoring import (
    SilhouetteScorer,
    fitted_camera,
    observe_silhouettes,
    reference_window,
)
from eigmotion.tracking.tracker import SCALE_FACTORS
from eigmotion.validation import Interval, Options, validate_params

if TYPE_CHECKING:
    from eigmotion.retrieval.database import MotionDatabase, QueryResult

_POSITIVE = Interval(Real, 0.0, None, closed="neither", noun="")
_NOT_NEGATIVE = Interval(Real, 0.0, None, noun="")


@dataclass(frozen=True)
class ContinuousPoseConfig:
    """How a retrieved motion is aligned to a clip.

    Parameters
    ----------
    margin_s : float
        Reference motion taken before and after the matched window, seconds (≥ 0).
    reference_fps : float or None
        Rate of the dictionary's frames, frames per second; ``None``: twice the clip's,
        at least 30.
    max_speed : float
        Largest speed of the playback relative to the reference (reference seconds per
        clip second), > 0; also the largest step per clip frame.
    speed_weight : float
        Cost per clip frame of playing at another speed than the reference's:
        ``speed_weight * |speed - 1|``, in similarity units (≥ 0).  Walking repeats
        itself and left and right legs look alike in a silhouette; without a prior the
        playback may hold a posture for a step and then catch up a cycle later.
    coarse_fps : float
        Clip frames per second scored in the coarse pass (> 0).
    coarse_reference_fps : float
        Reference frames per second scored in the coarse pass (> 0).
    band_s : float
        Fine pass: reference time searched either side of the coarse path, seconds.
    azimuth_search_deg : float
        The view's azimuth is searched within ± this of the matched one, degrees (0:
        keep the matched view).
    azimuth_step_deg : float
        Step of that search, degrees (> 0).
    elevation_search_deg, elevation_step_deg : float
        The same for the elevation, searched after the azimuth (a clip filmed from
        above or below the rig's rows), degrees.
    scales : tuple of float
        2D scales of the candidate silhouettes about the observed centroid.
    comparison_height_px : float
        Silhouettes are compared on a grid where the person is about this tall (the
        clip is block-averaged by an integer factor), pixels.
    shift_radius_px : int
        Shifts searched by the similarity, ± pixels of the comparison grid.
    smoothing_frames : int
        Width of the moving average applied to the chosen reference frames (1: none).
    min_silhouette_px : int
        A clip frame with fewer silhouette pixels carries no evidence.
    n_faces : int
        Triangles of the low-poly body that is rendered.
    cue : {"auto", "silhouette", "world", "keypoints"}
        What :func:`eigmotion.pose.clip_pose.clip_pose` fits the pose to
        (:data:`eigmotion.pose.keypoints.CUES`).
    """

    margin_s: float = 1.0
    reference_fps: float | None = None
    max_speed: float = 2.5
    speed_weight: float = 0.03
    coarse_fps: float = 10.0
    coarse_reference_fps: float = 15.0
    band_s: float = 0.3
    azimuth_search_deg: float = 30.0
    azimuth_step_deg: float = 7.5
    elevation_search_deg: float = 10.0
    elevation_step_deg: float = 5.0
    scales: tuple[float, ...] = (0.94, 1.0, 1.06)
    comparison_height_px: float = 64.0
    shift_radius_px: int = 3
    smoothing_frames: int = 5
    min_silhouette_px: int = 30
    n_faces: int = 4000
    cue: str = "auto"

    #: The valid values of each parameter (see :mod:`eigmotion.validation`).
    _parameter_constraints: ClassVar[dict] = {
        "max_speed": _POSITIVE,
        "coarse_fps": _POSITIVE,
        "coarse_reference_fps": _POSITIVE,
        "azimuth_step_deg": _POSITIVE,
        "elevation_step_deg": _POSITIVE,
        "comparison_height_px": _POSITIVE,
        "margin_s": _NOT_NEGATIVE,
        "band_s": _NOT_NEGATIVE,
        "azimuth_search_deg": _NOT_NEGATIVE,
        "elevation_search_deg": _NOT_NEGATIVE,
        "speed_weight": _NOT_NEGATIVE,
        "reference_fps": [None, _POSITIVE],
        "shift_radius_px": Interval(Integral, 0, None),
        "smoothing_frames": Interval(Integral, 1, None),
        "min_silhouette_px": Interval(Integral, 1, None),
        "n_faces": Interval(Integral, 100, None),
        "scales": SCALE_FACTORS,
        "cue": Options(str, CUES),
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints)
        object.__setattr__(self, "scales", tuple(float(s) for s in self.scales))


@dataclass(frozen=True, eq=False)
class ContinuousPose:
    """A retrieved motion aligned to a clip, one pose per clip frame.

    Attributes
    ----------
    motion : Motion
        On the avatar's canonical skeleton, metres (``length_unit_m = 1``), at the
        clip's frame rate and frame count, turned so that the clip's camera stands at
        azimuth 0 (on +Z, as in :mod:`eigmotion.pose.replay`); the root starts above the
        origin.
    reference_frames : (F,) int64
        The frame of the basic motion (its own frames and rate) each clip frame shows;
        non-decreasing, consecutive values at most :attr:`max_step_frames` apart.
    positions : (F, J, 3) float64
        World joint positions of :attr:`motion`, metres, Y up, floor at y = 0.
    names : tuple of str
        The ``J`` joint names.
    scores : (F,) float64
        Similarity of the chosen reference posture per clip frame, in [-1, 1] per
        scale (NaN where the clip frame shows no person).
    azimuth_deg, elevation_deg : float
        The view the motion was aligned under (the matched view, refined), degrees.
    matched_azimuth_deg, matched_elevation_deg : float
        The retrieved view, degrees.
    source_motion : str
        The basic motion's name.
    fps : float
        The clip's frame rate, frames per second.
    max_step_frames : int
        The playback's largest step between clip frames, in basic-motion frames
        (``max_speed`` times the clip's frame time, rounded up, plus one for rounding).
    timings_s : dict of str to float
        Wall time of each stage, seconds.
    """

    motion: Motion
    reference_frames: np.ndarray
    positions: np.ndarray
    names: tuple[str, ...]
    scores: np.ndarray
    azimuth_deg: float
    elevation_deg: float
    matched_azimuth_deg: float
    matched_elevation_deg: float
    source_motion: str
    fps: float
    max_step_frames: int
    timings_s: dict = field(default_factory=dict, repr=False)

    @property
    def n_frames(self) -> int:
        return len(self.reference_frames)

    def save_npz(self, path: str | os.PathLike) -> Path:
        """Write the joints per clip frame to an ``.npz`` file (at exactly ``path``).

        Keys: ``names (J,)`` str, ``positions (F, J, 3)`` float64 metres (Y up, floor
        y = 0, the clip's camera at azimuth 0), ``reference_frames (F,)`` int64 and
        ``fps`` float64 (the clip's frames per second).
        """
        path = Path(path)
        try:
            with path.open("wb") as fh:
                np.savez_compressed(
                    fh,
                    names=np.array(self.names, dtype=str),
                    positions=self.positions,
                    reference_frames=self.reference_frames,
                    fps=np.float64(self.fps),
                )
        except OSError as exc:
            raise InvalidParameterError(f"{path}: cannot write the pose: {exc.strerror}") from None
        return path

    def as_replay(self, avatar: Avatar | None = None) -> Replay:
        """The aligned motion skinned on the avatar (for :func:`eigmotion.pose.replay.
        replay_video`)."""
        avatar = avatar or load_default_avatar()
        anim = retarget(self.motion, avatar)
        return Replay(
            self.motion, pose_avatar(avatar, anim), avatar.faces, float(self.elevation_deg)
        )


# -- the search ----------------------------------------------------------------


def _coarse_path(
    scorer: SilhouetteScorer, fps: float, reference_fps: float, cfg: ContinuousPoseConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Clip frames sampled at ``coarse_fps`` and their reference frames (every
    reference frame at ``coarse_reference_fps`` scored)."""
    n_clip = len(scorer.observed.masks)
    clip_step = max(1, int(round(fps / cfg.coarse_fps)))
    ref_step = max(1, int(round(reference_fps / cfg.coarse_reference_fps)))
    frames = np.arange(0, n_clip, clip_step)
    if frames[-1] != n_clip - 1:
        frames = np.append(frames, n_clip - 1)
    entries = np.arange(0, scorer.reference.n_frames, ref_step)
    matrix = np.stack([scorer(int(f), entries) for f in frames])
    unit = clip_step / fps * reference_fps / ref_step
    max_step = max(1, int(np.ceil(cfg.max_speed * unit)))
    costs = speed_costs(max_step, unit, cfg.speed_weight)
    return frames, entries[monotone_path(matrix, max_step, costs)]


def _path_score(scorer: SilhouetteScorer, frames: np.ndarray, path: np.ndarray) -> float:
    return float(sum(scorer(int(f), np.array([r]))[0] for f, r in zip(frames, path, strict=True)))


def _fine_path(
    scorer: SilhouetteScorer,
    coarse_frames: np.ndarray,
    coarse_path: np.ndarray,
    fps: float,
    reference_fps: float,
    max_step: int,
    cfg: ContinuousPoseConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """Every clip frame, reference frames within ``band_s`` of the coarse path.

    Returns the (F,) reference frame per clip frame and its (F,) score (NaN where the
    clip frame shows no person)."""
    n_clip = len(scorer.observed.masks)
    n_ref = scorer.reference.n_frames
    guess = np.interp(np.arange(n_clip), coarse_frames, coarse_path)
    band = max(1, int(np.ceil(cfg.band_s * reference_fps)))
    matrix = np.full((n_clip, n_ref), -np.inf)
    for f in range(n_clip):
        lo = max(0, int(np.floor(guess[f])) - band)
        hi = min(n_ref, int(np.ceil(guess[f])) + band + 1)
        entries = np.arange(lo, hi)
        matrix[f, lo:hi] = scorer(f, entries)
    unit = reference_fps / fps
    path = monotone_path(matrix, max_step, speed_costs(max_step, unit, cfg.speed_weight))
    scores = matrix[np.arange(n_clip), path]
    scores[~scorer.observed.present] = np.nan
    return path, scores


def _offsets(search_deg: float, step_deg: float) -> np.ndarray:
    """Offsets ``0, ±step, ±2 step … within ±search``, nearest first, degrees."""
    n = int(np.floor(search_deg / step_deg + 1e-9))
    offsets = np.arange(-n, n + 1) * step_deg
    return offsets[np.argsort(np.abs(offsets), kind="stable")]


# -- the stage ---------------------------------------------------------------------


def align_motion(
    motion: Motion,
    window: tuple[int, int],
    azimuth_deg: float,
    elevation_deg: float,
    masks: np.ndarray,
    fps: float,
    config: ContinuousPoseConfig | None = None,
    avatar: Avatar | None = None,
    yfov_deg: float = 40.0,
) -> ContinuousPose:
    """Align a known motion to a single-camera clip, frame by frame.

    Parameters
    ----------
    motion : Motion
        The basic motion (any skeleton the avatar can be driven by).
    window : (int, int)
        ``[start, stop)`` frames of ``motion`` that matched the clip.
    azimuth_deg, elevation_deg : float
        The matched virtual camera's view of the motion, degrees.
    masks : (F, H, W) bool
        The clip's silhouettes.
    fps : float
        The clip's frame rate, frames per second.
    config : ContinuousPoseConfig, optional
    avatar : Avatar, optional
        Default :func:`eigmotion.body.avatar.load_default_avatar`.
    yfov_deg : float
        Vertical field of view of the virtual camera, degrees (the database rig's
        lens; the clip camera's is unknown and matters little).

    Returns
    -------
    ContinuousPose
    """
    config = config or ContinuousPoseConfig()
    masks = np.asarray(masks)
    if masks.ndim != 3 or masks.shape[0] < 1:
        raise InvalidParameterError(f"masks must be a non-empty (F, H, W) array, got {masks.shape}")
    masks = masks.astype(bool, copy=False)
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidParameterError(f"fps must be > 0, got {fps!r}")
    start, stop = int(window[0]), int(window[1])
    if not 0 <= start < stop <= motion.n_frames:
        raise InvalidParameterError(
            f"window [{start}, {stop}) is outside motion {motion.name!r} of "
            f"{motion.n_frames} frames"
        )
    if not (np.isfinite(azimuth_deg) and np.isfinite(elevation_deg) and -89 <= elevation_deg <= 89):
        raise InvalidParameterError(
            f"view must be a finite azimuth and an elevation in [-89, 89], got "
            f"({azimuth_deg!r}, {elevation_deg!r})"
        )
    if avatar is None:
        avatar = load_default_avatar()
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    reference_fps = config.reference_fps or max(2.0 * fps, 30.0)
    reference = reference_window(
        motion, (start, stop), reference_fps, config.margin_s, avatar, config.n_faces
    )
    observed = observe_silhouettes(masks, config.min_silhouette_px)
    t1 = time.perf_counter()
    timings["reference"] = t1 - t0

    def scorer_at(view: tuple[float, float]) -> SilhouetteScorer:
        camera = fitted_camera(reference, observed, view[0], view[1], yfov_deg)
        return SilhouetteScorer(
            reference,
            observed,
            camera,
            config.scales,
            config.shift_radius_px,
            config.comparison_height_px,
        )

    matched = (float(azimuth_deg), float(elevation_deg))
    scorer = scorer_at(matched)
    coarse_frames, coarse = _coarse_path(scorer, fps, reference_fps, config)
    t2 = time.perf_counter()
    timings["coarse"] = t2 - t1
    view = _refine_view(scorer_at, matched, coarse_frames, coarse, config)
    if view != matched:
        scorer = scorer_at(view)
    t3 = time.perf_counter()
    timings["view"] = t3 - t2
    max_step = max(1, int(np.ceil(config.max_speed * reference_fps / fps)))
    path, scores = _fine_path(scorer, coarse_frames, coarse, fps, reference_fps, max_step, config)
    t4 = time.perf_counter()
    timings["fine"] = t4 - t3

    frames = smooth_path(path, config.smoothing_frames)
    aligned = sample_motion(reference.on_avatar, frames, 1.0 / fps)
    aligned = turn_about_vertical(aligned, -view[0]).replace(
        name=f"{motion.name}_aligned", length_unit_m=1.0
    )
    source = reference.first_source_frame + np.round(frames * reference.source_per_reference)
    source = np.maximum.accumulate(np.clip(source.astype(np.int64), 0, motion.n_frames - 1))
    positions = forward_kinematics(aligned, length_unit_m=1.0, ground=False).positions
    timings["total"] = time.perf_counter() - t0
    return ContinuousPose(
        motion=aligned,
        reference_frames=source,
        positions=positions,
        names=tuple(aligned.skeleton.names),
        scores=scores,
        azimuth_deg=view[0],
        elevation_deg=view[1],
        matched_azimuth_deg=matched[0],
        matched_elevation_deg=matched[1],
        source_motion=motion.name,
        fps=float(fps),
        max_step_frames=int(np.ceil(max_step * reference.source_per_reference)) + 1,
        timings_s=timings,
    )


def _refine_view(
    scorer_at,
    matched: tuple[float, float],
    frames: np.ndarray,
    path: np.ndarray,
    config: ContinuousPoseConfig,
) -> tuple[float, float]:
    """The view, near the matched one, under which a path's postures score best:
    the azimuth first, then the elevation (degrees)."""
    view = matched
    for axis, search, step in (
        (0, config.azimuth_search_deg, config.azimuth_step_deg),
        (1, config.elevation_search_deg, config.elevation_step_deg),
    ):
        best, best_score = view, -np.inf
        for offset in _offsets(search, step):
            trial = list(view)
            trial[axis] += float(offset)
            if not -89.0 <= trial[1] <= 89.0:
                continue
            total = _path_score(scorer_at((trial[0], trial[1])), frames, path)
            if total > best_score + 1e-9:
                best, best_score = (trial[0], trial[1]), total
        view = best
    return view


def continuous_pose(
    db: MotionDatabase,
    result: QueryResult,
    masks: np.ndarray,
    fps: float,
    config: ContinuousPoseConfig | None = None,
    avatar: Avatar | None = None,
) -> ContinuousPose:
    """The best match of a query, aligned to its clip frame by frame.

    Parameters
    ----------
    db : MotionDatabase
        The database that answered (gives the motion and its rig's lens).
    result : QueryResult
        Its answer (:meth:`MotionDatabase.query_masks` or ``query_clip``).
    masks : (F, H, W) bool
        The clip's silhouettes.
    fps : float
        The clip's frame rate, frames per second.
    config : ContinuousPoseConfig, optional
    avatar : Avatar, optional

    Returns
    -------
    ContinuousPose
    """
    best = result.best
    yfov_deg = float(np.rad2deg(db.rig[0].yfov_rad))
    return align_motion(
        db.motion(best.motion_id),
        best.window,
        best.azimuth_deg,
        best.elevation_deg,
        masks,
        fps,
        config,
        avatar,
        yfov_deg,
    )
