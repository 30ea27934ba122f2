"""Scan or walk: a database's searches by scanning every entry against the tree's walk.

For batches of 1 … 32 queries and several ``top_k``, the median ms of
``TreeIndex.search`` (which scans a database of at most ``scan_entries`` entries;
``walk_top_k`` 0 here) and of
``TreeIndex.walk`` (the compiled tree walk, warm), over the stored points of a database
opened read-only; the answers are checked equal.  Queries are stored points moved by
a little noise.

    python benchmarks/speed/bench_scan_or_walk.py --db database/eigmotion.fs
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

from eigmotion.retrieval.search import TreeIndex
from eigmotion.retrieval.store import Store


def median_ms(call, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", default="database/eigmotion.fs")
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    with Store.open(args.db) as store:
        tree = TreeIndex.from_store(store)
        tree.walk_top_k = 0  # search() scans, although numba is loaded here
        points = store.arrays().points
    print(f"{tree.n_entries} entries, k = {tree.n_dims}; load average {os.getloadavg()[0]:.2f}")
    print("| queries | top_k | scanned ms | walked ms |")
    print("| --- | --- | --- | --- |")
    for n_queries in (1, 2, 4, 8, 16, 32):
        for top_k in (1, 8, 256):
            picked = points[rng.integers(0, len(points), n_queries)]
            queries = picked + rng.normal(0, 0.05, picked.shape).astype(np.float32)
            scanned, walked = tree.search(queries, top_k), tree.walk(queries, top_k)
            assert np.array_equal(scanned.ids, walked.ids)
            assert np.array_equal(scanned.distances, walked.distances)
            scan = median_ms(lambda q=queries, k=top_k: tree.search(q, k), args.repeat)
            walk = median_ms(lambda q=queries, k=top_k: tree.walk(q, k), args.repeat)
            print(f"| {n_queries} | {top_k} | {scan:.2f} | {walk:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
