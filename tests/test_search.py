"""Exact search through the key tree: equal to brute force, ties, errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from eigmotion.errors import InvalidParameterError
from eigmotion.retrieval.brute_force import BruteForceIndex, brute_force
from eigmotion.retrieval.keys import Quantizer
from eigmotion.retrieval.neighbours import (
    NearestEntries,
    kernels,
    pair_sq_distances,
    sq_distances_in_order,
)
from eigmotion.retrieval.search import TreeIndex

REPO = Path(__file__).resolve().parents[1]


def motion_like(n: int, n_dims: int, n_groups: int, rng) -> np.ndarray:
    """(n, n_dims) float32 points drawn like motion-image points.

    Eigenvalue-like decaying spread per axis (std ∝ 1/√axis); ``n_groups`` clusters
    (one per motion and view), each a smooth random walk (time windows sliding along
    the motion) plus a little noise.
    """
    scale = (1.0 / np.sqrt(np.arange(1, n_dims + 1))).astype(np.float32)
    per = -(-n // n_groups)
    centres = rng.standard_normal((n_groups, 1, n_dims), dtype=np.float32) * scale
    walk = rng.standard_normal((n_groups, per, n_dims), dtype=np.float32) * (0.03 * scale)
    walk = np.cumsum(walk, axis=1)
    walk += centres
    walk += rng.standard_normal(walk.shape, dtype=np.float32) * (0.02 * scale)
    return walk.reshape(-1, n_dims)[:n]


def queries_like(points: np.ndarray, n: int, rng, unknown: float = 0.1) -> np.ndarray:
    """(n, k) queries: known motions (an entry plus noise) and some unknown ones."""
    n_dims = points.shape[1]
    scale = 1.0 / np.sqrt(np.arange(1, n_dims + 1))
    known = points[rng.integers(0, len(points), n)] + 0.03 * scale * rng.standard_normal(
        (n, n_dims)
    )
    fresh = rng.random(n) < unknown
    known[fresh] = scale * rng.standard_normal((int(fresh.sum()), n_dims))
    return known


def naive(points, ids, queries, top_k):
    """Every distance by the shared formula, sorted by (distance, id)."""
    p = np.asarray(points, dtype=np.float32)
    out_ids, out_d = [], []
    for q in np.atleast_2d(queries).astype(np.float32):
        sq = pair_sq_distances(p.copy(), q)
        order = np.lexsort((ids, sq))[:top_k]
        out_ids.append(ids[order])
        out_d.append(np.sqrt(sq[order].astype(np.float64)))
    return np.array(out_ids), np.array(out_d)


def assert_same(result: NearestEntries, reference: NearestEntries):
    np.testing.assert_array_equal(result.ids, reference.ids)
    np.testing.assert_array_equal(result.distances, reference.distances)


def tree_of(points, ids, n_axes=4, n_sections=8, method="quantile", leaf_size=32, scan=False):
    """The tree over ``points``; batches are walked, never scanned, unless ``scan``."""
    quantizer = Quantizer(n_axes, n_sections, method).fit(points)
    tree = TreeIndex.from_arrays(quantizer.keys(points), points, ids, quantizer, leaf_size)
    if not scan:
        tree.scan_entries = 0
    tree.walk_top_k = 0  # scanned whether or not numba is loaded
    return tree


@pytest.mark.slow
def test_equals_brute_force_on_a_million_points():
    rng = np.random.default_rng(20)
    points = motion_like(1_000_000, 20, 2000, rng)
    ids = np.arange(points.shape[0])
    tree = tree_of(points, ids, n_axes=4, n_sections=8)
    queries = queries_like(points, 10_000, rng, unknown=0.02)
    found = tree.search(queries)
    # Multi-threaded BLAS on small blocks is slower on a busy machine, not faster.
    with threadpool_limits(limits=1):
        reference = BruteForceIndex.from_arrays(points, ids).search(queries)
    assert_same(found, reference)
    # Exact, yet it looked at a small fraction of the entries.
    assert np.median(found.examined) < 0.001 * points.shape[0]
    assert found.examined.mean() < 0.01 * points.shape[0]


@pytest.mark.parametrize("method", ["quantile", "equal"])
@pytest.mark.parametrize(("n_axes", "n_sections"), [(1, 2), (2, 16), (3, 8), (6, 4), (8, 8)])
@pytest.mark.parametrize("top_k", [1, 5])
def test_equals_brute_force(method, n_axes, n_sections, top_k):
    rng = np.random.default_rng(n_axes * 100 + n_sections)
    points = motion_like(3000, 12, 20, rng)
    ids = rng.permutation(10_000)[:3000]  # ids in no particular order
    tree = tree_of(points, ids, n_axes, n_sections, method, leaf_size=16)
    tree.check()
    queries = queries_like(points, 300, rng, unknown=0.2)
    found = tree.search(queries, top_k)
    assert found.ids.shape == found.distances.shape == (300, top_k)
    assert_same(found, brute_force(points, ids, queries, top_k))
    assert np.all(found.examined >= top_k)
    assert np.all(np.diff(found.distances, axis=1) >= 0)


@pytest.mark.parametrize("leaf_size", [1, 3, 64, 5000])
@pytest.mark.parametrize("top_k", [1, 40])
def test_leaf_sizes_and_large_top_k(leaf_size, top_k):
    rng = np.random.default_rng(leaf_size)
    points = motion_like(2000, 8, 10, rng)
    ids = np.arange(2000)
    tree = tree_of(points, ids, 3, 8, leaf_size=leaf_size)
    tree.check()
    queries = queries_like(points, 100, rng)
    assert_same(tree.search(queries, top_k), brute_force(points, ids, queries, top_k))


def renderings_like(n_motions: int, n_dims: int, rng, clothing: float = 0.0) -> np.ndarray:
    """(n_motions · 6 · 12, n_dims) float32 points shaped like a database's motion images.

    Each motion is a smooth sheet over 6 time windows × 12 views (a bilinear patch
    between random corners, bent by a sine over the views), the spread per axis
    falling like the default database's eigenvalues (0.26 … 0.04 over 40 axes);
    ``clothing`` adds the offset of another rendering of the same motions.
    """
    scale = (0.26 / np.sqrt(np.arange(1, n_dims + 1))).astype(np.float32)
    corners = rng.standard_normal((n_motions, 4, n_dims)).astype(np.float32) * scale
    u = np.linspace(0.0, 1.0, 6, dtype=np.float32)[:, None, None]
    v = np.linspace(0.0, 1.0, 12, dtype=np.float32)[None, :, None]
    bend = np.sin(2 * np.pi * v).astype(np.float32)
    out = []
    for c in corners:
        sheet = (1 - u) * (1 - v) * c[0] + u * (1 - v) * c[1] + (1 - u) * v * c[2]
        sheet = sheet + u * v * c[3] + 0.3 * bend * scale
        out.append(sheet.reshape(-1, n_dims))
    points = np.concatenate(out)
    points += clothing * scale * rng.standard_normal(points.shape).astype(np.float32)
    return points.astype(np.float32)


@pytest.mark.parametrize(("n_dims", "leaf_size"), [(40, 16), (40, 1), (40, 100), (3, 16)])
@pytest.mark.parametrize(("n_axes", "n_sections"), [(4, 8), (10, 4)])
def test_equals_brute_force_on_rendering_like_points(n_dims, leaf_size, n_axes, n_sections):
    # Sheets of windows × views per motion, a flat eigenvalue spectrum, leaves wider
    # than one vector block (100) and fewer axes (3) than are summed before dropping.
    rng = np.random.default_rng(n_dims + leaf_size)
    motions = renderings_like(60, n_dims, rng)
    points = motions + 0.01 * rng.standard_normal(motions.shape).astype(np.float32)
    ids = rng.permutation(len(points) * 2)[: len(points)]
    tree = tree_of(points, ids, min(n_axes, n_dims), n_sections, leaf_size=leaf_size)
    tree.check()
    np.testing.assert_array_equal(np.sort(tree.points, axis=0), np.sort(points, axis=0))
    # Known motions: the same sheets rendered again (other noise); unknown: new motions.
    known = motions[rng.choice(len(motions), 150)] + 0.02 * rng.standard_normal((150, n_dims))
    unknown = renderings_like(3, n_dims, rng)[rng.choice(216, 50)]
    for queries in (known, unknown):
        for top_k in (1, 7, 40):
            assert_same(tree.search(queries, top_k), brute_force(points, ids, queries, top_k))
    one = tree.search(known[0], 7)
    assert_same(one, brute_force(points, ids, known[0], 7))


def test_small_databases_are_scanned_without_building_the_tree():
    rng = np.random.default_rng(8)
    points = renderings_like(40, 40, rng)
    ids = np.arange(len(points))
    tree = tree_of(points, ids, scan=True)
    queries = points[rng.choice(len(points), 64)] + 0.01
    for batch in (queries[:1], queries[:5], queries):  # measured exactly, then screened
        scanned = tree.search(batch, 5)
        assert np.all(scanned.examined == len(points))  # says it scanned
        assert_same(scanned, brute_force(points, ids, batch, 5))
    cut = tree.search(queries, 5, max_distance=0.05)
    assert np.all(cut.examined == len(points))
    assert_same(cut, brute_force(points, ids, queries, 5, max_distance=0.05))
    assert not tree._built  # nothing walked yet: the tree was never built
    walked = tree.walk(queries, 5)
    assert tree._built
    assert_same(walked, tree.search(queries, 5))
    assert np.all(walked.examined < len(points))
    tree.scan_entries = len(points) - 1
    assert np.all(tree.search(queries, 5).examined < len(points))
    tree.scan_entries, tree.walk_top_k = len(points), 5  # numba is loaded: walked
    kernels()
    assert np.all(tree.search(queries, 5).examined < len(points))
    assert np.all(tree.search(queries, 6).examined == len(points))


@pytest.mark.parametrize("scan", [True, False])
def test_prepare_readies_the_first_search_and_changes_no_answer(scan):
    rng = np.random.default_rng(12)
    points = renderings_like(12, 16, rng)
    ids = np.arange(len(points))
    queries = points[rng.choice(len(points), 40)] + 0.01
    prepared, fresh = tree_of(points, ids, scan=scan), tree_of(points, ids, scan=scan)
    prepared.prepare()
    assert prepared._built is not scan  # a walked index's tree is built; a scanned one's not
    prepared.prepare()  # a second call finds it ready
    for batch in (queries[:1], queries):
        assert_same(prepared.search(batch, 5), fresh.search(batch, 5))
        assert_same(prepared.search(batch, 5), brute_force(points, ids, batch, 5))


def test_numpy_distances_equal_the_compiled_ones_bit_for_bit(rng):
    points = (rng.standard_normal((3000, 40)) * np.logspace(0, -3, 40)).astype(np.float32)
    queries = (rng.standard_normal((3000, 40)) * np.logspace(0, -3, 40)).astype(np.float32)
    compiled = np.empty(3000, np.float32)
    kernels().pair_sq_distances(points, queries, compiled)
    np.testing.assert_array_equal(sq_distances_in_order(points.T, queries.T), compiled)
    kernels().pair_sq_distances(points, queries[:1], compiled)
    np.testing.assert_array_equal(sq_distances_in_order(points.T, queries[:1].T), compiled)


def test_a_small_database_is_searched_without_numba(tmp_path):
    """A new process searching a small tree never imports numba (about 1 s to load)."""
    code = """
import sys
import numpy as np
from eigmotion.retrieval.keys import Quantizer
from eigmotion.retrieval.search import TreeIndex
rng = np.random.default_rng(3)
points = rng.standard_normal((5000, 12)).astype(np.float32)
quantizer = Quantizer(4, 8, "quantile").fit(points)
tree = TreeIndex.from_arrays(quantizer.keys(points), points, np.arange(5000), quantizer)
tree.prepare()  # as a query of a video does beside its silhouettes
for n in (1, 5, 40):
    found = tree.search(points[:n] + 0.01, top_k=9, max_distance=2.0)
    assert (found.examined == 5000).all() and (found.ids[:, 0] >= 0).all()
print("numba" in sys.modules)
"""
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True
    )
    assert done.stdout.strip() == "False", done.stderr


def test_brute_force_equals_naive_scan(rng):
    points = motion_like(5000, 10, 5, rng)
    ids = rng.permutation(5000)
    queries = queries_like(points, 50, rng)
    for top_k in (1, 7):
        result = brute_force(points, ids, queries, top_k)
        want_ids, want_d = naive(points, ids, queries, top_k)
        np.testing.assert_array_equal(result.ids, want_ids)
        np.testing.assert_array_equal(result.distances, want_d)
        assert np.all(result.examined == 5000)


def test_points_far_from_the_origin_screen_exactly():
    # Large norms and tiny gaps stress the float32 screen of brute force.
    rng = np.random.default_rng(3)
    points = (1000.0 + 1e-3 * rng.standard_normal((3000, 6))).astype(np.float32)
    ids = np.arange(3000)
    queries = points[:40] + 1e-4
    want_ids, want_d = naive(points, ids, queries, 3)
    result = brute_force(points, ids, queries, 3)
    np.testing.assert_array_equal(result.ids, want_ids)
    np.testing.assert_array_equal(result.distances, want_d)
    assert_same(tree_of(points, ids, 2, 8, leaf_size=8).search(queries, 3), result)


def test_ties_are_broken_by_id():
    # Duplicated points under shuffled ids, and points equidistant from the query.
    base = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 5.0]])
    points = np.repeat(base, 10, axis=0).astype(np.float32)
    ids = np.random.default_rng(1).permutation(np.arange(100, 140))
    tree = tree_of(points, ids, 2, 4, leaf_size=2)
    query = np.zeros(3)
    found = tree.search(query, top_k=30)
    near = np.sort(ids[:30])  # the 30 entries at distance 1, in id order
    np.testing.assert_array_equal(found.ids[0], near)
    np.testing.assert_array_equal(found.distances[0], np.ones(30))
    assert_same(found, brute_force(points, ids, query, 30))
    on_point = tree.search(base[3], top_k=3)
    np.testing.assert_array_equal(on_point.ids[0], np.sort(ids[30:])[:3])
    assert np.all(on_point.distances == 0)


def test_single_query_shape_and_from_store_equivalence(rng):
    points = motion_like(500, 6, 4, rng)
    ids = np.arange(500)
    tree = tree_of(points, ids, 2, 8)
    one = tree.search(points[7])
    assert one.ids.shape == (1, 1) and one.ids[0, 0] == 7 and one.distances[0, 0] == 0
    assert one.examined.shape == (1,)
    assert tree.n_entries == 500 and tree.n_dims == 6
    assert 1 <= tree.n_bins <= 64 and tree.n_leaves >= 500 // 32


def test_examines_few_entries_on_clustered_data():
    rng = np.random.default_rng(5)
    points = motion_like(100_000, 24, 200, rng)
    ids = np.arange(100_000)
    tree = tree_of(points, ids, 4, 8)
    queries = queries_like(points, 300, rng, unknown=0.0)
    found = tree.search(queries)
    assert_same(found, brute_force(points, ids, queries))
    assert found.examined.mean() < 0.01 * 100_000


def test_search_errors(rng):
    points = motion_like(100, 5, 2, rng)
    ids = np.arange(100)
    tree = tree_of(points, ids, 2, 4)
    for bad, match in [
        (np.zeros(4), r"\(5,\)"),
        (np.zeros((2, 6)), r"\(Q, 5\)"),
        (np.array([0, 0, np.nan, 0, 0]), "query 0"),
    ]:
        with pytest.raises(InvalidParameterError, match=match):
            tree.search(bad)
    for top_k in (0, 101, 2.0, True):
        with pytest.raises(InvalidParameterError, match="top_k"):
            tree.search(points[0], top_k)
    quantizer = tree.quantizer
    keys = quantizer.keys(points)
    with pytest.raises(InvalidParameterError, match="differ from the quantizer"):
        TreeIndex.from_arrays(keys[::-1], points, ids, quantizer)
    with pytest.raises(InvalidParameterError, match="unique"):
        TreeIndex.from_arrays(keys, points, np.zeros(100, dtype=int), quantizer)
    with pytest.raises(InvalidParameterError, match="leaf_size"):
        TreeIndex.from_arrays(keys, points, ids, quantizer, leaf_size=0)
    with pytest.raises(InvalidParameterError, match="NaN"):
        TreeIndex.from_arrays(keys, np.where(points > 0.5, np.nan, points), ids, quantizer)
    with pytest.raises(TypeError):
        TreeIndex()


def test_empty_index_refuses_queries():
    quantizer = Quantizer(1, 2).fit(np.zeros((1, 3)))
    tree = TreeIndex.from_arrays(np.zeros(0, int), np.zeros((0, 3)), np.zeros(0, int), quantizer)
    assert tree.n_entries == 0 and tree.n_bins == 0
    with pytest.raises(InvalidParameterError, match="exceeds the 0 entries"):
        tree.search(np.zeros(3))


@pytest.mark.parametrize("top_k", [1, 3])
def test_max_distance_cuts_like_brute_force(top_k):
    rng = np.random.default_rng(9)
    points = motion_like(20_000, 16, 40, rng)
    ids = np.arange(20_000)
    tree = tree_of(points, ids, 4, 8)
    queries = queries_like(points, 400, rng, unknown=0.5)
    full = brute_force(points, ids, queries, top_k)
    cutoff = float(np.median(full.distances[:, -1]))
    found = tree.search(queries, top_k, max_distance=cutoff)
    assert_same(found, brute_force(points, ids, queries, top_k, max_distance=cutoff))
    inside = full.distances <= cutoff
    np.testing.assert_array_equal(found.ids, np.where(inside, full.ids, -1))
    np.testing.assert_array_equal(found.distances, np.where(inside, full.distances, np.inf))
    unknown = ~inside[:, 0]
    # Queries with nothing near stop early instead of scanning far.
    assert found.examined[unknown].mean() < 0.2 * full.examined[0]
    assert found.examined[unknown].mean() < tree.search(queries[unknown]).examined.mean()


def test_max_distance_keeps_entries_exactly_at_the_cutoff():
    points = np.array([[1.0, 0.0], [0.0, 1.0], [3.0, 0.0]], dtype=np.float32)
    ids = np.array([7, 3, 5])
    tree = tree_of(points, ids, 1, 2, leaf_size=1)
    at = tree.search(np.zeros(2), top_k=3, max_distance=1.0)
    np.testing.assert_array_equal(at.ids, [[3, 7, -1]])
    np.testing.assert_array_equal(at.distances, [[1.0, 1.0, np.inf]])
    below = tree.search(np.zeros(2), top_k=2, max_distance=0.999)
    np.testing.assert_array_equal(below.ids, [[-1, -1]])
    assert_same(below, brute_force(points, ids, np.zeros(2), 2, max_distance=0.999))
    for bad in (-1.0, float("nan"), "far"):
        with pytest.raises(InvalidParameterError, match="max_distance"):
            tree.search(np.zeros(2), max_distance=bad)


def test_keys_left_unchecked_are_checked_by_the_first_walk():
    rng = np.random.default_rng(5)
    points = rng.standard_normal((600, 6)).astype(np.float32)
    quantizer = Quantizer(3, 4, "quantile").fit(points)
    keys = quantizer.keys(points)
    keys[17] = keys[17] + 1 if keys[17] < keys.max() else keys[17] - 1
    ids = np.arange(600)
    with pytest.raises(InvalidParameterError, match="keys differ"):
        TreeIndex.from_arrays(keys, points, ids, quantizer)
    tree = TreeIndex.from_arrays(keys, points, ids, quantizer, check_keys=False)
    tree.walk_top_k = 0  # scanned, whether or not numba is loaded
    assert_same(tree.search(points[:3], 4), brute_force(points, ids, points[:3], 4))
    with pytest.raises(InvalidParameterError, match="1 of 600 keys differ"):
        tree.walk(points[:3], 4)
