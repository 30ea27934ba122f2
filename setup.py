"""Build hook: a wheel carries the shipped data under ``eigmotion/_bundled/``.

The basic-motion library, the virtual camera rigs and the sample clips live at the top
of the source tree (``database/motions/``, ``virtual_cameras/``, ``database/samples/``).
A wheel gets copies of them inside the package, where :mod:`eigmotion.resources`
looks first.  An editable install copies nothing: there the source tree is used.
Everything else is declared in ``pyproject.toml``; ``MANIFEST.in`` puts these files in
the sdist, so a wheel built from it carries them too.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent

#: Folder of the source tree → the files of it that a wheel ships (globs).  The
#: scripts that wrote them (``*.py``) stay in the source tree.
SHIPPED = {
    "database/motions": (
        "library.toml",
        "SOURCES.md",
        "cmu/cmu-mocap-index.csv",
        "cmu/asf/*.asf",
        "cmu/amc/*.amc",
        "authored/*.bvh",
    ),
    "virtual_cameras": ("*.toml",),
    "database/samples": ("*.mp4", "*.png"),
}

BUNDLED = Path("eigmotion", "_bundled")


def shipped_files() -> list[Path]:
    """The shipped files, relative to the source tree's root, in a stable order."""
    files = []
    for folder, patterns in SHIPPED.items():
        for pattern in patterns:
            matches = sorted((ROOT / folder).glob(pattern))
            if not matches:
                raise FileNotFoundError(f"no shipped file matches {folder}/{pattern}")
            files += [path.relative_to(ROOT) for path in matches if path.is_file()]
    return files


class BuildWithShippedData(build_py):
    """``build_py`` that also copies the shipped data into ``eigmotion/_bundled/``."""

    def _bundled_targets(self) -> list[tuple[Path, Path]]:
        if getattr(self, "editable_mode", False):
            return []
        return [(ROOT / f, Path(self.build_lib) / BUNDLED / f) for f in shipped_files()]

    def run(self) -> None:
        super().run()
        # a file left by an earlier build, since removed from the source tree, must go
        shutil.rmtree(Path(self.build_lib) / BUNDLED, ignore_errors=True)
        for source, target in self._bundled_targets():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        bundled = [str(target) for _, target in self._bundled_targets()]
        return super().get_outputs(include_bytecode) + bundled


setup(cmdclass={"build_py": BuildWithShippedData})
