"""``eigmotion list``: the motions a database holds (or the library offers).

Examples::

    eigmotion list                      # the default database
    eigmotion list --db my.fs --json
    eigmotion list --library            # the bundled library's motions, no database needed

One line per motion: its name, label, performer, role (``basic`` or ``distractor``),
its number of database entries (motion images: views × bodies × windows) and its source
file.  ``--json`` prints one object: ``database``, ``n_entries`` and ``motions`` (a list
of objects with those fields; ``entries`` is ``null`` for ``--library``).
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

from eigmotion.mocap.library import MIRROR_SUFFIX, read_manifest
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.storage import DEFAULT_DB_PATH

_COLUMNS = ("name", "label", "performer", "role", "entries", "source")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--db", help=f"database file or zeo://host:port (default {DEFAULT_DB_PATH})"
    )
    parser.add_argument(
        "--library",
        nargs="?",
        const="",
        metavar="MANIFEST",
        help="list a library manifest's motions instead (default: the bundled library)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def _source(text: str) -> str:
    """Source files by their last two path parts (``amc/02_01.amc``)."""
    return ";".join(str(Path(*Path(p).parts[-2:])) for p in text.split(";") if p)


def database_motions(db: MotionDatabase) -> list[dict]:
    """One row per stored motion: name, label, performer, role, entries, source."""
    entries = Counter(db.store.arrays().motions.tolist())
    rows = []
    for motion_id in sorted(db.store.motion_ids()):
        record = db.motion_record(int(motion_id))
        meta = record["metadata"]
        rows.append(
            {
                "name": meta.get("name", str(motion_id)),
                "label": record["label"],
                "performer": meta.get("performer", ""),
                "role": meta.get("role", "basic"),
                "entries": entries.get(int(motion_id), 0),
                "source": _source(record["source"]),
            }
        )
    return rows


def library_motions(manifest: str | None) -> list[dict]:
    """One row per motion of a manifest (mirror images included), ``entries`` None."""
    rows = []
    for entry in read_manifest(manifest or None):
        source = _source(";".join(str(p) for p in entry.source))
        names = [entry.name] + ([entry.name + MIRROR_SUFFIX] if entry.mirror else [])
        for name in names:
            row = {"name": name, "label": entry.label, "performer": entry.performer}
            rows.append(row | {"role": entry.role, "entries": None, "source": source})
    return rows


def run(args: argparse.Namespace) -> int:
    if args.library is not None:
        where, rows, n_entries = args.library or "the bundled library", None, None
        rows = library_motions(args.library)
    else:
        where = str(args.db or DEFAULT_DB_PATH)
        with MotionDatabase.open(args.db or DEFAULT_DB_PATH) as db:
            rows, n_entries = database_motions(db), db.n_entries
    if args.json:
        print(json.dumps({"database": where, "n_entries": n_entries, "motions": rows}))
        return 0
    labels = len({row["label"] for row in rows})
    total = "" if n_entries is None else f", {n_entries:,} entries"
    print(f"{where}: {len(rows)} motions, {labels} labels{total}")
    cells = [[("" if row[c] is None else str(row[c])) for c in _COLUMNS] for row in rows]
    widths = [max(len(c), *(len(line[k]) for line in cells)) for k, c in enumerate(_COLUMNS)]
    for line in [list(_COLUMNS), *cells]:
        print(
            "  ".join(cell.ljust(width) for cell, width in zip(line, widths, strict=True)).rstrip()
        )
    return 0
