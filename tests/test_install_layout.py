"""A clone named ``eigmotion`` seen from the folder above it must not shadow the package.

From that folder Python would take the clone itself for a namespace package ``eigmotion``
(it has no ``__init__.py``); the README's commands install the checkout in setuptools'
``compat`` editable mode, which puts the checkout on ``sys.path`` so the real package wins.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import eigmotion

REPO = Path(__file__).resolve().parents[1]


def _installed_by_editable_finder() -> bool:
    """True for setuptools' default (strict/lenient) editable install: an import hook,
    which namespace packages found on ``sys.path`` come before."""
    return any(type(f).__name__ == "_EditableFinder" for f in sys.meta_path)


def test_a_clone_named_eigmotion_does_not_shadow_the_package(tmp_path):
    if _installed_by_editable_finder() and not os.environ.get("CI"):
        pytest.skip("installed with `pip install -e .` without editable_mode=compat")
    (tmp_path / "eigmotion").symlink_to(REPO, target_is_directory=True)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run(
        [sys.executable, "-c", "from eigmotion import __version__; import eigmotion.cli.main"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert eigmotion.__version__
