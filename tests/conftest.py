"""Shared fixtures: paths to the bundled data, small synthetic skeletons."""

from __future__ import annotations

import os
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
