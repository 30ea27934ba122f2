"""Accuracy of the retrieval engine on rendered query clips.

Every query clip is a library motion performed by a body shape the database was not
built with (1.62 m / girth 1.2, 1.85 m / girth 0.9), filmed by one still camera over a
textured background with a cast shadow, camouflaged clothing and sensor noise
(:func:`eigmotion.synth.clips.render_clip`, 320 × 240, 30 fps), written to ``.mp4`` with an
image of the empty scene, and answered through ``eigmotion query CLIP --db DB --json
--top 32 [--background EMPTY.png]`` (in-process, stdout captured), exactly as a user
would run it.  Four suites:

``seen``
    The acceptance test: every library motion, from views halfway between the rig's
    cameras (azimuth half a step off, elevation between two rows, or 10° for a single
    row; ``--clips-per-motion`` clips per motion, body shapes alternating), against the
    default database (built when missing).  Goal: top-1 label accuracy >= 95 %.
``loso``
    Leave one subject out: for each CMU performer, a database is built without that
    performer's motions (a temporary file, the default build configuration and
    ``--rig``) and the performer's clips are queried against it, from random views
    (azimuth 0–360°, elevation −5…30°, person 50–200 px tall).  A label that only the
    held-out performer shows is out of the library for that fold and should come back
    ``accepted: false``.
``holdout``
    People the database has never seen: the subject folds of ``loso`` plus folds that
    each hold out one authored variation of every label (with its mirror image), the
    query bodies dressed in the benchmark garments (none, skirt, long coat, loose
    trousers: :data:`eigmotion.body.garments.BENCHMARK_GARMENTS`, never in a database),
    random views and sizes as ``loso``.  Labels a fold leaves without any motion are
    out of the library there and should be rejected.
``unknown``
    Rejection: the distractor motions (duck, block) against the default database, and
    the motions of ``--holdout-labels`` against a database built without those labels,
    should all come back ``accepted: false``; clips of the other motions, against both
    databases, give the false-rejection rate.

For every database a suite queries it prints the per-label top-1 / top-3 accuracy with
counts (top-3: the true label among the first three distinct labels of the answer),
the overall accuracy and the rejection rates (each with its 95 % confidence
interval), the mean query time and the confusion matrix (true label rows × top-1 label
columns), then the in-library queries answered wrong.  ``--json-out`` writes the same,
with every query, as JSON; ``compare_runs.py`` compares two such files clip by clip.

Run from the repository root::

    python benchmarks/accuracy/bench_accuracy.py seen
    python benchmarks/accuracy/bench_accuracy.py loso --rig virtual_cameras/ring6.toml
    python benchmarks/accuracy/bench_accuracy.py holdout --rig virtual_cameras/ring6.toml
    python benchmarks/accuracy/bench_accuracy.py unknown --json-out unknown.json
    python benchmarks/accuracy/bench_accuracy.py all --clips-dir /tmp/clips    # reuse clips
    python benchmarks/accuracy/bench_accuracy.py seen --quick                  # smoke run

Clips are rendered into ``--clips-dir`` (a temporary folder by default) under names
that hold every parameter, and reused when already there.  On a shared 2-core machine
a clip takes about 3–8 s to render and 0.5–2 s to query; ``seen`` takes about 9
minutes, ``loso`` 8, ``unknown`` 7 (see docs/accuracy.md).
"""

from __future__ import annotations

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from dataclasses import asdict, dataclass, replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from eigmotion.errors import EigmotionError, InvalidParameterError  # noqa: E402
from eigmotion.evaluation.query_clips import (  # noqa: E402
    BODY_SHAPES,
    CLIP_FPS,
    DEFAULT_RIG,
    HEIGHT_PX,
    LOSO_ELEVATION_DEG,
    TOP_K,
    WIDTH_PX,
    ClipFiles,
    ClipMaker,
    ClipSpec,
    halfway_views,
    random_specs,
    seen_specs,
    subject_folds,
    variation_folds,
)
from eigmotion.evaluation.scoring import (  # noqa: E402
    NO_ANSWER,
    QueryOutcome,
    format_operating_points,
    format_score,
    markdown_table,
    operating_points,
    score,
)
from eigmotion.imaging.cameras import load_rig  # noqa: E402
from eigmotion.mocap.library import DISTRACTOR_LABELS, LABELS, LibraryMotion, load_library  # noqa: E402
from eigmotion.resources import rigs_dir  # noqa: E402
from eigmotion.retrieval.build import build_database  # noqa: E402
from eigmotion.retrieval.database import MotionDatabase  # noqa: E402
from eigmotion.retrieval.library_views import BuildConfig  # noqa: E402
from eigmotion.retrieval.storage import DEFAULT_DB_PATH  # noqa: E402

QUICK_RIG = rigs_dir() / "ring6.toml"

DEFAULT_HOLDOUT_LABELS = ("kick", "wave", "fall_down")
SUITES = ("seen", "loso", "holdout", "unknown")


# -- clips ----------------------------------------------------------------------------


# -- databases and queries --------------------------------------------------------------


@dataclass(frozen=True)
class Target:
    """A database to query: where, and which labels it holds."""

    name: str
    uri: str
    labels: frozenset[str]
    rig_name: str
    n_entries: int
    threshold: float


def open_target(name: str, uri: str | os.PathLike) -> Target:
    with MotionDatabase.open(uri) as db:
        labels = frozenset(db.motion_record(mid)["label"] for mid in db.store.motion_ids())
        return Target(name, os.fspath(uri), labels, db.rig.name, db.n_entries, db.threshold)


def stored_names(uri: str | os.PathLike) -> set[str]:
    with MotionDatabase.open(uri) as db:
        return {db.motion_record(mid)["metadata"].get("name") for mid in db.store.motion_ids()}


def build(library: Sequence[LibraryMotion], uri: Path, args: argparse.Namespace) -> dict:
    """Build a database with the default configuration (``--components`` aside) and
    ``args.build_rig``; return what was built as plain data."""
    config = BuildConfig()
    if args.components is not None:
        config = replace(config, n_components=args.components)
    if args.plain_bodies:
        config = replace(config, body_shapes=((None, 1.0),), garments=((),))
    rig_path = args.build_rig
    report = build_database(library, load_rig(rig_path), uri, config, workers=args.workers)
    return {
        "uri": report.uri,
        "rig": str(rig_path),
        "n_motions": report.n_motions,
        "n_entries": report.n_entries,
        "threshold": report.threshold,
        "n_components": report.n_components,
        "seconds": round(report.seconds, 1),
    }


def ensure_database(args, library: Sequence[LibraryMotion]) -> dict | None:
    """Build ``--db`` from ``library`` when missing (or ``--rebuild``); else check that
    it holds every motion of ``library``.  Returns the build report, if one was made."""
    uri = Path(args.db)
    if args.rebuild or not uri.is_file():
        print(f"building {uri} from {len(library)} motions with {args.build_rig}", file=sys.stderr)
        built = build(library, uri, args)
        args.rebuild = False  # once per run, whichever suites need it
        return built
    missing = sorted({m.name for m in library} - stored_names(uri))
    if missing:
        raise InvalidParameterError(
            f"{uri} lacks the library motion(s) {missing}: it was built from another "
            "library; pass --rebuild (or another --db)"
        )
    return None


def query(target: Target, clip: ClipFiles, use_background: bool) -> dict:
    """Answer one clip with ``eigmotion query ... --json``, run in-process.

    Returns
    -------
    dict
        ``ranked_labels``, ``accepted``, ``distance``, ``motion``, ``view`` and
        ``query_s`` (wall time of the whole command, seconds); a command that fails
        gives ``ranked_labels [NO_ANSWER]``, ``accepted False`` and its ``error``.
    """
    from eigmotion.cli.main import main

    argv = ["query", str(clip.video), "--db", target.uri, "--json"]
    if use_background:
        argv += ["--background", str(clip.background)]
    out, err = io.StringIO(), io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    seconds = time.perf_counter() - t0
    if code != 0:
        return {
            "ranked_labels": [NO_ANSWER],
            "accepted": False,
            "error": err.getvalue().strip(),
            "query_s": round(seconds, 3),
        }
    answer = json.loads(out.getvalue())
    return {
        "ranked_labels": [m["label"] for m in answer["labels"]],
        "accepted": bool(answer["accepted"]),
        "distance": answer["distance"],
        "p_known": answer["p_known"],
        "motion": answer["motion"],
        "view": answer["view"],
        "query_s": round(seconds, 3),
    }


def run_clips(
    specs: Sequence[ClipSpec],
    items: dict[str, LibraryMotion],
    targets: Sequence[Target],
    maker: ClipMaker,
    args: argparse.Namespace,
    desc: str,
) -> list[dict]:
    """Render every clip once and query it against every target.

    Returns
    -------
    list of dict
        One record per clip: the spec, ``person_px``, ``render_s`` and ``answers``
        (target name → :func:`query`'s answer and ``in_library``: whether that
        database holds the clip's label).
    """
    from tqdm import tqdm

    records = []
    for spec in tqdm(specs, desc=desc, unit="clip"):
        clip = maker.make(spec, items[spec.motion])
        answers = {
            t.name: {**query(t, clip, args.background), "in_library": spec.label in t.labels}
            for t in targets
        }
        records.append(
            {
                **asdict(spec),
                "video": clip.video.name,
                "person_px": round(clip.person_px, 1),
                "render_s": round(clip.render_s, 3),
                "answers": answers,
            }
        )
    return records


Judged = tuple[dict, dict, QueryOutcome]


def judge(records: Sequence[dict], target: Target) -> list[Judged]:
    """``(record, answer, outcome)`` of every clip ``target`` answered; a clip is in
    the library when ``target`` holds its label."""
    out = []
    for r in records:
        if target.name in r["answers"]:
            a = r["answers"][target.name]
            outcome = QueryOutcome(
                r["label"],
                a["ranked_labels"],
                a["accepted"],
                r["label"] in target.labels,
                a["query_s"],
                a.get("distance", float("inf")),
                0.0 if "error" in a else a.get("p_known"),  # absent from older runs
            )
            out.append((r, a, outcome))
    return out


LABEL_ORDER = (*LABELS, *DISTRACTOR_LABELS, NO_ANSWER)


def target_json(target: Target) -> dict:
    return {**asdict(target), "labels": sorted(target.labels)}


def describe(target: Target) -> str:
    return (
        f"database {target.uri} (rig {target.rig_name}, {target.n_entries} entries, "
        f"unknown threshold {target.threshold:.3f})"
    )


def report(title: str, header: str, judged: Sequence[Judged]) -> dict:
    """Print a score and the in-library clips answered wrong; return the score's JSON."""
    result = score([o for _, _, o in judged], TOP_K, LABEL_ORDER)
    print(f"\n### {title}\n\n{header}\n")
    print(format_score(result))
    outcomes = [o for _, _, o in judged]
    if outcomes and all(o.p_known is not None for o in outcomes):
        print("\nrejection at each share of `eigmotion query --false-rejection`:\n")
        print(format_operating_points(operating_points(outcomes)))
    wrong = [(r, a) for r, a, o in judged if o.in_library and not o.hit(1)]
    if wrong:
        print("\nin-library clips answered wrong (top-1):")
        for r, a in wrong:
            fold = f"{r['fold']:<10} " if "fold" in r else ""
            print(
                f"  {fold}{r['motion']:<30} az {r['azimuth_deg']:5.1f} "
                f"el {r['elevation_deg']:+5.1f} body {r['height_m']:.2f} m/{r['girth']:.1f} "
                f"{r['person_px']:4.0f} px → {' > '.join(a['ranked_labels'][:TOP_K])}"
                + ("" if a["accepted"] else "  (rejected)")
                + (f"  [{a['error']}]" if "error" in a else "")
            )
    return result.to_json()


# -- suites -----------------------------------------------------------------------------


def suite_seen(args, basic: list[LibraryMotion], distractors, maker: ClipMaker) -> dict:
    """Every library motion from halfway views against the default database."""
    built = ensure_database(args, basic)
    target = open_target("default", args.db)
    with MotionDatabase.open(args.db) as db:
        rig = db.rig
    items = _one_per_label(basic) if args.quick and not args.only else basic
    specs = [s for m in items for s in seen_specs(m, rig, args.clips_per_motion, args.seed)]
    records = run_clips(specs, {m.name: m for m in basic}, [target], maker, args, "seen")
    azimuths, elevations = halfway_views(rig)
    print(
        f"\n## seen: {len(items)} motions × {args.clips_per_motion} clip(s), body shapes "
        f"(height m, girth) {BODY_SHAPES}, views halfway between the rig's cameras "
        f"({len(azimuths)} azimuths from {azimuths.min():.0f}°, elevation "
        f"{', '.join(f'{e:.0f}°' for e in elevations)}), {_background_note(args)}"
    )
    scored = report("seen: default database", describe(target), judge(records, target))
    scored = {"database": target_json(target), **scored}
    return {"built": built, "scores": {"default": scored}, "queries": records}


def suite_loso(args, basic: list[LibraryMotion], distractors, maker: ClipMaker) -> dict:
    """Each CMU performer's motions against a database built without them."""
    folds = subject_folds(basic, args)
    return run_folds("loso", folds, basic, maker, args, ((),))


def suite_holdout(args, basic: list[LibraryMotion], distractors, maker: ClipMaker) -> dict:
    """People the database has never seen: new performers, held-out variations, clothes.

    The CMU subject folds of ``loso`` and, for the authored motions, folds that each
    hold out one variation of every label (the ``k``-th authored motion of each label
    in library order, with its mirror image); query bodies wear the benchmark garments
    (none, skirt, long coat, loose trousers), never used by a database.
    """
    from eigmotion.body.garments import BENCHMARK_GARMENTS

    folds = subject_folds(basic, args) + variation_folds(basic, args)
    outfits = ((), *((name,) for name in BENCHMARK_GARMENTS))
    return run_folds("holdout", folds, basic, maker, args, outfits)


def run_folds(
    suite: str,
    folds: Sequence[tuple[str, list]],
    basic: list[LibraryMotion],
    maker: ClipMaker,
    args: argparse.Namespace,
    outfits: Sequence[tuple[str, ...]],
) -> dict:
    """For each fold, a database without its motions, queried with clips of them."""
    if not folds:
        raise InvalidParameterError(f"{suite}: the selected library gives no fold")
    items = {m.name: m for m in basic}
    judged: list[Judged] = []
    fold_rows = []
    records: list[dict] = []
    with tempfile.TemporaryDirectory(prefix=f"eigmotion-{suite}-") as tmp:
        for name, held in folds:
            held_names = {m.name for m in held}
            train = [m for m in basic if m.name not in held_names]
            uri = Path(tmp) / f"without_{name}.fs"
            print(f"fold {name}: building without its {len(held)} motions", file=sys.stderr)
            built = build(train, uri, args)
            target = open_target(f"without_{name}", uri)
            specs = [s for m in held for s in random_specs(m, args, maker, outfits)]
            fold_records = run_clips(specs, items, [target], maker, args, name)
            for r in fold_records:
                r["fold"] = name
            fold = judge(fold_records, target)
            records += fold_records
            judged += fold
            inside = [o for _, _, o in fold if o.in_library]
            outside = [o for _, _, o in fold if not o.in_library]
            fold_rows.append(
                {
                    "fold": name,
                    "held_out": [m.name for m in held],
                    "out_of_library_labels": sorted({m.label for m in held} - target.labels),
                    "build": built,
                    "threshold": target.threshold,
                    "n_in_library": len(inside),
                    "top1": sum(o.hit(1) for o in inside),
                    "topk": sum(o.hit(TOP_K) for o in inside),
                    "false_rejected": sum(not o.accepted for o in inside),
                    "n_out_of_library": len(outside),
                    "out_of_library_rejected": sum(not o.accepted for o in outside),
                }
            )
            for suffix in ("", ".index", ".lock", ".tmp"):
                Path(f"{uri}{suffix}").unlink(missing_ok=True)
    px = np.array([r["person_px"] for r in records])
    dressed = ", ".join("+".join(o) or "none" for o in outfits)
    print(
        f"\n## {suite}: {len(folds)} folds, {args.clips_per_motion} clip(s) per held-out "
        f"motion, random views (azimuth 0–360°, elevation {LOSO_ELEVATION_DEG[0]:.0f}…"
        f"{LOSO_ELEVATION_DEG[1]:.0f}°), body shapes {BODY_SHAPES}, garments {dressed}, "
        f"person {px.min():.0f}–{px.max():.0f} px tall (median {np.median(px):.0f}) in "
        f"{WIDTH_PX}×{HEIGHT_PX}; fold databases built with {args.build_rig.name}, "
        f"{_background_note(args)}\n"
    )
    rows = [
        [
            f["fold"],
            str(len(f["held_out"])),
            ", ".join(f["out_of_library_labels"]) or "—",
            f"{f['top1']}/{f['n_in_library']}",
            f"{f['topk']}/{f['n_in_library']}",
            f"{f['false_rejected']}/{f['n_in_library']}",
            f"{f['out_of_library_rejected']}/{f['n_out_of_library']}",
            f"{f['threshold']:.3f}",
        ]
        for f in fold_rows
    ]
    header = [
        "fold",
        "motions held out",
        "out-of-library labels",
        "top-1",
        f"top-{TOP_K}",
        "falsely rejected",
        "out-of-library rejected",
        "threshold",
    ]
    print("\n".join(markdown_table(header, rows)))
    scored = report(
        f"{suite}: all folds (each clip against its own fold's database)",
        f"{len(folds)} fold databases built with {args.build_rig}",
        judged,
    )
    return {"folds": fold_rows, "scores": {"all_folds": scored}, "queries": records}


def suite_unknown(args, basic: list[LibraryMotion], distractors, maker: ClipMaker) -> dict:
    """Distractors and held-out labels should be rejected; the rest accepted."""
    built = ensure_database(args, basic)
    default = open_target("default", args.db)
    with MotionDatabase.open(args.db) as db:
        rig = db.rig
    holdout = tuple(args.holdout_labels[:1] if args.quick else args.holdout_labels)
    bad = sorted(set(holdout) - {m.label for m in basic})
    if bad:
        raise InvalidParameterError(f"--holdout-labels: {bad} not among the library's labels")
    held = [m for m in basic if m.label in holdout]
    kept = [m for m in basic if m.label not in holdout]
    if not kept:
        raise InvalidParameterError("--holdout-labels leave no motion to build a database from")
    shown_distractors = _one_per_label(distractors) if args.quick else distractors
    inside = _one_per_label(kept)[:4] if args.quick else kept
    n = args.clips_per_motion
    specs = [s for m in (*shown_distractors, *held) for s in seen_specs(m, rig, n, args.seed)]
    specs += [seen_specs(m, rig, 1, args.seed)[0] for m in inside]
    items = {m.name: m for m in (*basic, *distractors)}
    with tempfile.TemporaryDirectory(prefix="eigmotion-unknown-") as tmp:
        uri = Path(tmp) / "without_holdout.fs"
        print(f"building without {list(holdout)}", file=sys.stderr)
        built_holdout = build(kept, uri, args)
        without = open_target("without_holdout", uri)
        records = run_clips(specs, items, [default, without], maker, args, "unknown")
    print(
        f"\n## unknown: distractors {sorted({m.label for m in shown_distractors})} "
        f"({len(shown_distractors)} motions) and held-out labels {list(holdout)} "
        f"({len(held)} motions), {n} clip(s) each; {len(inside)} other motions × 1 clip "
        f"for the false rejections; views halfway between the default database's cameras; "
        f"the database without {list(holdout)} built with {args.build_rig.name}, "
        f"{_background_note(args)}"
    )
    scores = {
        "default": {
            "database": target_json(default),
            **report("unknown: default database", describe(default), judge(records, default)),
        },
        "without_holdout": {
            "database": target_json(without),
            **report(
                f"unknown: database without {', '.join(holdout)}",
                describe(without),
                judge(records, without),
            ),
        },
    }
    return {
        "built": built,
        "built_without_holdout": built_holdout,
        "holdout_labels": list(holdout),
        "scores": scores,
        "queries": records,
    }


def _background_note(args) -> str:
    if args.background:
        return "queried with the image of the empty scene"
    return "queried without a background image (estimated from the clip)"


def _one_per_label(motions: Sequence[LibraryMotion]) -> list[LibraryMotion]:
    out, seen = [], set()
    for m in motions:
        if m.label not in seen:
            seen.add(m.label)
            out.append(m)
    return out


# -- command line -----------------------------------------------------------------------


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description="accuracy of the retrieval engine on rendered query clips",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("suite", choices=(*SUITES, "all"))
    p.add_argument(
        "--db",
        type=Path,
        default=DEFAULT_DB_PATH,
        help="the database of seen/unknown (built when missing)",
    )
    p.add_argument("--rebuild", action="store_true", help="rebuild --db first")
    p.add_argument(
        "--rig",
        type=Path,
        default=None,
        help="rig of the databases this script builds (default "
        "virtual_cameras/default.toml; ring6.toml with --quick)",
    )
    p.add_argument("--workers", type=int, default=None, help="rendering processes of builds")
    p.add_argument(
        "--components",
        type=int,
        default=None,
        help="eigen-dimensions k of the databases this script builds (default from config)",
    )
    p.add_argument(
        "--plain-bodies",
        action="store_true",
        help="build databases with the plain avatar only (no body shapes or garments)",
    )
    p.add_argument(
        "--clips-per-motion",
        type=int,
        default=None,
        help="query clips per motion (default 2; 1 with --quick)",
    )
    p.add_argument(
        "--only",
        nargs="+",
        metavar="NAME",
        help="use only these library motions (names; distractors included)",
    )
    p.add_argument("--subjects", nargs="+", help="loso, holdout: performers to hold out (cmu_02 …)")
    p.add_argument(
        "--holdout-labels",
        nargs="+",
        default=list(DEFAULT_HOLDOUT_LABELS),
        help="unknown: labels left out of the second database",
    )
    p.add_argument(
        "--no-background",
        dest="background",
        action="store_false",
        help="query without the empty-scene image (estimated from the clip)",
    )
    p.add_argument("--clips-dir", type=Path, help="render clips here and reuse them")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quick", action="store_true", help="a small smoke run")
    p.add_argument("--json-out", type=Path, help="write the results as JSON")
    args = p.parse_args(argv)
    if args.clips_per_motion is None:
        args.clips_per_motion = 1 if args.quick else 2
    if args.clips_per_motion < 1:
        p.error(f"--clips-per-motion must be >= 1, got {args.clips_per_motion}")
    if args.components is not None and args.components < 1:
        p.error(f"--components must be >= 1, got {args.components}")
    if args.workers is not None and args.workers < 1:
        p.error(f"--workers must be >= 1, got {args.workers}")
    args.build_rig = args.rig or (QUICK_RIG if args.quick else DEFAULT_RIG)
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    everything = load_library(include_distractors=True)
    if args.only:
        names = {m.name for m in everything}
        unknown = sorted(set(args.only) - names)
        if unknown:
            raise InvalidParameterError(f"--only: no library motion named {unknown}")
        everything = [m for m in everything if m.name in set(args.only)]
    basic = [m for m in everything if m.role == "basic"]
    distractors = [m for m in everything if m.role == "distractor"]
    if not basic:
        raise InvalidParameterError("no basic motion selected: nothing to build or query")
    suites = SUITES if args.suite == "all" else (args.suite,)
    runners = {
        "seen": suite_seen,
        "loso": suite_loso,
        "holdout": suite_holdout,
        "unknown": suite_unknown,
    }
    out = {
        "command": ["python", "benchmarks/accuracy/bench_accuracy.py", *(argv or sys.argv[1:])],
        "settings": {
            "db": str(args.db),
            "plain_bodies": args.plain_bodies,
            "build_rig": str(args.build_rig),
            "seed": args.seed,
            "clips_per_motion": args.clips_per_motion,
            "quick": args.quick,
            "background_image": args.background,
            "body_shapes": BODY_SHAPES,
            "frame_px": [WIDTH_PX, HEIGHT_PX],
            "clip_fps": CLIP_FPS,
        },
        "suites": {},
    }
    with contextlib.ExitStack() as stack:
        clips_dir = args.clips_dir or Path(
            stack.enter_context(tempfile.TemporaryDirectory(prefix="eigmotion-clips-"))
        )
        maker = ClipMaker(clips_dir)
        for name in suites:
            t0 = time.perf_counter()
            result = runners[name](args, basic, distractors, maker)
            result["wall_s"] = round(time.perf_counter() - t0, 1)
            print(f"\n{name}: wall time {result['wall_s']:.0f} s")
            out["suites"][name] = result
    if args.json_out:
        args.json_out.write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"bench_accuracy: error: {exc}", file=sys.stderr)
        sys.exit(2)
