"""Scoring of retrieval queries (eigmotion.evaluation.scoring) and a smoke run of the accuracy
benchmark's ``seen`` suite."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from eigmotion.errors import EigmotionError, InvalidParameterError
from eigmotion.evaluation.query_clips import BODY_SHAPES, halfway_views, person_height_px
from eigmotion.evaluation.scoring import (
    ZERO_CELL,
    QueryOutcome,
    confusion_matrix,
    format_confusion,
    format_operating_points,
    format_rate,
    format_score,
    markdown_table,
    operating_points,
    rejection_rates,
    score,
    separation,
)
from eigmotion.evaluation.segments import segment_agreement
from eigmotion.evaluation.statistics import paired_comparison, proportion_interval
from eigmotion.imaging.cameras import load_rig

REPO = Path(__file__).resolve().parents[1]


def outcome(true, ranked, accepted=True, in_library=True, query_s=1.0, distance=None):
    return QueryOutcome(true, tuple(ranked), accepted, in_library, query_s, distance)


#: Eight hand-made queries against one database holding walk, run and jump (not duck).
QUERIES = [
    outcome("walk", ["walk", "run", "jump"], query_s=1.0),
    outcome("walk", ["run", "walk", "jump"], query_s=2.0),
    outcome("walk", ["run", "jump", "walk"], accepted=False, query_s=3.0),
    outcome("run", ["run", "walk"], query_s=1.0),
    outcome("run", ["jump", "walk", "run"], accepted=False, query_s=1.0),
    outcome("jump", ["jump"], query_s=2.0),
    outcome("duck", ["jump", "walk", "run"], accepted=False, in_library=False, query_s=4.0),
    outcome("duck", ["walk", "run"], accepted=True, in_library=False, query_s=2.0),
]


# -- outcomes and ranked labels -----------------------------------------------------------


@pytest.mark.parametrize(
    ("k", "hits"),
    [(1, [True, False, False]), (2, [True, True, False]), (3, [True, True, True])],
)
def test_hit_at_k(k, hits):
    assert [QUERIES[i].hit(k) for i in range(3)] == hits


@pytest.mark.parametrize(
    ("ranked", "query_s"),
    [((), 1.0), (("walk", "run", "walk"), 1.0), (("walk",), -0.5), (("walk",), math.nan)],
)
def test_bad_outcome_is_refused(ranked, query_s):
    with pytest.raises(InvalidParameterError):
        QueryOutcome("walk", ranked, True, True, query_s)


def test_hit_needs_positive_k():
    with pytest.raises(InvalidParameterError, match="k must be >= 1"):
        QUERIES[0].hit(0)


def test_outcome_errors_are_project_and_builtin_errors():
    with pytest.raises(EigmotionError):
        QueryOutcome("walk", (), True, True, 1.0)
    with pytest.raises(ValueError):
        QueryOutcome("walk", (), True, True, 1.0)


# -- confusion matrix ------------------------------------------------------------------


def test_confusion_matrix_counts_pairs():
    true = ["walk", "walk", "walk", "run", "run", "jump"]
    predicted = ["walk", "run", "run", "run", "jump", "jump"]
    cm = confusion_matrix(true, predicted, label_order=["walk", "run", "jump"])
    assert cm.true_labels == ("walk", "run", "jump")
    assert cm.predicted_labels == ("walk", "run", "jump")
    np.testing.assert_array_equal(cm.counts, [[1, 2, 0], [0, 1, 1], [0, 0, 1]])
    assert cm.counts.dtype == np.int64
    assert cm.count("walk", "run") == 2
    assert cm.count("walk", "duck") == 0
    assert cm.counts.sum() == len(true)


@pytest.mark.parametrize(
    ("order", "rows", "cols"),
    [
        (None, ("duck", "walk"), ("jump", "walk")),
        (["walk", "jump", "duck"], ("walk", "duck"), ("walk", "jump")),
        (["jump"], ("duck", "walk"), ("jump", "walk")),
    ],
)
def test_confusion_matrix_label_order(order, rows, cols):
    cm = confusion_matrix(["walk", "duck", "walk"], ["walk", "jump", "jump"], order)
    assert cm.true_labels == rows
    assert cm.predicted_labels == cols
    assert cm.count("duck", "jump") == 1
    assert cm.count("walk", "jump") == 1
    assert cm.count("walk", "walk") == 1


def test_confusion_matrix_needs_one_prediction_per_query():
    with pytest.raises(InvalidParameterError, match="one label per query"):
        confusion_matrix(["walk", "run"], ["walk"])


def test_confusion_json_and_text():
    cm = confusion_matrix(["walk", "run"], ["walk", "walk"], ["walk", "run"])
    data = json.loads(json.dumps(cm.to_json()))
    assert data == {
        "true_labels": ["walk", "run"],
        "predicted_labels": ["walk"],
        "counts": [[1], [1]],
    }
    text = format_confusion(confusion_matrix(["walk", "run"], ["walk", "run"]))
    assert ZERO_CELL in text
    assert text.splitlines()[0].split("|")[1].strip() == "true \\ top-1"


# -- scores -----------------------------------------------------------------------------


def test_score_of_hand_made_queries():
    result = score(QUERIES, k=3, label_order=["walk", "run", "jump", "duck"])
    # Accuracy counts the six in-library queries only.
    assert (result.n, result.n_queries) == (6, 8)
    assert (result.top1, result.topk, result.top1_accepted) == (3, 6, 3)
    assert result.top1_rate == pytest.approx(0.5)
    assert result.topk_rate == pytest.approx(1.0)
    by_label = {s.label: s for s in result.per_label}
    assert [s.label for s in result.per_label] == ["walk", "run", "jump", "duck"]
    walk, run, jump, duck = (by_label[x] for x in ("walk", "run", "jump", "duck"))
    assert (walk.n, walk.top1, walk.topk, walk.rejected) == (3, 1, 3, 1)
    assert (run.n, run.top1, run.topk, run.rejected) == (2, 1, 2, 1)
    assert (jump.n, jump.top1, jump.topk, jump.rejected) == (1, 1, 1, 0)
    assert not duck.in_library and (duck.n, duck.rejected) == (2, 1)
    assert walk.top1_rate == pytest.approx(1 / 3)
    rej = result.rejection
    assert (rej.n_in_library, rej.false_rejected, rej.n_out_of_library, rej.rejected) == (
        6,
        2,
        2,
        1,
    )
    assert rej.false_rejection_rate == pytest.approx(2 / 6)
    assert rej.rejection_rate == pytest.approx(0.5)
    assert result.mean_query_s == pytest.approx(16.0 / 8)
    assert result.confusion.count("duck", "jump") == 1
    assert result.confusion.count("run", "jump") == 1
    assert result.confusion.counts.sum() == 8


@pytest.mark.parametrize(("k", "topk"), [(1, 3), (2, 4), (3, 6), (10, 6)])
def test_score_top_k(k, topk):
    result = score(QUERIES, k=k)
    assert result.topk == topk
    assert result.top1 == 3


def test_rejection_rates_without_out_of_library_queries_are_nan():
    rej = rejection_rates(QUERIES[:6])
    assert rej.n_out_of_library == 0
    assert math.isnan(rej.rejection_rate)
    assert rej.false_rejection_rate == pytest.approx(2 / 6)
    assert rej.to_json()["rejection_rate"] is None


@pytest.mark.parametrize(
    ("outcomes", "k", "message"),
    [
        ([], 3, "at least one"),
        (QUERIES, 0, "k must be >= 1"),
        (
            [outcome("walk", ["walk"]), outcome("walk", ["run"], in_library=False)],
            3,
            "in the library for some",
        ),
    ],
)
def test_score_refuses_bad_input(outcomes, k, message):
    with pytest.raises(InvalidParameterError, match=message):
        score(outcomes, k=k)


def test_score_json_is_plain_and_complete():
    data = json.loads(json.dumps(score(QUERIES, label_order=["walk", "run"]).to_json()))
    assert data["top1"] == 3 and data["n_in_library"] == 6
    assert data["top1_rate"] == pytest.approx(0.5)
    assert data["rejection"]["rejected"] == 1
    assert len(data["per_label"]) == 4
    assert data["confusion"]["counts"][0] == [1, 2, 0]
    assert data["confidence"] == 0.95
    assert data["top1_interval"] == pytest.approx(wilson(3, 6), abs=1e-6)
    assert data["rejection"]["rejection_interval"] == pytest.approx(wilson(1, 2), abs=1e-6)


def wilson(successes, n, z=1.959963984540054):
    """The Wilson score interval in closed form, to check the library's against."""
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return [centre - half, centre + half]


@pytest.mark.parametrize(("successes", "n"), [(194, 220), (215, 220), (0, 8), (8, 8), (1, 2)])
def test_proportion_interval_is_wilsons(successes, n):
    low, high = proportion_interval(successes, n)
    assert [low, high] == pytest.approx(wilson(successes, n), abs=1e-9)
    assert 0.0 <= low <= successes / n <= high <= 1.0


def test_proportion_interval_narrows_with_more_queries_and_less_confidence():
    assert all(math.isnan(x) for x in proportion_interval(0, 0))
    wide, narrow = proportion_interval(88, 100), proportion_interval(880, 1000)
    assert narrow[1] - narrow[0] < (wide[1] - wide[0]) / 3
    low90, high90 = proportion_interval(88, 100, confidence=0.90)
    assert wide[0] < low90 and high90 < wide[1]


@pytest.mark.parametrize(
    ("successes", "n", "confidence", "message"),
    [(5, 4, 0.95, "successes <= n"), (-1, 4, 0.95, "successes <= n"), (1, 4, 1.0, "(0, 1)")],
)
def test_proportion_interval_refuses_bad_input(successes, n, confidence, message):
    with pytest.raises(InvalidParameterError, match=re.escape(message)):
        proportion_interval(successes, n, confidence)


@pytest.mark.parametrize(
    ("gained", "lost", "p_value"),
    [(9, 1, 0.021484375), (7, 3, 0.34375), (1, 9, 0.021484375), (6, 0, 0.03125), (0, 0, 1.0)],
)
def test_paired_comparison_is_an_exact_mcnemar_test(gained, lost, p_value):
    # 20 queries right in both runs and 5 wrong in both never count.
    before = [False] * gained + [True] * lost + [True] * 20 + [False] * 5
    after = [True] * gained + [False] * lost + [True] * 20 + [False] * 5
    found = paired_comparison(before, after)
    assert (found.gained, found.lost) == (gained, lost)
    assert (found.before, found.after, found.n) == (lost + 20, gained + 20, len(before))
    assert found.p_value == pytest.approx(p_value)


def test_paired_comparison_refuses_runs_of_different_queries():
    with pytest.raises(InvalidParameterError, match="one length"):
        paired_comparison([True, False], [True])


def test_format_score_shows_counts_rates_and_matrix():
    text = format_score(score(QUERIES, label_order=["walk", "run", "jump", "duck"]))
    assert "| walk " in text and "1/3 (33.3%; 95% CI 6.1–79.2%)" in text
    assert "duck (out of library)" in text
    assert "top-1 3/6 (50.0%; 95% CI 18.8–81.2%)" in text
    assert "out-of-library rejected 1/2 (50.0%; 95% CI 9.5–90.5%)" in text
    assert "falsely rejected 2/6 (33.3%; 95% CI 9.7–70.0%)" in text
    assert "mean query time: 2.00 s over 8 queries" in text
    assert "| true \\ top-1 |" in text


def distances(inside, outside):
    return [outcome("walk", ["walk"], distance=d) for d in inside] + [
        outcome("duck", ["walk"], in_library=False, distance=d) for d in outside
    ]


@pytest.mark.parametrize(
    ("inside", "outside", "quantile", "auc", "threshold", "rejected"),
    [
        ([0.1, 0.2, 0.3, 0.4], [0.35, 0.5], 0.5, 0.875, 0.25, 2),
        ([0.1, 0.2, 0.3, 0.4], [0.35, 0.5], 1.0, 0.875, 0.4, 1),
        ([0.1, 0.2], [0.2, 0.05], 1.0, 0.375, 0.2, 0),  # a tie counts half
        ([0.3, 0.4], [0.1, 0.2], 0.95, 0.0, 0.395, 0),
        ([0.3, 0.4], [math.inf, 0.5], 0.95, 1.0, 0.395, 2),
    ],
)
def test_separation(inside, outside, quantile, auc, threshold, rejected):
    sep = separation(distances(inside, outside), quantile)
    assert sep.auc == pytest.approx(auc)
    assert sep.threshold == pytest.approx(threshold)
    assert (sep.rejected, sep.n_out_of_library) == (rejected, len(outside))


@pytest.mark.parametrize(
    ("outcomes", "quantile", "message"),
    [
        (distances([0.1], [0.2]), 0.0, "quantile"),
        (distances([0.1], []), 0.95, "in-library and out-of-library"),
        (distances([0.1], [0.2]) + [outcome("walk", ["walk"])], 0.95, "distance of every"),
    ],
)
def test_separation_refuses_bad_input(outcomes, quantile, message):
    with pytest.raises(InvalidParameterError, match=message):
        separation(outcomes, quantile)


def test_score_reports_separation_only_when_it_can():
    assert score(QUERIES).separation is None  # no distances
    with_distances = distances([0.1, 0.2, 0.3, 0.4], [0.35, 0.5])
    result = score(with_distances)
    assert result.separation is not None and result.separation.auc == pytest.approx(0.875)
    assert "AUC 0.88" in format_score(result)
    assert score(with_distances[:4]).separation is None  # in-library only
    with pytest.raises(InvalidParameterError, match="distance"):
        outcome("walk", ["walk"], distance=-1.0)


def test_operating_points_count_what_each_share_turns_away():
    def judged(p_known, in_library):
        return QueryOutcome("walk", ("walk",), p_known >= 0.05, in_library, 0.0, 0.3, p_known)

    known = [judged(p, True) for p in (0.0, 0.04, 0.15, 0.5, 0.9)]
    unknown = [judged(p, False) for p in (0.01, 0.1, 0.25, 0.6)]
    points = operating_points(known + unknown, (0.05, 0.2, 0.55))
    assert [p.share for p in points] == [0.05, 0.2, 0.55]
    assert [(p.rates.false_rejected, p.rates.n_in_library) for p in points] == [
        (2, 5),
        (3, 5),
        (4, 5),
    ]
    assert [(p.rates.rejected, p.rates.n_out_of_library) for p in points] == [
        (1, 4),
        (2, 4),
        (3, 4),
    ]
    # at the database's own share, as the queries' accepted flags say
    assert points[0].rates == rejection_rates(known + unknown)
    table = format_operating_points(points).splitlines()
    assert len(table) == 2 + 3 and "--false-rejection" in table[0]
    cells = [cell.strip() for cell in table[3].split("|")[1:-1]]
    assert cells == ["0.20", format_rate(3, 5), format_rate(2, 4)]
    with pytest.raises(InvalidParameterError, match="p_known of every query"):
        operating_points([*known, outcome("walk", ["walk"])])
    with pytest.raises(InvalidParameterError, match="share must be in"):
        operating_points(known, (0.0,))
    with pytest.raises(InvalidParameterError, match="p_known must be in"):
        judged(1.5, True)


def test_markdown_table_pads_columns_and_checks_rows():
    lines = markdown_table(["a", "bb"], [["xxx", 1], ["y", 22]])
    assert lines == ["| a   | bb |", "|-----|----|", "| xxx | 1  |", "| y   | 22 |"]
    with pytest.raises(InvalidParameterError, match="row 1 has 1 cells"):
        markdown_table(["a", "b"], [["1", "2"], ["3"]])


# -- the query clips and the accuracy script ------------------------------------------


@pytest.mark.parametrize(
    ("rig_file", "azimuths", "elevations"),
    [
        ("default.toml", np.arange(15.0, 360.0, 30.0), [10.0]),
        ("ring6.toml", np.arange(30.0, 360.0, 60.0), [10.0]),
    ],
)
def test_halfway_views(rig_file, azimuths, elevations):
    az, el = halfway_views(load_rig(REPO / "virtual_cameras" / rig_file))
    np.testing.assert_allclose(np.sort(az), azimuths)
    np.testing.assert_allclose(el, elevations)


def test_person_height_px():
    masks = np.zeros((3, 20, 10), dtype=bool)
    masks[0, 2:12, 3] = True  # 10 rows
    masks[1, 5:19, 4:6] = True  # 14 rows
    assert person_height_px(masks) == pytest.approx(12.0)  # frame 2 is empty
    assert person_height_px(np.zeros((2, 4, 4), dtype=bool)) == 0.0


@pytest.mark.slow
def test_seen_quick_smoke_run(tmp_path):
    """Two motions, a ring6 database built into tmp, one clip each, through the CLI."""
    out = tmp_path / "seen.json"
    argv = [
        "seen",
        "--quick",
        "--only",
        "wave_14_24",
        "kick_135_04",
        "--rig",
        str(REPO / "virtual_cameras" / "ring6.toml"),
        "--components",
        "8",
        "--workers",
        "1",
        "--db",
        str(tmp_path / "tiny.fs"),
        "--clips-dir",
        str(tmp_path / "clips"),
        "--json-out",
        str(out),
    ]
    script = REPO / "benchmarks" / "accuracy" / "bench_accuracy.py"
    done = subprocess.run([sys.executable, str(script), *argv], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    data = json.loads(out.read_text())
    seen = data["suites"]["seen"]
    assert seen["built"]["n_motions"] == 2
    scored = seen["scores"]["default"]
    assert scored["n_queries"] == 2 and scored["n_in_library"] == 2
    assert scored["database"]["labels"] == ["kick", "wave"]
    # Two labels far apart (a kick, a wave): both must be told apart.
    assert scored["top1"] == 2
    for query in seen["queries"]:
        assert (query["height_m"], query["girth"]) in BODY_SHAPES
        assert query["azimuth_deg"] % 60.0 == pytest.approx(30.0)  # halfway between cameras
        assert query["answers"]["default"]["ranked_labels"][0] == query["label"]
        assert (tmp_path / "clips" / query["video"]).is_file()
        assert 50 < query["person_px"] <= 240


# -- segments ---------------------------------------------------------------------------


def test_segments_are_scored_by_frame_and_by_overlapping_part():
    parts = [(0, 40, "walk"), (40, 100, "wave")]
    found = segment_agreement(
        [(0, 30, "walk"), (30, 50, "punch"), (50, 100, "wave")], parts, filler={"walk"}
    )
    # Frames 30–50 are a punch: 10 of walking, 10 of waving, all specific and wrong.
    assert (found.frames, found.right, found.wrong) == (100, 80, 20)
    # walk 0–30 overlaps its part by 30/40, wave 50–100 by 50/60: found; punch: extra.
    assert (found.found, found.extra, found.missed) == (2, 1, 0)
    # Walking where the wave is counts against neither share but misses the wave.
    found = segment_agreement([(0, 100, "walk")], parts, filler={"walk"})
    assert (found.right, found.wrong, found.found, found.extra, found.missed) == (40, 0, 0, 1, 2)
    # Each part is matched once; without filler every other label is wrong.
    found = segment_agreement([(0, 50, "wave"), (50, 100, "wave")], [(0, 100, "wave")])
    assert (found.right, found.wrong, found.found, found.extra, found.missed) == (100, 0, 1, 1, 0)
    assert segment_agreement([(0, 40, "walk")], parts).wrong == 0  # frames left unlabelled


@pytest.mark.parametrize("parts", [[], [(5, 10, "walk")], [(0, 10, "walk"), (12, 20, "wave")]])
def test_parts_must_cover_the_clip(parts):
    with pytest.raises(InvalidParameterError, match="cover the clip"):
        segment_agreement([(0, 10, "walk")], parts)
