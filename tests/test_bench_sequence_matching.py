"""The distances of benchmarks/bench_sequence_matching.py: time warping, per-motion
nearest, ranked labels, and the person-frame silhouette sequence."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def bench(benchmark_script):
    with benchmark_script("bench_sequence_matching") as module:
        yield module


def _poses(n: int, rng) -> np.ndarray:
    return rng.random((n, 6)).astype(np.float32)


def test_dtw_of_a_sequence_with_itself_is_zero(bench):
    a = _poses(12, np.random.default_rng(0))
    assert bench.dtw_distance(a, a) == 0.0


def test_dtw_ignores_a_change_of_pace(bench):
    a = _poses(10, np.random.default_rng(1))
    slow = np.repeat(a, 3, axis=0)  # every pose held three times as long
    assert bench.dtw_distance(a, slow) == pytest.approx(0.0, abs=1e-12)
    # Frame by frame the two differ: a lock-step distance would not be zero.
    assert np.linalg.norm(a - slow[: len(a)], axis=1).sum() > 0.1


def test_dtw_is_symmetric_and_orders_by_similarity(bench):
    rng = np.random.default_rng(2)
    a = _poses(15, rng)
    near = a + 0.01 * rng.standard_normal(a.shape).astype(np.float32)
    far = _poses(15, rng)
    assert bench.dtw_distance(a, far) == pytest.approx(bench.dtw_distance(far, a))
    assert bench.dtw_distance(a, near) < bench.dtw_distance(a, far)


def test_dtw_equals_the_path_cost_by_hand(bench):
    a = np.array([[0.0], [1.0]], dtype=np.float32)
    b = np.array([[0.0], [2.0], [1.0]], dtype=np.float32)
    # Best path (0,0) (1,1) (1,2): costs 0 + 1 + 0, over 2 + 3 frames.
    assert bench.dtw_distance(a, b) == pytest.approx(1.0 / 5.0)


def test_per_motion_min_and_ranked_labels(bench):
    distances = np.array([0.5, 0.2, 0.9, 0.3, 0.1])
    motion_of = np.array([0, 0, 1, 2, 2])
    nearest = bench.per_motion_min(distances, motion_of, 4)
    np.testing.assert_array_equal(nearest, [0.2, 0.9, 0.1, np.inf])
    labels = np.array(["walk", "run", "walk", "jump"])
    # Motion 2 (walk) nearest, then motion 0 (walk again), then run; jump is absent.
    assert bench.ranked_labels_of(nearest, labels) == ["walk", "run"]


def test_silhouette_sequence_shape_and_rate(bench):
    from eigmotion.build import BuildConfig
    from eigmotion.scene import stick_figure_masks

    masks = stick_figure_masks(60, 120, 160, fps=30.0)  # 2 s at 30 fps
    sequence = bench.silhouette_sequence(masks, 30.0, BuildConfig())
    # Sampled at the motion image's 15 frames/s, 16 × 16 pixels per frame.
    assert sequence.shape == (30, bench.SEQUENCE_SIZE**2)
    assert sequence.dtype == np.float32
    assert 0.0 <= sequence.min() and sequence.max() <= 1.0
    assert np.all(sequence.sum(axis=1) > 0)  # the person is in every frame
