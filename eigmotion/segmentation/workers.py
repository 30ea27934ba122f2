"""The process-wide worker threads that segmentation and queries run their steps on.

Work that releases the GIL (OpenCV calls, compiled loops, NumPy sorts) runs on
:func:`worker_threads`, one thread per CPU, split with :func:`worker_shares`; while it
does, OpenCV's own thread pool is turned off (:func:`opencv_in_calling_threads`).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from functools import lru_cache

import cv2
import numpy as np

_opencv_scopes = 0  # calls inside opencv_in_calling_threads, across threads
_opencv_threads_before = 0  # OpenCV's thread count when the first of them entered
_opencv_scope_lock = threading.Lock()


@contextmanager
def opencv_in_calling_threads() -> Iterator[None]:
    """OpenCV's own thread pool turned off for the duration: each OpenCV call runs on
    the thread that makes it.

    The worker threads (:func:`worker_threads`) already run OpenCV calls side by side
    on every core; OpenCV's pool on top of them only contends for the same cores (its
    threads wait for work by spinning).  Six chunks of a 3 s clip's frames took 20.1
    and 19.1 ms for the two passes on two workers with the pool, 17.8 and 14.7 ms
    without it (``docs/database.md``, "Query time").  Nested and concurrent uses
    count: the pool's size is put back when the last of them ends.
    """
    global _opencv_scopes, _opencv_threads_before
    with _opencv_scope_lock:
        if _opencv_scopes == 0:
            _opencv_threads_before = cv2.getNumThreads()
            cv2.setNumThreads(1)
        _opencv_scopes += 1
    try:
        yield
    finally:
        with _opencv_scope_lock:
            _opencv_scopes -= 1
            if _opencv_scopes == 0:
                cv2.setNumThreads(_opencv_threads_before)


@lru_cache(maxsize=1)
def worker_threads() -> ThreadPoolExecutor:
    """The threads, one per CPU, that chunks of frames are segmented on and a query's
    independent steps run on (work that releases the GIL: OpenCV, compiled loops).
    A task running on them must not wait for another task it submits to them."""
    return ThreadPoolExecutor(max_workers=os.cpu_count() or 1, thread_name_prefix="eigmotion-seg")


def worker_shares(length: int) -> list[tuple[int, int]]:
    """Bounds ``[lo, hi)`` that split ``length`` items into one share per worker thread
    (:func:`worker_threads`), in order; empty shares are left out."""
    bounds = np.linspace(0, length, (os.cpu_count() or 1) + 1).astype(np.int64)
    return [(int(lo), int(hi)) for lo, hi in zip(bounds[:-1], bounds[1:], strict=True) if hi > lo]


# A forked child has none of its parent's threads: it starts a pool of its own.
os.register_at_fork(after_in_child=worker_threads.cache_clear)
