"""Wall-clock timing of a piece of work, as the speed benchmarks report it."""

from __future__ import annotations

import time

import numpy as np


def best_time(work, repeats: int = 3):
    """Shortest wall time, seconds, of ``repeats`` runs of ``work()`` and its last result."""
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = work()
        best = min(best, time.perf_counter() - start)
    return best, result
