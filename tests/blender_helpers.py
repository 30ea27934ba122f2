"""Read BVH files with Blender's importer and compare with eigmotion's own reading.

Blender's ``bpy`` module pins its own NumPy, so it usually lives in an interpreter of its
own: ``$EIGMOTION_BLENDER_PYTHON``, else ``.venv-blender/bin/python`` in the repository
(``.ci/run`` makes it), else the interpreter running the tests.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.kinematics import detect_length_unit, forward_kinematics

REPO = Path(__file__).resolve().parents[1]
IMPORT_SCRIPT = Path(__file__).resolve().parent / "blender_bvh_import.py"

# Blender's default BVH axes (forward -Z, up Y) map a file's (x, y, z) to (x, -z, y);
# this turns Blender's world (Z up) back to the file's Y-up axes.
BLENDER_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def blender_python() -> str | None:
    """The interpreter that can ``import bpy``, or ``None`` when there is none."""
    candidates = [os.environ.get("EIGMOTION_BLENDER_PYTHON", "")]
    candidates += [str(REPO / ".venv-blender" / "bin" / "python"), sys.executable]
    for python in filter(None, candidates):
        if not Path(python).exists():
            continue
        probe = [python, "-c", "import importlib.util as u, sys; sys.exit(not u.find_spec('bpy'))"]
        if subprocess.run(probe, capture_output=True, check=False).returncode == 0:
            return python
    return None


@dataclass
class BlenderReading:
    """One file as Blender places it, against eigmotion's forward kinematics (metres)."""

    path: Path
    blender_version: str
    max_joint_difference_m: float
    lowest_point_m: float
    eigmotion_lowest_point_m: float


def read_in_blender(python: str, paths: list[Path], out_dir: Path) -> list[BlenderReading]:
    """Import ``paths`` with Blender and compare every joint, every frame, with ours."""
    out = out_dir / "blender.json"
    run = subprocess.run(
        [python, str(IMPORT_SCRIPT), str(out), *map(str, paths)],
        capture_output=True,
        text=True,
        check=False,
        cwd=out_dir,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    data = json.loads(out.read_text())
    readings = []
    for path in paths:
        theirs = data["files"][str(path)]
        motion = read_bvh(path)
        unit = motion.length_unit_m or detect_length_unit(motion.skeleton)
        pose = forward_kinematics(motion, length_unit_m=unit, ground=False)
        heads = np.asarray(theirs["heads"]) @ BLENDER_TO_Y_UP.T * unit
        index = [motion.skeleton.index(name) for name in theirs["names"]]
        assert sorted(index) == list(range(motion.skeleton.n_joints))
        difference = np.abs(heads - pose.positions[:, index]).max()
        tails = np.asarray(theirs["leaf_tails"]) @ BLENDER_TO_Y_UP.T * unit
        lowest = min(heads[..., 1].min(), tails[..., 1].min())
        readings.append(
            BlenderReading(
                path=path,
                blender_version=data["blender"],
                max_joint_difference_m=float(difference),
                lowest_point_m=float(lowest),
                eigmotion_lowest_point_m=float(pose.all_points()[..., 1].min()),
            )
        )
    return readings


def assert_blender_reads_as_eigmotion(
    readings: list[BlenderReading], lowest_m: float = 0.0
) -> None:
    """Joints within 1 mm of ours, and the lowest point (a foot) within 3 cm of ``lowest_m``.

    ``lowest_m`` is where the lowest point belongs: the floor (0) for a file whose feet
    carry end sites at the soles, the height of the lowest joint of the true motion for
    one whose lowest joints are toe joints inside the foot.
    """
    for reading in readings:
        name = reading.path.name
        assert reading.max_joint_difference_m < 1e-3, (name, reading)
        assert abs(reading.lowest_point_m - lowest_m) < 0.03, (name, reading)
