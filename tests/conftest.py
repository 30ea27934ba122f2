"""Shared fixtures: paths to the bundled data, small synthetic skeletons."""

from __future__ import annotations

import contextlib
import importlib.util
import os
import sys
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

REPO = Path(__file__).resolve().parents[1]
CMU_DIR = REPO / "database" / "motions" / "cmu"


@pytest.fixture
def rng():
    return np.random.default_rng(0)


@pytest.fixture(scope="session")
def cmu_dir() -> Path:
    return CMU_DIR


@contextlib.contextmanager
def _benchmark_script(name: str):
    """``benchmarks/<name>.py`` imported as a module, and forgotten afterwards with any
    other script it imported (the scripts import each other from their folder)."""
    folder = str(REPO / "benchmarks")
    before = set(sys.modules)
    sys.path.insert(0, folder)
    spec = importlib.util.spec_from_file_location(name, REPO / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        for added in set(sys.modules) - before:
            origin = getattr(sys.modules[added], "__file__", None) or ""
            if Path(origin).parent == Path(folder):  # the package's own modules stay
                del sys.modules[added]
        sys.path.remove(folder)


@pytest.fixture(scope="session")
def benchmark_script():
    """``with benchmark_script("bench_accuracy") as module:`` a script of benchmarks/."""
    return _benchmark_script
