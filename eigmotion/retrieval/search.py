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
  1/8 of its entries (or leaves).

A query is answered in one compiled loop per batch, which releases the GIL; Python
only checks the arguments and allocates the answer, so one query at a time costs
little more than in a batch; a batch is answered in key order, so that one query
leaves in the caches much of what the next reads.  By default through the tree's
*cells* (:mod:`eigmotion.retrieval.cells`, :attr:`TreeIndex.cell_entries`):

1. the highest nodes holding at most ``cell_entries`` (4,000) entries — key prefixes,
   or median splits inside a large bin — are the cells; one pass over their boxes,
   stored dimension-major, bounds every cell;
2. the cells whose bound does not exceed the query's cutoff are taken nearest bound
   first; in each, its *groups* (the highest nodes within it holding at most
   ``group_entries``, 128) and their leaves are bounded (byte-coded boxes, each in
   its parent's frame, one contiguous run per cell), the leaves that may hold one
   of the k best ordered by bound and their entries measured, until the next
   leaf's or cell's bound exceeds the running k-th best.

With ``cell_entries = 0`` the node tree is walked instead
(:mod:`eigmotion.retrieval.walk`):

1. *Key lookup*: the query's own key (the patent's step, digit by digit) finds the
   deepest occupied key prefix; below it the child with the smallest bound is
   followed down to a leaf, whose distances give a first k-th best.
2. *Nearest bound first*: from the root, nodes are taken from a heap in order of
   their bound; a leaf's entries are measured, an inner node's children whose bound
   does not exceed the current k-th best go on the heap; the search ends when the
   nearest bound left exceeds the k-th best.

The walk's memory (1,021,440 real motion-image points: 1,283 entries and about 560
nodes visited, 4,100 child boxes bounded per query) decides its speed more than its
arithmetic, so:

* each node's children's boxes are stored one byte per corner coordinate, in a frame
  of the node's own (:func:`~eigmotion.retrieval.walk.box_codes`: a power-of-two step
  per axis, so every decoded corner is a float32 exactly and the decoded box holds the
  child's box), next to one another: a node's visit reads its frame, its children's
  codes and their references, three runs of memory;
* a heap item carries what its visit reads (a leaf's entry range; an inner node's
  children's slots and frame), so those loads wait on no table look-up, and the next
  item's memory is asked for (prefetched) while the current item is visited;
* bounds and a first estimate of each entry's distance are summed in SIMD registers in
  any order (see the arithmetic below); an entry whose estimate may enter the k best is
  measured again exactly.

The flat search reads the same way with fewer jumps: the cells' boxes are one
contiguous table (a few hundred KB), a cell's groups' and leaves' codes are
contiguous, and its entries are contiguous in key order.

``max_distance`` (the patent's "unknown motion" threshold) starts the k-th best at
that distance, so a query with nothing near is answered after a few steps.

A search over at most :attr:`TreeIndex.scan_entries` entries is answered by scanning
every entry instead (:class:`~eigmotion.retrieval.brute_force.BruteForceIndex`, NumPy,
no compiled loop to load), unless numba is loaded in the process already and at most
:attr:`TreeIndex.walk_top_k` nearest are asked for (warm, the walk is quicker there);
a scanned search's ``examined`` is N.  The tree is built only when something walks it
(:meth:`TreeIndex.walk` always walks) or reads its structure.

Arithmetic: queries are rounded to float32 like the points; a squared distance is
``Σ_a (p_a − h_a)²`` summed in order in float32, the order shared with
:class:`~eigmotion.retrieval.brute_force.BruteForceIndex`
(:mod:`eigmotion.retrieval.neighbours`); only such distances enter the answer.  A
bound (the same sum with each ``p_a`` replaced by the decoded box's nearest
coordinate) and an entry's estimate are summed in any order, within about ``(2k +
1)·2⁻²⁴`` of the in-order sum they stand for, and every cutoff they are compared with
is multiplied by :func:`~eigmotion.retrieval.walk.slack` ``= 1 + (k + 2)·2⁻²¹``; so
no entry that brute force would return is ever pruned, and the answers agree bit for
bit.
"""

from __future__ import annotations

import sys
import threading
from numbers import Integral

import numpy as np

from eigmotion.errors import DatabaseError, InvalidParameterError
from eigmotion.retrieval.brute_force import BruteForceIndex
from eigmotion.retrieval.cells import cell_kernels, cell_tables
from eigmotion.retrieval.keys import Quantizer, key_prefix
from eigmotion.retrieval.neighbours import (
    NearestEntries,
    check_ids,
    check_max_distance,
    check_points,
    check_queries,
    check_top_k,
)
from eigmotion.retrieval.walk import box_codes, node_refs, walk_kernels


def _expand_ranges(starts: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Concatenate ``arange(s, s + c)`` over pairs; (m,) and (m,) → (Σc,) int64."""
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    offsets = np.cumsum(counts) - counts
    return np.repeat(starts - offsets, counts) + np.arange(total)


def _check_keys(keys: np.ndarray, points: np.ndarray, ids: np.ndarray, quantizer) -> None:
    """Raise InvalidParameterError unless the (N,) ``keys`` are the quantizer's keys of
    the (N, k) ``points`` (ids (N,) name the first that differs)."""
    if not keys.size:
        return
    expected = quantizer.keys(points)
    wrong = np.flatnonzero(expected != keys)
    if wrong.size:
        raise InvalidParameterError(
            f"{wrong.size} of {keys.size} keys differ from the quantizer's keys of their "
            f"points (first: id {int(ids[wrong[0]])} has key {int(keys[wrong[0]])}, "
            f"expected {int(expected[wrong[0]])})"
        )


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
    def from_store(cls, store, leaf_size: int = 16) -> TreeIndex:
        """The tree of a database: the store's in-memory arrays and quantizer.

        Parameters
        ----------
        store : eigmotion.retrieval.store.Store
            An open store (anything with ``uri``, ``arrays()`` and ``quantizer()``).
        leaf_size : int

        Raises
        ------
        DatabaseError
            Naming the store, where its arrays are not entries a tree can hold (damage).
        """
        arrays = store.arrays()
        try:
            return cls.from_arrays(
                arrays.keys, arrays.points, arrays.ids, store.quantizer(), leaf_size,
                check_keys=False,
            )  # fmt: skip
        except InvalidParameterError as exc:
            raise DatabaseError(f"{store.uri}: the stored entries are damaged: {exc}") from None

    @classmethod
    def from_arrays(
        cls, keys, points, ids, quantizer: Quantizer, leaf_size: int = 16, check_keys: bool = True
    ) -> TreeIndex:
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
            visit more nodes; 16 suits motion-image points (k = 40).
        check_keys : bool
            Compare the keys with the quantizer's keys of the points here (True), or
            only when the tree is built (False: a database's scanned searches never
            read the keys, and its open does not pay for the check).

        Raises
        ------
        InvalidParameterError
            Inconsistent shapes, duplicate ids, non-finite points, or keys that differ
            from the quantizer's keys of the points (with ``check_keys`` False, raised
            by the first walk instead).
        """
        if not isinstance(quantizer, Quantizer):
            raise InvalidParameterError(f"quantizer must be a Quantizer, got {type(quantizer)}")
        if isinstance(leaf_size, bool) or not isinstance(leaf_size, Integral) or leaf_size < 1:
            raise InvalidParameterError(f"leaf_size must be a positive integer, got {leaf_size!r}")
        p = check_points(points)
        n = p.shape[0]
        i = check_ids(ids, n)
        k = np.asarray(keys)
        if k.shape != (n,) or (n and not np.issubdtype(k.dtype, np.integer)):
            raise InvalidParameterError(f"keys must be ({n},) integers, got {k.dtype} {k.shape}")
        k = k.astype(np.int64)
        if check_keys:
            _check_keys(k, p, i, quantizer)
        self = object.__new__(cls)
        self.n_sections = int(quantizer.n_sections)
        self.n_axes = int(quantizer.n_axes)
        self.leaf_size = int(leaf_size)
        self.quantizer = quantizer
        self._n_entries, self._n_dims = p.shape
        self._scan = None  # the brute-force index, made on the first scanned batch
        self._entries = (k, p, i)  # kept until the tree is built (and for scanning)
        self._built = False
        self._building = threading.Lock()  # one thread builds; the others wait for it
        self._keys_checked = bool(check_keys)
        self._kernel = None  # the compiled walk, fetched on the first walk
        self._cells = None  # (cell_entries, the flat search's tables), made on first use
        if n > self.scan_entries:  # every search walks: build now
            self._tree()
        return self

    def _tree(self) -> TreeIndex:
        """The built tree (built here on first use: a database's searches that are all
        answered by scanning never build it)."""
        if not self._built:
            with self._building:
                if not self._built:
                    keys, points, ids = self._entries
                    if not self._keys_checked:
                        _check_keys(keys, points, ids, self.quantizer)
                        self._keys_checked = True
                    self._build(keys, points, ids)
                    self._built = True
                    if self._n_entries > self.scan_entries:
                        self._entries = None
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

        self._keys, self._ids = keys, ids
        self._leaf_starts = starts
        self._depth = level
        self._start = np.concatenate(node_start)
        self._end = np.concatenate(node_end)
        self._size = self._end - self._start
        # The binary/R-ary tree as built.  Nodes are numbered level by level in entry
        # order, so every node's children are consecutive numbers.
        parent = np.concatenate(node_parent)
        self._parent = parent
        self._base_count = np.bincount(parent[1:], minlength=n_nodes)
        self._base_first = np.concatenate([[1], 1 + np.cumsum(self._base_count)[:-1]])
        self._is_leaf = self._base_count == 0
        self._prefix_digits = np.concatenate(
            [np.zeros(0, np.int64)] + [d.astype(np.int64) for d, _ in prefix_levels]
        )
        self._prefix_nodes = np.concatenate(
            [np.zeros(0, np.int64)] + [c.astype(np.int64) for _, c in prefix_levels]
        )
        self._prefix_first = np.cumsum([0] + [d.size for d, _ in prefix_levels]).astype(np.int64)
        self._edges = np.ascontiguousarray(self.quantizer.edges_, dtype=np.float64)
        self._boxes(points, starts, seg_node, level_first)
        self._flatten()
        self._points = points
        # The walk's tables: each search-tree child's box (low corner, high corner) in
        # child-list order, so a node's children's boxes lie together, and per node
        # its entries, its search-tree children and its base-tree children.
        parents = np.flatnonzero(self._child_count > 0)
        self._frames, self._codes = box_codes(
            self._lo, self._hi, parents, self._child_first, self._child_count, self._child_list
        )
        frame = np.zeros(self._size.size, dtype=np.int64)
        frame[parents] = np.arange(parents.size)
        refs = (self._start, self._end, self._child_first, self._child_count, frame)
        self._kid_a, self._kid_b = node_refs(self._child_list, *refs)
        (root_a,), (root_b,) = node_refs(np.zeros(1, dtype=np.int64), *refs)
        self._root = (int(root_a), int(root_b))
        self._nodes = np.ascontiguousarray(
            np.stack([self._start, self._end, self._base_first, self._base_count], axis=1),
            dtype=np.int64,
        )
        self._cells = None
        if self.cell_entries > 0:  # the flat search's tables, part of the tree
            self._make_cell_tables()

    def _boxes(self, points, starts, leaf_of_segment, level_first) -> None:
        """Tight boxes: leaves from their entries, then every parent from its children."""
        n_nodes, n_dims = self._size.size, self.n_dims
        lo = np.zeros((n_nodes, n_dims), dtype=np.float32)
        hi = np.zeros((n_nodes, n_dims), dtype=np.float32)
        if self._n_entries:
            # Reductions over segments run along contiguous memory when transposed.
            coords = np.ascontiguousarray(points.T)
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
    _FANOUT = 8

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
        self._widest = int(count.max(initial=0))  # most children of a node

    # -- description ----------------------------------------------------------------
    @property
    def points(self) -> np.ndarray:
        """(N, k) float32 entry points in tree order."""
        return self._tree()._points

    @property
    def ids(self) -> np.ndarray:
        """(N,) int64 entry ids in tree order."""
        return self._tree()._ids

    @property
    def keys(self) -> np.ndarray:
        """(N,) int64 entry keys in tree order (ascending)."""
        return self._tree()._keys

    @property
    def depth(self) -> int:
        """Levels of the built tree below the root (key digits, then bin splits)."""
        return self._tree()._depth

    @property
    def n_entries(self) -> int:
        """N, the number of entries."""
        return self._n_entries

    @property
    def n_dims(self) -> int:
        """k, the number of eigen-coordinates per point."""
        return self._n_dims

    @property
    def n_bins(self) -> int:
        """Occupied keys (bins of the B-tree)."""
        if self.n_entries == 0:
            return 0
        return int(np.count_nonzero(self.keys[1:] != self.keys[:-1])) + 1

    @property
    def n_leaves(self) -> int:
        """Leaves of the tree."""
        self._tree()
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
        points = self.points  # builds the tree
        if np.any(np.diff(self.keys) < 0):
            problems.append("entries are not in key order")
        for node in self._reachable():
            s, e = self._start[node], self._end[node]
            if s >= e:
                problems.append(f"node {node} is empty")
                continue
            block = points[s:e]
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
    #: Queries walked in one call of the compiled walk (in key order, see the module
    #: docstring).
    query_block = 512
    #: A search over at most ``scan_entries`` entries is answered by scanning every
    #: entry (:class:`~eigmotion.retrieval.brute_force.BruteForceIndex`: a few queries
    #: measured exactly in NumPy, a larger batch screened by matrix products), and the
    #: tree is then not built.  Measured on a database of 59,700 entries
    #: (``bench_scan_or_walk.py``, idle machine): one query scanned takes about 1 ms, a
    #: batch of 32 5–17 ms, while the walk's compiled loop and the tree cost a new
    #: process about 0.4 s to load (a cold query of a 3 s sample: 0.7–0.8 s wall
    #: scanned, 1.25–1.5 s walked); the default database (179,105 entries) is scanned
    #: too (docs/retrieval.md).  Larger databases are walked.  Set ``scan_entries = 0``
    #: to always walk.
    scan_entries = 250_000
    #: In a process that has loaded numba already (its load is then paid), a small
    #: database's searches for at most ``walk_top_k`` nearest entries are walked all the
    #: same: warm, the walk beats the scan there (``bench_scan_or_walk.py``).
    walk_top_k = 16
    #: Most entries in a cell of the flat search (:mod:`eigmotion.retrieval.cells`),
    #: which answers every walk; ``0``: walk the node tree nearest bound first
    #: instead (:mod:`eigmotion.retrieval.walk`).  Measured on 1,000,600 real
    #: motion-image points (``bench_search.py --real``, cells / groups): 4,000 / 128
    #: beat 1,000 / 64–1,000, 2,000 / 128, 4,000 / 256, 8,000 / 256 and 16,000 / 512.
    cell_entries = 4000
    #: Most entries in a group, the level between a cell and its leaves.
    group_entries = 128

    def search(self, queries, top_k: int = 1, max_distance: float = np.inf) -> NearestEntries:
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
        NearestEntries
            ``ids`` and ``distances`` (Q, top_k) equal to
            :func:`~eigmotion.retrieval.brute_force.brute_force`'s; ``examined`` counts the
            entries the query was compared with (its distance summed, or an estimate
            of it that showed it could not enter the k best): N for every query of
            a batch answered by scanning (see ``scan_entries``).
        """
        q = check_queries(queries, self.n_dims)
        top_k = check_top_k(top_k, self.n_entries)
        max_sq = check_max_distance(max_distance)
        if self._scanned() and not (top_k <= self.walk_top_k and "numba" in sys.modules):
            return self._scanner().search_checked(q, top_k, max_sq)
        return self._walk(q, top_k, max_sq)

    def prepare(self) -> None:
        """Make ready what this index's first search needs — the scanned entries laid
        out by coordinate, or the tree, its cells' tables and the compiled search — so
        that it is not waited for then.  A query of a video calls it on a thread of its
        own while the person is cut out of the frames (exact either way: the same arrays
        are made and the same loops loaded, only earlier).  Not to be called while
        another thread searches."""
        if self._scanned():
            self._scanner().prepare()
            return
        self._tree()
        if self.n_entries:  # one search of an entry: the compiled loops load on first call
            self._walk(np.ascontiguousarray(self._points[:1], np.float32), 1, np.inf)

    def _scanned(self) -> bool:
        """Whether the index is small enough to be searched by scanning (``scan_entries``)."""
        return self.n_entries <= self.scan_entries and self._entries is not None

    def _scanner(self) -> BruteForceIndex:
        """The brute-force index over the entries, made on first use."""
        if self._scan is None:
            _, points, ids = self._entries
            self._scan = BruteForceIndex(points, ids)
        return self._scan

    def walk(self, queries, top_k: int = 1, max_distance: float = np.inf) -> NearestEntries:
        """:meth:`search` through the tree for every batch, never by scanning (for
        checking the tree against brute force)."""
        q = check_queries(queries, self.n_dims)
        top_k = check_top_k(top_k, self.n_entries)
        return self._walk(q, top_k, check_max_distance(max_distance))

    def _walk(self, q: np.ndarray, top_k: int, max_sq: float) -> NearestEntries:
        self._tree()
        n = q.shape[0]
        ids = np.empty((n, top_k), dtype=np.int64)
        distances = np.empty((n, top_k), dtype=np.float64)
        examined = np.empty(n, dtype=np.int64)
        if n == 1:
            self._search_block(q, max_sq, ids, distances, examined)
            return NearestEntries(ids, distances, examined)
        # Queries in key order: one query's visits leave in the caches much of what
        # the next one, near it, reads.
        order = np.argsort(self.quantizer.keys(q), kind="stable")
        for lo in range(0, n, self.query_block):
            rows = order[lo : lo + self.query_block]
            block = [np.empty((rows.size, top_k), np.int64), np.empty((rows.size, top_k))]
            block.append(np.empty(rows.size, np.int64))
            self._search_block(q[rows], max_sq, *block)
            ids[rows], distances[rows], examined[rows] = block
        return NearestEntries(ids, distances, examined)

    def _cell_tables(self):
        """The flat search's tables for the current ``cell_entries`` and
        ``group_entries``: made with the tree, and again when either changes."""
        cells = self._cells
        if cells is None or cells[0] != (self.cell_entries, self.group_entries):
            with self._building:
                self._make_cell_tables()
        return self._cells[1]

    def _make_cell_tables(self) -> None:
        """Make the flat search's tables (:func:`~eigmotion.retrieval.cells.cell_tables`;
        1,000,600 real points, k = 40: 0.1–0.4 s, 18 MB beside the points' 160 MB)
        unless they are made for the current sizes."""
        sizes = (self.cell_entries, self.group_entries)
        if self._cells is None or self._cells[0] != sizes:
            tables = cell_tables(self._size, self._parent, self._is_leaf, self._start,
                                 self._lo, self._hi, *sizes)  # fmt: skip
            self._cells = (sizes, tables)

    def _search_block(self, queries, max_sq, ids, distances, examined) -> None:
        """Fill ``ids``, ``distances`` (Q, top_k) and ``examined`` (Q,) for ``queries``."""
        if self.cell_entries > 0:
            t = self._cell_tables()
            cell_kernels().search(
                self._points, self._ids, t.cell_lo, t.cell_hi, t.cell_groups, t.cell_frames,
                t.group_codes, t.group_leaves, t.group_frames, t.leaf_codes, t.leaf_entries,
                queries, max_sq, ids, distances, examined,
            )  # fmt: skip
            return
        if self._kernel is None:
            self._kernel = walk_kernels().walk
        self._kernel(
            self._points, self._ids, self._codes, self._frames, self._kid_a, self._kid_b,
            *self._root, self._nodes, self._lo, self._hi, queries, self._edges,
            self._prefix_digits, self._prefix_nodes, self._prefix_first, max_sq, ids,
            distances, examined,
        )  # fmt: skip
