"""eigmotion.evaluation.label_ranking (behind benchmarks/studies/bench_sequence_matching.py):
per-motion nearest and ranked labels (its time warping and sequences are the engine's,
tested in test_sequences.py)."""

from __future__ import annotations

import numpy as np

from eigmotion.evaluation.label_ranking import per_motion_min, ranked_labels_of


def test_per_motion_min_and_ranked_labels():
    distances = np.array([0.5, 0.2, 0.9, 0.3, 0.1])
    motion_of = np.array([0, 0, 1, 2, 2])
    nearest = per_motion_min(distances, motion_of, 4)
    np.testing.assert_array_equal(nearest, [0.2, 0.9, 0.1, np.inf])
    labels = np.array(["walk", "run", "walk", "jump"])
    # Motion 2 (walk) nearest, then motion 0 (walk again), then run; jump is absent.
    assert ranked_labels_of(nearest, labels) == ["walk", "run"]
