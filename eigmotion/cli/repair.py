"""``eigmotion repair``: copy every intact motion of a damaged database into a new file.

Examples::

    eigmotion repair damaged.fs --out repaired.fs

The damaged file is only read; ``--out`` must not exist.  Motions whose record,
silhouette sequences or any entry cannot be read are left out (``eigmotion check``
lists them); the copy's motion and entry ids count from 0 again.
"""

from __future__ import annotations

import argparse
import sys

from eigmotion.retrieval.salvage import inspect_database, repair_database


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("db", help="the damaged database file")
    parser.add_argument("--out", required=True, help="the new database file to write")


def run(args: argparse.Namespace) -> int:
    found = inspect_database(args.db)
    try:
        copied = repair_database(found, args.out)
    finally:
        if found.store is not None:
            found.store.close()
    print(
        f"repaired {args.db} into {args.out}: {copied} of {found.n_motions} motions, "
        f"{found.n_intact_entries} of {found.n_entries} entries",
        file=sys.stderr,
    )
    return 0
