"""benchmarks/bench_sequence_matching.py: per-motion nearest and ranked labels (its
time warping and sequences are the engine's, tested in test_sequences.py)."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def bench(benchmark_script):
    with benchmark_script("bench_sequence_matching") as module:
        yield module


def test_per_motion_min_and_ranked_labels(bench):
    distances = np.array([0.5, 0.2, 0.9, 0.3, 0.1])
    motion_of = np.array([0, 0, 1, 2, 2])
    nearest = bench.per_motion_min(distances, motion_of, 4)
    np.testing.assert_array_equal(nearest, [0.2, 0.9, 0.1, np.inf])
    labels = np.array(["walk", "run", "walk", "jump"])
    # Motion 2 (walk) nearest, then motion 0 (walk again), then run; jump is absent.
    assert bench.ranked_labels_of(nearest, labels) == ["walk", "run"]
