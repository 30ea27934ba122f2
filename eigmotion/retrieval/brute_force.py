"""Exact nearest neighbours by scanning every entry: the reference the key tree
(:class:`~eigmotion.retrieval.search.TreeIndex`) must equal, bit for bit.

Its distances are measured by the function the tree measures with
(:func:`~eigmotion.retrieval.neighbours.pair_sq_distances`).
"""

from __future__ import annotations

import numpy as np

from eigmotion.retrieval.neighbours import (
    NearestEntries,
    RunningBest,
    check_ids,
    check_max_distance,
    check_points,
    check_queries,
    check_top_k,
    pair_sq_distances,
    sq_distances_in_order,
)

#: Unit roundoff of float32.
_U32 = 2.0**-24


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
    #: Batches of fewer queries are measured exactly against every entry, axis by
    #: axis in NumPy (:meth:`_measure_every_entry`), instead of screened by matrix
    #: products: no rounding margin to re-check and no BLAS threads to start.  On
    #: 49,236 entries (k = 40) one query takes about 1.2 ms; on a busy two-core
    #: machine the screening's multi-threaded BLAS was slower up to 31 queries, with
    #: BLAS on one thread it was quicker from 4–8.
    exact_queries = 32

    def __init__(self, points: np.ndarray, ids: np.ndarray):
        self.points = points
        self.ids = ids
        self._augmented = None  # (N, k + 1) [p, ‖p‖²], for screening, made on first use
        self._max_norm = 0.0
        self._point_axes = None  # (k, N) points by coordinate, for the exact scan

    def prepare(self) -> None:
        """Lay the points out by coordinate, (k, N), for the exact scan of a few queries
        (:meth:`_measure_every_entry`), if not done yet."""
        if self._point_axes is None:
            self._point_axes = np.ascontiguousarray(self.points.T)

    @classmethod
    def from_arrays(cls, points, ids) -> BruteForceIndex:
        """An index over ``points`` (N, k) float and their unique ``ids`` (N,) int."""
        p = check_points(points)
        return cls(p, check_ids(ids, p.shape[0]))

    @property
    def n_entries(self) -> int:
        return self.points.shape[0]

    def search(self, queries, top_k: int = 1, max_distance: float = np.inf) -> NearestEntries:
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
        NearestEntries
            ``examined`` is ``N`` for every query.
        """
        q = check_queries(queries, self.points.shape[1])
        top_k = check_top_k(top_k, self.n_entries)
        return self.search_checked(q, top_k, check_max_distance(max_distance))

    def search_checked(self, q: np.ndarray, top_k: int, max_sq: float) -> NearestEntries:
        """:meth:`search` of arguments already checked: (Q, k) float32 queries, 1 <=
        ``top_k`` <= N and the squared ``max_distance``."""
        best = RunningBest(q.shape[0], top_k, max_sq)
        for lo in range(0, q.shape[0], self.query_block):
            block = q[lo : lo + self.query_block]
            if block.shape[0] < self.exact_queries:
                cand_q, cand_i, sq = self._measure_every_entry(block, top_k)
            else:
                cand_q, cand_i = self._screen(block, top_k, max_sq)
                sq = pair_sq_distances(
                    np.take(self.points, cand_i, axis=0), np.take(block, cand_q, axis=0)
                )
            best.add(cand_q + lo, sq, self.ids[cand_i])
        best.examined[:] = self.n_entries
        return best.result()

    def _measure_every_entry(
        self, queries: np.ndarray, top_k: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Candidates of a few queries by their exact distance to every entry.

        Returns (m,) query rows, (m,) entry indices and (m,) float32 squared distances:
        each query's entries no farther than its ``top_k``-th nearest (ties included).
        """
        self.prepare()
        found_q, found_i, found_sq = [], [], []
        for row, query in enumerate(queries):
            sq = sq_distances_in_order(self._point_axes, query[:, None])
            kth = np.partition(sq, top_k - 1)[top_k - 1]
            near = np.flatnonzero(sq <= kth)
            found_q.append(np.full(near.size, row, dtype=np.int64))
            found_i.append(near)
            found_sq.append(sq[near])
        return np.concatenate(found_q), np.concatenate(found_i), np.concatenate(found_sq)

    def _screen(
        self, queries: np.ndarray, top_k: int, max_sq: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (query row, entry index) that may be among each query's k best."""
        n_q, n_dims = queries.shape
        if self._augmented is None:
            sq_norms = np.einsum("ij,ij->i", self.points, self.points, dtype=np.float64)
            self._max_norm = float(np.sqrt(sq_norms.max())) if len(sq_norms) else 0.0
            self._augmented = np.hstack([self.points, sq_norms[:, None].astype(np.float32)])
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


def brute_force(
    points, ids, queries, top_k: int = 1, max_distance: float = np.inf
) -> NearestEntries:
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
    NearestEntries
        The reference :meth:`TreeIndex.search` must equal.
    """
    return BruteForceIndex.from_arrays(points, ids).search(queries, top_k, max_distance)
