"""Blender's own BVH importer places what eigmotion writes where eigmotion does.

``bpy.ops.import_anim.bvh`` with its default axes reads BVH files written by
``eigmotion query --bvh-out``, ``eigmotion convert`` and the authored library files;
every joint must lie within 1 mm of eigmotion's forward kinematics in every frame and the
lowest point within 3 cm of the floor.  ``eigmotion track``'s BVH is checked in
``tests/test_tracker_cli.py``.  Skipped only where no interpreter can import ``bpy``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from blender_helpers import assert_blender_reads_as_eigmotion, blender_python, read_in_blender

from eigmotion.cli.main import main
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.kinematics import forward_kinematics

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "database" / "samples"
AUTHORED = REPO / "database" / "motions" / "authored"


@pytest.fixture(scope="module")
def python():
    found = blender_python()
    if found is None:
        pytest.skip("Blender's bpy module is not importable (.ci/run installs it)")
    return found


def test_query_bvh_out_stands_on_the_floor_in_blender(python, four_motion_database, tmp_path):
    db = four_motion_database
    bvh = tmp_path / "kick.bvh"
    argv = ["query", str(SAMPLES / "kick.mp4"), "--db", str(db)]
    argv += ["--background", str(SAMPLES / "kick_background.png"), "--bvh-out", str(bvh)]
    assert main(argv) == 0
    assert read_bvh(bvh).skeleton.offsets[0].tolist() == [0.0, 0.0, 0.0]
    assert_blender_reads_as_eigmotion(read_in_blender(python, [bvh], tmp_path))


def test_converted_and_old_files_in_blender(python, cmu_dir, tmp_path):
    converted = tmp_path / "02_01.bvh"
    amc, asf = cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf"
    assert main(["convert", str(amc), "--asf", str(asf), str(converted)]) == 0
    # A file with part of its root position in the ROOT OFFSET, as written before:
    # eigmotion reads it as before, and convert moves the OFFSET into the channels.
    lines = (AUTHORED / "wave_both_hands.bvh").read_text().splitlines()
    assert lines[3] == "\tOFFSET 0.000000 0.000000 0.000000"
    assert lines[4].split()[2:5] == ["Xposition", "Yposition", "Zposition"]
    lines[3] = "\tOFFSET 0.000000 0.900000 0.000000"
    first = lines.index("MOTION") + 3
    for k in range(first, len(lines)):
        values = lines[k].split()
        values[1] = f"{float(values[1]) - 0.9:.6f}"
        lines[k] = " ".join(values)
    old = tmp_path / "old.bvh"
    old.write_text("\n".join(lines) + "\n")
    original = forward_kinematics(read_bvh(AUTHORED / "wave_both_hands.bvh"), ground=False)
    as_before = forward_kinematics(read_bvh(old), ground=False)
    assert np.abs(as_before.positions - original.positions).max() < 1e-5
    rewritten = tmp_path / "rewritten.bvh"
    assert main(["convert", str(old), str(rewritten)]) == 0
    assert_blender_reads_as_eigmotion(read_in_blender(python, [converted, rewritten], tmp_path))


def test_authored_library_files_in_blender(python, tmp_path):
    paths = sorted(AUTHORED.glob("*.bvh"))
    assert len(paths) > 40
    assert_blender_reads_as_eigmotion(read_in_blender(python, paths, tmp_path))
