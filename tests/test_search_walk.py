"""The key tree's searches — the flat search through its cells and the node walk: their
byte-coded boxes, screens near rounding, ties, tiny trees."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.retrieval.brute_force import brute_force
from eigmotion.retrieval.cells import cell_tables
from eigmotion.retrieval.keys import Quantizer
from eigmotion.retrieval.neighbours import NearestEntries
from eigmotion.retrieval.search import TreeIndex
from eigmotion.retrieval.walk import box_codes

#: (cell_entries, group_entries) of the searches tested: the node walk, small cells
#: and groups (many of each even over a few hundred entries), the defaults.
LAYOUTS = {
    "node walk": (0, TreeIndex.group_entries),
    "small cells": (48, 12),
    "default cells": (TreeIndex.cell_entries, TreeIndex.group_entries),
}


@pytest.fixture(params=list(LAYOUTS))
def layout(request):
    return LAYOUTS[request.param]


def walked(points, ids, leaf_size=4, n_axes=3, n_sections=4, layout=None) -> TreeIndex:
    quantizer = Quantizer(n_axes, n_sections).fit(points)
    tree = TreeIndex.from_arrays(quantizer.keys(points), points, ids, quantizer, leaf_size)
    tree.check()
    if layout is not None:
        tree.cell_entries, tree.group_entries = layout
    return tree


def assert_same(result: NearestEntries, reference: NearestEntries):
    np.testing.assert_array_equal(result.ids, reference.ids)
    np.testing.assert_array_equal(result.distances, reference.distances)


@pytest.mark.parametrize("offset", [0.0, 1e-30, 300.0, -5e4])
def test_box_codes_hold_every_child_box_and_decode_exactly(offset):
    rng = np.random.default_rng(1)
    points = (offset + rng.standard_normal((3000, 6)) * [1, 1e-3, 1e-6, 0, 5, 1]).astype(np.float32)
    tree = walked(points, np.arange(3000))
    parents = np.flatnonzero(tree._child_count > 0)
    frames, codes = box_codes(
        tree._lo, tree._hi, parents, tree._child_first, tree._child_count, tree._child_list
    )
    base, step = frames[:, 0], frames[:, 1]
    owner = np.repeat(np.arange(parents.size), tree._child_count[parents])
    slots = np.concatenate(
        [
            np.arange(f, f + c)
            for f, c in zip(tree._child_first[parents], tree._child_count[parents], strict=True)
        ]
    )
    kids = tree._child_list[slots]
    for corner, inside in ((0, np.less_equal), (1, np.greater_equal)):
        code = codes[slots, corner].astype(np.float32)
        decoded32 = base[owner] + code * step[owner]  # float32 arithmetic, as compiled
        decoded64 = base[owner].astype(np.float64) + code.astype(np.float64) * step[owner]
        np.testing.assert_array_equal(decoded32.astype(np.float64), decoded64)  # exact
        box = tree._lo[kids] if corner == 0 else tree._hi[kids]
        assert np.all(inside(decoded32, box))
    assert np.all(step > 0) and np.all(np.log2(step) == np.round(np.log2(step)))


@pytest.mark.parametrize("offset", [0.0, 300.0, -7000.0])
@pytest.mark.parametrize("leaf_size", [1, 4, 16])
def test_queries_a_rounding_away_from_entries_are_answered_exactly(offset, leaf_size, layout):
    # Entries far from the origin, queries equal to entries or one float32 step away
    # on one or every axis: screens are summed in any order, distances in order, and
    # no rounding may hide the entry brute force finds.
    rng = np.random.default_rng(int(abs(offset)) + leaf_size)
    points = (offset + 1e-3 * rng.standard_normal((2000, 12))).astype(np.float32)
    ids = rng.permutation(5000)[:2000]
    tree = walked(points, ids, leaf_size, layout=layout)
    rows = points[rng.choice(2000, 60)]
    one_axis = rows.copy()
    one_axis[:, 3] = np.nextafter(one_axis[:, 3], np.float32(np.inf))
    every_axis = np.nextafter(rows, np.float32(-np.inf))
    for queries in (rows, one_axis, every_axis):
        for top_k in (1, 3):
            assert_same(tree.walk(queries, top_k), brute_force(points, ids, queries, top_k))
        assert np.all(tree.walk(rows).distances[:, 0] == 0.0)


def test_ties_across_leaves_and_top_k_beyond_a_leaf(layout):
    # Eight copies of every point, ids shuffled: ties broken by id across leaves of 4.
    rng = np.random.default_rng(2)
    points = np.repeat(rng.standard_normal((150, 5)).astype(np.float32), 8, axis=0)
    ids = rng.permutation(len(points))
    tree = walked(points, ids, leaf_size=4, layout=layout)
    queries = np.concatenate([points[::37], points[::41] + 0.01])
    for top_k in (8, 9, 30, 60):  # 60: beyond a small cell too
        found = tree.walk(queries, top_k)
        assert_same(found, brute_force(points, ids, queries, top_k))
    cutoff = float(np.median(found.distances[:, 10]))
    assert_same(
        tree.walk(queries, 30, max_distance=cutoff),
        brute_force(points, ids, queries, 30, max_distance=cutoff),
    )


@pytest.mark.parametrize("n", [1, 2, 3, 17])
def test_tiny_trees(n, layout):
    rng = np.random.default_rng(n)
    points = rng.standard_normal((n, 4)).astype(np.float32)
    ids = np.arange(10, 10 + n)
    tree = walked(points, ids, leaf_size=2, n_axes=2, layout=layout)
    queries = np.concatenate([points, rng.standard_normal((5, 4)).astype(np.float32)])
    for top_k in range(1, n + 1):
        assert_same(tree.walk(queries, top_k), brute_force(points, ids, queries, top_k))
    for max_distance in (0.0, 0.5):
        assert_same(
            tree.walk(queries, n, max_distance=max_distance),
            brute_force(points, ids, queries, n, max_distance=max_distance),
        )


def test_a_batch_equals_its_queries_one_by_one(layout):
    # The batch is walked in key order, in blocks: the answers come back in the
    # queries' own order.
    rng = np.random.default_rng(3)
    points = rng.standard_normal((5000, 10)).astype(np.float32)
    ids = np.arange(5000)
    tree = walked(points, ids, leaf_size=8, n_axes=4, layout=layout)
    tree.query_block = 7
    queries = rng.standard_normal((50, 10)).astype(np.float32)
    batch = tree.walk(queries, 3)
    for i, query in enumerate(queries):
        one = tree.walk(query, 3)
        np.testing.assert_array_equal(one.ids[0], batch.ids[i])
        np.testing.assert_array_equal(one.distances[0], batch.distances[i])
        assert one.examined[0] == batch.examined[i]
    assert_same(batch, brute_force(points, ids, queries, 3))


@pytest.mark.parametrize(("cell_entries", "group_entries"), [(40, 10), (300, 40), (5, 50)])
def test_cells_and_groups_partition_the_entries_and_hold_their_boxes(cell_entries, group_entries):
    rng = np.random.default_rng(4)
    points = (rng.standard_normal((3000, 7)) * [1, 2, 1e-3, 0, 5, 1, 3] + 40).astype(np.float32)
    tree = walked(points, np.arange(3000), leaf_size=4)
    t = cell_tables(tree._size, tree._parent, tree._is_leaf, tree._start, tree._lo, tree._hi,
                    cell_entries, group_entries)  # fmt: skip
    entries = t.leaf_entries
    assert entries[0] == 0 and entries[-1] == 3000 and np.all(np.diff(entries) >= 1)
    assert np.all(np.diff(entries) <= 4)  # the tree's leaves
    group_first = entries[t.group_leaves]  # each group's first entry, then N
    cell_first = group_first[t.cell_groups]
    assert np.all(np.diff(t.group_leaves) >= 1) and np.all(np.diff(t.cell_groups) >= 1)
    groups_above = np.diff(group_first) > min(group_entries, cell_entries)
    cells_above = np.diff(cell_first) > cell_entries
    # A group or cell holds more entries than its limit only when it is one leaf.
    assert np.all(np.diff(t.group_leaves)[groups_above] == 1)
    assert np.all(np.diff(t.group_leaves[t.cell_groups])[cells_above] == 1)
    for c in range(t.cell_lo.shape[1]):  # tight cell boxes
        block = tree.points[cell_first[c] : cell_first[c + 1]]
        np.testing.assert_array_equal(t.cell_lo[:, c], block.min(0))
        np.testing.assert_array_equal(t.cell_hi[:, c], block.max(0))
    levels = (
        (t.cell_frames, t.cell_groups, t.group_codes, group_first),
        (t.group_frames, t.group_leaves, t.leaf_codes, entries),
    )
    for frames, inside, codes, first in levels:  # each decoded box holds its entries
        owner = np.repeat(np.arange(inside.size - 1), np.diff(inside))
        low = frames[owner, 0] + codes[:, 0].astype(np.float32) * frames[owner, 1]
        high = frames[owner, 0] + codes[:, 1].astype(np.float32) * frames[owner, 1]
        for row in range(codes.shape[0]):
            block = tree.points[first[row] : first[row + 1]]
            assert np.all(low[row] <= block.min(0)) and np.all(high[row] >= block.max(0))


def test_far_queries_and_max_distance_through_small_cells():
    # Queries far from every entry (every cell's bound large, nearly equal) and a
    # cutoff that leaves some answers empty, across cells of 30 and groups of 6.
    rng = np.random.default_rng(5)
    points = rng.standard_normal((4000, 9)).astype(np.float32)
    ids = rng.permutation(10_000)[:4000]
    tree = walked(points, ids, leaf_size=3, n_axes=4, layout=(30, 6))
    far = (rng.standard_normal((40, 9)) * 50).astype(np.float32)
    near = points[::97] + 0.05
    for queries in (far, near):
        for top_k in (1, 7, 45):
            assert_same(tree.walk(queries, top_k), brute_force(points, ids, queries, top_k))
    cutoff = 0.3
    for top_k in (1, 45):
        found = tree.walk(near, top_k, max_distance=cutoff)
        assert_same(found, brute_force(points, ids, near, top_k, max_distance=cutoff))
    assert np.any(found.ids == -1)
    assert np.all(tree.walk(far, 3, max_distance=1.0).ids == -1)
    assert np.all(tree.walk(far, 3, max_distance=1.0).examined == 0)
