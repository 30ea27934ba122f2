"""What the two exact nearest-neighbour searches share.

:class:`~eigmotion.retrieval.search.TreeIndex` (the key tree) and
:class:`~eigmotion.retrieval.brute_force.BruteForceIndex` (the reference) answer with the
same :class:`NearestEntries`, check their arguments alike, keep each query's running
best in a :class:`RunningBest`, and measure every distance with the one compiled
function here (:func:`pair_sq_distances`, the coordinates' squared differences summed
in order in float32), so that equal pairs give bit-identical distances and the tree's
answers equal brute force's bit for bit.  The compiled loops here (numba, compiled on
first use) are the shared distance and the running best's insertion; the tree's walk
(:mod:`eigmotion.retrieval.walk`) calls their compiled forms.
"""

from __future__ import annotations

import sys
import threading
from dataclasses import dataclass
from functools import lru_cache
from numbers import Integral, Real
from types import SimpleNamespace

import numpy as np

from eigmotion.errors import InvalidParameterError


@dataclass(frozen=True)
class NearestEntries:
    """Nearest entries of a batch of queries.

    Attributes
    ----------
    ids : (Q, top_k) int64
        Entry ids, nearest first; equal distances in increasing id order;
        ``NO_ENTRY`` (-1) in slots left empty by ``max_distance``.
    distances : (Q, top_k) float64
        Euclidean distances (not squared) in eigen-coordinate units; inf in empty
        slots.
    examined : (Q,) int64
        Entries the query was compared with: their distance summed, or (in the key
        tree) an estimate of it that showed they could not enter the k best.
    """

    ids: np.ndarray
    distances: np.ndarray
    examined: np.ndarray


# -- shared arithmetic -------------------------------------------------------------


def pair_sq_distances(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Squared distances of row pairs, (m, k) and (m, k) or (k,) float32 → (m,) float32.

    The single distance formula of the searches: brute force and the tree both use it
    (:func:`_row_sq_distance`, the coordinates' squared differences summed in order in
    float32), so equal pairs give bit-identical distances.
    """
    points = np.ascontiguousarray(points, dtype=np.float32)
    queries = np.ascontiguousarray(np.atleast_2d(queries), dtype=np.float32)
    if "numba" not in sys.modules:  # no compiler to load: NumPy, the same sums
        return sq_distances_in_order(points.T, queries.T)
    out = np.empty(points.shape[0], np.float32)
    kernels().pair_sq_distances(points, queries, out)
    return out


def sq_distances_in_order(point_axes: np.ndarray, query_axes: np.ndarray) -> np.ndarray:
    """:func:`_row_sq_distance` in NumPy, axis by axis over many rows at once.

    Parameters
    ----------
    point_axes : (k, m) float32
        Points by coordinate (a transposed (m, k) array, or its contiguous copy).
    query_axes : (k, m) or (k, 1) float32
        The queries by coordinate, one per point or one for all.

    Returns
    -------
    (m,) float32
        ``Σ_a (p_a − h_a)²`` summed in order in float32, term by term the compiled
        loop's sum (no fused multiply-add in either), so bit-identical to it.
    """
    total = np.zeros(point_axes.shape[1], dtype=np.float32)
    diff = np.empty_like(total)
    for a in range(point_axes.shape[0]):
        np.subtract(point_axes[a], query_axes[a], out=diff)
        np.multiply(diff, diff, out=diff)
        total += diff
    return total


def _row_sq_distance(point, query):  # pragma: no cover - JIT
    """``Σ_a (point_a − query_a)²`` of two (k,) float32 rows, summed in order in float32."""
    total = np.float32(0.0)
    for a in range(point.shape[0]):
        d = point[a] - query[a]
        total += d * d
    return total


def _pair_sq_distances_kernel(points, queries, out):  # pragma: no cover - JIT
    """``out`` (m,) float32: :func:`_row_sq_distance` of each row of ``points`` (m, k)
    to the same row of ``queries`` (m, k), or to its one row (1, k)."""
    one = queries.shape[0] == 1
    for i in range(points.shape[0]):
        out[i] = _row_sq_distance(points[i], queries[0] if one else queries[i])


def _offer(sq, entry_id, sq_row, id_row):  # pragma: no cover - JIT
    """Put (``sq``, ``entry_id``) into the sorted best (k,) rows if it is smaller than
    the k-th best (by distance, then id), dropping the k-th."""
    last = sq_row.shape[0] - 1
    if sq > sq_row[last] or (sq == sq_row[last] and entry_id >= id_row[last]):
        return
    i = last
    while i > 0 and (sq < sq_row[i - 1] or (sq == sq_row[i - 1] and entry_id < id_row[i - 1])):
        sq_row[i], id_row[i] = sq_row[i - 1], id_row[i - 1]
        i -= 1
    sq_row[i], id_row[i] = sq, entry_id


_COMPILING = threading.Lock()


def kernels():
    """The compiled loops (numba is imported and they are compiled on first use, once,
    whichever thread asks first)."""
    with _COMPILING:
        return _compiled_kernels()


@lru_cache(maxsize=1)
def _compiled_kernels():
    """The row helpers are compiled first and put in place of their Python sources, so
    the kernels calling them find compiled functions.  No fast-math: every sum is
    taken in order, the same in brute force and in the tree's walk
    (:mod:`eigmotion.retrieval.walk`, which calls ``row_sq_distance`` and ``offer``)."""
    from numba import njit

    global _row_sq_distance, _offer
    jit = njit(cache=True, nogil=True)
    _row_sq_distance = jit(_row_sq_distance)
    _offer = jit(_offer)
    return SimpleNamespace(
        pair_sq_distances=jit(_pair_sq_distances_kernel),
        row_sq_distance=_row_sq_distance,
        offer=_offer,
    )


def check_points(points, name: str = "points") -> np.ndarray:
    p = np.asarray(points)
    if p.ndim != 2 or p.shape[1] < 1:
        raise InvalidParameterError(f"{name} must be 2-D (N, k), got shape {p.shape}")
    if not np.issubdtype(p.dtype, np.floating):
        raise InvalidParameterError(f"{name} must be floating point, got dtype {p.dtype}")
    p = np.ascontiguousarray(p, dtype=np.float32)
    if not np.all(np.isfinite(p)):
        row = int(np.flatnonzero(~np.all(np.isfinite(p), axis=1))[0])
        raise InvalidParameterError(f"{name} row {row} holds NaN or infinity (as float32)")
    return p


def check_ids(ids, n: int) -> np.ndarray:
    i = np.asarray(ids)
    if i.shape != (n,) or (n and not np.issubdtype(i.dtype, np.integer)):
        raise InvalidParameterError(f"ids must be ({n},) integers, got {i.dtype} {i.shape}")
    i = i.astype(np.int64)
    if n and (i.min() < 0 or i.max() == np.iinfo(np.int64).max):
        raise InvalidParameterError("ids must lie in 0 … 2**63 − 2 (-1 marks an empty slot)")
    if n > 1 and not np.all(i[1:] > i[:-1]):
        ordered = np.sort(i)
        same = np.flatnonzero(ordered[1:] == ordered[:-1])
        if same.size:
            raise InvalidParameterError(f"ids must be unique; {int(ordered[same[0]])} repeats")
    return i


def check_queries(queries, n_dims: int) -> np.ndarray:
    if (
        type(queries) is np.ndarray
        and queries.dtype == np.float32
        and queries.shape[-1:] == (n_dims,)
        and queries.ndim <= 2
        and queries.flags.c_contiguous
        and np.isfinite(queries).all()
    ):  # the common case, checked quickly: one query costs little
        return queries if queries.ndim == 2 else queries[None, :]
    q = np.asarray(queries)
    if q.ndim == 1:
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != n_dims:
        raise InvalidParameterError(
            f"queries must be ({n_dims},) or (Q, {n_dims}), got shape {np.shape(queries)}"
        )
    if not (np.issubdtype(q.dtype, np.floating) or np.issubdtype(q.dtype, np.integer)):
        raise InvalidParameterError(f"queries must be real numbers, got dtype {q.dtype}")
    q = np.ascontiguousarray(q, dtype=np.float32)
    if not np.all(np.isfinite(q)):
        row = int(np.flatnonzero(~np.all(np.isfinite(q), axis=1))[0])
        raise InvalidParameterError(f"query {row} holds NaN or infinity (as float32)")
    return q


def check_max_distance(max_distance) -> float:
    """The squared cutoff of a ``max_distance`` parameter (>= 0, may be inf)."""
    if isinstance(max_distance, bool) or not isinstance(max_distance, Real):
        raise InvalidParameterError(f"max_distance must be a number, got {max_distance!r}")
    if not float(max_distance) >= 0.0:
        raise InvalidParameterError(f"max_distance must be >= 0, got {max_distance!r}")
    return float(max_distance) ** 2


def check_top_k(top_k, n_entries: int) -> int:
    if isinstance(top_k, bool) or not isinstance(top_k, Integral) or top_k < 1:
        raise InvalidParameterError(f"top_k must be a positive integer, got {top_k!r}")
    if top_k > n_entries:
        raise InvalidParameterError(f"top_k={top_k} exceeds the {n_entries} entries")
    return int(top_k)


#: Id of an empty slot in a result (fewer than top_k entries within max_distance).
NO_ENTRY = -1

SENTINEL = np.iinfo(np.int64).max


class RunningBest:
    """Running k best (squared distance, id) per query, ties by smaller id.

    Empty slots hold ``(max_sq, SENTINEL)``, which sorts after any entry at the same
    distance, so entries at exactly ``max_distance`` are kept.
    """

    def __init__(self, n_queries: int, top_k: int, max_sq: float = np.inf):
        self.top_k = top_k
        self.max_sq = max_sq
        self.sq = np.full((n_queries, top_k), max_sq)
        self.ids = np.full((n_queries, top_k), SENTINEL, dtype=np.int64)
        self.examined = np.zeros(n_queries, dtype=np.int64)

    def bound(self) -> np.ndarray:
        """(Q,) float64: the k-th best squared distance so far (max_sq until k found)."""
        return self.sq[:, -1]

    def add(self, q: np.ndarray, sq: np.ndarray, ids: np.ndarray) -> None:
        """Merge candidates ``(q, sq, ids)``, each (m,), into the running best."""
        if q.size == 0:
            return
        if self.sq.shape[0] == 1:  # one query: no grouping needed
            self.examined[0] += q.size
            better = sq <= self.sq[0, -1]
            if not better.any():
                return
            all_sq = np.concatenate([self.sq[0], sq[better]])
            all_ids = np.concatenate([self.ids[0], ids[better]])
            order = np.lexsort((all_ids, all_sq))[: self.top_k]
            self.sq[0] = all_sq[order]
            self.ids[0] = all_ids[order]
            return
        self.examined += np.bincount(q, minlength=self.examined.size)
        bound = self.sq[:, -1]
        if self.top_k == 1:  # only each query's nearest new candidates matter
            bound = bound.copy()
            np.minimum.at(bound, q, sq)
        better = sq <= bound[q]  # only these can enter the k best
        if not better.any():
            return
        q, sq, ids = q[better], sq[better], ids[better]
        rows = np.unique(q)
        old_sq, old_ids = self.sq[rows], self.ids[rows]
        have = old_ids != SENTINEL
        old_q = np.broadcast_to(rows[:, None], old_sq.shape)[have]
        all_q = np.concatenate([old_q, q])
        all_sq = np.concatenate([old_sq[have], sq])
        all_ids = np.concatenate([old_ids[have], ids])
        order = np.lexsort((all_ids, all_sq, all_q))
        all_q, all_sq, all_ids = all_q[order], all_sq[order], all_ids[order]
        rank = _rank_in_groups(all_q)
        keep = rank < self.top_k
        self.sq[rows] = self.max_sq
        self.ids[rows] = SENTINEL
        self.sq[all_q[keep], rank[keep]] = all_sq[keep]
        self.ids[all_q[keep], rank[keep]] = all_ids[keep]

    def result(self) -> NearestEntries:
        empty = self.ids == SENTINEL
        ids = np.where(empty, NO_ENTRY, self.ids)
        distances = np.where(empty, np.inf, np.sqrt(self.sq))
        return NearestEntries(ids, distances, self.examined.copy())


def _rank_in_groups(groups: np.ndarray) -> np.ndarray:
    """Position of each element within its run of equal values, for a sorted (m,) array."""
    n = groups.size
    if n == 0 or groups[0] == groups[-1]:
        return np.arange(n)
    first = np.empty(n, dtype=bool)
    first[0] = True
    np.not_equal(groups[1:], groups[:-1], out=first[1:])
    index = np.arange(n)
    return index - np.maximum.accumulate(np.where(first, index, 0))
