"""The 2-layer search tree, the exhaustive reference and the coarse-to-fine first search."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from eigmotion.errors import InvalidParameterError
from eigmotion.tracking.search import (
    beam_search,
    build_cluster_tree,
    build_two_layer_tree,
    exhaustive_search,
    farthest_point_sample,
    two_layer_search,
)


class CountingScores:
    """A scoring function over postures that records every call."""

    def __init__(self, values):
        self.values = np.asarray(values, dtype=float)
        self.calls: list[np.ndarray] = []

    def __call__(self, items):
        self.calls.append(np.asarray(items))
        return self.values[items]


def line_tree(m, t):
    """Candidates 0..m-1 on a line (distance = |i - j|), nearest first."""
    pos = np.arange(m, dtype=float)
    return build_two_layer_tree(np.arange(m), np.abs(pos[:, None] - pos[None, :]), t)


def test_tree_layout():
    tree = line_tree(8, 3)
    np.testing.assert_array_equal(tree.layer1, [0, 3, 6])
    # 1 -> 0 (distance 1 vs 2); 2 -> 3; 4 -> 3; 5 -> 6; 7 -> 6
    np.testing.assert_array_equal(tree.parent, [0, 0, 1, 1, 1, 2, 2, 2])
    np.testing.assert_array_equal(tree.children(1), [2, 4])


def test_search_scores_layer1_then_children_of_the_best():
    values = np.array([0.1, 0.2, 0.9, 0.3, 0.95, 0.0, 0.5, 0.4])
    scores = CountingScores(values)
    result = two_layer_search(line_tree(8, 3), scores, top_k=1)
    np.testing.assert_array_equal(scores.calls[0], [0, 3, 6])
    # best layer-1: 6 (0.5) -> children 5, 7
    np.testing.assert_array_equal(scores.calls[1], [5, 7])
    assert result.best == 6 and result.n_evaluations == 5
    # with k = 2 the children of 3 (2 and 4) are scored too and 4 wins
    result = two_layer_search(line_tree(8, 3), CountingScores(values), top_k=2)
    assert result.best == 4 and result.score == pytest.approx(0.95)


@settings(max_examples=60, deadline=None)
@given(
    m=st.integers(1, 45),
    t=st.integers(1, 6),
    seed=st.integers(0, 10_000),
)
def test_tree_equals_exhaustive_when_k_covers_layer1(m, t, seed):
    rng = np.random.default_rng(seed)
    values = rng.normal(size=m)
    points = rng.normal(size=(m, 3))
    distances = np.linalg.norm(points[:, None] - points[None], axis=-1)
    tree = build_two_layer_tree(np.arange(m), distances, t)
    k = len(tree.layer1)
    got = two_layer_search(tree, CountingScores(values), top_k=k)
    ref = exhaustive_search(np.arange(m), CountingScores(values))
    assert got.best == ref.best and got.score == ref.score
    assert sorted(got.evaluated.tolist()) == list(range(m))


@pytest.mark.parametrize("t, k", [(3, 3), (2, 1), (4, 2)])
def test_tree_scores_fewer_postures(t, k):
    m = 40
    scores = CountingScores(np.random.default_rng(0).normal(size=m))
    result = two_layer_search(line_tree(m, t), scores, top_k=k)
    layer1 = -(-m // t)
    assert result.n_evaluations <= layer1 + k * (2 * t)
    assert len(set(result.evaluated.tolist())) == result.n_evaluations


def test_beam_search_finds_a_smooth_optimum():
    rng = np.random.default_rng(2)
    points = rng.uniform(-1, 1, size=(3000, 2))
    target = np.array([0.31, -0.42])
    values = -np.linalg.norm(points - target, axis=1)

    def distance_to(a, items):
        return np.linalg.norm(points[items] - points[a], axis=1)

    tree = build_cluster_tree(np.arange(3000), distance_to, branching=16)
    assert len(tree) == 16
    scores = CountingScores(values)
    result = beam_search(tree, scores, beam=3)
    assert np.linalg.norm(points[result.best] - target) < 0.05
    assert result.n_evaluations < 300
    assert len(set(result.evaluated.tolist())) == result.n_evaluations


def test_cluster_tree_holds_every_item_once():
    pts = np.random.default_rng(5).normal(size=(500, 3))

    def distance_to(a, items):
        return np.linalg.norm(pts[items] - pts[a], axis=1)

    tree = build_cluster_tree(np.arange(500), distance_to, branching=8)
    seen = []

    def walk(nodes, depth):
        assert len(nodes) <= 8
        for node in nodes:
            seen.append(node.item)
            walk(node.children, depth + 1)

    walk(tree, 0)
    assert sorted(seen) == list(range(500))
    # with beam = branching every posture is scored: the exhaustive answer
    values = np.random.default_rng(6).normal(size=500)
    result = beam_search(tree, CountingScores(values), beam=8**3)
    assert result.best == int(np.argmax(values)) and result.n_evaluations == 500


def test_farthest_point_sample_covers_items():
    pts = np.array([0.0, 0.1, 5.0, 5.1, 10.0])

    def distance_to(a, items):
        return np.abs(pts[items] - pts[a])

    picks, owner = farthest_point_sample(np.arange(5), distance_to, 3)
    assert picks.tolist() == [0, 4, 2]  # the first item, then the farthest each time
    np.testing.assert_array_equal(picks[owner], [0, 0, 2, 2, 4])


def test_errors():
    with pytest.raises(InvalidParameterError, match="layer_step"):
        build_two_layer_tree(np.arange(3), np.zeros((3, 3)), 0)
    with pytest.raises(InvalidParameterError, match="distances"):
        build_two_layer_tree(np.arange(3), np.zeros((2, 2)), 1)
    with pytest.raises(InvalidParameterError, match="top_k"):
        two_layer_search(line_tree(3, 1), CountingScores([0, 1, 2]), 0)
    with pytest.raises(InvalidParameterError, match="branching"):
        build_cluster_tree(np.arange(3), lambda a, items: np.zeros(len(items)), 1)
    with pytest.raises(InvalidParameterError, match="beam"):
        beam_search((), CountingScores([]), 0)
    with pytest.raises(InvalidParameterError, match="no candidate"):
        exhaustive_search(np.zeros(0, np.int64), CountingScores([]))
    with pytest.raises(InvalidParameterError, match="returned"):
        exhaustive_search(np.arange(3), lambda items: np.zeros(2))
