"""The wheel works on its own: built, installed into a fresh virtual environment and run
from a folder outside the source tree, it finds its shipped library, rigs and samples
(``eigmotion/_bundled/``, written by ``setup.py``), builds a small database and answers
a sample clip."""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: What a wheel build reads from the source tree (the sdist holds the same, MANIFEST.in).
BUILD_INPUTS = (
    "pyproject.toml",
    "setup.py",
    "MANIFEST.in",
    "README.md",
    "eigmotion",
    "database/motions",
    "database/samples",
    "virtual_cameras",
)

#: Four bundled motions, one label each, for a database built in seconds.
SMALL_LIBRARY = (
    ("walk_02_02", "walk", ("cmu/amc/02_02.amc", "cmu/asf/02.asf"), (0, 298)),
    ("kick_135_04", "kick", ("cmu/amc/135_04.amc", "cmu/asf/135.asf"), (290, 470)),
    ("run_jogging", "run", ("authored/run_jogging.bvh",), (0, 49)),
    ("pick_up_squatting", "pick_up", ("authored/pick_up_squatting.bvh",), (0, 70)),
)


def _copy_build_inputs(target: Path) -> None:
    """The files a wheel build needs, without build outputs, caches or databases."""
    ignore = shutil.ignore_patterns(
        "__pycache__", "*.pyc", "_bundled", "*.egg-info", "*.fs", "*.fs.*", "build", "dist"
    )
    for name in BUILD_INPUTS:
        source, copy = REPO / name, target / name
        copy.parent.mkdir(parents=True, exist_ok=True)
        if source.is_dir():
            shutil.copytree(source, copy, ignore=ignore)
        else:
            shutil.copyfile(source, copy)


def _small_manifest(motions_dir: Path) -> str:
    """A library manifest naming :data:`SMALL_LIBRARY`'s files by absolute path."""
    tables = []
    for name, label, sources, (start, stop) in SMALL_LIBRARY:
        paths = ", ".join(json.dumps(str(motions_dir / s)) for s in sources)
        tables.append(
            f'[[motion]]\nname = "{name}"\nlabel = "{label}"\nsource = [{paths}]\n'
            f'frame_range = [{start}, {stop}]\nperformer = "test"\nvariation = "a test motion"\n'
            'licence = "see SOURCES.md"\nattribution = "see SOURCES.md"\n'
        )
    return "\n".join(tables)


def _run(command: list, cwd: Path, env: dict) -> subprocess.CompletedProcess:
    done = subprocess.run(
        [str(c) for c in command], cwd=cwd, env=env, capture_output=True, text=True, timeout=900
    )
    assert done.returncode == 0, f"{command} failed:\n{done.stdout}\n{done.stderr}"
    return done


@pytest.mark.slow
def test_installed_wheel_builds_and_queries_outside_the_source_tree(tmp_path):
    source, wheels, work = tmp_path / "source", tmp_path / "wheels", tmp_path / "work"
    work.mkdir()
    _copy_build_inputs(source)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["XDG_DATA_HOME"] = str(tmp_path / "data_home")

    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", wheels, source], work, env)
    (wheel,) = wheels.glob("eigmotion-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for shipped in (
        "eigmotion/_bundled/database/motions/library.toml",
        "eigmotion/_bundled/database/motions/cmu/amc/02_02.amc",
        "eigmotion/_bundled/database/motions/authored/run_jogging.bvh",
        "eigmotion/_bundled/virtual_cameras/default.toml",
        "eigmotion/_bundled/database/samples/walk.mp4",
        "eigmotion/data/avatar/makehuman/base.obj",
        "eigmotion/serve/static/index.html",
        "eigmotion/serve/static/three/three.module.min.js",
        "eigmotion/serve/static/three/LICENSE",
    ):
        assert shipped in names
    assert not any(n.startswith("eigmotion/_bundled/") and n.endswith(".py") for n in names)

    # A fresh environment holding the wheel alone; its dependencies are this
    # interpreter's (a plain path line: no .pth of ours, so no editable install, is run).
    environment = tmp_path / "venv"
    venv.create(environment, with_pip=True)
    python = environment / "bin" / "python"
    _run([python, "-m", "pip", "install", "--no-deps", "-q", wheel], work, env)
    purelib = _run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], work, env
    ).stdout.strip()
    parents = [p for p in site.getsitepackages() if Path(p).is_dir()]
    (Path(purelib) / "_parent_site_packages.pth").write_text("\n".join(parents) + "\n")

    found = _run(
        [
            python,
            "-c",
            "import eigmotion, eigmotion.resources as r; print(eigmotion.__file__); "
            "print(r.source_checkout()); print(r.library_manifest().parent); "
            "print(r.rigs_dir()); print(r.samples_dir())",
        ],
        work,
        env,
    ).stdout.split("\n")
    package_file, checkout = Path(found[0]), found[1]
    motions_dir, rigs_dir, samples_dir = (Path(s) for s in found[2:5])
    assert package_file.is_relative_to(environment)
    assert checkout == "False"
    for folder in (motions_dir, rigs_dir, samples_dir):
        assert folder.is_relative_to(environment) and folder.is_dir()

    (work / "small.toml").write_text(_small_manifest(motions_dir))
    command = environment / "bin" / "eigmotion"
    build = [command, "build", "--motions", "small.toml", "--rig", rigs_dir / "ring6.toml"]
    _run([*build, "--db", "X.fs", "--quiet"], work, env)
    answer = _run(
        [
            command,
            "query",
            samples_dir / "walk.mp4",
            "--background",
            samples_dir / "walk_background.png",
            "--db",
            "X.fs",
            "--json",
        ],
        work,
        env,
    )
    result = json.loads(answer.stdout)
    assert result["label"] == "walk"
    assert result["accepted"]
