"""The motion database: build it, query it, index new motions into it.

Steps 4–6 of the retrieval engine, on top of :mod:`eigmotion.retrieval.build` (motion images
of library × rig), :mod:`eigmotion.retrieval.eigenspace`, :mod:`eigmotion.retrieval.keys`,
:mod:`eigmotion.retrieval.search` and :mod:`eigmotion.retrieval.store` (the only module that touches
ZODB).  Every query takes the patent's path: motion image → eigenspace point → exact
nearest entries through the B-tree → label, motion, view; a distance over the stored
threshold means "unknown motion".
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from eigmotion import resources
from eigmotion.errors import DatabaseError, InvalidParameterError, VideoError
from eigmotion.imaging.cameras import Camera, CameraRig
from eigmotion.mocap.bvh import format_bvh, parse_bvh
from eigmotion.mocap.library import FILLER_LABELS, LibraryMotion
from eigmotion.mocap.motion import Motion
from eigmotion.retrieval.build import BuildConfig, ViewImages, render_views, window_bounds
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.keys import Quantizer
from eigmotion.retrieval.motion_image import ClipMotionImages
from eigmotion.retrieval.search import NO_ENTRY, BruteForceIndex, TreeIndex
from eigmotion.retrieval.sequences import (
    CANDIDATE_MOTIONS,
    fit_pose_space,
    fused_scores,
    pace_factors,
    pose_coordinates,
    pose_speeds,
    sequence_distances,
    sequence_frames,
    view_reach,
)
from eigmotion.retrieval.store import Store, parse_uri
from eigmotion.segmentation.config import SilhouetteConfig
from eigmotion.segmentation.video import ClipMasks, load_clip_masks
from eigmotion.segmentation.workers import opencv_in_calling_threads, worker_threads

#: Where ``eigmotion build`` with no options writes.
DEFAULT_DB_PATH = resources.default_database()

#: Working resolution of query silhouettes: the longer side of a frame, pixels.  The
#: motion image is 32–64 pixels, so segmenting at full video resolution only costs
#: time (measured in docs/retrieval.md).
QUERY_SILHOUETTE_SIDE_PX = 160

#: A window overrides a filler answer only when its nearest specific entry is nearer
#: than this fraction of its nearest filler entry (specific motions such as a walking
#: turn hold walking steps of their own), among :data:`WINDOW_CANDIDATES` nearest.
SPECIFIC_MARGIN = 0.7
WINDOW_CANDIDATES = 8
#: Windows that must show the same specific action for it to override filler: one
#: window alone is as often a walk's stride matched to a walking turn's.
MIN_SPECIFIC_WINDOWS = 2
#: What a change of label between consecutive windows costs the clip's segments, as a
#: fraction of the database's threshold: one window that matches another action
#: than its neighbours is more often a poor match than an action of its own
#: (:func:`window_label_path`).
SEGMENT_SWITCH_COST = 0.15
#: Nearest entries the whole clip's search returns: enough to hold the
#: :data:`~eigmotion.retrieval.sequences.CANDIDATE_MOTIONS` nearest distinct motions that are
#: ranked again by their silhouette sequences (a motion's renderings from neighbouring
#: views and bodies crowd its nearest entries), and the labels beyond them
#: (:func:`candidate_motions`).
CANDIDATE_ENTRIES = 256

#: Quantile of the leave-one-motion-out distances that sets the "unknown" threshold.
THRESHOLD_QUANTILE = 0.95
#: Levels at which the build stores the quantiles of those distances: 0, 0.5, ...,
#: 100 %.  Level 190 is :data:`THRESHOLD_QUANTILE` exactly.
CALIBRATION_LEVELS = np.arange(201) / 200


# -- rigs as plain data -------------------------------------------------------------


def rig_to_plain(rig: CameraRig) -> dict:
    """A rig as plain values (for the store's config)."""
    return {
        "name": rig.name,
        "cameras": [
            {
                "name": c.name,
                "K": c.K.tolist(),
                "R": c.R.tolist(),
                "t": c.t.tolist(),
                "width": c.width,
                "height": c.height,
                "azimuth_deg": c.azimuth_deg,
                "elevation_deg": c.elevation_deg,
            }
            for c in rig.cameras
        ],
    }


def rig_from_plain(data: dict) -> CameraRig:
    cams = tuple(
        Camera(
            np.asarray(c["K"]),
            np.asarray(c["R"]),
            np.asarray(c["t"]),
            c["width"],
            c["height"],
            c["name"],
            c["azimuth_deg"],
            c["elevation_deg"],
        )
        for c in data["cameras"]
    )
    return CameraRig(cams, data["name"])


# -- building -----------------------------------------------------------------------


@dataclass(frozen=True)
class BuildReport:
    """What a build made.

    Attributes
    ----------
    uri : str
    n_motions, n_entries, n_components : int
    explained_variance : float
        Fraction of the motion images' variance the eigenspace keeps.
    threshold : float
        Distance above which a query is "unknown", eigen-coordinate units.
    seconds : float
        Wall time of the build.
    """

    uri: str
    n_motions: int
    n_entries: int
    n_components: int
    explained_variance: float
    threshold: float
    seconds: float


@dataclass
class _Collected:
    vectors: list = field(default_factory=list)
    motion: list = field(default_factory=list)
    body: list = field(default_factory=list)
    azimuth: list = field(default_factory=list)
    elevation: list = field(default_factory=list)
    start: list = field(default_factory=list)
    stop: list = field(default_factory=list)
    labels: list = field(default_factory=list)
    #: (motion index, azimuth, elevation, (F, SEQUENCE_SIZE**2 + 1) frames) per rendering
    sequences: list = field(default_factory=list)

    def add(self, view: ViewImages, rig: CameraRig) -> None:
        n = len(view.vectors)
        cam = rig[view.view_index]
        if len(view.sequence):
            self.sequences.append(
                (view.motion_index, cam.azimuth_deg, cam.elevation_deg, view.sequence)
            )
        self.vectors.append(view.vectors)
        self.motion += [view.motion_index] * n
        self.body += [view.shape_index] * n
        self.azimuth += [cam.azimuth_deg] * n
        self.elevation += [cam.elevation_deg] * n
        self.start += view.windows[:, 0].tolist()
        self.stop += view.windows[:, 1].tolist()
        self.labels += view.labels

    def arrays(self):
        return (
            np.concatenate(self.vectors).astype(np.float32),
            np.asarray(self.motion, dtype=np.int64),
            np.asarray(self.body, dtype=np.int64),
            np.asarray(self.azimuth, dtype=np.float64),
            np.asarray(self.elevation, dtype=np.float64),
            np.asarray(self.start, dtype=np.int64),
            np.asarray(self.stop, dtype=np.int64),
            list(self.labels),
        )


def leave_one_motion_out_distances(
    points: np.ndarray,
    performance_of: np.ndarray,
    whole: np.ndarray,
    body_of: np.ndarray | None = None,
) -> np.ndarray | None:
    """How far new performances of the library's motions lie from the database.

    Each whole-motion entry is queried as a query would be, against every entry of
    the OTHER performances rendered on the OTHER bodies (as if that performance were
    new, by someone whose body and clothes the database does not hold, as in every
    real query): its nearest distance is what a known motion done by someone else
    looks like.  The "unknown" threshold is the :data:`THRESHOLD_QUANTILE` of these
    distances (:func:`leave_one_motion_out_threshold`), and their quantiles, stored
    (:func:`calibration_quantiles`), give each answer its ``p_known``.

    Parameters
    ----------
    points : (N, k) float
    performance_of : (N,) int
        Performance index of each entry: a motion and its mirror image are one
        performance (the mirror of a walk seen from the left is the walk seen from
        the right).
    whole : (N,) bool
        Entries that cover a whole motion.
    body_of : (N,) int, optional
        The body (shape and outfit, an index into ``BuildConfig.bodies``) each entry
        was rendered on.  Not given, or one body in all: every body of the other
        performances is compared with.

    Returns
    -------
    (M,) float64 or None
        One distance per whole-motion entry, eigenspace units (each measured in the
        points' own dtype, as a query's search measures it); None for a database of
        one performance, which has nothing to compare with but itself.
    """
    if len(np.unique(performance_of)) == 1:
        return None
    points = np.asarray(points)
    several_bodies = body_of is not None and len(np.unique(body_of)) > 1
    body_of = np.asarray(body_of) if several_bodies else np.zeros(len(points), np.int64)
    found = []
    for performance in np.unique(performance_of[whole]):
        mine = performance_of == performance
        for body in np.unique(body_of[whole & mine]):
            queries = np.flatnonzero(whole & mine & (body_of == body))
            others = points[~mine & (body_of != body) if several_bodies else ~mine]
            for block in np.array_split(queries, -(-len(queries) // _QUERY_BLOCK)):
                found.append(_nearest_distances(points[block], others))
    return np.concatenate(found).astype(np.float64)


def leave_one_motion_out_threshold(
    points: np.ndarray,
    performance_of: np.ndarray,
    whole: np.ndarray,
    body_of: np.ndarray | None = None,
) -> float:
    """The "unknown" threshold from the database itself: the
    :data:`THRESHOLD_QUANTILE` of :func:`leave_one_motion_out_distances` (same
    parameters) — about that share of new performances of library motions is accepted.

    Returns
    -------
    float
        For a database of one performance, twice its largest distance from the
        centre of its entries: the threshold then accepts anything as near as the
        database is wide.
    """
    distances = leave_one_motion_out_distances(points, performance_of, whole, body_of)
    return _threshold(distances, points)


def _threshold(distances: np.ndarray | None, points: np.ndarray) -> float:
    """:func:`leave_one_motion_out_threshold` from its distances (None for one
    performance) and the (N, k) points."""
    if distances is None:
        points = np.asarray(points)
        return float(2.0 * np.linalg.norm(points - points.mean(axis=0), axis=1).max())
    return float(np.quantile(distances, THRESHOLD_QUANTILE))


def calibration_quantiles(distances: np.ndarray | None) -> list[float] | None:
    """The quantiles of :func:`leave_one_motion_out_distances` at
    :data:`CALIBRATION_LEVELS`, as the store keeps them: (201,) float, eigenspace
    units, non-decreasing; None where there are no distances."""
    if distances is None:
        return None
    return np.quantile(distances, CALIBRATION_LEVELS).tolist()


#: Whole-motion entries whose distances to the rest are computed together: bounds
#: the (block × entries) matrix of :func:`leave_one_motion_out_threshold`.
_QUERY_BLOCK = 256


def _stored_quantiles(uri: str, stored: dict) -> np.ndarray | None:
    """The build's :func:`calibration_quantiles` read back and checked: (201,) float,
    or None for a database built without them."""
    quantiles = stored.get("calibration_quantiles")
    if quantiles is None:
        return None
    try:
        quantiles = np.asarray(quantiles, dtype=np.float64)
    except (TypeError, ValueError):
        quantiles = np.empty(0)
    if (
        quantiles.shape != CALIBRATION_LEVELS.shape
        or not np.all(np.isfinite(quantiles))
        or np.any(np.diff(quantiles) < 0)
    ):
        raise DatabaseError(
            f"{uri}: the stored calibration quantiles are damaged (expected "
            f"{len(CALIBRATION_LEVELS)} finite, non-decreasing distances); build it again"
        )
    return quantiles


def _nearest_distances(queries: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(Q,) Euclidean distance from each of ``queries`` (Q, k) to its nearest among
    ``points`` (N, k).  The nearest is found by one float64 matrix product for all
    the pairs; its distance is then the norm of the difference in the points' own
    dtype, as a query's search measures it."""
    q64, p64 = queries.astype(np.float64), points.astype(np.float64)
    squared = (
        np.einsum("ij,ij->i", q64, q64)[:, None]
        + np.einsum("ij,ij->i", p64, p64)[None, :]
        - 2.0 * q64 @ p64.T
    )
    return np.linalg.norm(points[np.argmin(squared, axis=1)] - queries, axis=1)


def build_database(
    library: Sequence[LibraryMotion],
    rig: CameraRig,
    uri: str | os.PathLike = DEFAULT_DB_PATH,
    config: BuildConfig | None = None,
    workers: int | None = None,
    progress: bool = True,
    views: Iterable[ViewImages] | None = None,
) -> BuildReport:
    """Build a database from a motion library and a rig of virtual cameras.

    Renders every (motion, body shape, view), fits the eigenspace, cuts the keys,
    calibrates the "unknown" threshold and writes everything in one transaction.  A
    file database is written beside the target and moved over it only once complete,
    so a failed or interrupted build leaves any previous database as it was.

    Parameters
    ----------
    library : sequence of LibraryMotion
    rig : CameraRig
    uri : str or path
        Where to write (see :mod:`eigmotion.retrieval.store`); an existing database there is
        replaced.
    config : BuildConfig, optional
    workers : int, optional
        Processes for rendering.
    progress : bool
        Progress bars on stderr.
    views : iterable of ViewImages, optional
        The motion images of every (motion, body, view), as :func:`~eigmotion.retrieval.build.
        render_views` yields them for ``library``, ``rig`` and ``config`` (its
        ``motion_index`` an index into ``library``), when they were made already —
        e.g. from stored silhouettes; default: rendered here.

    Returns
    -------
    BuildReport
    """
    t0 = time.perf_counter()
    config = config or BuildConfig()
    if not library:
        raise InvalidParameterError("the motion library is empty: nothing to build")
    names = [m.name for m in library]
    if len(set(names)) != len(names):
        raise InvalidParameterError("motion names in the library must be unique")
    collected = _Collected()
    if views is None:
        views = render_views(library, rig, config, workers=workers, progress=progress)
    for view in views:
        collected.add(view, rig)
    X, motion_of, body_of, az, el, start, stop, labels = collected.arrays()
    if not collected.sequences:
        raise InvalidParameterError("no rendering of the library shows a person: nothing to build")
    space = Eigenspace(config.n_components, config.explained_variance).fit(X)
    pose_space = fit_pose_space(np.concatenate([seq for *_, seq in collected.sequences]))
    points = space.transform(X).astype(np.float32)
    n_axes = min(config.key_axes, space.n_components_)
    quantizer = Quantizer(n_axes, config.key_sections, config.key_method).fit(points)
    keys = quantizer.keys(points)
    whole = (start == 0) & (stop == np.array([m.motion.n_frames for m in library])[motion_of])
    originals = [m.mirror_of or m.name for m in library]
    performance = np.unique(originals, return_inverse=True)[1]
    calibration = leave_one_motion_out_distances(points, performance[motion_of], whole, body_of)
    threshold = _threshold(calibration, points)
    recon = space.reconstruction_error(X)
    stored_config = {
        "build": config.to_dict(),
        "rig": rig_to_plain(rig),
        "threshold": threshold,
        "calibration_quantiles": calibration_quantiles(calibration),
        "reconstruction_error_median": float(np.median(recon)),
        "reconstruction_error_p95": float(np.quantile(recon, 0.95)),
    }
    with _replacing(uri) as target:
        store = Store.create(target, overwrite=True)
        try:
            with store.transaction():
                store.initialise(stored_config, space, quantizer, pose_space)
                motion_ids = [_add_motion(store, m) for m in library]
                of_entry = np.asarray(motion_ids)[motion_of]
                store.add_entries(of_entry, points, keys, az, el, start, stop, labels, body_of)
                _add_sequences(store, motion_ids, collected.sequences, pose_space)
        finally:
            store.close()
    return BuildReport(
        os.fspath(uri),
        len(library),
        len(points),
        int(space.n_components_),
        float(np.sum(space.explained_variance_ratio_)),
        threshold,
        time.perf_counter() - t0,
    )


def _add_motion(store: Store, item: LibraryMotion) -> int:
    motion = item.motion
    return store.add_motion(
        item.label,
        ";".join(str(p) for p in item.source),
        format_bvh(motion),
        {
            "name": item.name,
            "performer": item.performer,
            "variation": item.variation,
            "role": item.role,
            "mirror_of": item.mirror_of or "",
            "action": list(item.action or ()),
            "filler": item.filler or "",
            "n_frames": motion.n_frames,
            "frame_time_s": motion.frame_time_s,
            "length_unit_m": -1.0 if motion.length_unit_m is None else motion.length_unit_m,
        },
    )


def _add_sequences(store: Store, motion_ids: Sequence[int], sequences: list, pose_space) -> None:
    """Store every rendering's silhouette sequence in the pose eigenspace, motion by
    motion (``sequences`` as :class:`_Collected` holds them, motion indices into
    ``motion_ids``)."""
    by_motion: dict[int, list] = {}
    for motion_index, azimuth, elevation, frames in sequences:
        by_motion.setdefault(motion_index, []).append((azimuth, elevation, frames))
    for motion_index, rows in by_motion.items():
        azimuth, elevation, frames = zip(*rows, strict=True)
        coordinates = [pose_coordinates(pose_space, f) for f in frames]
        store.add_sequences(motion_ids[motion_index], azimuth, elevation, coordinates)


@contextlib.contextmanager
def _replacing(uri: str | os.PathLike):
    """Yield where to write a new database; for files, a side file moved over the
    target only when the block succeeds."""
    text = os.fspath(uri)
    scheme, target = parse_uri(text)
    if scheme != "file":
        yield text
        return
    path = Path(target)
    if not path.parent.is_dir():
        raise DatabaseError(f"{path}: folder {path.parent} does not exist")
    side = path.with_name(path.name + ".building")
    _remove_file_storage(side)
    try:
        yield str(side)
    except BaseException:
        _remove_file_storage(side)
        raise
    for suffix in (".index", ".lock", ".tmp"):
        with contextlib.suppress(FileNotFoundError):
            Path(f"{path}{suffix}").unlink()
    os.replace(side, path)
    with contextlib.suppress(FileNotFoundError):
        os.replace(f"{side}.index", f"{path}.index")
    _remove_file_storage(side)


def _remove_file_storage(path: Path) -> None:
    for suffix in ("", ".index", ".lock", ".tmp", ".old"):
        with contextlib.suppress(FileNotFoundError):
            Path(f"{path}{suffix}").unlink()


# -- querying -----------------------------------------------------------------------


@dataclass(frozen=True)
class Match:
    """One database entry returned for a query.

    Attributes
    ----------
    label : str
    motion : str
        The basic motion's name.
    motion_id : int
    entry_id : int
    distance : float
        Euclidean distance in the eigenspace.
    azimuth_deg, elevation_deg : float
        The matching virtual camera.
    window : (int, int)
        ``[start, stop)`` frames of the basic motion.
    sequence_distance : float or None
        Time-warped distance between the clip's silhouette sequence and the motion's
        nearest rendering, times what their difference of pace costs (pose-eigenspace
        units, :mod:`eigmotion.retrieval.sequences`); None when the motion was not compared
        that way.
    """

    label: str
    motion: str
    motion_id: int
    entry_id: int
    distance: float
    azimuth_deg: float
    elevation_deg: float
    window: tuple[int, int]
    sequence_distance: float | None = None

    def to_json(self) -> dict:
        out = {
            "label": self.label,
            "motion": self.motion,
            "distance": round(self.distance, 6),
            "view": {"azimuth_deg": self.azimuth_deg, "elevation_deg": self.elevation_deg},
        }
        if self.sequence_distance is not None:
            out["sequence_distance"] = round(self.sequence_distance, 6)
        return out


def window_label_path(
    labels: Sequence[Sequence[str]], distances: np.ndarray, switch_cost: float
) -> tuple[list[str], np.ndarray]:
    """One label per window of a clip: the labelling whose windows lie nearest their
    labels, each change of label between consecutive windows counted as
    ``switch_cost`` more (a Viterbi path).

    The labels to choose from are those of the windows' nearest entries: a label that
    is no window's nearest does not take over the clip for coming second everywhere.
    A label's distance from a window is that of the window's nearest entry of the
    label; where none of the window's searched entries has the label, the farthest of
    them stands in (the label is at least that far).  With ``switch_cost`` 0 every
    window takes the label of its nearest entry.

    Parameters
    ----------
    labels : sequence of W sequences of K str
        The labels of each window's K nearest entries, nearest first.
    distances : (W, K) float
        Their distances, eigenspace units.
    switch_cost : float
        Eigenspace units, >= 0.

    Returns
    -------
    path : list of W str
    distances : (W,) float64
        Each window's distance from its label in ``path``.
    """
    distances = np.asarray(distances, dtype=np.float64)
    if distances.ndim != 2 or distances.shape[0] != len(labels) or not len(labels):
        raise InvalidParameterError(
            f"distances must be (W, K) for {len(labels)} windows, got {distances.shape}"
        )
    candidates = list(dict.fromkeys(row[0] for row in labels))
    cost = np.repeat(distances[:, -1:], len(candidates), axis=1)  # (W, L)
    for w, row in enumerate(labels):
        for label, dist in zip(reversed(row), distances[w, ::-1], strict=True):
            if label in candidates:
                cost[w, candidates.index(label)] = dist  # the nearest written last
    total = cost[0].copy()
    came_from = np.empty(cost.shape, np.int64)
    for w in range(1, len(cost)):
        switch = total.min() + switch_cost
        stays = total <= switch  # a tie keeps the label
        came_from[w] = np.where(stays, np.arange(len(candidates)), total.argmin())
        total = np.where(stays, total, switch) + cost[w]
    chosen = [int(total.argmin())]
    for w in range(len(cost) - 1, 0, -1):
        chosen.append(int(came_from[w, chosen[-1]]))
    chosen.reverse()
    return [candidates[c] for c in chosen], cost[np.arange(len(cost)), chosen]


def candidate_motions(nearest: Sequence[Match]) -> list[Match]:
    """The motions a query ranks again by their silhouette sequences.

    The :data:`~eigmotion.retrieval.sequences.CANDIDATE_MOTIONS` nearest, and then the nearest
    motion of every other label among ``nearest``: the nearest motions of a clip often
    show only three or four labels, and a label the sequences never see cannot be
    ranked in, first or among the first three.

    Parameters
    ----------
    nearest : sequence of Match
        Distinct motions, each by its nearest entry, nearest first.

    Returns
    -------
    list of Match
        A subsequence of ``nearest``, in its order.
    """
    chosen = list(nearest[:CANDIDATE_MOTIONS])
    labels = {m.label for m in chosen}
    for match in nearest[CANDIDATE_MOTIONS:]:
        if match.label not in labels:
            chosen.append(match)
            labels.add(match.label)
    return chosen


@dataclass(frozen=True)
class Segment:
    """A stretch of the query clip with one label.

    ``start_frame``/``end_frame`` are ``[start, end)`` frames of the clip."""

    start_frame: int
    end_frame: int
    label: str
    distance: float

    def to_json(self) -> dict:
        return {
            "start_frame": self.start_frame,
            "end_frame": self.end_frame,
            "label": self.label,
            "distance": round(self.distance, 6),
        }


@dataclass(frozen=True)
class QueryResult:
    """The answer to one clip (see :meth:`MotionDatabase.query_masks`).

    Attributes
    ----------
    best : Match
        The clip's answer: the whole clip's nearest motion by motion image and
        silhouette sequence together (:func:`~eigmotion.retrieval.sequences.fused_scores`) —
        its nearest entry — unless that is filler (:data:`FILLER_LABELS`: walking
        into a turn) and a window of the clip shows a specific action — then that
        window's nearest entry.
    accepted : bool
        The whole clip's nearest entry (or the window that answers) lies within the
        threshold — as near as the database's own motions come to one another's
        performances, which is what the threshold is calibrated on; otherwise the
        motion is unknown.  The answer itself may be a motion whose nearest entry is
        farther: it was ranked first by both distances together.
    threshold : float
        The "unknown" threshold ``accepted`` was judged against, eigenspace units: the
        database's own, or the one for the false rejection the query asked for
        (:meth:`MotionDatabase.threshold_at`).
    p_known : float or None
        In [0, 1]: the share of new performances of the library's own motions that lie
        at least as far from the database as this clip (the distance ``accepted`` is
        judged by, against the quantiles the build stored,
        :func:`leave_one_motion_out_distances`).  Near 1, as near as most known
        motions come; near 0, farther than nearly all.  ``accepted`` at a false
        rejection r is ``p_known >= r``.  None for a database built without them.
    top : list of Match
        Distinct motions in that order, ``best`` first.
    labels : list of Match
        Every label the query ranked, once, in that order: the first motion of each in
        the ranking that ``top`` begins (``best`` first).  Its first three are the
        top-3 that ``docs/accuracy.md`` measures.
    segments : list of Segment
    examined : int
        Entries whose distance was computed by the whole-clip search.
    examined_windows : int
        The same, summed over the searches of the sliding windows (segments).
    db_entries : int
    timing_ms : dict of str to float
        Wall time of the query's steps, ms: ``motion_images`` (the whole clip's),
        ``search`` (the whole clip's; the windows' motion images and searches run
        beside it and the next step), ``sequences`` (the candidates ranked), ``total``.
    motion_image : (D,) float32
        The clip's motion image.
    """

    best: Match
    accepted: bool
    threshold: float
    p_known: float | None
    top: list[Match]
    labels: list[Match]
    segments: list[Segment]
    examined: int
    examined_windows: int
    db_entries: int
    timing_ms: dict[str, float]
    motion_image: np.ndarray

    def to_json(self) -> dict:
        out = self.best.to_json()
        out["accepted"] = bool(self.accepted)
        out["threshold"] = round(self.threshold, 6)
        out["p_known"] = None if self.p_known is None else round(self.p_known, 4)
        out["top"] = [m.to_json() for m in self.top]
        out["labels"] = [m.to_json() for m in self.labels]
        out["segments"] = [s.to_json() for s in self.segments]
        out["examined"] = int(self.examined)
        out["examined_windows"] = int(self.examined_windows)
        out["db_entries"] = int(self.db_entries)
        out["timing_ms"] = {k: round(v, 3) for k, v in self.timing_ms.items()}
        return out


class MotionDatabase:
    """An open motion database, ready for queries (and, opened writable, indexing).

    Use :meth:`open`; it is a context manager.

    Attributes
    ----------
    store : Store
    config : BuildConfig
    rig : CameraRig
    threshold : float
        The "unknown" threshold, eigenspace units.
    calibration_quantiles : (201,) float or None
        The quantiles of :func:`leave_one_motion_out_distances` at
        :data:`CALIBRATION_LEVELS`; None for a database built without them.
    """

    def __init__(self, store: Store):
        self.store = store
        stored = store.config
        self.config = BuildConfig.from_dict(stored["build"])
        self.rig = rig_from_plain(stored["rig"])
        self.threshold = float(stored["threshold"])
        self.calibration_quantiles = _stored_quantiles(store.uri, stored)
        self.reconstruction_error_p95 = float(stored["reconstruction_error_p95"])
        self.eigenspace = store.eigenspace()
        self.pose_space = store.pose_space()
        self._load_index()

    def _load_index(self) -> None:
        arrays = self.store.arrays()
        self.index = TreeIndex.from_store(self.store)
        self._motion_of = dict(zip(arrays.ids.tolist(), arrays.motions.tolist(), strict=True))
        self._entry_labels: dict[int, str] = {}
        self._motions = {int(mid): self.store.motion(int(mid)) for mid in self.store.motion_ids()}
        self._sequences: dict = {}  # motion id → (MotionSequences, starts, speeds), on first use

    @classmethod
    def open(cls, uri: str | os.PathLike = DEFAULT_DB_PATH, read_only: bool = True):
        """Open a database built by :func:`build_database`."""
        if Path(os.fspath(uri)) == DEFAULT_DB_PATH and not DEFAULT_DB_PATH.is_file():
            raise DatabaseError(
                f"{DEFAULT_DB_PATH}: the default database has not been built yet; "
                "run 'eigmotion build' (or pass --db)"
            )
        return cls(Store.open(uri, read_only=read_only))

    def close(self) -> None:
        self.store.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    @property
    def n_entries(self) -> int:
        return self.index.n_entries

    def motion_record(self, motion_id: int) -> dict:
        return self._motions[motion_id]

    def threshold_at(self, false_rejection: float) -> float:
        """The distance beyond which a query is "unknown" when about
        ``false_rejection`` of new performances of the library's motions may be turned
        away (the database's own threshold turns away 5 %; more turns away more
        unknown motions too).

        Parameters
        ----------
        false_rejection : float
            In (0, 1).

        Returns
        -------
        float
            Eigenspace units.
        """
        if not 0.0 < false_rejection < 1.0:
            raise InvalidParameterError(
                f"the false rejection must be between 0 and 1, got {false_rejection}"
            )
        if self.calibration_quantiles is None:
            raise DatabaseError(
                f"{self.store.uri}: built without the distances of its own motions' "
                "performances, so only its own threshold can be used; build it again"
            )
        # The share beyond quantile i is CALIBRATION_LEVELS[200 - i]: read backwards, so
        # that 0.05 gives the 95th percentile to the bit (1 - 0.05 is not 0.95).
        beyond = self.calibration_quantiles[::-1]
        return float(np.interp(false_rejection, CALIBRATION_LEVELS, beyond))

    def p_known(self, distance: float) -> float | None:
        """The share of new performances of the library's motions that lie at least
        ``distance`` (eigenspace units) from the database, in [0, 1]; None for a
        database built without those distances.  ``distance <= threshold_at(r)``
        exactly when ``p_known(distance) >= r``."""
        if self.calibration_quantiles is None:
            return None
        shares_beyond = CALIBRATION_LEVELS[::-1]
        return float(np.interp(distance, self.calibration_quantiles, shares_beyond))

    def motion(self, motion_id: int) -> Motion:
        """A stored basic motion, read back from its BVH text."""
        rec = self._motions[motion_id]
        meta = rec["metadata"]
        motion = parse_bvh(rec["bvh"])
        unit = meta.get("length_unit_m", -1.0)
        return motion.replace(
            name=meta.get("name", str(motion_id)), length_unit_m=None if unit < 0 else unit
        )

    def _match(self, entry_id: int, distance: float) -> Match:
        entry = self.store.entry(entry_id)
        rec = self._motions[entry["motion"]]
        return Match(
            self._label_of(entry_id),
            rec["metadata"].get("name", str(entry["motion"])),
            int(entry["motion"]),
            int(entry_id),
            float(distance),
            float(entry["view_azimuth_deg"]),
            float(entry["view_elevation_deg"]),
            (int(entry["start_frame"]), int(entry["end_frame"])),
        )

    def _label_of(self, entry_id: int) -> str:
        """The entry's label: its motion's, or the filler's for a window outside the
        motion's action (:func:`eigmotion.retrieval.build.window_labels`); read once, then kept."""
        label = self._entry_labels.get(entry_id)
        if label is None:
            label = self._entry_labels[entry_id] = self.store.entry(entry_id)["label"]
        return label

    @opencv_in_calling_threads()
    def query_masks(
        self, masks: np.ndarray, fps: float, top_k: int = 3, false_rejection: float | None = None
    ) -> QueryResult:
        """Answer a clip given as silhouettes.

        Parameters
        ----------
        masks : (F, H, W) bool
            The person's silhouette per frame.
        fps : float
            The clip's frame rate, frames per second.
        top_k : int
            Distinct motions to list in ``top``: the :data:`~eigmotion.retrieval.sequences.
            CANDIDATE_MOTIONS` nearest and the nearest of every further label
            (:func:`candidate_motions`) ranked by both distances, then further
            motions by motion image distance (as many as the whole clip's search
            returned).  ``labels`` lists every ranked label whatever ``top_k`` is.
        false_rejection : float, optional
            In (0, 1): judge ``accepted`` at the threshold that turns away this share
            of new performances of the library's motions (:meth:`threshold_at`);
            default the database's own threshold (5 %).

        Returns
        -------
        QueryResult
        """
        if top_k < 1:
            raise InvalidParameterError(f"top_k must be >= 1, got {top_k}")
        threshold = self.threshold
        if false_rejection is not None:
            threshold = self.threshold_at(false_rejection)
        timing: dict[str, float] = {}
        t0 = time.perf_counter()
        cfg = self.config
        windows = window_bounds(len(masks), fps, cfg.window_s, cfg.window_step_s)
        images = ClipMotionImages(masks, cfg.motion_image, clip_fps=fps)
        whole_vector = images.window(*windows[0])  # no person or no motion: raised here
        # The windows' search and the clip's silhouette sequence do not wait for the
        # whole clip's search: they run beside it.
        workers = worker_threads()
        windowed_job = workers.submit(self._search_windows, images, windows[1:])
        sequence_job = workers.submit(
            lambda: pose_coordinates(self.pose_space, sequence_frames(images))
        )
        point = self.eigenspace.transform(whole_vector[None])  # (1, D) float32 already
        t1 = time.perf_counter()
        timing["motion_images"] = (t1 - t0) * 1e3
        whole = self.index.search(point, top_k=min(CANDIDATE_ENTRIES, self.n_entries))
        t2 = time.perf_counter()
        timing["search"] = (t2 - t1) * 1e3
        nearest = self._nearest_motions(whole.ids[0], whole.distances[0])
        candidates = candidate_motions(nearest)
        ranked = self._ranked_by_sequence(sequence_job.result(), candidates)
        timing["sequences"] = (time.perf_counter() - t2) * 1e3
        kept, windowed = windowed_job.result()
        compared = {m.motion_id for m in candidates}
        ranking = ranked + [m for m in nearest if m.motion_id not in compared]
        best = self._most_specific(ranking[0], windowed)
        segments = self._segments(kept, windowed, len(masks), best)
        ranking = [best] + [m for m in ranking if m.motion_id != best.motion_id]
        by_label: dict[str, Match] = {}
        for match in ranking:
            by_label.setdefault(match.label, match)
        examined_windows = 0 if windowed is None else int(windowed.examined.sum())
        timing["total"] = (time.perf_counter() - t0) * 1e3
        nearest_distance = min(float(whole.distances[0, 0]), best.distance)
        return QueryResult(
            best,
            bool(nearest_distance <= threshold),
            threshold,
            self.p_known(nearest_distance),
            ranking[:top_k],
            list(by_label.values()),
            segments,
            int(whole.examined[0]),
            examined_windows,
            self.n_entries,
            timing,
            whole_vector,
        )

    def _search_windows(self, images: ClipMotionImages, windows: np.ndarray):
        """The :data:`WINDOW_CANDIDATES` nearest entries of each window's motion image.

        Parameters
        ----------
        images : ClipMotionImages
            The clip's.
        windows : (W, 2) int
            Frame bounds ``[start, stop)`` of the windows (the whole clip's excluded).

        Returns
        -------
        kept : list of (int, int)
            The bounds of the windows that show a person moving, in order.
        SearchResult or None
            Their search, one row per kept window; None when none is kept.
        """
        vectors, kept = [], []
        for start, stop in windows:
            try:
                vectors.append(images.window(start, stop))
                kept.append((int(start), int(stop)))
            except VideoError:
                continue  # no person or no motion in this window: not a segment
        if not vectors:
            return kept, None
        points = self.eigenspace.transform(np.asarray(vectors, dtype=np.float32))
        return kept, self.index.search(points, top_k=min(WINDOW_CANDIDATES, self.n_entries))

    def _nearest_motions(self, entry_ids: np.ndarray, distances: np.ndarray) -> list[Match]:
        """The nearest entry of each distinct motion among ``entry_ids`` (nearest
        first; ``NO_ENTRY`` slots at the end are skipped)."""
        nearest: list[Match] = []
        seen: set[int] = set()
        for entry_id, dist in zip(entry_ids.tolist(), distances.tolist(), strict=True):
            if entry_id == NO_ENTRY:
                break
            motion_id = self._motion_of[entry_id]
            if motion_id in seen:
                continue
            seen.add(motion_id)
            nearest.append(self._match(entry_id, dist))
        return nearest

    def _ranked_by_sequence(self, query: np.ndarray, nearest: list[Match]) -> list[Match]:
        """The candidate motions ranked by motion image and silhouette sequence together.

        Parameters
        ----------
        query : (F, p + 1) float32
            The clip's silhouette sequence in pose coordinates
            (:func:`~eigmotion.retrieval.sequences.pose_coordinates` of
            :func:`~eigmotion.retrieval.sequences.sequence_frames`).
        nearest : list of Match
            Each candidate motion's nearest entry, nearest first.

        Returns
        -------
        list of Match
            The same motions, each with its ``sequence_distance`` — to its nearest
            rendering seen from within :data:`~eigmotion.retrieval.sequences.VIEW_REACH_DEG` of
            its entry's view, times what their difference of pace costs
            (:func:`~eigmotion.retrieval.sequences.pace_factors`) — in order of
            :func:`~eigmotion.retrieval.sequences.fused_scores`.
        """
        parts, lengths, speeds, owners = [], [], [], []
        for candidate, match in enumerate(nearest):
            stored, starts, stored_speeds = self._stored_sequences(match.motion_id)
            near = np.flatnonzero(view_reach(stored.azimuth_deg, match.azimuth_deg))
            # The renderings are kept in order of azimuth: those in reach are one run,
            # or two where the reach wraps around 0°.
            for run in np.split(near, np.flatnonzero(np.diff(near) > 1) + 1):
                if run.size:
                    parts.append(stored.frames[starts[run[0]] : starts[run[-1] + 1]])
                    lengths.append(stored.lengths[run])
                    speeds.append(stored_speeds[run])
                    owners.append(np.full(run.size, candidate))
        compared = np.full(len(nearest), np.inf)
        if lengths:
            found = sequence_distances(
                query, np.concatenate(parts), np.concatenate(lengths), workers=worker_threads()
            )
            found *= pace_factors(pose_speeds(query, [len(query)])[0], np.concatenate(speeds))
            np.minimum.at(compared, np.concatenate(owners), found)
        order = np.argsort(
            fused_scores(np.array([m.distance for m in nearest]), np.array(compared)),
            kind="stable",
        )
        return [
            dataclasses.replace(
                nearest[i],
                sequence_distance=float(compared[i]) if np.isfinite(compared[i]) else None,
            )
            for i in order
        ]

    def _stored_sequences(self, motion_id: int):
        """A motion's :class:`~eigmotion.retrieval.store.MotionSequences` with its renderings in
        order of azimuth, the (R + 1,) first frame of each rendering (then the number
        of frames), and their (R,) pose speeds (:func:`~eigmotion.retrieval.sequences.
        pose_speeds`): read from the store once, then kept."""
        found = self._sequences.get(motion_id)
        if found is None:
            stored = self.store.sequences(motion_id)
            order = np.argsort(stored.azimuth_deg, kind="stable")
            ends = np.cumsum(stored.lengths)
            stored = dataclasses.replace(
                stored, azimuth_deg=stored.azimuth_deg[order],
                elevation_deg=stored.elevation_deg[order], lengths=stored.lengths[order],
                frames=np.concatenate(
                    [stored.frames[ends[r] - stored.lengths[r] : ends[r]] for r in order]
                ),
            )  # fmt: skip
            starts = np.concatenate([[0], np.cumsum(stored.lengths)])
            speeds = pose_speeds(stored.frames, stored.lengths)
            found = self._sequences[motion_id] = (stored, starts, speeds)
        return found

    def _most_specific(self, whole: Match, windowed) -> Match:
        """The clip's answer: the whole clip's nearest entry, unless that is filler
        (:data:`FILLER_LABELS`: walking into a turn) and the windows show a specific
        action — at least :data:`MIN_SPECIFIC_WINDOWS` windows whose nearest entry has
        that label, lies within the threshold and is nearer than
        :data:`SPECIFIC_MARGIN` times the window's nearest filler entry (the library's
        walking turns hold walking steps of their own) — then the nearest of those
        window entries."""
        if windowed is None or whole.label not in FILLER_LABELS:
            return whole
        specific: dict[str, list[tuple[float, int]]] = {}
        for ids, dists in zip(windowed.ids, windowed.distances, strict=True):
            labels = [self._label_of(int(i)) for i in ids]
            if labels[0] in FILLER_LABELS or dists[0] > self.threshold:
                continue
            filler = [d for d, label in zip(dists, labels, strict=True) if label in FILLER_LABELS]
            if not filler or dists[0] < SPECIFIC_MARGIN * filler[0]:
                specific.setdefault(labels[0], []).append((float(dists[0]), int(ids[0])))
        shown = [min(found) for found in specific.values() if len(found) >= MIN_SPECIFIC_WINDOWS]
        if not shown:
            return whole
        dist, entry_id = min(shown)
        return self._match(entry_id, dist)

    def _segments(self, kept, windowed, n_frames: int, best: Match) -> list[Segment]:
        """The clip's parts: consecutive windows with the same label
        (:func:`window_label_path`), merged; overlapping windows of different labels
        are split at the midpoint of their overlap.  Where the windows show one action
        throughout, it is the clip's answer, ``best``: the whole clip, ranked by its
        silhouette sequence as well, tells it better than any window."""
        if windowed is None:
            return [Segment(0, n_frames, best.label, best.distance)]
        labels = [[self._label_of(int(i)) for i in ids] for ids in windowed.ids]
        path, costs = window_label_path(
            labels, windowed.distances, SEGMENT_SWITCH_COST * self.threshold
        )
        if len(set(path)) == 1:
            return [Segment(kept[0][0], kept[-1][1], best.label, best.distance)]
        segments: list[Segment] = []
        for (start, stop), label, dist in zip(kept, path, costs.tolist(), strict=True):
            if segments and segments[-1].label == label and start < segments[-1].end_frame:
                last = segments[-1]
                segments[-1] = Segment(last.start_frame, stop, label, min(last.distance, dist))
            else:
                if segments and start < segments[-1].end_frame:
                    last = segments[-1]
                    cut = (start + last.end_frame) // 2
                    segments[-1] = Segment(last.start_frame, cut, last.label, last.distance)
                    start = cut
                segments.append(Segment(start, stop, label, dist))
        return segments

    def query_clip(
        self,
        path: str | os.PathLike,
        background: str | os.PathLike | None = None,
        top_k: int = 3,
        every_frame: bool = False,
        progress: bool = False,
        false_rejection: float | None = None,
    ) -> tuple[QueryResult, ClipMasks]:
        """Answer a clip on disk (video, folder of frames, or .npz of masks).

        Parameters
        ----------
        path : str or PathLike
        background : str or PathLike, optional
            An image of the empty scene.
        top_k : int
        every_frame : bool
            Also cut the person out of every frame, for a frame-by-frame 3D answer, and
            return those silhouettes.  The answer itself always comes from the frames
            the motion image samples (the database's ``sample_fps``), cut out on their
            own: without a background image the empty scene is estimated from the
            frames segmented, and the noise levels are taken over them, so silhouettes
            cut from every frame differ a little; the answer does not depend on
            whether a 3D answer was asked for.
        progress : bool
            Progress bars on stderr while a long video is read.
        false_rejection : float, optional
            As for :meth:`query_masks`.

        Returns
        -------
        result : QueryResult
            Segment frames are frames of the clip.  ``timing_ms["silhouettes"]`` is
            the time the answer's silhouettes took; with ``every_frame``,
            ``timing_ms["every_frame_silhouettes"]`` that of the others.
        clip : ClipMasks
            The silhouettes the answer was computed from; with ``every_frame``, those
            of every frame.
        """
        t0 = time.perf_counter()
        if false_rejection is not None:
            self.threshold_at(false_rejection)  # a bad value is told before the video is read
        config = SilhouetteConfig(work_max_side_px=QUERY_SILHOUETTE_SIDE_PX)
        sample_fps = self.config.motion_image.sample_fps
        clip = load_clip_masks(path, background, config, sample_fps, progress)
        t1 = time.perf_counter()
        result = self.query_masks(clip.masks, clip.fps, top_k, false_rejection)
        # Segments come in mask indices; a mask's successor starts the next segment.
        starts = np.append(clip.frame_indices, clip.n_frames)
        segments = [
            dataclasses.replace(seg, start_frame=int(starts[seg.start_frame]),
                                end_frame=int(starts[seg.end_frame]))
            for seg in result.segments
        ]  # fmt: skip
        timing = {"silhouettes": (t1 - t0) * 1e3, **result.timing_ms}
        if every_frame:
            t2 = time.perf_counter()
            clip = load_clip_masks(path, background, config, progress=progress)
            timing["every_frame_silhouettes"] = (time.perf_counter() - t2) * 1e3
        timing["total"] = (time.perf_counter() - t0) * 1e3
        return dataclasses.replace(result, segments=segments, timing_ms=timing), clip

    # -- indexing ---------------------------------------------------------------------
    def index_motion(self, item: LibraryMotion, progress: bool = True) -> IndexReport:
        """Add a motion to this (writable) database without changing the eigenspace.

        Its motion images are rendered with the stored build configuration and rig,
        projected into the stored eigenspace and inserted under their keys, and its
        silhouette sequences into the stored pose eigenspace, in one transaction; it
        is queryable at once.

        Returns
        -------
        IndexReport
            Including how well the eigenspace represents the new motion.
        """
        if self.store.read_only:
            raise DatabaseError(f"{self.store.uri}: opened read-only; indexing needs writing")
        names = {rec["metadata"].get("name") for rec in self._motions.values()}
        if item.name in names:
            raise InvalidParameterError(
                f"a motion named {item.name!r} is already in the database; choose another name"
            )
        collected = _Collected()
        for view in render_views([item], self.rig, self.config, workers=None, progress=progress):
            collected.add(view, self.rig)
        X, _, body_of, az, el, start, stop, labels = collected.arrays()
        points = self.eigenspace.transform(X).astype(np.float32)
        keys = self.store.quantizer().keys(points)
        error = float(np.median(self.eigenspace.reconstruction_error(X)))
        with self.store.transaction():
            motion_id = _add_motion(self.store, item)
            of_entry = np.full(len(points), motion_id)
            self.store.add_entries(of_entry, points, keys, az, el, start, stop, labels, body_of)
            _add_sequences(self.store, [motion_id], collected.sequences, self.pose_space)
        self._load_index()
        return IndexReport(
            item.name,
            motion_id,
            len(points),
            error,
            self.reconstruction_error_p95,
            error > self.reconstruction_error_p95,
        )

    def stored_library(self) -> list[LibraryMotion]:
        """Every stored motion as a :class:`LibraryMotion` (for a refit rebuild)."""
        out = []
        for mid, rec in sorted(self._motions.items()):
            meta = rec["metadata"]
            out.append(
                LibraryMotion(
                    name=meta.get("name", str(mid)),
                    label=rec["label"],
                    motion=self.motion(mid),
                    source=tuple(Path(s) for s in rec["source"].split(";") if s),
                    performer=meta.get("performer", ""),
                    variation=meta.get("variation", ""),
                    licence="",
                    role=meta.get("role", "basic"),
                    mirror_of=meta.get("mirror_of") or None,
                    action=tuple(meta["action"]) if meta.get("action") else None,
                    filler=meta.get("filler") or None,
                )
            )
        return out


@dataclass(frozen=True)
class IndexReport:
    """What indexing a motion did.

    Attributes
    ----------
    name : str
    motion_id : int
    n_entries : int
        Motion images inserted (views × windows × body shapes).
    reconstruction_error : float
        Median distance of its motion images from the eigenspace.
    reference_error : float
        The 95th percentile of that distance over the images the eigenspace was fitted
        on.
    badly_represented : bool
        ``reconstruction_error > reference_error``: the eigenspace was not made for
        this motion; rebuild with ``refit``.
    """

    name: str
    motion_id: int
    n_entries: int
    reconstruction_error: float
    reference_error: float
    badly_represented: bool


def brute_force_check(db: MotionDatabase, queries: np.ndarray, top_k: int = 1) -> bool:
    """True when the tree's answers equal brute force over every entry."""
    arrays = db.store.arrays()
    exact = BruteForceIndex.from_arrays(arrays.points, arrays.ids).search(queries, top_k)
    tree = db.index.search(queries, top_k)
    return bool(
        np.array_equal(exact.ids, tree.ids) and np.array_equal(exact.distances, tree.distances)
    )
