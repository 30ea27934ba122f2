"""Silhouette sequences: a clip's poses in order, compared by dynamic time warping.

A motion image sums a clip's frame differences into one picture; which pose came
before which is mostly gone.  On people the database has never seen, that order
carries what the after-image loses (``docs/accuracy.md``): the two err on different
clips, and together they name more clips right than either alone.  So every rendering
of a whole basic motion (one body, one view) also keeps its silhouettes as a sequence,
and a query's candidate motions — those whose entries the B-tree search returned — are
ranked again by both distances (:func:`fused_scores`)::

    masks (F, H, W) ──sample at the motion image's sample_fps──▶ (F', H, W)
        ──align in the motion image's frame (the person frame) at SEQUENCE_SIZE px──▶
          (F'', SEQUENCE_SIZE, SEQUENCE_SIZE) in [0, 1]
        ──rows below the body centre × LOWER_BODY_WEIGHT, and the rise of the top
          of the body beside them──▶ (F'', SEQUENCE_SIZE² + 1)   (sequence_frames)
        ──the silhouettes into the pose eigenspace (PCA of every database frame,
          POSE_COMPONENTS axes), the rise × RISE_WEIGHT beside them──▶
          (F'', POSE_COMPONENTS + 1) float32                  (pose_coordinates)

Two sequences are compared by dynamic time warping (:func:`sequence_distances`): the
cheapest monotone alignment of their frames, each step costing the Euclidean distance
of two frames' pose coordinates, summed over the path and divided by the two lengths,
so the pace of a performance does not count against it.  The path keeps to a band
around the diagonal, :data:`WARP_BAND` of the longer sequence wide on each side (a
Sakoe–Chiba band): on the holdout clips it answers as well as a free path, for less
work.  The warping is NumPy over the anti-diagonals of every compared sequence at once
(:func:`_warp`), or numba's compiled loop once numba is loaded in the process anyway
(:func:`_warper`); both give the same distances to the bit.  A query needs only each
candidate motion's least distance over its renderings
(:func:`nearest_sequence_distances`): a rendering whose lower bound
(:func:`_lower_bounds`: every path passes each row and each column of the frame
distances, so it costs at least the sum of their cheapest cells; exact in floating
point) is not below its candidate's least distance so far is not warped, the least
distances staying the same to the bit.  A query compares its
sequence only with the renderings of each candidate motion seen from within
:data:`VIEW_REACH_DEG` of azimuth of the view the motion's nearest entry came from: the
motion image already found the viewing direction.

Time warping forgives any difference of pace, so a jog matches a walk as well as a
run.  Each sequence's pose speed (:func:`pose_speeds`: the mean step between its
frames, smoothed over time) keeps some of it: a rendering's distance is multiplied by
:func:`pace_factors`, which grows with the ratio of the clip's pose speed to the
rendering's.

The lower half of each aligned frame — below the body centre, the legs — counts
:data:`LOWER_BODY_WEIGHT` of the upper: skirts, coats and loose trousers reshape the
legs' silhouette far more than any garment does the arms', and what tells most
actions apart (a wave, a punch, covering the head, sitting down) is the upper body.

Aligning every frame on its body centre takes away how high the body is: a jump, a
crouch and a sit-down keep their shapes but lose their rise and fall.  So each frame
also carries the rise of the top of the body
(:meth:`~eigmotion.retrieval.motion_image.ClipMotionImages.rise`, in body heights), weighted by
:data:`RISE_WEIGHT`, beside its pose coordinates.

The constants below were chosen on the holdout benchmark's folds
(``docs/accuracy.md``: "Silhouette sequences in the query", "holdout — legs weighed
less, every label ranked", "holdout — the rise of the body in the sequences" and
"holdout — pace in the silhouette sequences", the last three checked on clips of
another seed).
"""

from __future__ import annotations

import sys
from concurrent.futures import Executor
from functools import lru_cache

import cv2
import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.retrieval.eigenspace import Eigenspace
from eigmotion.retrieval.motion_image import ClipMotionImages

#: Side of the person-frame silhouettes of a sequence, pixels.
SEQUENCE_SIZE = 16
#: Axes of the pose eigenspace the sequences are stored in.
POSE_COMPONENTS = 48
#: A candidate motion is compared with its renderings whose camera azimuth lies within
#: this many degrees of the view of its nearest entry, degrees.
VIEW_REACH_DEG = 60.0
#: Weight of the rows below the body centre (the lower half of each aligned frame)
#: against those above, in the sequences' frames.
LOWER_BODY_WEIGHT = 0.25
#: Weight of a frame's rise of the top of the body (in body heights) beside its pose
#: coordinates.
RISE_WEIGHT = 8.0
#: Weight of a difference of pace: a rendering's sequence distance is multiplied by
#: ``1 + PACE_WEIGHT · |ln((s_q + PACE_FLOOR) / (s_r + PACE_FLOOR))|`` (:func:`pace_factors`).
PACE_WEIGHT = 1.0
#: Added to both pose speeds before their ratio is taken, pose-coordinate units per
#: frame: the speed of a clip's still body is mostly the jitter of its silhouettes,
#: which this keeps from counting as pace.
PACE_FLOOR = 0.4
#: Passes of the [1, 2, 1] / 4 filter over time before a sequence's pose speed is taken.
PACE_SMOOTHING_PASSES = 2
#: Weight of the sequence distance in :func:`fused_scores`.
SEQUENCE_WEIGHT = 2.0
#: Distinct motions of the whole clip's nearest entries that are ranked again (and
#: beyond them the nearest motion of each further label,
#: :func:`eigmotion.retrieval.database.candidate_motions`).
CANDIDATE_MOTIONS = 20
#: Half-width of the band around the diagonal that the time warping's path keeps to,
#: as a share of the longer sequence's frames (Sakoe–Chiba); 1 or more: no band.
WARP_BAND = 0.3


def widen_frames(stored: np.ndarray, out: np.ndarray) -> None:
    """``out[...] = stored``: (n, d) float16 frames as stored, written into the (n, d)
    C-contiguous float32 ``out``.

    OpenCV converts with the CPU's half-precision instructions, about three times
    NumPy's ``astype`` (which converts value by value); every finite float16 is a
    float32, so the values are the same to the bit (stored frames are finite:
    :func:`~eigmotion.retrieval.schema.checked_sequences`).
    """
    if len(stored):
        cv2.multiply(stored, 1.0, dst=out, dtype=cv2.CV_32F)


def sequence_frames(images: ClipMotionImages) -> np.ndarray:
    """A clip's silhouettes as a sequence of aligned frames.

    Parameters
    ----------
    images : ClipMotionImages
        The clip as the motion image sees it (the database's configuration and the
        clip's frame rate): the same sampled frames, aligned in the same frame (body
        centre on the square's centre), at :data:`SEQUENCE_SIZE` pixels.

    Returns
    -------
    (F'', SEQUENCE_SIZE**2 + 1) float32
        Per frame, the aligned silhouette row-major in [0, 1], the rows from
        ``SEQUENCE_SIZE // 2`` down (below the body centre) multiplied by
        :data:`LOWER_BODY_WEIGHT`; then the rise of the top of the body, body heights
        (:meth:`~eigmotion.retrieval.motion_image.ClipMotionImages.rise`).  Frames without a
        person are left out.

    Raises
    ------
    VideoError
        No person in enough frames.
    """
    aligned = images.aligned(SEQUENCE_SIZE)
    aligned[:, SEQUENCE_SIZE // 2 :] *= LOWER_BODY_WEIGHT
    return np.concatenate(
        [aligned.reshape(len(aligned), -1), images.rise()[:, None]], axis=1, dtype=np.float32
    )


def pose_coordinates(pose_space: Eigenspace, frames: np.ndarray) -> np.ndarray:
    """A sequence's frames as dynamic time warping compares them.

    Parameters
    ----------
    pose_space : Eigenspace
        The pose eigenspace (:func:`fit_pose_space`), p axes.
    frames : (F, SEQUENCE_SIZE**2 + 1) float
        From :func:`sequence_frames`.

    Returns
    -------
    (F, p + 1) float32
        The silhouettes' pose coordinates, then the rise × :data:`RISE_WEIGHT`.
    """
    frames = np.asarray(frames, dtype=np.float32)
    silhouettes = pose_space.transform(frames[:, : SEQUENCE_SIZE**2])
    return np.concatenate(
        [silhouettes, RISE_WEIGHT * frames[:, SEQUENCE_SIZE**2 :]], axis=1, dtype=np.float32
    )


def _warp_loop(cost, lengths, out):  # pragma: no cover - JIT
    """:func:`_warp` as a loop over the cells, for numba: the same sums in the same
    order (no fast-math), so the same distances to the bit.  ``cost`` is ``_warp``'s
    laid out (R, n, m_max)."""
    n = cost.shape[1]
    for r in range(cost.shape[0]):
        m = lengths[r]
        previous = np.full(m + 1, np.inf)
        current = np.full(m + 1, np.inf)
        previous[0] = 0.0
        for i in range(n):
            current[0] = np.inf
            for j in range(1, m + 1):
                step = min(previous[j], current[j - 1], previous[j - 1])
                current[j] = cost[r, i, j - 1] + step
            previous, current = current, previous
        out[r] = previous[m] / (n + m)


@lru_cache(maxsize=1)
def _compiled_warp_loop():
    """:func:`_warp_loop` compiled (numba's disk cache: a few ms once numba is loaded)."""
    from numba import njit

    return njit(cache=True, nogil=True)(_warp_loop)


def _warp_with_loop(cost: np.ndarray, lengths: np.ndarray, out: np.ndarray) -> None:
    """:func:`_warp` by numba's compiled loop over the cells."""
    _compiled_warp_loop()(np.ascontiguousarray(cost.transpose(2, 0, 1)), lengths, out)


def _warper():
    """The time warping to run: numba's compiled loop when numba is already loaded in
    the process (the tree search loads it), as it is then the quicker; else the NumPy
    one, which does not need numba's import and set-up (about 0.45 s of CPU in a new
    process).  The distances are the same to the bit either way."""
    return _warp_with_loop if "numba" in sys.modules else _warp


def _frame_distances(
    query: np.ndarray, frames: np.ndarray, starts: np.ndarray, workers: Executor | None
) -> np.ndarray:
    """(n, M) float32: the Euclidean distance of every query frame to every frame,
    ``sqrt(max(‖a‖² + ‖b‖² − 2 a·b, 0))`` in float32.

    ``‖a − b‖² = ‖a‖² + ‖b‖² − 2 a·b``: one matrix product for every pair of frames
    (float32: distances of pose coordinates of order 1 come out within about 1e-3).
    Always the same two products, the frames up to the sequence boundary nearest half
    of them and the rest (the later one on ``workers`` when given): how a product's
    sums are grouped can change its last bit, so the distances do not depend on the
    threads or on which sequences are warped afterwards.
    """
    cost = np.empty((len(query), len(frames)), np.float32)
    query_norms = np.einsum("ij,ij->i", query, query)

    def fill(lo: int, hi: int) -> None:  # frames [lo, hi)
        part = frames[lo:hi]
        out = cost[:, lo:hi]
        np.multiply(query @ part.T, np.float32(-2.0), out=out)
        out += query_norms[:, None]
        out += np.einsum("ij,ij->i", part, part)[None, :]
        np.maximum(out, np.float32(0.0), out=out)
        np.sqrt(out, out=out)

    count = len(starts) - 1
    half = int(np.searchsorted(starts, starts[-1] / 2.0))
    if not 0 < half < count:
        fill(0, len(frames))
    elif workers is None:
        fill(0, int(starts[half]))
        fill(int(starts[half]), len(frames))
    else:
        later = workers.submit(fill, int(starts[half]), len(frames))
        fill(0, int(starts[half]))
        later.result()
    return cost


def _banded_costs(cost: np.ndarray, starts: np.ndarray, band: float) -> np.ndarray:
    """(n, m_max, R) float32: sequence ``r``'s frame distances (from
    :func:`_frame_distances`) at ``[:, j, r]``, inf where the path may not go.

    Query frame ``i`` is aligned only with frames ``j`` (1-based) within ``band ·
    max(n, m)`` of ``(i + ½) · m / n + ½``; beyond a sequence's end, inf too.
    """
    n = cost.shape[0]
    lengths = np.diff(starts)
    column = np.arange(int(lengths.max()))[:, None]  # j − 1
    frame = np.minimum(starts[None, :-1] + column, cost.shape[1] - 1)
    out = np.take(cost, frame, axis=1)
    if band < 1.0:
        row = np.arange(n)[:, None]
        m = lengths[None, :]
        centre = (row + 0.5) * m / n + 0.5
        reach = band * np.maximum(n, m)
        first = np.maximum(1, np.ceil(centre - reach)).astype(np.int64)
        last = np.minimum(m, np.floor(centre + reach)).astype(np.int64)
        j = column[None] + 1
        # last <= m: a frame beyond the sequence's end is beyond its band's end too
        outside = (j < first[:, None, :]) | (j > last[:, None, :])
    else:
        beyond = column >= lengths[None, :]  # (m_max, R)
        outside = np.broadcast_to(beyond[None], out.shape)
    np.copyto(out, np.float32(np.inf), where=outside)
    return out


def _warp(cost: np.ndarray, lengths: np.ndarray, out: np.ndarray) -> None:
    """``out`` (R,): per sequence ``r``, the cheapest monotone alignment of the query's
    n frames with its ``lengths[r]`` frames, summed frame distances over ``n + m``.

    ``cost`` (n, m_max, R) float32 are the frame distances, inf where the path may not
    go (:func:`_banded_costs`); inf when no path keeps to the band.  The cumulative
    costs (float64) are filled one anti-diagonal ``i + j`` at a time, for every
    sequence at once: each cell needs only the two diagonals before its own, and gets
    the same sum, ``cost + min(left, up, diagonal)``, as a loop over the cells.
    """
    n, longest, count = cost.shape
    before = np.full((n + 1, count), np.inf)  # diagonal d − 2
    before[0] = 0.0  # the path's start, cell (0, 0)
    last_diagonal = np.full((n + 1, count), np.inf)  # diagonal d − 1
    ends = n + lengths  # the diagonal of each sequence's last cell (n, m)
    for diagonal in range(2, n + longest + 1):
        lo, hi = max(1, diagonal - longest), min(n, diagonal - 1)
        rows = np.arange(lo, hi + 1)
        current = np.full((n + 1, count), np.inf)
        step = np.minimum(last_diagonal[lo - 1 : hi], last_diagonal[lo : hi + 1])
        np.minimum(step, before[lo - 1 : hi], out=step)
        np.add(cost[rows - 1, diagonal - rows - 1], step, out=current[lo : hi + 1])
        done = ends == diagonal
        if done.any():
            out[done] = current[n, done] / ends[done]
        before, last_diagonal = last_diagonal, current


def _lower_bounds(cost: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """(R,) float64: per sequence, a bound its :func:`_warp` distance is never below,
    to the last bit.

    A path passes through every query frame (row) and every frame of the sequence
    (column), in order: its sum is at least the sum of each row's cheapest cell in
    the band, and at least that of each column's.  Both are summed in float64 in
    row (column) order, as the path's sum is, and rounding is monotone, so each
    partial sum of the path is at least the bound's: the bound holds in floating
    point too.  ``cost`` as for :func:`_warp`.
    """
    n, longest, _ = cost.shape
    by_rows = np.add.accumulate(cost.min(axis=1), axis=0, dtype=np.float64)[-1]
    columns = cost.min(axis=0).astype(np.float64)  # (m_max, R)
    columns[np.arange(longest)[:, None] >= lengths[None, :]] = 0.0  # beyond the end
    by_columns = np.add.accumulate(columns, axis=0)[-1]
    return np.maximum(by_rows, by_columns) / (n + lengths)


def _warp_some(
    cost: np.ndarray, lengths: np.ndarray, which: np.ndarray, workers: Executor | None
) -> np.ndarray:
    """(len(which),) float64: :func:`_warp` of the sequences ``which`` of ``cost``,
    half of them on ``workers`` when given and there are enough to pay for a thread."""
    out = np.empty(len(which))
    if not len(which):
        return out
    warper = _warper()

    def warp(lo: int, hi: int) -> None:
        chosen = which[lo:hi]
        longest = int(lengths[chosen].max())
        warper(cost[:, :longest, chosen], lengths[chosen], out[lo:hi])

    half = len(which) // 2
    if workers is None or half < _THREADED_WARP_MIN:
        warp(0, len(which))
    else:
        later = workers.submit(warp, half, len(which))
        warp(0, half)
        later.result()
    return out


#: Fewest sequences per thread for :func:`_warp_some` to split its work over two
#: threads: below it, one thread's interpreter overhead costs more than the split saves.
_THREADED_WARP_MIN = 64


def _checked_band(band: float | None) -> float:
    band = float(WARP_BAND if band is None else band)
    if not band > 0.0:
        raise InvalidParameterError(f"band must be > 0, got {band}")
    return band


def sequence_distances(
    query: np.ndarray,
    frames: np.ndarray,
    lengths: np.ndarray,
    workers: Executor | None = None,
    band: float | None = None,
) -> np.ndarray:
    """Dynamic time warping of one sequence against several.

    Parameters
    ----------
    query : (n, d) float
        The query's frames (pose coordinates).
    frames : (M, d) float
        The frames of every sequence compared with, one after the other.
    lengths : (R,) int
        Frames of each of those R sequences, summing to ``M``; each >= 1.
    workers : Executor, optional
        Threads to share the work with (BLAS and NumPy release the GIL); the
        distances are the same either way.  Not to be called from one of those threads.
    band : float, optional
        Half-width of the band around the diagonal the path keeps to, a share of the
        longer sequence's frames (:data:`WARP_BAND` when not given; 1 or more: none).

    Returns
    -------
    (R,) float64
        Per sequence, the cheapest monotone alignment's summed frame distances
        (Euclidean, computed in float32) over ``n + m``.
    """
    band = _checked_band(band)
    query = np.ascontiguousarray(query, dtype=np.float32)
    frames = np.ascontiguousarray(frames, dtype=np.float32)
    lengths = np.asarray(lengths, dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    cost = _banded_costs(_frame_distances(query, frames, starts, workers), starts, band)
    return _warp_some(cost, lengths, np.arange(len(lengths)), workers)


def nearest_sequence_distances(
    query: np.ndarray,
    frames: np.ndarray,
    lengths: np.ndarray,
    owners: np.ndarray,
    factors: np.ndarray,
    n_owners: int,
    workers: Executor | None = None,
    band: float | None = None,
) -> np.ndarray:
    """Per owner, the least of its sequences' :func:`sequence_distances` times their
    factors, to the bit, without warping the sequences that cannot be it.

    Each sequence's distance has a lower bound (:func:`_lower_bounds`, from the same
    frame distances, exact in floating point).  Each owner's sequence of least bound
    is warped first; then only those whose bound (times their factor) lies below
    their owner's least distance so far.  The rest could not have been the least.

    Parameters
    ----------
    query, frames, lengths, workers, band
        As for :func:`sequence_distances`.
    owners : (R,) int
        Owner of each sequence, in ``[0, n_owners)``.
    factors : (R,) float
        What each sequence's distance is multiplied by (> 0; :func:`pace_factors`).
    n_owners : int

    Returns
    -------
    (n_owners,) float64
        ``np.minimum.at(inf, owners, sequence_distances(...) * factors)``: inf for an
        owner without sequences (or with no path within the band).
    """
    band = _checked_band(band)
    nearest = np.full(n_owners, np.inf)
    if not len(lengths):
        return nearest
    query = np.ascontiguousarray(query, dtype=np.float32)
    frames = np.ascontiguousarray(frames, dtype=np.float32)
    lengths = np.asarray(lengths, dtype=np.int64)
    owners = np.asarray(owners, dtype=np.int64)
    factors = np.asarray(factors, dtype=np.float64)
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    cost = _banded_costs(_frame_distances(query, frames, starts, workers), starts, band)
    bounds = _lower_bounds(cost, lengths) * factors
    by_owner = np.lexsort((bounds, owners))  # each owner's, least bound first
    first = np.ones(len(by_owner), dtype=bool)
    first[1:] = owners[by_owner[1:]] != owners[by_owner[:-1]]
    for which in (by_owner[first], None):
        if which is None:  # the rest, unless their bound already rules them out
            rest = by_owner[~first]
            which = np.sort(rest[bounds[rest] < nearest[owners[rest]]])
        found = _warp_some(cost, lengths, which, workers)
        found *= factors[which]
        np.minimum.at(nearest, owners[which], found)
    return nearest


def pose_speeds(frames: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """How fast each sequence's pose changes: the mean step between its frames.

    Each sequence is first smoothed over time (:data:`PACE_SMOOTHING_PASSES` passes of
    the [1, 2, 1] / 4 filter; its first and last frames are kept), which takes out most
    of the frame-to-frame jitter of silhouettes cut out of a video.

    Parameters
    ----------
    frames : (M, d) float
        The frames of R sequences (pose coordinates, :func:`pose_coordinates`), one
        sequence after the other.
    lengths : (R,) int
        Frames of each sequence, summing to ``M``; each >= 1.

    Returns
    -------
    (R,) float64
        Mean Euclidean distance between consecutive smoothed frames, pose-coordinate
        units per frame (at the motion image's ``sample_fps``); 0 for a single frame.
    """
    frames = np.asarray(frames)
    lengths = np.asarray(lengths, dtype=np.int64)
    if not len(lengths):
        return np.empty(0)
    stops = np.cumsum(lengths)
    # Blocks of whole sequences, about SPEED_BLOCK_FRAMES frames each: each sequence's
    # speed is its own frames' alone, and a block's arrays stay in the CPU's cache.
    cuts = np.searchsorted(stops, np.arange(SPEED_BLOCK_FRAMES, stops[-1], SPEED_BLOCK_FRAMES))
    bounds = np.unique(np.concatenate([[0], cuts + 1, [len(lengths)]]))
    bounds = bounds[bounds <= len(lengths)]
    speeds = np.empty(len(lengths))
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        first = stops[lo] - lengths[lo]
        speeds[lo:hi] = _block_pose_speeds(frames[first : stops[hi - 1]], lengths[lo:hi])
    return speeds


#: Frames smoothed at a time by :func:`pose_speeds` (whole sequences of them).
SPEED_BLOCK_FRAMES = 1024


def _block_pose_speeds(frames: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """:func:`pose_speeds` of sequences held in one block of frames."""
    x = np.array(frames, dtype=np.float64)
    stops = np.cumsum(lengths)
    ends = np.zeros(len(x), dtype=bool)  # each sequence's first and last frame
    ends[stops - 1] = True
    ends[stops - lengths] = True
    kept = x[ends]
    for _ in range(PACE_SMOOTHING_PASSES):
        x[1:-1] = 0.25 * x[:-2] + 0.5 * x[1:-1] + 0.25 * x[2:]
        x[ends] = kept  # the filter never reaches across two sequences
    step = np.diff(x, axis=0)
    steps = np.sqrt(np.einsum("ij,ij->i", step, step))
    within = np.ones(len(steps), dtype=bool)
    within[stops[:-1] - 1] = False  # the step from one sequence into the next
    owner = np.repeat(np.arange(len(lengths)), lengths)[:-1]
    totals = np.bincount(owner[within], weights=steps[within], minlength=len(lengths))
    return totals / np.maximum(lengths - 1, 1)


def pace_factors(query_speed: float, speeds: np.ndarray) -> np.ndarray:
    """What a difference of pace multiplies each sequence distance by.

    Dynamic time warping forgives any difference of pace, so a jog matches a walk,
    and a quick hop the slow sway of a wave, as well as a motion of their own.  The
    pose speed (:func:`pose_speeds`) keeps some of it: ``1 + PACE_WEIGHT ·
    |ln((query_speed + PACE_FLOOR) / (speed + PACE_FLOOR))|``, 1 for the same pace.

    Parameters
    ----------
    query_speed : float
        The query's pose speed, pose-coordinate units per frame.
    speeds : (R,) float
        The pose speed of each rendering compared with.

    Returns
    -------
    (R,) float64
        Each >= 1.
    """
    speeds = np.asarray(speeds, dtype=np.float64)
    ratio = (float(query_speed) + PACE_FLOOR) / (speeds + PACE_FLOOR)
    return 1.0 + PACE_WEIGHT * np.abs(np.log(ratio))


def fit_pose_space(frames: np.ndarray) -> Eigenspace:
    """The pose eigenspace: :data:`POSE_COMPONENTS` axes of the PCA of the frames'
    silhouettes (every non-degenerate axis when there are fewer).

    Parameters
    ----------
    frames : (N, SEQUENCE_SIZE**2 + 1) float
        The frames of every rendering's sequence (:func:`sequence_frames`), N >= 2;
        the rise does not enter the eigenspace.
    """
    silhouettes = np.asarray(frames)[:, : SEQUENCE_SIZE**2]
    try:
        return Eigenspace(POSE_COMPONENTS).fit(silhouettes)
    except InvalidParameterError:
        if len(silhouettes) < 2:
            raise
        return Eigenspace(None, explained_variance=1.0).fit(silhouettes)


def view_reach(azimuth_deg: np.ndarray, centre_deg: float) -> np.ndarray:
    """(R,) bool: which azimuths lie within :data:`VIEW_REACH_DEG` of ``centre_deg``
    (degrees, around the circle)."""
    offset = (np.asarray(azimuth_deg, dtype=np.float64) - centre_deg + 180.0) % 360.0 - 180.0
    return np.abs(offset) <= VIEW_REACH_DEG + 1e-9


def fused_scores(image_distances: np.ndarray, sequence_distances: np.ndarray) -> np.ndarray:
    """One score per candidate motion from its two distances; smaller is nearer.

    Each distance is divided by the smallest of its kind among the candidates, so the
    two count alike whatever their units; the sequence's is weighted by
    :data:`SEQUENCE_WEIGHT`.

    Parameters
    ----------
    image_distances : (M,) float
        Eigenspace distance of each motion's nearest entry.
    sequence_distances : (M,) float
        Its silhouette sequence distance (inf where none was compared).

    Returns
    -------
    (M,) float64
        inf for a motion without a sequence distance.
    """
    image = np.asarray(image_distances, dtype=np.float64)
    sequence = np.asarray(sequence_distances, dtype=np.float64)
    finite = sequence[np.isfinite(sequence)]
    tiny = np.finfo(np.float64).tiny
    image_scale = max(float(image.min()), tiny) if image.size else 1.0
    sequence_scale = max(float(finite.min()), tiny) if finite.size else 1.0
    return image / image_scale + SEQUENCE_WEIGHT * sequence / sequence_scale
