"""``eigmotion check``: is a database file whole, and what of it can be recovered.

Examples::

    eigmotion check database/eigmotion.fs

Reads the file only.  Exit 0 when the database opens and every motion is intact,
1 when it is damaged (the lines say where, and how many motions and entries are
intact: ``eigmotion repair`` copies those into a new file).
"""

from __future__ import annotations

import argparse

from eigmotion.retrieval.salvage import inspect_database, report_lines
from eigmotion.retrieval.storage import DEFAULT_DB_PATH


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "db", nargs="?", default=None, help="database file (default database/eigmotion.fs)"
    )


def run(args: argparse.Namespace) -> int:
    uri = str(args.db or DEFAULT_DB_PATH)
    found = inspect_database(uri)
    try:
        for line in report_lines(found, uri):
            print(line)
    finally:
        if found.store is not None:
            found.store.close()
    whole = (
        found.readable is None
        and not found.problem
        and not found.damaged_motions
        and not found.scan.damaged
        and found.index != "damaged"
    )
    if not whole:
        print(f"to recover: eigmotion repair {uri} --out NEW.fs")
    return 0 if whole else 1
