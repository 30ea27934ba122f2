"""Shared fixtures: paths to the bundled data, small synthetic skeletons, real databases."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pytest

from eigmotion.imaging.cameras import load_rig
from eigmotion.mocap.library import load_library
from eigmotion.retrieval.build import build_database
from eigmotion.retrieval.library_views import BuildConfig

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

REPO = Path(__file__).resolve().parents[1]
CMU_DIR = REPO / "database" / "motions" / "cmu"


@pytest.fixture
def rng():
    return np.random.default_rng(0)


@pytest.fixture(scope="session")
def cmu_dir() -> Path:
    return CMU_DIR


@pytest.fixture(scope="session")
def ring6_database(tmp_path_factory) -> Callable[[Sequence[str], BuildConfig], Path]:
    """``ring6_database(names, config)``: the path of a real database of the library
    motions ``names`` seen by ``virtual_cameras/ring6.toml``, built with ``config``
    once per session (two workers) and shared by every module that asks for the same
    motions and configuration.  Tests must not change it."""
    built: dict[tuple[tuple[str, ...], BuildConfig], Path] = {}

    def database(names: Sequence[str], config: BuildConfig) -> Path:
        key = (tuple(names), config)
        if key not in built:
            by_name = {m.name: m for m in load_library()}
            path = tmp_path_factory.mktemp("db") / "real.fs"
            rig = load_rig(REPO / "virtual_cameras" / "ring6.toml")
            motions = [by_name[name] for name in names]
            build_database(motions, rig, path, config, workers=2, progress=False)
            built[key] = path
        return built[key]

    return database


#: The library motions and build of the small real database that most test modules ask
#: ``ring6_database`` for (one build per session serves them all).
FOUR_MOTIONS = ("walk_02_01", "kick_135_04", "wave_14_24", "pick_up_02_06_a")
FOUR_MOTION_CONFIG = BuildConfig(
    n_components=16, key_axes=3, key_sections=6, garments=((),), body_shapes=((None, 1.0),)
)


@pytest.fixture(scope="session")
def four_motion_database(ring6_database) -> Path:
    """The path of the real database of :data:`FOUR_MOTIONS` (tests must not change it)."""
    return ring6_database(FOUR_MOTIONS, FOUR_MOTION_CONFIG)
