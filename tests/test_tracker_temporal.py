"""The Viterbi path over each frame's best candidates (temporal decision)."""

from __future__ import annotations

import numpy as np
import pytest
from test_tracker_tracking import cmu, mpjpe_mm, walk_setup  # noqa: F401 - fixtures

from eigmotion.errors import InvalidParameterError
from eigmotion.tracking.temporal import viterbi_path
from eigmotion.tracking.tracker import SilhouetteTracker, TrackerConfig

# three postures: 0 and 1 close (10° apart), 2 far from both (90°)
VECTORS = np.array([[0.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 90.0]])


def test_path_trades_score_for_continuity():
    candidates = [np.array([0, 2]), np.array([2, 1]), np.array([1, 2])]
    scores = [np.array([1.0, 0.9]), np.array([1.05, 1.0]), np.array([1.0, 0.5])]
    # no transition cost: the best of each frame (greedy)
    assert viterbi_path(candidates, scores, VECTORS, 0.0).tolist() == [0, 0, 0]
    # a cost of 0.1 per 30°: the jump to posture 2 and back (2 × 0.3) is not worth 0.05
    assert viterbi_path(candidates, scores, VECTORS, 0.1).tolist() == [0, 1, 0]
    assert viterbi_path([], [], VECTORS, 0.1).tolist() == []
    with pytest.raises(InvalidParameterError, match="weight"):
        viterbi_path(candidates, scores, VECTORS, -1.0)
    with pytest.raises(InvalidParameterError, match="candidates"):
        viterbi_path([np.array([], np.int64)], [np.array([])], VECTORS, 0.1)


def test_tracker_on_the_best_path(walk_setup):  # noqa: F811 - fixture
    dictionary, bodies, cams, masks, truth, _ = walk_setup
    greedy = SilhouetteTracker(dictionary, cams, bodies).track(masks, frame_time_s=1 / 25)
    config = TrackerConfig(path_candidates=5, path_weight=0.0)
    same = SilhouetteTracker(dictionary, cams, bodies, config).track(masks, frame_time_s=1 / 25)
    assert np.array_equal(same.entries, greedy.entries)  # no cost: the greedy choice
    assert all(len(e.alternatives) == 5 and e.entry == e.alternatives[0] for e in same.estimates)
    config = TrackerConfig(path_candidates=5, path_weight=1.0)
    path = SilhouetteTracker(dictionary, cams, bodies, config).track(masks, frame_time_s=1 / 25)
    assert np.all(np.isin(path.entries, [e.alternatives for e in path.estimates]))
    jumps = [
        np.abs(np.diff(dictionary.vectors[r.entries], axis=0)).max(axis=1).sum()
        for r in (greedy, path)
    ]
    assert jumps[1] < jumps[0]  # a smoother sequence of postures
    assert mpjpe_mm(path, truth) < 80.0
