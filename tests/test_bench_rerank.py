"""benchmarks/bench_rerank.py: variants of the query-time constants, set and put back,
and the scores it prints (the queries themselves are the engine's, tested in
test_database.py)."""

from __future__ import annotations

import pytest

import eigmotion.database as database_module
import eigmotion.sequences as sequences_module
from eigmotion.errors import InvalidParameterError


@pytest.fixture(scope="module")
def bench(benchmark_script):
    with benchmark_script("bench_rerank") as module:
        yield module


def test_a_variant_names_query_time_constants_only(bench):
    assert bench.parse_variant("PACE_WEIGHT=0,SEQUENCE_WEIGHT=3") == {
        "PACE_WEIGHT": 0.0,
        "SEQUENCE_WEIGHT": 3.0,
    }
    assert bench.parse_variant("") == {}
    for bad in ("RISE_WEIGHT=2", "PACE_WEIGHT", "PACE_WEIGHT=x", "PACE_WEIGHT=inf", "pace=1"):
        with pytest.raises(InvalidParameterError, match="--variant"):
            bench.parse_variant(bad)


def test_a_variant_sets_constants_where_they_are_read_and_puts_them_back(bench):
    weight, motions = sequences_module.PACE_WEIGHT, database_module.CANDIDATE_MOTIONS
    with bench.Variant({"PACE_WEIGHT": 0.0, "CANDIDATE_MOTIONS": 15.0}):
        assert sequences_module.PACE_WEIGHT == 0.0
        # read by both modules: set in both, with the type it had
        assert sequences_module.CANDIDATE_MOTIONS == database_module.CANDIDATE_MOTIONS == 15
        assert isinstance(database_module.CANDIDATE_MOTIONS, int)
    assert sequences_module.PACE_WEIGHT == weight
    assert database_module.CANDIDATE_MOTIONS == sequences_module.CANDIDATE_MOTIONS == motions
    with pytest.raises(RuntimeError), bench.Variant({"SPECIFIC_MARGIN": 0.1}):
        raise RuntimeError("a failed run")
    assert database_module.SPECIFIC_MARGIN != 0.1


def test_scores_count_top_1_and_top_k_per_label(bench):
    clips = [
        bench.HeldOutClip("a", "walk", ("w1",), None, 15.0),
        bench.HeldOutClip("b", "walk", ("w1",), None, 15.0),
        bench.HeldOutClip("c", "run", ("r1",), None, 15.0),
    ]
    answers = [("walk", "run"), ("run", "turn", "jump", "walk"), ("walk", "jump", "run")]
    s = bench.scores(clips, answers)
    assert s["n"] == {"walk": 2, "run": 1}
    assert s["top1"]["walk"] == 1 and s["top1"]["run"] == 0
    assert s["topk"]["walk"] == 1 and s["topk"]["run"] == 1  # the 4th label is not top-3
