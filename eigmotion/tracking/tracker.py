"""The silhouette-dictionary pose tracker: one posture estimate per set of views.

Per step (the paper's section 2): locate the person on the stage from the
silhouettes' centroids (:mod:`~eigmotion.tracking.position`), take the candidate
postures near the previous estimate (:func:`~eigmotion.tracking.dictionary.
select_candidates`), render their silhouettes with the body centre at the person's
position, score them against the observed silhouettes over small shifts
(:mod:`~eigmotion.tracking.similarity`) through the 2-layer search tree
(:mod:`~eigmotion.tracking.search`), and keep the best.  The first step, with no
previous posture, searches the whole dictionary coarse to fine.

The best shifts also refine the position: the body centre's projection moved by each
camera's best shift gives new rays, whose intersection is the reported position.

Candidate silhouettes are rendered only inside the rectangle ``R(c)`` and at a reduced
resolution (``downsample``), through a camera whose image is that rectangle.

For a single camera (e.g. a virtual camera for a clip whose motion is known), the
candidate silhouettes can also be scaled in 2D about the body centre (``scales``),
standing in for the unknown distance and body size.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from numbers import Integral, Real
from typing import ClassVar
from weakref import WeakKeyDictionary

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.tracking.body import PostureBodies, avatar_bodies
from eigmotion.tracking.calibration import CameraPair
from eigmotion.tracking.dictionary import PostureDictionary, closeness_matrix, select_candidates
from eigmotion.tracking.frame_scoring import FrameScorer
from eigmotion.tracking.heading import (
    FACING_PAIRS,
    facing_deg,
    heading_penalty,
    rough_positions,
    travel_headings,
)
from eigmotion.tracking.position import intersect_plane_lines, mask_centroid, select_pair
from eigmotion.tracking.postures import d1_distance
from eigmotion.tracking.search import (
    ClusterNode,
    SearchResult,
    beam_search,
    build_cluster_tree,
    build_two_layer_tree,
    exhaustive_search,
    two_layer_search,
)
from eigmotion.tracking.temporal import along_best_path
from eigmotion.validation import Interval, Options, SequenceOf, validate_params

#: Each posture dictionary's cluster trees (:meth:`SilhouetteTracker.cluster_tree`),
#: by ``init_branching``; an entry goes with its dictionary.
_CLUSTER_TREES: WeakKeyDictionary[PostureDictionary, dict[int, tuple[ClusterNode, ...]]] = (
    WeakKeyDictionary()
)

RenderMasks = Callable[[np.ndarray, np.ndarray, Camera], np.ndarray]

#: 2D scales of a candidate silhouette searched about its centre (a constraint of
#: :mod:`eigmotion.validation`).
SCALE_FACTORS = SequenceOf(Interval(Real, 0.2, 5.0, noun="factors"))
_COUNT = Interval(Integral, 1, None)
_POSITIVE = Interval(Real, 0.0, None, closed="neither", noun="")


@dataclass(frozen=True)
class TrackerConfig:
    """Parameters of the tracker; the defaults are the paper's where it gives them.

    Parameters
    ----------
    layer_step : int
        ``t``: every t-th candidate is in layer 1 of the search tree (paper: 3).
    top_k : int
        ``k``: layer-1 postures whose children are scored (paper: 3).
    max_candidates : int
        ``T_n``: candidates past this rank are dropped (paper: 40).
    max_d1_deg : float
        ``T_d1``: candidates differ from the previous posture by less, degrees.
    max_d2_m : float
        ``T_d2``: largest projected joint displacement of a candidate, metres.
    max_heading_deg : float or None
        ``T_h``: the heading's own threshold (see :func:`~eigmotion.tracking.
        dictionary.select_candidates`); ``None``: the heading is one of d1's
        components, as in the paper.
    shift_radius_px : int
        The shift neighbourhood ``D``: ±this many full-resolution pixels each way.
    downsample : int
        Candidate and observed silhouettes are compared at 1/downsample resolution.
    scales : tuple of float
        2D scales of the candidate silhouettes searched per camera (1 = none).
    body_scale : float or None
        Uniform scale of the body model about its root (a shorter or taller person
        than the model): a number fixes it (1 keeps the model's size; the person's
        height over the model's if known); ``None`` measures it on the first
        estimates: the median ratio of the observed silhouette's height to the
        estimated posture's, over cameras and estimates.
    body_scale_range : (float, float)
        Bounds of the measured body scale.
    body_scale_estimates : int
        Number of first estimates the body scale is measured on (it is then kept).
    scale_from_top : bool
        Measure the observed height from the top of the silhouette down to where the
        estimate's feet stand (True) rather than to the silhouette's lowest row:
        feet lost to background subtraction then do not shrink the body.
    exhaustive : bool
        Score every candidate instead of searching the tree (the reference).
    init_branching, init_beam : int
        Coarse-to-fine search of the first frame (:func:`~eigmotion.tracking.search.
        beam_search`).
    init_refinements : int
        Local searches repeated on the first frame after the coarse-to-fine one.
    recovery_ratio : float or None
        When an estimate's score falls below this fraction of the median score of
        the last ``recovery_window`` estimates, the tracker may have lost the person's
        posture (e.g. a turn the local candidates could not follow): the whole
        dictionary is searched again, coarse to fine, and the better answer kept.
        ``None``: never (the paper's tracker).
    recovery_window : int
        Estimates whose median score is the reference of ``recovery_ratio``.
    min_silhouette_px : int
        A view whose silhouette has fewer pixels is ignored.
    travel_tolerance_deg : float or None
        Direction-of-travel prior (:mod:`~eigmotion.tracking.heading`): while the
        body centre moves at ``travel_min_speed_mps`` or faster, postures facing more
        than this many degrees away from its direction of travel lose
        ``travel_weight`` of score per 90° beyond it.  ``None``: off (the paper's
        tracker).  Needs two cameras or more and whole clips
        (:meth:`~SilhouetteTracker.track`), or the direction given to
        :meth:`~SilhouetteTracker.step`.
    travel_weight : float
        Score taken off per 90° beyond the tolerance (one camera's score is ≤ 1).
    travel_window_s : float
        Seconds over which the direction of travel is measured (centred).
    travel_min_speed_mps : float
        Slower than this, metres per second, the direction of travel is not used.
    path_candidates : int
        Temporal decision (:mod:`~eigmotion.tracking.temporal`): with 2 or more, each
        estimate keeps this many best-scored postures and :meth:`~SilhouetteTracker.track`
        picks one per frame by a Viterbi path (score minus ``path_weight`` per 30° of d1
        between consecutive postures); 1: the greedy choice frame by frame (the paper's).
    path_weight : float
        Score lost per 30° of d1 between consecutive estimates on the Viterbi path.
    keypoints : bool
        The keypoints stage (:mod:`~eigmotion.tracking.keypoint_fit`): where the front
        end gives the pose network's landmarks of every camera, each estimate is fitted
        to the joints triangulated from them; without landmarks the tracker's estimate
        stands.
    keypoint_weight : float
        How far, in [0, 1], each fitted joint's target lies from the tracker's joint
        toward the triangulated one.
    joint_smooth_s : float
        Last, with or without the keypoints stage, the joints' paths over the clip are
        smoothed by a Gaussian of this sigma, seconds, and each estimate is fitted to
        them (:meth:`~eigmotion.tracking.keypoint_fit.KeypointFitter.fit`, bone lengths
        kept); 0: not.
    """

    layer_step: int = 3
    top_k: int = 3
    max_candidates: int = 40
    max_d1_deg: float = 30.0
    max_d2_m: float = 0.3
    max_heading_deg: float | None = None
    shift_radius_px: int = 6
    downsample: int = 2
    scales: tuple[float, ...] = (1.0,)
    body_scale: float | None = None
    body_scale_range: tuple[float, float] = (0.8, 1.25)
    body_scale_estimates: int = 8
    scale_from_top: bool = False
    exhaustive: bool = False
    init_branching: int = 24
    init_beam: int = 5
    init_refinements: int = 4
    recovery_ratio: float | None = 0.93
    recovery_window: int = 15
    min_silhouette_px: int = 30
    travel_tolerance_deg: float | None = 50.0
    travel_weight: float = 1.0
    travel_window_s: float = 0.5
    travel_min_speed_mps: float = 0.3
    path_candidates: int = 1
    path_weight: float = 0.1
    keypoints: bool = True
    keypoint_weight: float = 0.5
    joint_smooth_s: float = 0.08

    #: The valid values of each parameter (see :mod:`eigmotion.validation`); the
    #: order of ``body_scale_range`` is checked after.
    _parameter_constraints: ClassVar[dict] = {
        "layer_step": _COUNT,
        "top_k": _COUNT,
        "max_candidates": _COUNT,
        "downsample": _COUNT,
        "init_beam": _COUNT,
        "min_silhouette_px": _COUNT,
        "body_scale_estimates": _COUNT,
        "recovery_window": _COUNT,
        "shift_radius_px": Interval(Integral, 0, None),
        "init_refinements": Interval(Integral, 0, None),
        "init_branching": Interval(Integral, 2, None),
        "max_d1_deg": _POSITIVE,
        "max_d2_m": _POSITIVE,
        "max_heading_deg": [None, _POSITIVE],
        "scales": SCALE_FACTORS,
        "scale_from_top": Options(bool, [True, False]),
        "recovery_ratio": [None, Interval(Real, 0.0, 1.0, closed="right", noun="")],
        "body_scale": [None, Interval(Real, 0.3, 3.0, noun="a factor")],
        "travel_tolerance_deg": [None, Interval(Real, 0.0, 180.0, noun="degrees")],
        "travel_weight": Interval(Real, 0.0, None, noun=""),
        "travel_window_s": _POSITIVE,
        "travel_min_speed_mps": Interval(Real, 0.0, None, noun=""),
        "path_candidates": _COUNT,
        "path_weight": Interval(Real, 0.0, None, noun=""),
        "keypoints": Options(bool, [True, False]),
        "keypoint_weight": Interval(Real, 0.0, 1.0, noun="a fraction"),
        "joint_smooth_s": Interval(Real, 0.0, 10.0, noun="seconds"),
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints)
        object.__setattr__(self, "scales", tuple(float(s) for s in self.scales))
        lo, hi = (float(v) for v in self.body_scale_range)
        if not (0.3 <= lo <= hi <= 3.0):
            raise InvalidParameterError(
                f"body_scale_range must be (low, high) within [0.3, 3], got "
                f"{self.body_scale_range!r}"
            )
        object.__setattr__(self, "body_scale_range", (lo, hi))


@dataclass(frozen=True, eq=False)
class Estimate:
    """One step's result.

    Attributes
    ----------
    entry : int
        Dictionary entry of the estimated posture (-1 while no person was seen yet).
    position_m : (3,) float64
        Body-centre position ``G``, world metres (NaN while no person was seen yet).
    score : float
        Similarity ``s(m)`` of the posture (NaN when the person was not seen).
    n_evaluations : int
        Postures scored (each scored posture costs one silhouette per camera and scale).
    cameras : tuple of int
        Cameras used.
    shifts_px : (len(cameras), 2) float64
        Best shift of the candidate silhouette per camera, full-resolution pixels.
    scales : (len(cameras),) float64
        Best 2D scale per camera.
    body_scale : float
        Scale of the body model (about its root) used for this estimate.
    found : bool
        False when no camera saw the person (the previous estimate is repeated).
    alternatives : (K,) int64
        With ``path_candidates`` of 2 or more: the best-scored entries, best first
        (``entry`` among them); empty otherwise.
    alternative_scores : (K,) float64
    alternative_positions_m : (K, 3) float64
        Each alternative's shift-refined body-centre position, world metres.
    """

    entry: int
    position_m: np.ndarray
    score: float
    n_evaluations: int
    cameras: tuple[int, ...]
    shifts_px: np.ndarray
    scales: np.ndarray
    body_scale: float = 1.0
    found: bool = True
    alternatives: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    alternative_scores: np.ndarray = field(default_factory=lambda: np.zeros(0))
    alternative_positions_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


@dataclass(frozen=True, eq=False)
class TrackResult:
    """Estimates of a whole clip.

    Attributes
    ----------
    entries : (F,) int64
        Dictionary entry per estimate (-1 before the person was first seen).
    positions_m : (F, 3) float64
        Body-centre positions, world metres.
    joint_positions_m : (F, J, 3) float64
        Joint positions, world metres (NaN before the person was first seen).
    joint_names : tuple of str
    scores : (F,) float64
    n_evaluations : (F,) int64
    found : (F,) bool
    frames : (F,) int64
        The input frame of each estimate.
    frame_time_s : float
        Seconds between estimates.
    estimates : tuple of Estimate
    """

    entries: np.ndarray
    positions_m: np.ndarray
    joint_positions_m: np.ndarray
    joint_names: tuple[str, ...]
    scores: np.ndarray
    n_evaluations: np.ndarray
    found: np.ndarray
    frames: np.ndarray
    frame_time_s: float
    estimates: tuple[Estimate, ...] = field(default=())

    @property
    def n_estimates(self) -> int:
        return len(self.entries)


def _height_ratio(observed: np.ndarray, rendered: np.ndarray, from_top: bool) -> float:
    """The observed silhouette's height over the rendered one's (NaN if either is empty).

    ``from_top``: both measured from the rendered silhouette's lowest row (the feet on
    the floor where the body stands) up to each one's top row, so that feet missing
    from the observed silhouette (cut out with the floor) do not shorten it.
    """
    rows_o = np.flatnonzero(np.asarray(observed).any(axis=1))
    rows_r = np.flatnonzero(np.asarray(rendered).any(axis=1))
    if not (rows_o.size and rows_r.size):
        return float("nan")
    bottom_o = rows_r[-1] if from_top else rows_o[-1]
    return float(bottom_o - rows_o[0] + 1) / float(rows_r[-1] - rows_r[0] + 1)


def _default_renderer() -> RenderMasks:
    return render_masks


class SilhouetteTracker:
    """Multi-camera posture tracking against a posture dictionary.

    Parameters
    ----------
    dictionary : PostureDictionary
    cameras : sequence of Camera
        Calibrated cameras (any number ≥ 1), in the order masks are given.
    bodies : PostureBodies, optional
        The body model posed in every entry; default :func:`~eigmotion.tracking.body.
        avatar_bodies` (the default avatar, decimated).
    config : TrackerConfig, optional
    pairs : sequence of CameraPair
        With more than two cameras: camera pairs owning stage regions; the pair in
        charge of the person's position is used.  Empty: all cameras that see the
        person are used.
    render_masks : callable, optional
        ``render_masks(vertices (M, V, 3), faces (T, 3), camera) -> (M, H, W) bool``;
        default :func:`eigmotion.imaging.silhouettes.render_masks` (CPU).

    Attributes
    ----------
    previous_ : Estimate or None
        The last estimate with a person, after :meth:`step`.
    body_scale_ : float
        The body model's current scale (chosen over the first estimates).
    facing_deg : (N,) float64 or None
        The way each dictionary entry faces, degrees (0 = +Z, 90 = +X); None for a
        skeleton without the hips and shoulders of the canonical one (no prior then).
    travel_deg_ : float
        The direction of travel given to the last :meth:`step` (NaN: none).
    """

    def __init__(
        self,
        dictionary: PostureDictionary,
        cameras: Sequence[Camera],
        bodies: PostureBodies | None = None,
        config: TrackerConfig | None = None,
        pairs: Sequence[CameraPair] = (),
        render_masks: RenderMasks | None = None,
    ):
        self.dictionary = dictionary
        self.cameras = tuple(cameras)
        if not self.cameras:
            raise InvalidParameterError("the tracker needs at least one camera")
        self.bodies = bodies if bodies is not None else avatar_bodies(dictionary)
        if len(self.bodies) != len(dictionary):
            raise InvalidParameterError(
                f"bodies hold {len(self.bodies)} postures, the dictionary {len(dictionary)}"
            )
        self.config = config if config is not None else TrackerConfig()
        self.pairs = tuple(pairs)
        for pair in self.pairs:
            if max(pair.cameras) >= len(self.cameras):
                raise InvalidParameterError(
                    f"camera pair {pair.cameras} names a camera beyond the "
                    f"{len(self.cameras)} given"
                )
        self.render_masks = render_masks if render_masks is not None else _default_renderer()
        self._default_height_m = float(np.median(dictionary.body_height_m))
        names = dictionary.joint_names
        has_pairs = all(a in names and b in names for a, b in FACING_PAIRS)
        self.facing_deg = facing_deg(dictionary.joint_positions, names) if has_pairs else None
        self.travel_deg_ = float("nan")
        self.reset()

    # -- state ---------------------------------------------------------------------
    def cluster_tree(self) -> tuple[ClusterNode, ...]:
        """The dictionary's clusters for coarse-to-fine searches: built on first use,
        once per dictionary and ``init_branching``, and shared by every tracker of that
        dictionary (the clusters depend on nothing else)."""
        trees = _CLUSTER_TREES.setdefault(self.dictionary, {})
        branching = self.config.init_branching
        if branching not in trees:
            vectors = self.dictionary.vectors

            def distance_to(a: int, items: np.ndarray) -> np.ndarray:
                return d1_distance(vectors[items], vectors[a])

            trees[branching] = build_cluster_tree(
                np.arange(len(self.dictionary)), distance_to, branching
            )
        return trees[branching]

    def reset(self) -> None:
        """Forget the previous posture and body scale: start afresh."""
        self.previous_: Estimate | None = None
        fixed = self.config.body_scale
        self.body_scale_ = 1.0 if fixed is None else float(fixed)
        self._scale_samples: list[float] = []
        self._n_scale_estimates = 0
        self._recent_scores: list[float] = []

    # -- one step --------------------------------------------------------------------
    def _check_masks(self, masks: Sequence[np.ndarray]) -> list[np.ndarray]:
        if len(masks) != len(self.cameras):
            raise InvalidParameterError(
                f"{len(masks)} silhouettes given for {len(self.cameras)} cameras"
            )
        out = []
        for cam, mask in zip(self.cameras, masks, strict=True):
            mask = np.asarray(mask)
            if mask.shape != (cam.height, cam.width):
                raise InvalidParameterError(
                    f"camera {cam.name!r}: silhouette of shape {mask.shape}, expected "
                    f"({cam.height}, {cam.width})"
                )
            out.append(mask.astype(bool, copy=False))
        return out

    def _cameras_in_use(
        self, visible: list[int], centroids: dict[int, np.ndarray], height_m: float
    ) -> list[int]:
        if not self.pairs or len(visible) <= 2:
            return visible
        prior = None if self.previous_ is None else self.previous_.position_m
        rough = intersect_plane_lines(
            [self.cameras[c] for c in visible],
            np.stack([centroids[c] for c in visible]),
            height_m,
            prior,
        )
        pair = select_pair(self.pairs, self.cameras, rough)
        chosen = [c for c in pair.cameras if c in visible]
        return chosen or visible

    def travel_penalty(self, entries: np.ndarray) -> np.ndarray:
        """(M,) score taken off entries for facing away from the direction of travel
        given to the current :meth:`step` (zeros when it is unknown or the prior off)."""
        tolerance = self.config.travel_tolerance_deg
        if tolerance is None or self.facing_deg is None or not np.isfinite(self.travel_deg_):
            return np.zeros(len(entries))
        return heading_penalty(
            self.facing_deg[entries], self.travel_deg_, tolerance, self.config.travel_weight
        )

    def travel_directions(
        self, masks: Sequence[np.ndarray], frames: np.ndarray, frame_time_s: float
    ) -> np.ndarray:
        """(F,) degrees: the direction of travel at each of ``frames``
        (:func:`~eigmotion.tracking.heading.travel_headings` of the centroids' positions,
        :func:`~eigmotion.tracking.heading.rough_positions`), the ``travel_deg`` of
        :meth:`step`; all NaN with the prior off or fewer than two cameras.

        Parameters
        ----------
        masks : sequence of C (F', H_c, W_c) bool
        frames : (F,) int
            Frames of the clip to be estimated.
        frame_time_s : float
            Seconds per input frame.
        """
        cfg = self.config
        frames = np.asarray(frames, dtype=np.int64)
        if cfg.travel_tolerance_deg is None or len(self.cameras) < 2:
            return np.full(len(frames), np.nan)
        positions = rough_positions(
            self.cameras, masks, frames, self._default_height_m, cfg.min_silhouette_px
        )
        return travel_headings(
            positions, frames * frame_time_s, cfg.travel_window_s, cfg.travel_min_speed_mps
        )

    def step(self, masks: Sequence[np.ndarray], travel_deg: float = float("nan")) -> Estimate:
        """Estimate the posture from one silhouette per camera.

        Parameters
        ----------
        masks : sequence of (H_c, W_c) bool
            Observed silhouettes (background subtraction), one per camera, each of its
            camera's image size.
        travel_deg : float
            The body centre's direction of travel at this frame, degrees (0 = +Z, 90 =
            +X); NaN when unknown or too slow.  With ``travel_tolerance_deg`` set,
            postures facing away from it are penalised.

        Returns
        -------
        Estimate
        """
        cfg = self.config
        masks = self._check_masks(masks)
        self.travel_deg_ = float(travel_deg)
        visible = [i for i, m in enumerate(masks) if m.sum() >= cfg.min_silhouette_px]
        prev = self.previous_
        if not visible:
            entry = -1 if prev is None else prev.entry
            where = np.full(3, np.nan) if prev is None else prev.position_m
            return Estimate(
                entry,
                where,
                float("nan"),
                0,
                (),
                np.zeros((0, 2)),
                np.zeros(0),
                self.body_scale_,
                False,
            )
        base_height = (
            self._default_height_m
            if prev is None
            else float(self.dictionary.body_height_m[prev.entry])
        )
        height_m = self.body_scale_ * base_height
        centroids = {i: mask_centroid(masks[i]) for i in visible}
        used = self._cameras_in_use(visible, centroids, height_m)
        cams = [self.cameras[c] for c in used]
        position = intersect_plane_lines(
            cams,
            np.stack([centroids[c] for c in used]),
            height_m,
            None if prev is None else prev.position_m,
        )
        if prev is None:
            estimate = self._initial_search(masks, used, position)
        else:
            estimate = self._local_search(masks, used, position, prev.entry, cfg.exhaustive)
            estimate = self._recover(masks, used, position, estimate)
        self._recent_scores = (self._recent_scores + [estimate.score])[-cfg.recovery_window :]
        measuring = self._n_scale_estimates < cfg.body_scale_estimates
        if cfg.body_scale is None and measuring and prev is not None:
            estimate = self._measure_body_scale(masks, estimate)
        self.previous_ = estimate
        return estimate

    def _scorer(
        self,
        masks: list[np.ndarray],
        used: list[int],
        position: np.ndarray,
        pool: np.ndarray,
    ) -> FrameScorer:
        """Scoring of entries of ``pool`` in this frame (windows fitted to the pool)."""
        return FrameScorer(self, masks, used, position, np.asarray(pool))

    def _finish(self, result: SearchResult, scorer: FrameScorer) -> Estimate:
        shifts, scales = scorer.detail[result.best]
        order = np.argsort(-result.scores, kind="stable")[: self.config.path_candidates]
        if self.config.path_candidates < 2:
            order = order[:0]
        others = result.evaluated[order]
        return Estimate(
            result.best,
            scorer.refined_position(result.best, shifts),
            result.score,
            result.n_evaluations,
            tuple(scorer.used),
            shifts,
            scales,
            scorer.body_scale,
            True,
            others,
            result.scores[order],
            np.array(
                [scorer.refined_position(int(e), scorer.detail[int(e)][0]) for e in others]
            ).reshape(-1, 3),
        )

    def _local_search(
        self,
        masks: list[np.ndarray],
        used: list[int],
        position: np.ndarray,
        previous: int,
        exhaustive: bool,
    ) -> Estimate:
        cfg = self.config
        rotations = np.stack([self.cameras[c].R for c in used])
        candidates, _ = select_candidates(
            self.dictionary,
            previous,
            rotations,
            cfg.max_d1_deg,
            cfg.max_d2_m,
            cfg.max_candidates,
            cfg.max_heading_deg,
        )
        scorer = self._scorer(masks, used, position, candidates)
        if exhaustive:
            result = exhaustive_search(candidates, scorer)
        else:
            layer1 = candidates[:: cfg.layer_step]
            distances = np.full((len(candidates), len(candidates)), np.inf)
            distances[:, :: cfg.layer_step] = closeness_matrix(
                self.dictionary,
                candidates,
                layer1,
                rotations,
                cfg.max_d1_deg,
                cfg.max_d2_m,
                cfg.max_heading_deg,
            )
            tree = build_two_layer_tree(candidates, distances, cfg.layer_step)
            result = two_layer_search(tree, scorer, cfg.top_k)
        return self._finish(result, scorer)

    def _recover(
        self, masks: list[np.ndarray], used: list[int], position: np.ndarray, estimate: Estimate
    ) -> Estimate:
        """Search the whole dictionary again when the score has dropped."""
        cfg = self.config
        if cfg.recovery_ratio is None or len(self._recent_scores) < 3:
            return estimate
        if estimate.score >= cfg.recovery_ratio * float(np.median(self._recent_scores)):
            return estimate
        other = self._global_search(masks, used, position)
        best = other if other.score > estimate.score else estimate
        return replace(best, n_evaluations=estimate.n_evaluations + other.n_evaluations)

    def _initial_search(
        self, masks: list[np.ndarray], used: list[int], position: np.ndarray
    ) -> Estimate:
        return self._global_search(masks, used, position, measure_scale=True)

    def _global_search(
        self,
        masks: list[np.ndarray],
        used: list[int],
        position: np.ndarray,
        measure_scale: bool = False,
    ) -> Estimate:
        """Coarse-to-fine search of the whole dictionary, then local refinements."""
        cfg = self.config
        everything = np.arange(len(self.dictionary))
        scorer = self._scorer(masks, used, position, everything)
        result = beam_search(self.cluster_tree(), scorer, cfg.init_beam)
        estimate = self._finish(result, scorer)
        evaluations = estimate.n_evaluations
        if measure_scale and cfg.body_scale is None:
            estimate = self._measure_body_scale(masks, estimate)
        for _ in range(cfg.init_refinements):
            again = self._local_search(
                masks, used, estimate.position_m, estimate.entry, cfg.exhaustive
            )
            evaluations += again.n_evaluations
            done = again.entry == estimate.entry
            estimate = again
            if done:
                break
        return replace(estimate, n_evaluations=evaluations)

    def _measure_body_scale(self, masks: list[np.ndarray], estimate: Estimate) -> Estimate:
        """Compare the observed silhouettes' heights with the estimate's; the median
        ratio so far (times the scale it was measured at) becomes the body scale."""
        cfg = self.config
        for c in estimate.cameras:
            ratio = _height_ratio(masks[c], self.silhouette(estimate, c), cfg.scale_from_top)
            if ratio > 0:
                self._scale_samples.append(estimate.body_scale * ratio)
        self._n_scale_estimates += 1
        if not self._scale_samples:
            return estimate
        lo, hi = cfg.body_scale_range
        self.body_scale_ = float(np.clip(np.median(self._scale_samples), lo, hi))
        if self.body_scale_ == estimate.body_scale:
            return estimate
        height = self.body_scale_ * float(self.dictionary.body_height_m[estimate.entry])
        position = estimate.position_m.copy()
        position[1] = height
        return replace(estimate, position_m=position, body_scale=self.body_scale_)

    # -- whole clips -----------------------------------------------------------------
    def track(
        self,
        masks: Sequence[np.ndarray],
        frame_step: int = 1,
        frame_time_s: float = 1.0 / 25.0,
        progress: Callable[[int, int], None] | None = None,
    ) -> TrackResult:
        """Track a whole clip seen by every camera.

        Parameters
        ----------
        masks : sequence of C (F, H_c, W_c) bool
            Silhouettes per camera and frame (the clips must have equal length).
        frame_step : int
            Estimate every ``frame_step``-th frame (the paper: every 4th of 100 fps).
        frame_time_s : float
            Seconds per input frame (the estimates are ``frame_step`` times apart).
        progress : callable, optional
            Called as ``progress(done, total)`` after each estimate.

        Returns
        -------
        TrackResult
        """
        if len(masks) != len(self.cameras):
            raise InvalidParameterError(f"{len(masks)} clips given for {len(self.cameras)} cameras")
        lengths = {len(m) for m in masks}
        if len(lengths) != 1:
            raise InvalidParameterError(f"the clips have different frame counts {sorted(lengths)}")
        if int(frame_step) != frame_step or frame_step < 1:
            raise InvalidParameterError(f"frame_step must be an integer >= 1, got {frame_step!r}")
        n_frames = lengths.pop()
        frames = np.arange(0, n_frames, int(frame_step), dtype=np.int64)
        self.reset()
        travel = self.travel_directions(masks, frames, frame_time_s)
        estimates = []
        for i, f in enumerate(frames):
            estimates.append(self.step([m[f] for m in masks], travel[i]))
            if progress is not None:
                progress(i + 1, len(frames))
        if self.config.path_candidates > 1:
            estimates = along_best_path(estimates, self.dictionary.vectors, self.config.path_weight)
        return self.result(estimates, frames, frame_time_s * frame_step)

    def result(
        self, estimates: Sequence[Estimate], frames: np.ndarray, frame_time_s: float
    ) -> TrackResult:
        """Collect estimates into a :class:`TrackResult`."""
        entries = np.array([e.entry for e in estimates], dtype=np.int64)
        positions = np.stack([e.position_m for e in estimates]) if estimates else np.zeros((0, 3))
        joints = np.full((len(entries), self.dictionary.n_joints, 3), np.nan)
        ok = entries >= 0
        scales = np.array([e.body_scale for e in estimates], dtype=np.float64)
        if np.any(ok):
            joints[ok] = self.bodies.joints(entries[ok], positions[ok], scales[ok])
        return TrackResult(
            entries,
            positions,
            joints,
            self.dictionary.joint_names,
            np.array([e.score for e in estimates], dtype=np.float64),
            np.array([e.n_evaluations for e in estimates], dtype=np.int64),
            np.array([e.found for e in estimates], dtype=bool),
            np.asarray(frames, dtype=np.int64),
            float(frame_time_s),
            tuple(estimates),
        )

    def silhouette(self, estimate: Estimate, camera: int) -> np.ndarray:
        """(H, W) bool: the estimated posture's silhouette in a camera, full size.

        The body is placed at the estimate's (shift-refined) position; for overlays.
        """
        if estimate.entry < 0:
            return np.zeros((self.cameras[camera].height, self.cameras[camera].width), bool)
        cam = self.cameras[camera]
        verts = self.bodies.vertices(
            np.array([estimate.entry]), estimate.position_m, estimate.body_scale
        )
        return self.render_masks(verts, self.bodies.faces, cam)[0]
