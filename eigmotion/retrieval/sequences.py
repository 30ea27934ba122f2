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
(:func:`_warper`); both give the same distances to the bit.  A query compares its
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


def _warp_loop(dots, query_norms, frame_norms, starts, band, out):  # pragma: no cover - JIT
    """:func:`_warp` as a loop over the cells, for numba: the same sums in the same
    order (no fast-math), so the same distances to the bit."""
    n = dots.shape[0]
    minus_two = np.float32(-2.0)
    zero = np.float32(0.0)
    for r in range(len(starts) - 1):
        lo, m = starts[r], starts[r + 1] - starts[r]
        previous = np.full(m + 1, np.inf)
        current = np.full(m + 1, np.inf)
        previous[0] = 0.0
        reach = band * max(n, m)
        for i in range(n):
            first, last = 1, m
            if band < 1.0:
                centre = (i + 0.5) * m / n + 0.5
                first = max(1, int(np.ceil(centre - reach)))
                last = min(m, int(np.floor(centre + reach)))
            for j in range(0, first):
                current[j] = np.inf
            for j in range(first, last + 1):
                cost = dots[i, lo + j - 1] * minus_two + query_norms[i]
                cost = np.sqrt(max(cost + frame_norms[lo + j - 1], zero))
                step = min(previous[j], current[j - 1], previous[j - 1])
                current[j] = cost + step
            for j in range(last + 1, m + 1):
                current[j] = np.inf
            previous, current = current, previous
        out[r] = previous[m] / (n + m)


@lru_cache(maxsize=1)
def _compiled_warp_loop():
    """:func:`_warp_loop` compiled (numba's disk cache: a few ms once numba is loaded)."""
    from numba import njit

    return njit(cache=True, nogil=True)(_warp_loop)


def _warper():
    """The time warping to run: numba's compiled loop when numba is already loaded in
    the process (the tree search loads it), as it is then the quicker; else the NumPy
    one, which does not need numba's import and set-up (about 0.45 s of CPU in a new
    process).  The distances are the same to the bit either way."""
    return _compiled_warp_loop() if "numba" in sys.modules else _warp


def _warp(
    dots: np.ndarray, query_norms: np.ndarray, frame_norms: np.ndarray, starts: np.ndarray,
    band: float, out: np.ndarray,
) -> None:  # fmt: skip
    """``out`` (R,): per sequence ``r`` (frames ``starts[r] … starts[r + 1]``), the
    cheapest monotone alignment of the query's frames with its frames, summed frame
    distances over ``n + m``.

    A frame distance is ``sqrt(max(‖a‖² + ‖b‖² − 2 a·b, 0))`` in float32, from
    ``dots`` (n, M) float32 ``a·b`` and the squared norms (n,) and (M,).  Query frame
    ``i`` is aligned only with frames ``j`` (1-based) within ``band · max(n, m)`` of
    ``(i + ½) · m / n + ½``; inf when no path keeps to that band.

    The cumulative costs (float64) are filled one anti-diagonal ``i + j`` at a time,
    for every sequence at once: each cell needs only the two diagonals before its own,
    and gets the same sum, ``cost + min(left, up, diagonal)``, as a loop over the cells.
    """
    n = dots.shape[0]
    lengths = np.diff(starts)
    count, longest = len(lengths), int(lengths.max())
    # (n, M + 1) frame distances, inf outside each sequence's band and in the last column.
    cost = np.empty((n, dots.shape[1] + 1), np.float32)
    np.multiply(dots, np.float32(-2.0), out=cost[:, :-1])
    cost[:, :-1] += query_norms[:, None]
    cost[:, :-1] += frame_norms[None, :]
    np.maximum(cost[:, :-1], np.float32(0.0), out=cost[:, :-1])
    np.sqrt(cost[:, :-1], out=cost[:, :-1])
    cost[:, -1] = np.inf
    if band < 1.0:
        # Per query frame, each sequence's frames [first, last] (1-based) in its band,
        # marked by +1 at its first and −1 after its last frame, summed along the row.
        row = np.arange(n)[:, None]
        m = lengths[None, :]
        centre = (row + 0.5) * m / n + 0.5
        reach = band * np.maximum(n, m)
        first = np.maximum(1, np.ceil(centre - reach)).astype(np.int64)
        last = np.minimum(m, np.floor(centre + reach)).astype(np.int64)
        marks = np.zeros((n, dots.shape[1] + 1), np.int32)
        rows = np.broadcast_to(row, first.shape)
        keep = first <= last
        np.add.at(marks, (rows[keep], (starts[:-1] + first - 1)[keep]), 1)
        np.add.at(marks, (rows[keep], (starts[:-1] + last)[keep]), -1)
        np.copyto(cost, np.float32(np.inf), where=np.cumsum(marks, axis=1) == 0)
    # (n, m_max, R): sequence r's frame j at [:, j, r]; inf beyond its end.
    column = np.arange(longest)[:, None]
    frame = np.where(column < lengths[None, :], starts[None, :-1] + column, dots.shape[1])
    cost = np.take(cost, frame, axis=1)
    # A diagonal's cells by their row i (0 … n), each a row of the R sequences.
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
        Threads to warp the later half of the sequences on (its matrix product
        included) while the calling thread warps the first (BLAS and NumPy release
        the GIL); the distances are the same either way.  Not to be
        called from one of those threads.
    band : float, optional
        Half-width of the band around the diagonal the path keeps to, a share of the
        longer sequence's frames (:data:`WARP_BAND` when not given; 1 or more: none).

    Returns
    -------
    (R,) float64
        Per sequence, the cheapest monotone alignment's summed frame distances
        (Euclidean, computed in float32) over ``n + m``.
    """
    band = float(WARP_BAND if band is None else band)
    if not band > 0.0:
        raise InvalidParameterError(f"band must be > 0, got {band}")
    query = np.ascontiguousarray(query, dtype=np.float32)
    frames = np.ascontiguousarray(frames, dtype=np.float32)
    starts = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    out = np.empty(len(lengths))
    query_norms = np.einsum("ij,ij->i", query, query)
    warper = _warper()

    def warp(first: int, stop: int) -> None:  # sequences [first, stop)
        # ‖a − b‖² = ‖a‖² + ‖b‖² − 2 a·b: one matrix product for every pair of frames
        # (float32: distances of pose coordinates of order 1 come out within about
        # 1e-3); the rest of each frame distance is taken inside the warp, as needed.
        part = frames[starts[first] : starts[stop]]
        dots = query @ part.T
        norms = np.einsum("ij,ij->i", part, part)
        bounds = starts[first : stop + 1] - starts[first]
        warper(dots, query_norms, norms, bounds, band, out[first:stop])

    # Always the same two halves, whether or not the later one runs on a worker: the
    # distances do not depend on the threads.
    half = int(np.searchsorted(starts, starts[-1] / 2.0))
    if not 0 < half < len(lengths):
        warp(0, len(lengths))
    elif workers is None:
        warp(0, half)
        warp(half, len(lengths))
    else:
        later = workers.submit(warp, half, len(lengths))
        warp(0, half)
        later.result()
    return out


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
    x = np.array(frames, dtype=np.float64)
    lengths = np.asarray(lengths, dtype=np.int64)
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
