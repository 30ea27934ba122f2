"""Where eigmotion finds the data it ships and where it keeps the default database.

The basic-motion library (``database/motions/``), the virtual camera rigs
(``virtual_cameras/``) and the sample clips (``database/samples/``) live at the top of
the source tree; a wheel carries copies of them inside the package, under
``eigmotion/_bundled/`` (written by ``setup.py`` at build time).  Both layouts are
found here, the wheel's first, so nothing else needs to know how eigmotion was
installed.

The default database is ``database/eigmotion.fs`` in a source checkout (where the
README's commands write it) and ``$XDG_DATA_HOME/eigmotion/eigmotion.fs``
(``~/.local/share/eigmotion/eigmotion.fs``) for an installed wheel.
"""

from __future__ import annotations

import os
from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent
_BUNDLED_DIR = _PACKAGE_DIR / "_bundled"
_SOURCE_ROOT = _PACKAGE_DIR.parent


def _shipped(*parts: str) -> Path:
    """The shipped file or folder ``parts``: the wheel's copy, else the source tree's."""
    bundled = _BUNDLED_DIR.joinpath(*parts)
    return bundled if bundled.exists() else _SOURCE_ROOT.joinpath(*parts)


def source_checkout() -> bool:
    """True when eigmotion runs from its source tree (an editable install or a clone)."""
    return not _BUNDLED_DIR.exists() and (_SOURCE_ROOT / "database" / "motions").is_dir()


def library_manifest() -> Path:
    """The bundled basic-motion library's manifest, ``database/motions/library.toml``."""
    return _shipped("database", "motions", "library.toml")


def rigs_dir() -> Path:
    """The folder of the bundled virtual camera rigs (``*.toml``)."""
    return _shipped("virtual_cameras")


def default_rig() -> Path:
    """The rig ``eigmotion build`` uses by default, ``virtual_cameras/default.toml``."""
    return rigs_dir() / "default.toml"


def samples_dir() -> Path:
    """The folder of the bundled sample clips and their empty-scene images."""
    return _shipped("database", "samples")


def default_database() -> Path:
    """The database commands use when ``--db`` is not given (see the module docstring)."""
    if source_checkout():
        return _SOURCE_ROOT / "database" / "eigmotion.fs"
    data_home = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(data_home) / "eigmotion" / "eigmotion.fs"
