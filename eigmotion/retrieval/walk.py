"""The key tree's compiled best-first walk (see :mod:`eigmotion.retrieval.search`).

Every loop here is compiled by numba on first use (:func:`walk_kernels`).  Two kinds
of sums are taken:

* *screens* — a box's lower bound and an entry's first estimate of its squared
  distance — are summed over the axes in any order, in SIMD registers
  (``fastmath`` reassociation and fused multiply-add, no assumption about infinities
  or NaN).  A float32 sum of ``k`` non-negative terms, in any order, lies within a
  factor ``1 ± γ_k`` (``γ_k = k·u / (1 − k·u)``, ``u = 2⁻²⁴``) of the exact sum of its
  terms, and a fused term is at most ``1 + u`` times the rounded one; each term of a
  screen is at most the in-order sum's term it stands for (a box's decoded corner is
  exact and lies between the query and the entry, and rounding is monotonic).  So a
  screen never exceeds the in-order sum by more than about ``(2k + 1)·u`` of it, and
  every cutoff a screen is compared with is multiplied by :func:`slack` ``= 1 + (k +
  2)·2⁻²¹``, four times that.
* *distances* — an entry that passes its screen is measured again with the shared
  in-order sum (:func:`eigmotion.retrieval.neighbours.pair_sq_distances`'s), the
  very bits brute force computes, and only that distance enters the running best.

So no entry brute force returns is ever pruned by a screen, and the answers equal
brute force's bit for bit.
"""

from __future__ import annotations

import threading
from functools import lru_cache
from types import SimpleNamespace

import numpy as np

from eigmotion.retrieval.neighbours import NO_ENTRY, SENTINEL, kernels

#: Relative slack per axis of the cutoffs a screen is compared with (see :func:`slack`).
SLACK_PER_AXIS = 2.0**-21


def slack(n_dims: int) -> float:
    """The factor ``1 + (k + 2)·2⁻²¹`` every cutoff compared with a screen of ``k =
    n_dims`` axes is multiplied by (see the module docstring)."""
    return 1.0 + (n_dims + 2) * SLACK_PER_AXIS


#: Columns of the per-node table ``nodes`` (int64): first entry, end entry, first
#: base-tree child, base-tree children (0 for a leaf).
START, END, BASE_FIRST, BASE_COUNT = range(4)

#: An inner node's reference ``b``: its children's count shifted left by this, or'ed
#: with its frame (:func:`node_refs`).
_COUNT_SHIFT = 32
_FRAME_MASK = (1 << _COUNT_SHIFT) - 1

# numba's fast-math flags for the screens: reorder sums and fuse multiply-adds, but
# keep IEEE infinities and NaN (``max_distance`` may be inf).
SCREEN_MATH = {"reassoc", "contract", "nsz", "arcp"}


def box_codes(
    lo: np.ndarray,
    hi: np.ndarray,
    parents: np.ndarray,
    first: np.ndarray,
    count: np.ndarray,
    children: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The search-tree children's boxes, one byte per corner coordinate.

    Each parent's box gets a *frame* per axis: a power-of-two ``step`` at least 1/254
    of the box's width (and at least 2⁻²² of its largest magnitude) and a ``base``, the
    parent's low corner rounded down to a multiple of ``step``.  A child's corner is
    stored as codes ``⌊(lo − base)/step⌋`` and ``⌈(hi − base)/step⌉`` (0 … 255), so the
    decoded box ``[base + c_lo·step, base + c_hi·step]`` holds the child's box.  Every
    decoded coordinate is an integer below 2²⁴ times a power of two: float32 holds it
    exactly, so the decoding is exact however the compiled loop orders or fuses it.

    Parameters
    ----------
    lo, hi : (n_nodes, k) float32
        Every node's tight box.
    parents : (P,) int64
        The nodes with search-tree children.
    first, count : (n_nodes,) int64
        Each node's children's first slot in ``children`` and their number.
    children : (S,) int64
        The search-tree children, each parent's together.

    Returns
    -------
    frames : (P, 2, k) float32
        ``base`` and ``step`` of each parent (in ``parents``' order), per axis.
    codes : (S, 2, k) uint8
        Each child slot's low and high corner codes in its parent's frame.
    """
    n_dims = lo.shape[1]
    low, high = lo[parents].astype(np.float64), hi[parents].astype(np.float64)
    need = np.maximum((high - low) / 254.0, np.maximum(np.abs(low), np.abs(high)) * 2.0**-22)
    step = np.exp2(np.ceil(np.log2(np.maximum(need, 2.0**-100))))
    step = np.where(step < need, 2.0 * step, step)
    base = np.floor(low / step) * step
    frames = np.stack([base, step], axis=1).astype(np.float32)
    slot_parent = np.repeat(np.arange(parents.size), count[parents])
    slots = np.repeat(first[parents] - np.cumsum(count[parents]) + count[parents],
                      count[parents]) + np.arange(slot_parent.size)  # fmt: skip
    codes = np.zeros((children.size, 2, n_dims), dtype=np.uint8)
    kids = children[slots]
    f_base, f_step = base[slot_parent], step[slot_parent]
    codes[slots, 0] = np.floor((lo[kids] - f_base) / f_step)
    codes[slots, 1] = np.ceil((hi[kids] - f_base) / f_step)
    return frames, codes


def node_refs(
    nodes: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    first: np.ndarray,
    count: np.ndarray,
    frame: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """What a visit of each of ``nodes`` reads, as two (n,) int64 references ``a``,
    ``b``: a leaf's entries ``start … end − 1`` as ``(start, −end − 1)``; an inner
    node's children's slots ``first … first + count − 1`` and its frame of their box
    codes (:func:`box_codes`) as ``(first, count << 32 | frame)``."""
    leaf = count[nodes] == 0
    a = np.where(leaf, start[nodes], first[nodes])
    b = np.where(leaf, -end[nodes] - 1, (count[nodes] << _COUNT_SHIFT) | frame[nodes])
    return a.astype(np.int64), b.astype(np.int64)


def _screen_box(codes, slot, frames, frame, query):  # pragma: no cover - JIT
    """Lower bound (float32, any summation order) of the squared distance from
    ``query`` (k,) to the decoded box of child ``slot`` (:func:`box_codes`) in its
    parent's frame ``frame``."""
    total = np.float32(0.0)
    for a in range(query.shape[0]):
        d = _box_gap(frames[frame, 0, a], frames[frame, 1, a], codes[slot, 0, a],
                     codes[slot, 1, a], query[a])  # fmt: skip
        total += d * d
    return total


def _box_gap(base, step, code_low, code_high, q):  # pragma: no cover - JIT
    """``q``'s signed distance to the interval ``[base + code_low·step, base +
    code_high·step]`` (0 inside), float32.  Compiled without fast-math, so inlined into
    a screen its arithmetic is never reordered: the corners are exact, the difference
    rounded once."""
    low = base + np.float32(code_low) * step
    high = base + np.float32(code_high) * step
    near = low if low > q else q
    near = near if near < high else high
    return near - q


def _screen_point(points, row, query):  # pragma: no cover - JIT
    """Squared distance (float32, any summation order) of ``points[row]`` to ``query``."""
    total = np.float32(0.0)
    for a in range(query.shape[0]):
        d = points[row, a] - query[a]
        total += d * d
    return total


def _measure(points, ids, first, stop, query, slack, sq_row, id_row):  # pragma: no cover - JIT
    """Offer the entries ``first … stop-1`` to the running best: each is screened, and
    measured exactly (the shared in-order sum) only when its screen may enter."""
    last = sq_row.shape[0] - 1
    for row in range(first, stop):
        if _screen_point(points, row, query) <= sq_row[last] * slack:
            _offer(_exact_sq(points[row], query), ids[row], sq_row, id_row)


def _key_start(
    query, top_k, edges, digits, prefix_nodes, level_first, nodes, lo, hi
):  # pragma: no cover - JIT
    """A leaf near ``query`` measured first, for a first k-th best.

    The query's own key (the patent's lookup: its section on each key axis, digit by
    digit) finds the deepest occupied key prefix holding >= ``top_k`` entries; below it
    the base-tree child with the smallest bound is followed down to a leaf.
    ``digits`` / ``prefix_nodes`` list each level's key prefixes and their nodes, level
    ``d`` in ``level_first[d] … level_first[d+1]-1``.  Returns -1 when no leaf on that
    path holds ``top_k`` entries.
    """
    current = 0
    prefix = 0
    for depth in range(level_first.shape[0] - 1):
        section = np.searchsorted(edges[depth], query[depth], side="right")
        prefix = prefix * (edges.shape[1] + 1) + section
        first, stop = level_first[depth], level_first[depth + 1]
        if stop > first:
            pos = first + np.searchsorted(digits[first:stop], prefix)
            pos = min(pos, stop - 1)
            node = prefix_nodes[pos]
            if digits[pos] == prefix and nodes[node, END] - nodes[node, START] >= top_k:
                current = node
    while nodes[current, BASE_COUNT] > 0:
        chosen = -1
        chosen_bound = np.inf
        kid_first = nodes[current, BASE_FIRST]
        for kid in range(kid_first, kid_first + nodes[current, BASE_COUNT]):
            if nodes[kid, END] - nodes[kid, START] < top_k:
                continue
            bound = np.float32(0.0)
            for a in range(query.shape[0]):
                d = min(max(lo[kid, a], query[a]), hi[kid, a]) - query[a]
                bound += d * d
            if bound < chosen_bound:
                chosen, chosen_bound = kid, bound
        if chosen < 0:
            return -1
        current = chosen
    return current


def _walk(points, ids, codes, frames, kid_a, kid_b, root_a, root_b, nodes, lo, hi, queries,
          edges, digits, prefix_nodes, level_first, max_sq, out_ids, out_distances,
          examined):  # fmt: skip  # pragma: no cover - JIT
    """Exact k nearest entries of each query, nearest lower bound first.

    Fills ``out_ids`` (Q, k) int64 and ``out_distances`` (Q, k) float64 (nearest first;
    ``NO_ENTRY`` and inf in slots left empty by the squared cutoff ``max_sq``) and
    ``examined`` (Q,) int64 with the entries screened.  Each query first measures the
    leaf its key leads to (:func:`_key_start`), then pops nodes from a heap ordered by
    lower bound, skipping that leaf, and stops when the nearest bound left exceeds its
    k-th best.  An entry enters the best when its (squared distance, id) is smaller
    than the k-th best's.

    A heap item carries what its node's visit reads (:func:`node_refs`): a leaf's
    entry range, or an inner node's children's slots and frame, so a visit's loads
    (the frame, the children's codes and references, the leaf's points) do not wait
    on one another.
    """
    slack = 1.0 + (queries.shape[1] + 2) * SLACK_PER_AXIS  # slack(k)
    top_k = out_ids.shape[1]
    last = top_k - 1
    sq_row = np.empty(top_k, np.float64)
    id_row = np.empty(top_k, np.int64)
    # The heap grows (doubling) as needed: a query holds few nodes in it, and a small
    # allocation per call keeps one query at a time cheap.
    capacity = min(nodes.shape[0], 1024)
    heap_bound = np.empty(capacity, np.float32)
    heap_a = np.empty(capacity, np.int64)
    heap_b = np.empty(capacity, np.int64)
    for qi in range(queries.shape[0]):
        query = queries[qi]
        sq_row[:] = max_sq
        id_row[:] = SENTINEL
        g = _key_start(query, top_k, edges, digits, prefix_nodes, level_first, nodes, lo, hi)
        measured = 0
        g_start = -1
        if g >= 0:
            g_start = nodes[g, START]
            _measure(points, ids, g_start, nodes[g, END], query, slack, sq_row, id_row)
            measured = nodes[g, END] - g_start
        heap_bound[0], heap_a[0], heap_b[0] = np.float32(0.0), root_a, root_b
        size_heap = 1
        while size_heap > 0:
            bound, item_a, item_b = heap_bound[0], heap_a[0], heap_b[0]
            size_heap -= 1
            if size_heap > 0:  # the last item sifts down from the top
                last_bound = heap_bound[size_heap]
                last_a, last_b = heap_a[size_heap], heap_b[size_heap]
                i = 0
                while True:
                    child = 2 * i + 1
                    if child >= size_heap:
                        break
                    if child + 1 < size_heap and heap_bound[child + 1] < heap_bound[child]:
                        child += 1
                    if heap_bound[child] >= last_bound:
                        break
                    heap_bound[i] = heap_bound[child]
                    heap_a[i], heap_b[i] = heap_a[child], heap_b[child]
                    i = child
                heap_bound[i], heap_a[i], heap_b[i] = last_bound, last_a, last_b
                _prefetch_visit(heap_a[0], heap_b[0], points, ids, codes, frames, kid_a, kid_b)
            if bound > sq_row[last] * slack:
                break  # every bound left is at least as far
            if item_b < 0:  # a leaf: entries item_a … -item_b - 2
                if item_a != g_start:
                    stop = -item_b - 1
                    _measure(points, ids, item_a, stop, query, slack, sq_row, id_row)
                    measured += stop - item_a
                continue
            c_first, frame = item_a, item_b & _FRAME_MASK
            for slot in range(c_first, c_first + (item_b >> _COUNT_SHIFT)):
                kid_bound = _screen_box(codes, slot, frames, frame, query)
                if kid_bound > sq_row[last] * slack:
                    continue
                if size_heap == heap_bound.shape[0]:
                    heap_bound = _grown(heap_bound, size_heap)
                    heap_a = _grown(heap_a, size_heap)
                    heap_b = _grown(heap_b, size_heap)
                i = size_heap  # sift up
                size_heap += 1
                while i > 0:
                    parent = (i - 1) // 2
                    if heap_bound[parent] <= kid_bound:
                        break
                    heap_bound[i] = heap_bound[parent]
                    heap_a[i], heap_b[i] = heap_a[parent], heap_b[parent]
                    i = parent
                heap_bound[i], heap_a[i], heap_b[i] = kid_bound, kid_a[slot], kid_b[slot]
                if i == 0:  # the next visit
                    _prefetch_visit(heap_a[0], heap_b[0], points, ids, codes, frames, kid_a,
                                    kid_b)  # fmt: skip
        examined[qi] = measured
        _write_best(sq_row, id_row, out_ids[qi], out_distances[qi])


def _write_best(sq_row, id_row, ids_out, distances_out):  # pragma: no cover - JIT
    """A query's running best (squared distances, ids) as its answer row: ids and
    distances, ``NO_ENTRY`` and inf in slots nothing filled."""
    for t in range(sq_row.shape[0]):
        if id_row[t] == SENTINEL:
            ids_out[t], distances_out[t] = NO_ENTRY, np.inf
        else:
            ids_out[t], distances_out[t] = id_row[t], np.sqrt(sq_row[t])


def _prefetch_visit(item_a, item_b, points, ids, codes, frames, kid_a,
                    kid_b):  # fmt: skip  # pragma: no cover - JIT
    """Ask the memory for what the visit of heap item ``(item_a, item_b)`` reads (a
    leaf's points and ids; an inner node's frame, children's codes and references), so
    that it arrives while the current visit runs."""
    if item_b < 0:
        n_dims = points.shape[1]
        stop = -item_b - 1
        for offset in range(item_a * n_dims, stop * n_dims, 16):  # 16 float32: 64 bytes
            _prefetch(points, offset)
        _prefetch(points, stop * n_dims - 1)
        _prefetch(ids, item_a)
        _prefetch(ids, stop - 1)
        return
    count, frame = item_b >> _COUNT_SHIFT, item_b & _FRAME_MASK
    width = frames.shape[1] * frames.shape[2]
    for offset in range(frame * width, (frame + 1) * width, 16):
        _prefetch(frames, offset)
    width = codes.shape[1] * codes.shape[2]
    for offset in range(item_a * width, (item_a + count) * width, 64):  # 64 bytes
        _prefetch(codes, offset)
    _prefetch(codes, (item_a + count) * width - 1)
    _prefetch(kid_a, item_a)
    _prefetch(kid_a, item_a + count - 1)
    _prefetch(kid_b, item_a)
    _prefetch(kid_b, item_a + count - 1)


def _prefetch_intrinsic():
    """``_prefetch(array, offset)``: a compiled hint to bring the cache line holding
    item ``offset`` of a C-contiguous ``array`` (counted flat) into the caches."""
    from numba.core import cgutils, types
    from numba.extending import intrinsic

    ir = cgutils.ir  # llvmlite's IR builder, as numba uses it

    @intrinsic
    def prefetch(typingctx, array, offset):
        if not isinstance(array, types.Array) or not isinstance(offset, types.Integer):
            return None

        def codegen(context, builder, signature, args):
            data = context.make_array(signature.args[0])(context, builder, args[0]).data
            pointer = builder.bitcast(builder.gep(data, [args[1]]), cgutils.voidptr_t)
            suffix = "p0" if str(pointer.type) == "ptr" else "p0i8"
            i32 = ir.IntType(32)
            fnty = ir.FunctionType(ir.VoidType(), [pointer.type, i32, i32, i32])
            fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch." + suffix)
            builder.call(fn, [pointer, i32(0), i32(3), i32(1)])  # read, keep, data
            return context.get_dummy_value()

        return types.void(array, offset), codegen

    return prefetch


def _grown(array, size):  # pragma: no cover - JIT
    """A copy of ``array``'s first ``size`` items in an array twice that long."""
    out = np.empty(2 * size, array.dtype)
    out[:size] = array[:size]
    return out


# The shared in-order distance and the running best's insertion
# (:mod:`eigmotion.retrieval.neighbours`), compiled: set by :func:`_compiled`.
_exact_sq = _offer = _prefetch = None

_COMPILING = threading.Lock()


def walk_kernels() -> SimpleNamespace:
    """The compiled walk (numba is imported and it is compiled on first use, once,
    whichever thread asks first): ``walk(points, ids, codes, frames, kid_a, kid_b, root_a,
    root_b, nodes, lo, hi, queries, edges, digits, prefix_nodes, level_first, max_sq,
    out_ids, out_distances, examined)``, and the pieces the flat search
    (:mod:`eigmotion.retrieval.cells`) shares: ``screen_box``, ``measure`` and
    ``write_best``."""
    with _COMPILING:
        return _compiled()


@lru_cache(maxsize=1)
def _compiled() -> SimpleNamespace:
    from numba import njit

    global _box_gap, _screen_box, _screen_point, _measure, _key_start, _walk, _grown
    global _exact_sq, _offer, _prefetch, _prefetch_visit, _write_best
    _prefetch = _prefetch_intrinsic()
    shared = kernels()
    _exact_sq, _offer = shared.row_sq_distance, shared.offer  # compiled already
    plain = njit(cache=True, nogil=True)
    screen = njit(cache=True, nogil=True, fastmath=SCREEN_MATH)
    _box_gap = plain(_box_gap)
    _screen_box = screen(_screen_box)
    _screen_point = screen(_screen_point)
    _measure = plain(_measure)
    _key_start = plain(_key_start)
    _grown = plain(_grown)
    _prefetch_visit = plain(_prefetch_visit)
    _write_best = plain(_write_best)
    _walk = plain(_walk)
    return SimpleNamespace(
        walk=_walk, screen_box=_screen_box, measure=_measure, write_best=_write_best
    )
