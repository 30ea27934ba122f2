"""Two runs of ``bench_accuracy.py`` compared clip by clip: did the change help?

The clips both runs asked (the same video asked of the database of the same name) are
paired, and for each measure — top-1 and top-k of the in-library clips, their false
rejections, the rejection of out-of-library ones — :func:`compare_runs` gives both
counts, the clips the second run gained and lost, and the exact McNemar test's p-value
of that split (:func:`eigmotion.evaluation.statistics.paired_comparison`); then the clips
whose top-1 answer changed, by name.  ``benchmarks/accuracy/compare_runs.py`` is the
command line.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from eigmotion.errors import InvalidParameterError
from eigmotion.evaluation.scoring import QueryOutcome
from eigmotion.evaluation.statistics import markdown_table, paired_comparison

#: The rank of the top-k measure when a run does not say.
DEFAULT_K = 3


#: One clip asked of one database: (the clip's video file name, the database's name).
Key = tuple[str, str]


def load_run(path: Path) -> dict:
    """A ``bench_accuracy.py --json-out`` file, checked to hold suites of queries."""
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise InvalidParameterError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InvalidParameterError(f"{path}: not a JSON file ({exc})") from None
    suites = data.get("suites") if isinstance(data, dict) else None
    if not isinstance(suites, dict) or not suites:
        raise InvalidParameterError(
            f"{path}: holds no suites; give a file written by bench_accuracy.py --json-out"
        )
    for name, suite in suites.items():
        if not isinstance(suite, dict) or not isinstance(suite.get("queries"), list):
            raise InvalidParameterError(f"{path}: suite {name!r} holds no list of queries")
    return data


def asked(path: Path, suite: dict) -> tuple[dict[Key, QueryOutcome], int]:
    """Every clip a suite asked of each database, as a query outcome, and the k of its
    top-k.

    Raises
    ------
    InvalidParameterError
        A query without the fields an answer needs.
    """
    scores = [s for s in suite.get("scores", {}).values() if isinstance(s, dict)]
    out_of_library = {
        row["label"]
        for s in scores
        for row in s.get("per_label", [])
        if not row.get("in_library", True)
    }
    k = next((int(s["k"]) for s in scores if "k" in s), DEFAULT_K)
    found: dict[Key, QueryOutcome] = {}
    for record in suite["queries"]:
        try:
            for target, answer in record["answers"].items():
                label = record["label"]
                found[(record["video"], target)] = QueryOutcome(
                    label,
                    tuple(answer["ranked_labels"]),
                    bool(answer["accepted"]),
                    bool(answer.get("in_library", label not in out_of_library)),
                    float(answer.get("query_s", 0.0)),
                )
        except (KeyError, TypeError, AttributeError, ValueError) as exc:
            raise InvalidParameterError(
                f"{path}: a query lacks what an answer needs ({exc!r} in {str(record)[:80]}…)"
            ) from None
    return found, k


def compare_suite(name: str, before: dict, after: dict, paths: Sequence[Path]) -> list[str]:
    """The Markdown lines comparing one suite of two runs."""
    first, k = asked(paths[0], before)
    second, _ = asked(paths[1], after)
    common = [key for key in first if key in second]
    if not common:
        return [f"## {name}", "", "no clip asked of the same database in both runs"]
    # A clip's status must be the same in both runs for the pair to mean anything.
    keys = [key for key in common if first[key].in_library == second[key].in_library]
    pairs = [(first[key], second[key]) for key in keys]
    inside = [(a, b) for a, b in pairs if a.in_library]
    outside = [(a, b) for a, b in pairs if not a.in_library]
    measures = [
        ("top-1 (in library)", inside, lambda q: q.hit(1)),
        (f"top-{k} (in library)", inside, lambda q: q.hit(k)),
        ("accepted (in library)", inside, lambda q: q.accepted),
        ("rejected (out of library)", outside, lambda q: not q.accepted),
    ]
    rows = []
    for measure, group, right in measures:
        if not group:
            continue
        change = paired_comparison([right(a) for a, _ in group], [right(b) for _, b in group])
        rows.append(
            [
                measure,
                f"{change.before}/{change.n}",
                f"{change.after}/{change.n}",
                str(change.gained),
                str(change.lost),
                f"{change.p_value:.3f}",
            ]
        )
    only = len(first) + len(second) - 2 * len(common)
    lines = [
        f"## {name}",
        "",
        f"{len(pairs)} clips asked in both runs ({len(inside)} in library); not compared: "
        f"{only} asked in one run only, {len(common) - len(pairs)} in the library in one "
        "run only",
        "",
        *markdown_table(["measure", "before", "after", "gained", "lost", "p (McNemar)"], rows),
    ]
    changed = [
        key for key in keys if first[key].in_library and first[key].hit(1) != second[key].hit(1)
    ]
    for title, keep in (("top-1 gained", True), ("top-1 lost", False)):
        shown = [key for key in changed if second[key].hit(1) == keep]
        if shown:
            lines += ["", f"{title}:"]
            lines += [
                f"  {video} ({target}): {first[video, target].predicted} → "
                f"{second[video, target].predicted}"
                for video, target in shown
            ]
    return lines


def compare_runs(before: Path, after: Path, suites: Sequence[str] | None = None) -> list[str]:
    """The Markdown lines comparing two ``bench_accuracy.py --json-out`` files, suite
    by suite (a blank line between two suites).

    Parameters
    ----------
    before, after : Path
        The first and the second run.
    suites : sequence of str, optional
        The suites to compare; default: every suite both runs hold.

    Raises
    ------
    InvalidParameterError
        A file that is missing or not a run, or a suite not in both runs.
    """
    runs = [load_run(before), load_run(after)]
    common = [s for s in runs[0]["suites"] if s in runs[1]["suites"]]
    wanted = suites or common
    missing = [s for s in wanted if s not in common]
    if missing or not wanted:
        raise InvalidParameterError(
            f"suite(s) {', '.join(missing) or '(none)'} not in both runs; both hold: "
            f"{', '.join(common) or 'none in common'}"
        )
    lines: list[str] = []
    for i, name in enumerate(wanted):
        if i:
            lines.append("")
        lines += compare_suite(name, *(run["suites"][name] for run in runs), (before, after))
    return lines
