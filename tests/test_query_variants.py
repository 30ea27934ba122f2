"""eigmotion.evaluation.query_variants (behind benchmarks/accuracy/bench_rerank.py):
variants of the query-time constants, set and put back, and the scores it reports (the
queries themselves are the engine's, tested in test_database.py)."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import eigmotion.evaluation.query_variants as variants
import eigmotion.retrieval.database as database_module
import eigmotion.retrieval.query_windows as query_windows_module
import eigmotion.retrieval.sequences as sequences_module
from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.scoring import QueryOutcome
from eigmotion.evaluation.segments import SegmentAgreement
from eigmotion.retrieval.database import (
    QUERY_SILHOUETTE_CONFIG,
    QUERY_SILHOUETTE_MIN_SIDE_PX,
    QUERY_SILHOUETTE_SIDE_PX,
)
from eigmotion.segmentation.config import SilhouetteConfig

REPO = Path(__file__).resolve().parents[1]


def test_a_variant_names_query_time_constants_only():
    assert variants.parse_variant("PACE_WEIGHT=0,SEQUENCE_WEIGHT=3") == {
        "PACE_WEIGHT": 0.0,
        "SEQUENCE_WEIGHT": 3.0,
    }
    assert variants.parse_variant("") == {}
    for bad in ("RISE_WEIGHT=2", "PACE_WEIGHT", "PACE_WEIGHT=x", "PACE_WEIGHT=inf", "pace=1"):
        with pytest.raises(InvalidParameterError, match="--variant"):
            variants.parse_variant(bad)


def test_a_variant_sets_constants_where_they_are_read_and_puts_them_back():
    weight, motions = sequences_module.PACE_WEIGHT, database_module.CANDIDATE_MOTIONS
    with variants.Variant({"PACE_WEIGHT": 0.0, "CANDIDATE_MOTIONS": 15.0}):
        assert sequences_module.PACE_WEIGHT == 0.0
        # read by both modules: set in both, with the type it had
        assert sequences_module.CANDIDATE_MOTIONS == database_module.CANDIDATE_MOTIONS == 15
        assert isinstance(database_module.CANDIDATE_MOTIONS, int)
    assert sequences_module.PACE_WEIGHT == weight
    assert database_module.CANDIDATE_MOTIONS == sequences_module.CANDIDATE_MOTIONS == motions
    with pytest.raises(RuntimeError), variants.Variant({"SPECIFIC_MARGIN": 0.1}):
        raise RuntimeError("a failed run")
    assert query_windows_module.SPECIFIC_MARGIN != 0.1


def test_silhouette_settings_change_the_query_cut_and_are_checked():
    assert variants.parse_silhouette_setting("low_factor=2.5") == ("low_factor", 2.5)
    assert variants.parse_silhouette_setting("shadow_ratio=[0.35, 0.85]") == (
        "shadow_ratio",
        [0.35, 0.85],
    )
    assert variants.parse_silhouette_setting("background=median") == ("background", "median")
    with pytest.raises(InvalidParameterError, match="NAME=VALUE"):
        variants.parse_silhouette_setting("low_factor")
    # the query's own cut unless a setting changes it; the working size too
    assert variants.cut_config([]) == QUERY_SILHOUETTE_CONFIG
    assert QUERY_SILHOUETTE_CONFIG == SilhouetteConfig(
        work_max_side_px=QUERY_SILHOUETTE_SIDE_PX, work_min_side_px=QUERY_SILHOUETTE_MIN_SIDE_PX
    )
    changed = variants.cut_config([("low_factor", 2.5), ("shadow_ratio", [0.35, 0.85])])
    assert (changed.low_factor, changed.shadow_ratio) == (2.5, (0.35, 0.85))
    assert changed.work_max_side_px == QUERY_SILHOUETTE_SIDE_PX
    assert variants.cut_config([("work_max_side_px", 320)]).work_max_side_px == 320
    with pytest.raises(InvalidParameterError, match="low_factr"):
        variants.cut_config([("low_factr", 2.0)])
    with pytest.raises(InvalidParameterError, match="low_factor"):
        variants.cut_config([("low_factor", 0.5)])


def test_scores_count_top_1_and_top_k_per_label():
    clips = [
        variants.HeldOutClip("a", "walk", ("w1",), None, 15.0),
        variants.HeldOutClip("b", "walk", ("w1",), None, 15.0),
        variants.HeldOutClip("c", "run", ("r1",), None, 15.0),
    ]
    ranked = [("walk", "run"), ("run", "turn", "jump", "walk"), ("walk", "jump", "run")]
    answers = [
        QueryOutcome(clip.label, labels, True, True, 0.0, 0.3)
        for clip, labels in zip(clips, ranked, strict=True)
    ]
    s = variants.scores(clips, answers)
    assert s["n"] == {"walk": 2, "run": 1}
    assert s["top1"]["walk"] == 1 and s["top1"]["run"] == 0
    assert s["topk"]["walk"] == 1 and s["topk"]["run"] == 1  # the 4th label is not top-3


def test_runs_are_compared_with_the_shipped_one_clip_by_clip():
    clips = [variants.HeldOutClip(str(i), "walk", ("w1",), None, 15.0) for i in range(12)]

    def answers(right):
        return [
            QueryOutcome("walk", ("walk",) if ok else ("run", "jump", "turn"), True, True, 0.0)
            for ok in right
        ]

    shipped = [True] * 2 + [False] * 10
    better = [False] * 2 + [True] * 10  # 10 gained, 2 lost
    out = variants.runs_report(clips, {"shipped": answers(shipped), "X=1": answers(better)})
    assert "| shipped | 2/12  | 1.00      | —" in out
    assert "| X=1     | 10/12 | 5.00      | +10 −2             | 0.04" in out
    assert "shipped: top-1 2/12 (16.7%; 95% CI 4.7–44.8%)" in out
    assert "| X=1             | 10/12" in out  # per label


def test_unknown_tables_count_rejections_per_label_left_out():
    known = [QueryOutcome("walk", ("walk",), True, True, 0.0, d) for d in (0.1, 0.2, 0.3)]
    known.append(QueryOutcome("run", ("walk",), False, True, 0.0, 0.5))
    unknown = [
        QueryOutcome("walk", ("run",), True, False, 0.0, 0.25),
        QueryOutcome("walk", ("turn",), False, False, 0.0, 0.6),
        QueryOutcome("run", ("walk",), True, False, 0.0, 0.2),
    ]
    out = variants.unknown_report(known, unknown, {"run": 0.31, "walk": 0.32})
    assert "| run            | 0.310     | 0/1      | walk 1" in out
    assert "| walk           | 0.320     | 1/2      | run 1" in out
    assert "unknown motions rejected 1/3 (33.3%; 95% CI 6.1–79.2%)" in out
    assert "known motions falsely rejected 1/4 (25.0%; 95% CI 4.6–69.9%)" in out
    # distance alone: of 12 pairs, 0.6 is farther than all four known, 0.25 than two,
    # 0.2 than one and ties one: 7.5 / 12
    assert "AUC 0.625" in out
    assert "--false-rejection" not in out  # no p_known: no operating points

    def with_p(outcome, p_known):
        return dataclasses.replace(outcome, p_known=p_known)

    known = [with_p(o, p) for o, p in zip(known, (0.9, 0.5, 0.15, 0.02), strict=True)]
    unknown = [with_p(o, p) for o, p in zip(unknown, (0.3, 0.01, 0.6), strict=True)]
    out = variants.unknown_report(known, unknown, {"run": 0.31, "walk": 0.32})
    assert "| 0.20              | 2/4 (50.0%; 95% CI 15.0–85.0%) | 1/3 (33.3%" in out


def test_mask_agreement_counts_what_the_estimate_missed_and_added():
    given = np.zeros((10, 8, 6), bool)
    given[:, 2:6, 2:4] = True  # a still body of 8 pixels, in every frame
    given[:5, 0, 0] = True  # a limb in half of the frames
    estimated = given.copy()
    estimated[:, 2:4, 2:4] = False  # its upper half missed throughout
    estimated[:3, 5, 2:4] = False  # and its lower row in 3 frames of 10: still shown
    estimated[:, 7, 5] = True  # a speck of scene in every frame
    found = variants.mask_agreement(estimated, given)
    reference = 10 * 8 + 5
    kept = reference - 40 - 6
    assert found.iou == pytest.approx(kept / (reference + 10))
    assert found.missed == pytest.approx(46 / reference)
    assert found.added == pytest.approx(10 / reference)
    assert (found.still, found.still_missed) == (8, 4)
    assert variants.mask_agreement(given, given) == variants.MaskAgreement(1.0, 0.0, 0.0, 8, 0)
    with pytest.raises(InvalidParameterError, match="differ in shape"):
        variants.mask_agreement(given[:9], given)


def test_mask_agreement_is_tabled_per_label():
    given = np.zeros((4, 5, 5), bool)
    given[:, 1:4, 2] = True
    half = given.copy()
    half[:, 1, 2] = False
    clips = [
        variants.HeldOutClip("a", "wave", ("w",), half, 15.0, given),
        variants.HeldOutClip("b", "walk", ("w",), given.copy(), 15.0, given),
    ]
    out = variants.mask_agreement_report(clips)
    assert "| walk  | 1     | 1.00 | 0.00   | 0.00  | 0.00" in out
    assert "| wave  | 1     | 0.67 | 0.33   | 0.00  | 0.33" in out
    assert "| all   | 2     | 0.83 | 0.17   | 0.00  | 0.17" in out


def test_compare_cuts_asks_for_cuts_without_the_empty_scene(tmp_path):
    done = subprocess.run(
        [
            sys.executable,
            str(REPO / "benchmarks" / "accuracy" / "bench_rerank.py"),
            "--compare-cuts",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert done.stderr == (
        "bench_rerank: error: --compare-cuts compares cuts made with --no-background\n"
    )


def test_pairs_join_clips_of_other_labels_of_one_size():
    masks = np.zeros((3, 4, 5), bool)
    clips = [
        variants.HeldOutClip("a", "walk", ("w",), masks, 15.0),
        variants.HeldOutClip("b", "walk", ("w",), masks, 15.0),
        variants.HeldOutClip("c", "wave", ("v",), masks, 15.0),
        variants.HeldOutClip("d", "punch", ("p",), np.zeros((3, 8, 5), bool), 15.0),
    ]
    pairs = variants.composite_pairs(clips)
    assert pairs[:3] == [(0, 2), (1, 2), (2, pairs[2][1])] and pairs[2][1] in (0, 1)
    assert len(pairs) == 3  # nothing else is cut at the punch's size
    assert variants.composite_pairs(clips) == pairs  # a fixed seed


def test_segment_tables_compare_each_run_with_the_shipped_one():
    one = SegmentAgreement(100, 80, 20, 1, 1, 0)
    two = SegmentAgreement(100, 60, 30, 1, 3, 1)
    out = variants.segments_report(
        {"shipped": {"alone": [one], "pairs": [two]}, "X=0": {"alone": [two], "pairs": [two]}}
    )
    rows = [
        [cell.strip() for cell in line.strip("|").split("|")]
        for line in out.splitlines()
        if line.startswith("| ") and "alone" in line
    ]
    # F1 = 2·found / (2·found + extra + missed); segments per clip = found + extra.
    assert rows == [
        ["shipped", "alone (1)", "0.800 (1.00)", "0.200 (1.00)", "0.667 (1.00)", "2.000 (1.00)"],
        ["X=0", "alone (1)", "0.600 (0.75)", "0.300 (1.50)", "0.333 (0.50)", "4.000 (2.00)"],
    ]
