"""eigmotion.evaluation.compare and benchmarks/accuracy/compare_runs.py: two
bench_accuracy.py runs paired clip by clip."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.compare import compare_runs

REPO = Path(__file__).resolve().parents[1]


def record(video, label, ranked, accepted=True, in_library=None, target="without_a"):
    answer = {"ranked_labels": list(ranked), "accepted": accepted, "distance": 0.3}
    if in_library is not None:
        answer["in_library"] = in_library
    return {"video": video, "label": label, "answers": {target: answer}}


def write_run(path, queries, out_of_library=("kick",)):
    per_label = [{"label": label, "in_library": False} for label in out_of_library]
    suite = {"scores": {"all_folds": {"k": 3, "per_label": per_label}}, "queries": queries}
    path.write_text(json.dumps({"suites": {"holdout": suite}}))
    return path


def test_runs_are_paired_by_clip_and_database(tmp_path):
    before = [record(f"w{i}.mp4", "walk", ["run", "walk"], in_library=True) for i in range(10)]
    before += [
        record("r0.mp4", "run", ["run"], in_library=True),
        record("k0.mp4", "kick", ["walk"]),  # no in_library: from the scores
        record("k1.mp4", "kick", ["walk"], accepted=False),
        record("only_before.mp4", "walk", ["walk"], in_library=True),
    ]
    after = [record(f"w{i}.mp4", "walk", ["walk"], in_library=True) for i in range(9)]
    after += [
        record("w9.mp4", "walk", ["jump", "turn", "run"], in_library=True),
        record("r0.mp4", "run", ["walk", "run"], in_library=True),
        record("k0.mp4", "kick", ["walk"], accepted=False),
        record("k1.mp4", "kick", ["walk"], accepted=False),
        record("w0.mp4", "walk", ["walk"], in_library=True, target="without_b"),
    ]
    paths = write_run(tmp_path / "a.json", before), write_run(tmp_path / "b.json", after)
    out = "\n".join(compare_runs(*paths))
    assert (
        "13 clips asked in both runs (11 in library); not compared: 2 asked in one run "
        "only, 0 in the library in one run only"
    ) in out
    # 9 walks gained, the run lost at top-1: p = 20/1024 (two-sided).
    assert "| top-1 (in library)        | 1/11   | 9/11  | 9      | 1    | 0.021" in out
    assert "| top-3 (in library)        | 11/11  | 10/11 | 0      | 1    | 1.000" in out
    assert "| rejected (out of library) | 1/2    | 2/2   | 1      | 0    | 1.000" in out
    gained, lost = out.split("top-1 gained:")[1].split("top-1 lost:")
    assert gained.count("→ walk") == 9 and "w9.mp4" not in gained
    assert "r0.mp4 (without_a): run → walk" in lost


def test_a_clip_whose_library_status_changed_is_not_compared(tmp_path):
    before = [record("a.mp4", "walk", ["walk"], in_library=True)]
    after = [record("a.mp4", "walk", ["walk"], in_library=False)]
    paths = write_run(tmp_path / "a.json", before), write_run(tmp_path / "b.json", after)
    out = "\n".join(compare_runs(*paths))
    assert "0 clips asked in both runs (0 in library); not compared: 0 asked in one run" in out
    assert "1 in the library in one run only" in out


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("not json", "not a JSON file"),
        ('{"suites": {}}', "holds no suites"),
        ('{"suites": {"holdout": {"queries": 3}}}', "holds no list of queries"),
        ('{"suites": {"holdout": {"queries": [{"video": "a.mp4"}]}}}', "lacks what an answer"),
        (
            '{"suites": {"holdout": {"queries": [{"video": "a.mp4", "label": "walk", '
            '"answers": {"db": {"ranked_labels": [], "accepted": true}}}]}}}',
            "at least one label",
        ),
    ],
)
def test_bad_runs_are_named(tmp_path, text, message):
    bad = tmp_path / "bad.json"
    bad.write_text(text)
    good = write_run(tmp_path / "good.json", [record("a.mp4", "walk", ["walk"])])
    with pytest.raises(InvalidParameterError, match=message):
        compare_runs(bad, good)


def test_a_suite_not_in_both_runs_is_refused(tmp_path):
    good = write_run(tmp_path / "good.json", [record("a.mp4", "walk", ["walk"])])
    with pytest.raises(InvalidParameterError, match="seen.*both hold: holdout"):
        compare_runs(good, good, ["seen"])


def test_a_missing_file_is_one_line_and_exit_2(tmp_path):
    done = subprocess.run(
        [
            sys.executable,
            str(REPO / "benchmarks" / "accuracy" / "compare_runs.py"),
            "x.json",
            "y.json",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert done.stderr == "compare_runs: error: x.json: no such file\n"
