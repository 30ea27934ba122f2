"""The key tree's flat search: every cell's box in one pass, then the near cells' leaves.

:class:`~eigmotion.retrieval.search.TreeIndex` answers a query by default through three
tables built from its tree (:func:`cell_tables`), or, with ``cell_entries = 0``, by
walking its node tree nearest bound first (:mod:`eigmotion.retrieval.walk`):

* *cells*: the highest nodes of the tree holding at most ``cell_entries`` entries
  (key-prefix nodes — ranges of the B-tree's sorted keys — or, inside a large bin,
  its median splits), a partition of the entries into contiguous ranges.  Their
  tight boxes are stored dimension-major, ``(k, C)`` low and high corners, so that
  one query bounds every cell in one pass over contiguous memory, in SIMD registers;
* *groups*: within each cell, the highest nodes holding at most ``group_entries``;
* *leaves*: the tree's leaves, each group's together.

A group's box is stored as byte codes in its cell's frame, a leaf's in its group's
(:func:`~eigmotion.retrieval.walk.box_codes`: every decoded corner is a float32
exactly and the decoded box holds the tight one), each cell's groups and each group's
leaves side by side, in entry order.

A query bounds every cell, keeps those whose bound does not exceed its cutoff in a
heap, and takes them nearest bound first; in a cell, the groups that may hold one of
the k best nearest bound first, and in a group its leaves likewise, their entries
screened and measured; each stops when the next bound exceeds the running k-th best.

The screens (a box's bound, an entry's first estimate) and the exact distances follow
:mod:`eigmotion.retrieval.walk`'s rule: screens are summed in any order, every cutoff
they are compared with is multiplied by :func:`~eigmotion.retrieval.walk.slack`, and
only the shared in-order distance enters the answer; every box bounded (tight, or
decoded exactly) holds its entries, so each of a bound's terms is at most the in-order
distance's term it stands for, and the answers equal brute force's bit for bit.
"""

from __future__ import annotations

import threading
from functools import lru_cache
from types import SimpleNamespace

import numpy as np

from eigmotion.retrieval.neighbours import SENTINEL
from eigmotion.retrieval.walk import SCREEN_MATH, SLACK_PER_AXIS, box_codes, walk_kernels

# The walk's box bound, entry measure and answer row, compiled: set by :func:`_compiled`.
_screen_box = _measure = _write_best = None


def _highest_within(size, parent, is_leaf, start, limit) -> np.ndarray:
    """The highest nodes holding at most ``limit`` entries (and the leaves holding
    more), in entry order: a partition of the entries into contiguous ranges."""
    small = (size <= limit) | is_leaf
    above = np.where(parent >= 0, size[np.maximum(parent, 0)], np.iinfo(np.int64).max)
    nodes = np.flatnonzero(small & (above > limit))
    return nodes[np.argsort(start[nodes], kind="stable")]


def cell_tables(
    size: np.ndarray,
    parent: np.ndarray,
    is_leaf: np.ndarray,
    start: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    cell_entries: int,
    group_entries: int,
) -> SimpleNamespace:
    """The flat search's tables of a built tree.

    Parameters
    ----------
    size, parent, start : (n_nodes,) int64
        Each node's entries, parent (-1 for the root) and first entry.
    is_leaf : (n_nodes,) bool
        Whether the node is a leaf.
    lo, hi : (n_nodes, k) float32
        Each node's tight box.
    cell_entries, group_entries : int
        Most entries in a cell and in a group (a leaf holding more is a cell or a
        group all the same).  Each cell is cut into the highest nodes within it
        holding at most ``group_entries``, its groups; each group into its leaves.

    Returns
    -------
    SimpleNamespace
        ``cell_lo``, ``cell_hi`` (k, C) float32: the cells' boxes, dimension-major, in
        entry order; ``cell_groups`` (C + 1,) int64: cell ``c``'s groups are
        ``cell_groups[c] … cell_groups[c+1]-1``; ``cell_frames`` (C, 2, k) float32 and
        ``group_codes`` (G, 2, k) uint8: the groups' boxes coded in their cell's frame
        (:func:`~eigmotion.retrieval.walk.box_codes`); ``group_leaves`` (G + 1,) int64,
        ``group_frames`` (G, 2, k) and ``leaf_codes`` (L, 2, k) likewise for the
        leaves of each group; ``leaf_entries`` (L + 1,) int64: leaf ``l``'s entries
        are ``leaf_entries[l] … leaf_entries[l+1]-1``.
    """
    n_entries = int(size[0])
    group_entries = min(group_entries, cell_entries)
    cells = _highest_within(size, parent, is_leaf, start, cell_entries)
    groups = _highest_within(size, parent, is_leaf, start, group_entries)
    leaves = np.flatnonzero(is_leaf)
    leaves = leaves[np.argsort(start[leaves], kind="stable")]
    out = SimpleNamespace(
        cell_lo=np.ascontiguousarray(lo[cells].T),
        cell_hi=np.ascontiguousarray(hi[cells].T),
        leaf_entries=np.append(start[leaves], n_entries).astype(np.int64),
    )
    for upper, lower, name in ((cells, groups, "cell"), (groups, leaves, "group")):
        inside = np.searchsorted(start[lower], np.append(start[upper], n_entries))
        first = np.zeros(size.size, np.int64)
        count = np.zeros(size.size, np.int64)
        first[upper], count[upper] = inside[:-1], np.diff(inside)
        frames, codes = box_codes(lo, hi, upper, first, count, lower)
        setattr(out, f"{name}_frames", frames)
        setattr(out, "group_codes" if name == "cell" else "leaf_codes", codes)
        setattr(out, "cell_groups" if name == "cell" else "group_leaves", inside.astype(np.int64))
    return out


def _cell_bounds(cell_lo, cell_hi, query, out):  # pragma: no cover - JIT
    """``out`` (C,) float32: each cell's bound (its box's nearest point's squared
    distance to ``query``), the axes' terms added in order, each SIMD lane a cell."""
    out[:] = 0.0
    for a in range(query.shape[0]):
        q = query[a]
        low_row, high_row = cell_lo[a], cell_hi[a]
        for c in range(out.shape[0]):
            low, high = low_row[c], high_row[c]
            near = low if low > q else q
            near = near if near < high else high
            d = near - q
            out[c] += d * d


def _sift_down(bounds, items, size, i, bound, item):  # pragma: no cover - JIT
    """Put (``bound``, ``item``) at position ``i`` of the min-heap ``bounds[:size]``
    (``items`` alongside), whose sub-heaps below ``i`` are heaps, and sift it down."""
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and bounds[child + 1] < bounds[child]:
            child += 1
        if bounds[child] >= bound:
            break
        bounds[i], items[i] = bounds[child], items[child]
        i = child
    bounds[i], items[i] = bound, item


def _insert(bounds, items, size, bound, item):  # pragma: no cover - JIT
    """Insert (``bound``, ``item``) into ``bounds[:size]`` sorted ascending (``items``
    alongside); returns the new size."""
    i = size
    while i > 0 and bounds[i - 1] > bound:
        bounds[i], items[i] = bounds[i - 1], items[i - 1]
        i -= 1
    bounds[i], items[i] = bound, item
    return size + 1


def _search_cells(points, ids, cell_lo, cell_hi, cell_groups, cell_frames, group_codes,
                  group_leaves, group_frames, leaf_codes, leaf_entries, queries, max_sq,
                  out_ids, out_distances, examined):  # fmt: skip  # pragma: no cover - JIT
    """Exact k nearest entries of each query through the cells (module docstring).

    Fills ``out_ids`` (Q, k) int64 and ``out_distances`` (Q, k) float64 (nearest
    first; ``NO_ENTRY`` and inf in slots left empty by the squared cutoff ``max_sq``)
    and ``examined`` (Q,) int64 with the entries screened.
    """
    slack = 1.0 + (queries.shape[1] + 2) * SLACK_PER_AXIS  # walk.slack(k)
    top_k = out_ids.shape[1]
    last = top_k - 1
    n_cells = cell_lo.shape[1]
    bounds = np.empty(n_cells, np.float32)
    heap_bound = np.empty(n_cells, np.float32)
    heap_cell = np.empty(n_cells, np.int64)
    most_groups = np.max(np.diff(cell_groups))
    most_leaves = np.max(np.diff(group_leaves))
    near_group_bound = np.empty(most_groups, np.float32)
    near_group = np.empty(most_groups, np.int64)
    near_bound = np.empty(most_leaves, np.float32)
    near_leaf = np.empty(most_leaves, np.int64)
    sq_row = np.empty(top_k, np.float64)
    id_row = np.empty(top_k, np.int64)
    for qi in range(queries.shape[0]):
        query = queries[qi]
        sq_row[:] = max_sq
        id_row[:] = SENTINEL
        measured = 0
        _cell_bounds(cell_lo, cell_hi, query, bounds)
        cutoff = sq_row[last] * slack
        size = 0
        for c in range(n_cells):
            if bounds[c] <= cutoff:
                heap_bound[size], heap_cell[size] = bounds[c], c
                size += 1
        for i in range(size // 2 - 1, -1, -1):  # heapify, bottom up
            _sift_down(heap_bound, heap_cell, size, i, heap_bound[i], heap_cell[i])
        while size > 0:
            bound, cell = heap_bound[0], heap_cell[0]
            size -= 1
            if size > 0:
                _sift_down(heap_bound, heap_cell, size, 0, heap_bound[size], heap_cell[size])
            cutoff = sq_row[last] * slack
            if bound > cutoff:
                break  # every cell left is at least as far
            # The cell's groups that may hold one of the k best, nearest bound first;
            # in each, its leaves likewise.
            n_groups = 0
            for group in range(cell_groups[cell], cell_groups[cell + 1]):
                group_bound = _screen_box(group_codes, group, cell_frames, cell, query)
                if group_bound <= cutoff:
                    n_groups = _insert(near_group_bound, near_group, n_groups, group_bound, group)
            for g in range(n_groups):
                cutoff = sq_row[last] * slack
                if near_group_bound[g] > cutoff:
                    break
                group = near_group[g]
                n_near = 0
                for leaf in range(group_leaves[group], group_leaves[group + 1]):
                    leaf_bound = _screen_box(leaf_codes, leaf, group_frames, group, query)
                    if leaf_bound <= cutoff:
                        n_near = _insert(near_bound, near_leaf, n_near, leaf_bound, leaf)
                for j in range(n_near):
                    if near_bound[j] > sq_row[last] * slack:
                        break
                    first, stop = leaf_entries[near_leaf[j]], leaf_entries[near_leaf[j] + 1]
                    _measure(points, ids, first, stop, query, slack, sq_row, id_row)
                    measured += stop - first
        examined[qi] = measured
        _write_best(sq_row, id_row, out_ids[qi], out_distances[qi])


_COMPILING = threading.Lock()


def cell_kernels() -> SimpleNamespace:
    """The compiled flat search (numba is imported and it is compiled on first use,
    once, whichever thread asks first): ``search(points, ids, cell_lo, cell_hi,
    cell_groups, cell_frames, group_codes, group_leaves, group_frames, leaf_codes,
    leaf_entries, queries, max_sq, out_ids, out_distances, examined)`` with the tables
    of :func:`cell_tables`."""
    with _COMPILING:
        return _compiled()


@lru_cache(maxsize=1)
def _compiled() -> SimpleNamespace:
    from numba import njit

    global _cell_bounds, _measure, _sift_down, _insert, _search_cells
    global _screen_box, _write_best
    walk = walk_kernels()  # compiled: the walk's box bound, entry measure and answer row
    _screen_box, _measure, _write_best = walk.screen_box, walk.measure, walk.write_best
    plain = njit(cache=True, nogil=True)
    screen = njit(cache=True, nogil=True, fastmath=SCREEN_MATH)
    _cell_bounds = screen(_cell_bounds)
    _sift_down = plain(_sift_down)
    _insert = plain(_insert)
    _search_cells = plain(_search_cells)
    return SimpleNamespace(search=_search_cells)
