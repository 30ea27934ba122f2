"""Exact nearest-neighbour search through the key tree.

Step 6 of the retrieval engine.  The patent looks a query's point up under its own
K-digit key and takes the nearest point of that one bin; once ``R >= 8`` the true
nearest neighbour usually sits in a neighbouring bin and is missed.  :class:`TreeIndex`
instead returns exactly what brute force over every entry returns — the same ids and
the same distances, ties broken by the smaller id — while computing distances to a
small fraction of the entries.

The tree (held in memory, built from the store's arrays; the B-tree stays the index of
record):

* levels 1 … K follow the key digits: a node of level ``d`` holds every entry whose key
  starts with one ``d``-digit prefix (a contiguous range of the sorted B-tree keys),
  its children split it by the next digit; level K nodes are the bins, the B-tree's
  occupied keys;
* a bin larger than ``leaf_size`` entries is split further at the median of its
  widest coordinate (any of the k axes, not only the K key axes; the width is judged
  on 16 sampled entries) until every leaf holds at most ``leaf_size`` entries; a
  key-prefix node that is already that small is a leaf;
* every node keeps the tight bounding box of its entries over all k coordinates, so
  the squared distance from a query ``h`` to the box's nearest point is a lower bound
  on its squared distance to anything inside, far tighter than the section
  boundaries alone, and it covers the axes beyond K;
* for searching, each node's children are its highest descendants holding at most
  1/16 of its entries (or leaves).

A query:

1. *Key lookup* (vectorised over queries with numpy): the query's own key (the
   patent's step) finds the deepest occupied key prefix; below it the child with the
   smallest bound is followed until at most 8 leaves' worth of entries remain; their
   distances give a first k-th best.
2. *Nearest bound first* (a compiled loop per query, which releases the GIL): from
   the root, nodes are taken from a heap in order of their bound; a leaf's entries
   are measured, an inner node's children whose bound does not exceed the current
   k-th best go on the heap; the search ends when the nearest bound left exceeds the
   k-th best.

``max_distance`` (the patent's "unknown motion" threshold) starts the k-th best at
that distance, so a query with nothing near is answered after a few steps.

Arithmetic: queries are rounded to float32 like the points; a squared distance is
``Σ_a (p_a − h_a)²`` summed in order in float32 by one function shared with
:class:`BruteForceIndex`, and a bound is the same sum with each ``p_a`` replaced by the
box's nearest coordinate.  Rounding is monotonic, so bound ≤ distance holds in
floating point, no entry that brute force would return is ever pruned, and the
answers agree bit for bit.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from functools import lru_cache
from numbers import Integral, Real

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.retrieval.keys import Quantizer, key_prefix

#: Relative slack on pruning comparisons; bounds are exact lower bounds in floating
#: point already, this only guards against a different summation order.
_SLACK = 1.0 + 1e-9

#: Unit roundoff of float32.
_U32 = 2.0**-24


@dataclass(frozen=True)
class SearchResult:
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
        Entries whose distance to the query was computed.
    """

    ids: np.ndarray
    distances: np.ndarray
    examined: np.ndarray


# -- shared arithmetic -------------------------------------------------------------


def _pair_sq_distances(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Squared distances of row pairs, (m, k) and (m, k) or (k,) float32 → (m,) float32.

    The single distance formula of this module: brute force and the tree both use it
    (:func:`_row_sq_distance`, the coordinates' squared differences summed in order in
    float32), so equal pairs give bit-identical distances.
    """
    points = np.ascontiguousarray(points, dtype=np.float32)
    queries = np.ascontiguousarray(np.atleast_2d(queries), dtype=np.float32)
    out = np.empty(points.shape[0], np.float32)
    _kernels().pair_sq_distances(points, queries, out)
    return out


def _row_sq_distance(point, query):  # pragma: no cover - JIT
    """``Σ_a (point_a − query_a)²`` of two (k,) float32 rows, summed in order in float32."""
    total = np.float32(0.0)
    for a in range(point.shape[0]):
        d = point[a] - query[a]
        total += d * d
    return total


def _row_box_bound(lo, hi, query):  # pragma: no cover - JIT
    """The same sum with each ``point_a`` replaced by the box ``[lo, hi]``'s coordinate
    nearest the query's: never more than :func:`_row_sq_distance` to a point inside."""
    total = np.float32(0.0)
    for a in range(query.shape[0]):
        near = min(max(lo[a], query[a]), hi[a])
        d = near - query[a]
        total += d * d
    return total


def _pair_sq_distances_kernel(points, queries, out):  # pragma: no cover - JIT
    """``out`` (m,) float32: :func:`_row_sq_distance` of each row of ``points`` (m, k)
    to the same row of ``queries`` (m, k), or to its one row (1, k)."""
    one = queries.shape[0] == 1
    for i in range(points.shape[0]):
        out[i] = _row_sq_distance(points[i], queries[0] if one else queries[i])


def _best_first(
    points, ids, lo, hi, first, count, children, is_leaf, start, end, queries, starts_at,
    slack, best_sq, best_ids, examined,
):  # fmt: skip  # pragma: no cover - JIT
    """Exact k nearest entries of each query, nearest lower bound first.

    ``best_sq`` (Q, k) float64 and ``best_ids`` (Q, k) int64 hold each query's running
    best, nearest first (empty slots: the cutoff and ``_SENTINEL``); ``examined`` (Q,)
    int64 gets the entries measured.  Each query first measures the entries of its
    node ``starts_at`` (the key lookup's), then pops nodes from a heap ordered by
    lower bound, skipping what that node held, and stops when the nearest bound left
    exceeds its k-th best.  An entry enters the best when its (squared distance, id)
    is smaller than the k-th best's.
    """
    n_nodes = lo.shape[0]
    top_k = best_sq.shape[1]
    heap_bound = np.empty(n_nodes, np.float32)
    heap_node = np.empty(n_nodes, np.int64)
    for qi in range(queries.shape[0]):
        query = queries[qi]
        sq_row, id_row = best_sq[qi], best_ids[qi]
        g = starts_at[qi]
        g_start, g_end = start[g], end[g]
        for e in range(g_start, g_end):
            _offer(_row_sq_distance(points[e], query), ids[e], sq_row, id_row)
        measured = g_end - g_start
        heap_bound[0], heap_node[0] = np.float32(0.0), 0  # the root
        size = 1
        while size > 0:
            bound, node = heap_bound[0], heap_node[0]
            size -= 1
            if size > 0:  # the last item sifts down from the top
                last_bound, last_node = heap_bound[size], heap_node[size]
                i = 0
                while True:
                    child = 2 * i + 1
                    if child >= size:
                        break
                    if child + 1 < size and heap_bound[child + 1] < heap_bound[child]:
                        child += 1
                    if heap_bound[child] >= last_bound:
                        break
                    heap_bound[i], heap_node[i] = heap_bound[child], heap_node[child]
                    i = child
                heap_bound[i], heap_node[i] = last_bound, last_node
            if bound > sq_row[top_k - 1] * slack:
                break  # every bound left is at least as far
            if is_leaf[node]:
                if start[node] >= g_start and end[node] <= g_end:
                    continue  # measured first
                for e in range(start[node], end[node]):
                    _offer(_row_sq_distance(points[e], query), ids[e], sq_row, id_row)
                measured += end[node] - start[node]
                continue
            for c in range(first[node], first[node] + count[node]):
                kid = children[c]
                if start[kid] >= g_start and end[kid] <= g_end:
                    continue
                kid_bound = _row_box_bound(lo[kid], hi[kid], query)
                if kid_bound > sq_row[top_k - 1] * slack:
                    continue
                i = size  # sift up
                size += 1
                while i > 0:
                    parent = (i - 1) // 2
                    if heap_bound[parent] <= kid_bound:
                        break
                    heap_bound[i], heap_node[i] = heap_bound[parent], heap_node[parent]
                    i = parent
                heap_bound[i], heap_node[i] = kid_bound, kid
        examined[qi] = measured


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


def _kernels():
    """The compiled loops (numba is imported and they are compiled on first use, once,
    whichever thread asks first)."""
    with _COMPILING:
        return _compiled_kernels()


@lru_cache(maxsize=1)
def _compiled_kernels():
    """The row helpers are compiled first and put in place of their Python sources, so
    the kernels calling them find compiled functions.  No fast-math: every sum is
    taken in order, the same in brute force and in the tree."""
    from types import SimpleNamespace

    from numba import njit

    global _row_sq_distance, _row_box_bound, _offer
    jit = njit(cache=True, nogil=True)
    _row_sq_distance = jit(_row_sq_distance)
    _row_box_bound = jit(_row_box_bound)
    _offer = jit(_offer)
    return SimpleNamespace(
        pair_sq_distances=jit(_pair_sq_distances_kernel), best_first=jit(_best_first)
    )


def _check_points(points, name: str = "points") -> np.ndarray:
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


def _check_ids(ids, n: int) -> np.ndarray:
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


def _check_queries(queries, n_dims: int) -> np.ndarray:
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


def _check_max_distance(max_distance) -> float:
    """The squared cutoff of a ``max_distance`` parameter (>= 0, may be inf)."""
    if isinstance(max_distance, bool) or not isinstance(max_distance, Real):
        raise InvalidParameterError(f"max_distance must be a number, got {max_distance!r}")
    if not float(max_distance) >= 0.0:
        raise InvalidParameterError(f"max_distance must be >= 0, got {max_distance!r}")
    return float(max_distance) ** 2


def _check_top_k(top_k, n_entries: int) -> int:
    if isinstance(top_k, bool) or not isinstance(top_k, Integral) or top_k < 1:
        raise InvalidParameterError(f"top_k must be a positive integer, got {top_k!r}")
    if top_k > n_entries:
        raise InvalidParameterError(f"top_k={top_k} exceeds the {n_entries} entries")
    return int(top_k)


#: Id of an empty slot in a result (fewer than top_k entries within max_distance).
NO_ENTRY = -1

_SENTINEL = np.iinfo(np.int64).max


class _TopK:
    """Running k best (squared distance, id) per query, ties by smaller id.

    Empty slots hold ``(max_sq, _SENTINEL)``, which sorts after any entry at the same
    distance, so entries at exactly ``max_distance`` are kept.
    """

    def __init__(self, n_queries: int, top_k: int, max_sq: float = np.inf):
        self.top_k = top_k
        self.max_sq = max_sq
        self.sq = np.full((n_queries, top_k), max_sq)
        self.ids = np.full((n_queries, top_k), _SENTINEL, dtype=np.int64)
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
        have = old_ids != _SENTINEL
        old_q = np.broadcast_to(rows[:, None], old_sq.shape)[have]
        all_q = np.concatenate([old_q, q])
        all_sq = np.concatenate([old_sq[have], sq])
        all_ids = np.concatenate([old_ids[have], ids])
        order = np.lexsort((all_ids, all_sq, all_q))
        all_q, all_sq, all_ids = all_q[order], all_sq[order], all_ids[order]
        rank = _rank_in_groups(all_q)
        keep = rank < self.top_k
        self.sq[rows] = self.max_sq
        self.ids[rows] = _SENTINEL
        self.sq[all_q[keep], rank[keep]] = all_sq[keep]
        self.ids[all_q[keep], rank[keep]] = all_ids[keep]

    def result(self) -> SearchResult:
        empty = self.ids == _SENTINEL
        ids = np.where(empty, NO_ENTRY, self.ids)
        distances = np.where(empty, np.inf, np.sqrt(self.sq))
        return SearchResult(ids, distances, self.examined.copy())


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


def _expand_ranges(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Concatenate ``arange(s, s + c)`` over pairs; (m,) and (m,) → (Σc,) int64."""
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.cumsum(counts) - counts
    return np.repeat(starts - offsets, counts) + np.arange(total)


# -- brute force -------------------------------------------------------------------


class BruteForceIndex:
    """Exact nearest neighbours by scanning every entry (the reference).

    A float32 matrix product per block scores every entry, ``‖p‖² − 2 p·h`` (one
    product of ``[p, ‖p‖²]`` and ``[−2h, 1]``); only the blocks whose best score lies
    within a rigorous rounding-error margin of each query's k-th best are scored again
    to pick candidates, and the candidates are re-measured with the exact formula
    shared with :class:`TreeIndex`.

    Use :meth:`from_arrays` to build one.

    Attributes
    ----------
    points : (N, k) float32
    ids : (N,) int64
    """

    #: Queries per screening block; entries per block at least ``entry_block``, at
    #: most ``max_entry_block``, and about ``block_scores`` scores per block.
    query_block = 512
    entry_block = 8192
    max_entry_block = 65536
    block_scores = 1 << 22

    def __init__(self, points: np.ndarray, ids: np.ndarray):
        self.points = points
        self.ids = ids
        sq_norms = np.einsum("ij,ij->i", points, points, dtype=np.float64)
        self._augmented = np.hstack([points, sq_norms[:, None].astype(np.float32)])
        self._max_norm = float(np.sqrt(sq_norms.max())) if len(points) else 0.0

    @classmethod
    def from_arrays(cls, points, ids) -> BruteForceIndex:
        """An index over ``points`` (N, k) float and their unique ``ids`` (N,) int."""
        p = _check_points(points)
        return cls(p, _check_ids(ids, p.shape[0]))

    @property
    def n_entries(self) -> int:
        return self.points.shape[0]

    def search(self, queries, top_k: int = 1, max_distance: float = np.inf) -> SearchResult:
        """The ``top_k`` nearest entries of each query, by scanning all of them.

        Parameters
        ----------
        queries : (k,) or (Q, k) array of float
            Rounded to float32, like the points.
        top_k : int
            At most the number of entries.
        max_distance : float
            Entries farther than this are not returned.

        Returns
        -------
        SearchResult
            ``examined`` is ``N`` for every query.
        """
        q = _check_queries(queries, self.points.shape[1])
        top_k = _check_top_k(top_k, self.n_entries)
        max_sq = _check_max_distance(max_distance)
        best = _TopK(q.shape[0], top_k, max_sq)
        for lo in range(0, q.shape[0], self.query_block):
            block = q[lo : lo + self.query_block]
            cand_q, cand_i = self._screen(block, top_k, max_sq)
            sq = _pair_sq_distances(
                np.take(self.points, cand_i, axis=0), np.take(block, cand_q, axis=0)
            )
            best.add(cand_q + lo, sq, self.ids[cand_i])
        best.examined[:] = self.n_entries
        return best.result()

    def _screen(
        self, queries: np.ndarray, top_k: int, max_sq: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (query row, entry index) that may be among each query's k best."""
        n_q, n_dims = queries.shape
        augmented = np.empty((n_q, n_dims + 1), dtype=np.float32)
        augmented[:, :n_dims] = queries * np.float32(-2.0)  # exact scaling
        augmented[:, n_dims] = 1.0
        q_sq = np.einsum("ij,ij->i", queries, queries, dtype=np.float64)
        q_norm = np.sqrt(q_sq)
        # A float32 product of k + 1 terms errs by at most (k + 1) u (‖p‖ + ‖h‖)²
        # whatever the summation order, the exact formula by (k + 2) u (‖p‖ + ‖h‖)²;
        # a true k-best entry therefore always scores within 2 margins of the k-th
        # smallest score.
        margin = 4.0 * (n_dims + 8) * _U32 * (self._max_norm + q_norm) ** 2
        width = int(np.clip(self.block_scores // n_q, self.entry_block, self.max_entry_block))
        starts = np.arange(0, self.n_entries, width)
        block_best = np.empty((n_q, starts.size), dtype=np.float32)
        kth = np.full((n_q, top_k), np.inf, dtype=np.float32)
        for b, lo in enumerate(starts):
            scores = augmented @ self._augmented[lo : lo + width].T
            if top_k == 1:
                block_best[:, b] = scores.min(axis=1)
                np.minimum(kth[:, 0], block_best[:, b], out=kth[:, 0])
            else:
                part = min(top_k, scores.shape[1])
                smallest = np.partition(scores, part - 1, axis=1)[:, :part]
                block_best[:, b] = smallest.min(axis=1)
                kth = np.partition(np.hstack([kth, smallest]), top_k - 1, axis=1)[:, :top_k]
        # Scores are squared distances less ‖h‖², so the cutoff moves by ‖h‖² too.
        threshold = np.minimum(kth.max(axis=1), max_sq - q_sq) + 2.0 * margin
        threshold = threshold.astype(np.float32)
        # Second pass: score again only the blocks that may hold a k-best entry.
        rows, blocks = np.nonzero(block_best <= threshold[:, None])
        found_q, found_i = [], []
        for b in np.unique(blocks):
            lo = starts[b]
            these = rows[blocks == b]
            scores = augmented[these] @ self._augmented[lo : lo + width].T
            flat = np.flatnonzero(scores <= threshold[these, None])
            r, c = np.divmod(flat, scores.shape[1])
            found_q.append(these[r])
            found_i.append(c + lo)
        if not found_q:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        return np.concatenate(found_q), np.concatenate(found_i)


def brute_force(points, ids, queries, top_k: int = 1, max_distance: float = np.inf) -> SearchResult:
    """Exact nearest neighbours by scanning every entry.

    Parameters
    ----------
    points : (N, k) array of float
        Entry points (used as float32).
    ids : (N,) array of int
        Unique entry ids.
    queries : (k,) or (Q, k) array of float
    top_k : int
    max_distance : float
        Entries farther than this are not returned.

    Returns
    -------
    SearchResult
        The reference :meth:`TreeIndex.search` must equal.
    """
    return BruteForceIndex.from_arrays(points, ids).search(queries, top_k, max_distance)


# -- the tree ----------------------------------------------------------------------


class TreeIndex:
    """Exact nearest-neighbour search over the key tree (see the module docstring).

    Build with :meth:`from_arrays` or :meth:`from_store`; query with :meth:`search`.

    Attributes
    ----------
    n_sections, n_axes : int
        ``R`` and ``K`` of the keys.
    leaf_size : int
        Most entries in a leaf.
    points : (N, k) float32
        Entry points in tree order.
    ids : (N,) int64
        Entry ids in tree order (keys ascending).
    keys : (N,) int64
        Entry keys in tree order.
    quantizer : Quantizer
        The quantizer that made the keys (gives a query its own key).
    depth : int
        Levels of the built tree below the root (key digits, then bin splits).
    """

    def __init__(self):
        raise TypeError("build a TreeIndex with TreeIndex.from_arrays() or from_store()")

    # -- building ---------------------------------------------------------------------
    @classmethod
    def from_store(cls, store, leaf_size: int = 32) -> TreeIndex:
        """The tree of a database: the store's in-memory arrays and quantizer.

        Parameters
        ----------
        store : eigmotion.retrieval.store.Store
            An open store (anything with ``arrays()`` and ``quantizer()``).
        leaf_size : int
        """
        arrays = store.arrays()
        return cls.from_arrays(
            arrays.keys, arrays.points, arrays.ids, store.quantizer(), leaf_size=leaf_size
        )

    @classmethod
    def from_arrays(cls, keys, points, ids, quantizer: Quantizer, leaf_size: int = 32) -> TreeIndex:
        """Build the tree over entries.

        Parameters
        ----------
        keys : (N,) array of int
            Each entry's B-tree key; must equal ``quantizer.keys(points)``.
        points : (N, k) array of float
            Eigen-coordinates (used as float32), ``k >= quantizer.n_axes``.
        ids : (N,) array of int
            Unique entry ids (they break distance ties).
        quantizer : Quantizer
            The fitted quantizer that made the keys.
        leaf_size : int
            Most entries per leaf, >= 1.  Smaller leaves examine fewer entries but
            visit more nodes; 32 suits k = 20 … 50.

        Raises
        ------
        InvalidParameterError
            Inconsistent shapes, duplicate ids, non-finite points, or keys that differ
            from the quantizer's keys of the points.
        """
        if not isinstance(quantizer, Quantizer):
            raise InvalidParameterError(f"quantizer must be a Quantizer, got {type(quantizer)}")
        if isinstance(leaf_size, bool) or not isinstance(leaf_size, Integral) or leaf_size < 1:
            raise InvalidParameterError(f"leaf_size must be a positive integer, got {leaf_size!r}")
        p = _check_points(points)
        n = p.shape[0]
        i = _check_ids(ids, n)
        k = np.asarray(keys)
        if k.shape != (n,) or (n and not np.issubdtype(k.dtype, np.integer)):
            raise InvalidParameterError(f"keys must be ({n},) integers, got {k.dtype} {k.shape}")
        k = k.astype(np.int64)
        if n:
            expected = quantizer.keys(p)
            wrong = np.flatnonzero(expected != k)
            if wrong.size:
                raise InvalidParameterError(
                    f"{wrong.size} of {n} keys differ from the quantizer's keys of their "
                    f"points (first: id {int(i[wrong[0]])} has key {int(k[wrong[0]])}, "
                    f"expected {int(expected[wrong[0]])})"
                )
        self = object.__new__(cls)
        self.n_sections = int(quantizer.n_sections)
        self.n_axes = int(quantizer.n_axes)
        self.leaf_size = int(leaf_size)
        self.quantizer = quantizer
        self._build(k, p, i)
        return self

    #: Entries sampled per segment to pick the coordinate a bin is split along.
    _SPLIT_SAMPLES = 16

    def _build(self, keys: np.ndarray, points: np.ndarray, ids: np.ndarray) -> None:
        n, n_dims = points.shape
        if n and np.all(ids[1:] > ids[:-1]):
            order = np.argsort(keys, kind="stable")
        else:
            order = np.lexsort((ids, keys))
        keys, ids, points = keys[order], ids[order], points[order]
        R, K, leaf = self.n_sections, self.n_axes, self.leaf_size

        # The current level's partition of the sorted entries into segments: where
        # each starts, which node it is, and whether it is still to be split.
        starts = np.zeros(1, dtype=np.int64)
        seg_node = np.zeros(1, dtype=np.int64)
        seg_active = np.array([n > leaf])
        node_start, node_end, node_parent = [starts], [np.array([n])], [np.array([-1])]
        level_first = [0, 1]  # level l holds nodes level_first[l] … level_first[l+1]-1
        prefix_levels = []  # per key digit d = 1..K: (prefixes, nodes) created at level d
        n_nodes, level = 1, 0
        while seg_active.any():
            ends = np.append(starts[1:], n)
            if level < K:
                prefix = key_prefix(keys, R, K, level + 1)
                cuts = np.flatnonzero(prefix[1:] != prefix[:-1]) + 1
                owner = np.searchsorted(starts, cuts, side="right") - 1
                cuts = cuts[seg_active[owner] & (starts[owner] != cuts)]
            else:
                # Below the bins: halve each large segment at the median of the
                # coordinate that spreads widest over a sample of its entries.
                split = np.flatnonzero(seg_active)
                sizes = (ends - starts)[split]
                steps = np.arange(self._SPLIT_SAMPLES)
                sample = points[starts[split, None] + steps * sizes[:, None] // steps.size]
                axis = np.argmax(sample.max(axis=1) - sample.min(axis=1), axis=1)
                moving = _expand_ranges(starts[split], sizes)
                segment = np.repeat(np.arange(split.size), sizes)
                value = points[moving, np.repeat(axis, sizes)]
                moved = moving[np.lexsort((value, segment))]
                keys[moving], ids[moving] = keys[moved], ids[moved]
                points[moving] = points[moved]
                cuts = starts[split] + sizes // 2
            new_starts = np.sort(np.concatenate([starts, cuts]))
            new_ends = np.append(new_starts[1:], n)
            parent_seg = np.searchsorted(starts, new_starts, side="right") - 1
            fresh = seg_active[parent_seg]
            created = np.arange(n_nodes, n_nodes + int(fresh.sum()))
            node_start.append(new_starts[fresh])
            node_end.append(new_ends[fresh])
            node_parent.append(seg_node[parent_seg[fresh]])
            if level < K:
                digits = key_prefix(keys[new_starts[fresh]], R, K, level + 1)
                prefix_levels.append((digits, created))
            seg_node = seg_node[parent_seg]
            seg_node[fresh] = created
            seg_active = fresh & (new_ends - new_starts > leaf)
            starts = new_starts
            n_nodes += created.size
            level_first.append(n_nodes)
            level += 1

        self.keys, self.ids = keys, ids
        self.points = points
        self.depth = level
        self._start = np.concatenate(node_start)
        self._end = np.concatenate(node_end)
        self._size = self._end - self._start
        # The binary/R-ary tree as built.  Nodes are numbered level by level in entry
        # order, so every node's children are consecutive numbers.
        parent = np.concatenate(node_parent)
        self._base_count = np.bincount(parent[1:], minlength=n_nodes)
        self._base_first = np.concatenate([[1], 1 + np.cumsum(self._base_count)[:-1]])
        self._is_leaf = self._base_count == 0
        self._prefix_levels = prefix_levels
        self._boxes(starts, seg_node, level_first)
        self._flatten()

    def _boxes(self, starts, leaf_of_segment, level_first) -> None:
        """Tight boxes: leaves from their entries, then every parent from its children."""
        n_nodes, n_dims = self._size.size, self.n_dims
        lo = np.zeros((n_nodes, n_dims), dtype=np.float32)
        hi = np.zeros((n_nodes, n_dims), dtype=np.float32)
        if self.n_entries:
            # Reductions over segments run along contiguous memory when transposed.
            coords = np.ascontiguousarray(self.points.T)
            lo[leaf_of_segment] = np.minimum.reduceat(coords, starts, axis=1).T
            hi[leaf_of_segment] = np.maximum.reduceat(coords, starts, axis=1).T
        for level in range(len(level_first) - 3, -1, -1):
            first, stop, below = level_first[level : level + 3]
            inner = np.arange(first, stop)[~self._is_leaf[first:stop]]
            if inner.size:
                offsets = self._base_first[inner] - stop
                lo[inner] = np.minimum.reduceat(lo[stop:below], offsets, axis=0)
                hi[inner] = np.maximum.reduceat(hi[stop:below], offsets, axis=0)
        self._lo, self._hi = lo, hi

    #: A search-tree node's children are its highest descendants with at most
    #: 1/_FANOUT of its entries (or leaves): about _FANOUT children per node, so a
    #: query takes few vectorised steps however deep the built tree is.
    _FANOUT = 16

    def _flatten(self) -> None:
        """Search-tree children (CSR over node ids) of every node reachable from the root."""
        n_nodes = self._size.size
        first = np.zeros(n_nodes, dtype=np.int64)
        count = np.zeros(n_nodes, dtype=np.int64)
        lists, offset = [], 0
        level = np.zeros(0 if self._is_leaf[0] else 1, dtype=np.int64)
        while level.size:
            limit = self._size[level] // self._FANOUT
            owner = np.repeat(np.arange(level.size), self._base_count[level])
            node = _expand_ranges(self._base_first[level], self._base_count[level])
            done_owner, done_node = [], []
            while node.size:
                deeper = ~self._is_leaf[node] & (self._size[node] > limit[owner])
                done_owner.append(owner[~deeper])
                done_node.append(node[~deeper])
                owner, node = owner[deeper], node[deeper]
                owner = np.repeat(owner, self._base_count[node])
                node = _expand_ranges(self._base_first[node], self._base_count[node])
            owner, node = np.concatenate(done_owner), np.concatenate(done_node)
            order = np.lexsort((self._start[node], owner))
            owner, node = owner[order], node[order]
            counts = np.bincount(owner, minlength=level.size)
            first[level] = offset + np.cumsum(counts) - counts
            count[level] = counts
            lists.append(node)
            offset += node.size
            level = node[~self._is_leaf[node]]
        self._child_first = first
        self._child_count = count
        self._child_list = np.concatenate(lists) if lists else np.zeros(0, dtype=np.int64)

    # -- description ----------------------------------------------------------------
    @property
    def n_entries(self) -> int:
        """N, the number of entries."""
        return self.points.shape[0]

    @property
    def n_dims(self) -> int:
        """k, the number of eigen-coordinates per point."""
        return self.points.shape[1]

    @property
    def n_bins(self) -> int:
        """Occupied keys (bins of the B-tree)."""
        if self.n_entries == 0:
            return 0
        return int(np.count_nonzero(self.keys[1:] != self.keys[:-1])) + 1

    @property
    def n_leaves(self) -> int:
        """Leaves of the tree."""
        return int(np.count_nonzero(self._is_leaf[self._reachable()]))

    def _reachable(self) -> np.ndarray:
        """Nodes of the search tree, level by level."""
        nodes = [np.array([0])]
        while True:
            last = nodes[-1][~self._is_leaf[nodes[-1]]]
            if last.size == 0:
                break
            nodes.append(
                self._child_list[_expand_ranges(self._child_first[last], self._child_count[last])]
            )
        return np.concatenate(nodes)

    def __repr__(self) -> str:
        return (
            f"TreeIndex({self.n_entries} entries, k={self.n_dims}, R={self.n_sections}, "
            f"K={self.n_axes}, {self.n_bins} bins, leaf_size={self.leaf_size})"
        )

    def check(self) -> None:
        """Verify the tree's invariants, as ``BTrees``' ``_check()`` does (for tests).

        Raises
        ------
        InvalidParameterError
            Entries out of key order, a node whose box is not the tight box of its
            entries, children that do not tile their parent, or a leaf larger than
            ``leaf_size``.
        """
        problems = []
        if np.any(np.diff(self.keys) < 0):
            problems.append("entries are not in key order")
        for node in self._reachable():
            s, e = self._start[node], self._end[node]
            if s >= e:
                problems.append(f"node {node} is empty")
                continue
            block = self.points[s:e]
            if not (
                np.array_equal(block.min(0), self._lo[node])
                and np.array_equal(block.max(0), self._hi[node])
            ):
                problems.append(f"node {node}: box is not the tight box of its entries")
            if self._is_leaf[node]:
                if e - s > self.leaf_size:
                    problems.append(f"leaf {node} holds {e - s} > {self.leaf_size} entries")
                continue
            first = self._child_first[node]
            kids = self._child_list[first : first + self._child_count[node]]
            if (
                kids.size == 0
                or self._start[kids[0]] != s
                or self._end[kids[-1]] != e
                or np.any(self._start[kids[1:]] != self._end[kids[:-1]])
            ):
                problems.append(f"children of node {node} do not tile it")
        if problems:
            raise InvalidParameterError("; ".join(problems[:5]))

    # -- searching --------------------------------------------------------------------
    #: Queries searched together (bounds the size of the working arrays).
    query_block = 512

    def search(self, queries, top_k: int = 1, max_distance: float = np.inf) -> SearchResult:
        """The ``top_k`` nearest entries of each query, exactly as brute force finds them.

        Parameters
        ----------
        queries : (k,) or (Q, k) array of float
            Points in the eigenspace (``Eigenspace.transform`` of query images),
            rounded to float32 like the entries.
        top_k : int
            At most the number of entries.
        max_distance : float
            Entries farther than this are not returned (the patent's "unknown
            motion" threshold); it also prunes the search from the start, so
            queries with nothing near are answered quickly.

        Returns
        -------
        SearchResult
            ``ids`` and ``distances`` (Q, top_k) equal to :func:`brute_force`'s;
            ``examined`` counts the entries whose distance was computed.
        """
        q = _check_queries(queries, self.n_dims)
        top_k = _check_top_k(top_k, self.n_entries)
        max_sq = _check_max_distance(max_distance)
        parts = [
            self._search_block(q[lo : lo + self.query_block], top_k, max_sq)
            for lo in range(0, q.shape[0], self.query_block)
        ]
        if len(parts) == 1:
            return parts[0]
        return SearchResult(
            np.concatenate([p.ids for p in parts]),
            np.concatenate([p.distances for p in parts]),
            np.concatenate([p.examined for p in parts]),
        )

    def _lower_bounds(self, nodes: np.ndarray, rows: np.ndarray, queries: np.ndarray):
        """(m,) float32 squared distance from query ``rows`` to the boxes of ``nodes``
        (the box's nearest point minus the query, squared and summed), vectorised: it
        only picks where the key lookup descends, so its summation order may differ
        from :func:`_row_box_bound`'s."""
        qq = queries[0] if queries.shape[0] == 1 else np.take(queries, rows, axis=0)
        near = np.take(self._lo, nodes, axis=0)  # np.take gathers faster than indexing
        np.maximum(near, qq, out=near)
        np.minimum(near, np.take(self._hi, nodes, axis=0), out=near)
        near -= qq
        near *= near
        return near.sum(axis=1)

    #: The first node a query examines holds at most this many leaves' worth of entries.
    _GREEDY_LEAVES = 8

    def _greedy(self, queries: np.ndarray, top_k: int) -> np.ndarray:
        """(Q,) a small node near each query, examined first for a first k-th distance.

        The query's own key (the patent's lookup) finds the deepest occupied key prefix
        holding >= top_k entries; below it, the child with the smallest bound is
        followed until the node is small.
        """
        current = np.zeros(queries.shape[0], dtype=np.int64)
        prefix = np.zeros(queries.shape[0], dtype=np.int64)
        edges = self.quantizer.edges_
        for depth, (digits, nodes) in enumerate(self._prefix_levels):
            section = np.searchsorted(edges[depth], queries[:, depth], side="right")
            prefix = prefix * self.n_sections + section
            if digits.size:
                pos = np.minimum(np.searchsorted(digits, prefix), digits.size - 1)
                node = nodes[pos]
                ok = (digits[pos] == prefix) & (self._size[node] >= top_k)
                current[ok] = node[ok]
        budget = max(top_k, self._GREEDY_LEAVES * self.leaf_size)
        active = np.flatnonzero(~self._is_leaf[current] & (self._size[current] > budget))
        while active.size:
            counts = self._base_count[current[active]]
            kids = _expand_ranges(self._base_first[current[active]], counts)
            rows = np.repeat(active, counts)
            bound = self._lower_bounds(kids, rows, queries)
            bound[self._size[kids] < top_k] = np.inf
            first = np.cumsum(counts) - counts
            best = np.lexsort((bound, rows))[first]
            moved = np.isfinite(bound[best])
            current[active[moved]] = kids[best[moved]]
            active = active[moved]
            active = active[
                ~self._is_leaf[current[active]] & (self._size[current[active]] > budget)
            ]
        return current

    def _search_block(self, queries: np.ndarray, top_k: int, max_sq: float) -> SearchResult:
        best = _TopK(queries.shape[0], top_k, max_sq)
        _kernels().best_first(
            self.points, self.ids, self._lo, self._hi, self._child_first, self._child_count,
            self._child_list, self._is_leaf, self._start, self._end, queries,
            self._greedy(queries, top_k), _SLACK, best.sq, best.ids, best.examined,
        )  # fmt: skip
        return best.result()
