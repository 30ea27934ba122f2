"""Every bundled CMU clip reads into a plausible person; ``eigmotion convert`` end to end.

Per-clip criteria (world: metres, Y up, the floor y = 0 set by forward kinematics at
the lowest point of the whole clip):

* rest pose: 1.5–1.9 m from the head's end site down to the lowest point;
* bone lengths constant to 1e-6 m over all frames;
* nothing below the floor (>= -1e-9 m), and the point that defines the floor is a
  foot point (the ``*foot``/``*toes`` joints or their end sites); in >= 95 % of the
  frames the lowest point of the body is a foot point;
* foot contact, for clips where the person stands on the floor (all but the two
  sitting clips 14_27 and 14_29, whose feet rest on the stool): split the clip into
  0.5 s windows and take in each the lowest foot point, the moment of contact.  The
  median of those is the contact level; it must be <= 6 cm, and >= 75 % of the
  windows must lie within 3 cm of it.  (The floor is the single lowest point of the
  clip, a toe pressed down or marker noise, so the usual contact level sits a few
  centimetres above it: 0.3–5.8 cm over these clips; and some capture floors slope
  by a few centimetres over the walk, which the 3 cm band allows.)
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from eigmotion.cli.main import main
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.asf import INCH_M
from eigmotion.mocap.bvh import read_bvh, write_bvh
from eigmotion.mocap.canonical import CANONICAL_JOINTS
from eigmotion.mocap.kinematics import forward_kinematics, rest_points

REPO = Path(__file__).resolve().parents[1]
CMU = REPO / "database" / "motions" / "cmu"
CLIPS = sorted(p.stem for p in (CMU / "amc").glob("*.amc"))
SITTING = {"14_27", "14_29"}


def _asf(clip: str) -> Path:
    return CMU / "asf" / f"{clip.split('_')[0]}.asf"


def test_all_listed_clips_are_here():
    assert len(CLIPS) == 23
    for clip in CLIPS:
        assert _asf(clip).is_file()


@pytest.mark.parametrize("clip", CLIPS)
def test_cmu_clip_is_a_plausible_person(clip):
    motion = read_amc(CMU / "amc" / f"{clip}.amc", _asf(clip))
    sk = motion.skeleton
    assert motion.length_unit_m == pytest.approx(INCH_M / 0.45)
    assert sk.n_joints == 31 and motion.n_frames > 100
    assert np.all(np.isfinite(motion.values))

    rest = rest_points(sk) * motion.length_unit_m
    head_end = rest[sk.n_joints + sorted(sk.end_sites).index(sk.index("head"))]
    height_m = head_end[1] - rest[:, 1].min()
    assert 1.5 <= height_m <= 1.9, height_m

    pose = forward_kinematics(motion)
    lengths = pose.bone_lengths()
    assert np.abs(lengths - lengths[0]).max() < 1e-6

    points = pose.all_points()
    labels = list(sk.names) + [sk.names[j] for j in pose.end_site_joints]
    foot = np.array([i for i, n in enumerate(labels) if n.endswith(("foot", "toes"))])
    assert len(foot) == 6  # lfoot, ltoes, rfoot, rtoes and the two toe end sites
    heights = points[..., 1]
    assert heights.min() >= -1e-9 and heights[:, foot].min() <= 1e-9
    lowest_is_foot = np.isin(heights.argmin(axis=1), foot)
    assert lowest_is_foot.mean() >= 0.95

    if clip in SITTING:
        return
    foot_low = heights[:, foot].min(axis=1)
    window = int(round(0.5 / motion.frame_time_s))
    contact = np.array([foot_low[i : i + window].min() for i in range(0, len(foot_low), window)])
    level = np.median(contact)
    assert level <= 0.06, level
    assert np.mean(np.abs(contact - level) <= 0.03) >= 0.75


# -- eigmotion convert --------------------------------------------------------------------


@pytest.fixture(scope="module")
def walk():
    return read_amc(CMU / "amc" / "02_01.amc", _asf("02_01"))


def test_convert_amc_trim_resample_rename(tmp_path, walk, capsys):
    out = tmp_path / "walk.bvh"
    args = ["convert", str(CMU / "amc" / "02_01.amc"), "--asf", str(_asf("02_01")), str(out)]
    args += ["--start", "12", "--stop", "252", "--fps", "30", "--canonical-names"]
    assert main(args) == 0
    assert "60 frames" in capsys.readouterr().out
    got = read_bvh(out)
    assert got.skeleton.names == CANONICAL_JOINTS
    assert got.n_frames == 60 and got.fps == pytest.approx(30)
    # Every 4th input frame of 120 fps, same world positions (BVH detects the unit).
    ours = forward_kinematics(got, ground=False).positions
    ref = forward_kinematics(walk.trim(12, 252), ground=False).positions[::4]
    np.testing.assert_allclose(ours, ref, atol=1e-4)


def test_convert_bvh_to_bvh_keeps_channels(tmp_path, walk):
    src = tmp_path / "in.bvh"
    write_bvh(walk.trim(0, 30), src)
    out = tmp_path / "out.bvh"
    assert main(["convert", str(src), str(out), "--start", "5"]) == 0
    np.testing.assert_allclose(read_bvh(out).values, read_bvh(src).values[5:], atol=1e-6)


@pytest.mark.parametrize(
    "make, extra, message",
    [
        (lambda d: d / "02_01.amc", [], "needs its skeleton: --asf"),
        (lambda d: d / "walk.fbx", [], "unknown motion format"),
        (lambda d: d / "short.bvh", [], r"short.bvh:\d+: .*truncated"),
        (lambda d: d / "ok.bvh", ["--stop", "0"], "empty"),
        (lambda d: d / "ok.bvh", ["--fps", "-3"], "fps must be > 0"),
        (lambda d: d / "odd.bvh", ["--canonical-names"], "Tail"),
        (lambda d: d / "ok.bvh", ["--joint-map", "{tmp}/map.toml"], "--canonical-names"),
        (lambda d: d / "missing.bvh", [], "No such file"),
    ],
    ids=[
        "amc-without-asf",
        "unknown-format",
        "truncated",
        "empty-range",
        "bad-fps",
        "unmappable-names",
        "joint-map-alone",
        "missing-file",
    ],
)
def test_convert_errors_are_one_line_exit_2(tmp_path, walk, capsys, make, extra, message):
    ok = walk.trim(0, 3)
    write_bvh(ok, tmp_path / "ok.bvh")
    text = (tmp_path / "ok.bvh").read_text()
    (tmp_path / "short.bvh").write_text(text[: len(text) - 40])
    (tmp_path / "02_01.amc").write_text("1\n")
    (tmp_path / "walk.fbx").write_text("")
    (tmp_path / "map.toml").write_text('[joints]\nroot = "Hips"\n')
    names = list(ok.skeleton.names)
    names[-1] = "Tail"
    write_bvh(ok.replace(skeleton=ok.skeleton.renamed(names)), tmp_path / "odd.bvh")
    extra = [arg.format(tmp=tmp_path) for arg in extra]
    code = main(["convert", str(make(tmp_path)), str(tmp_path / "out.bvh"), *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("eigmotion convert: error: ")
    assert re.search(message, err), err


def test_convert_with_a_joint_map_file(tmp_path, walk):
    ok = walk.trim(0, 3)
    names = list(ok.skeleton.names)
    names[-1] = "Tail"
    src = tmp_path / "odd.bvh"
    write_bvh(ok.replace(skeleton=ok.skeleton.renamed(names)), src)
    (tmp_path / "map.toml").write_text('[joints]\nTail = "RThumb"\n')
    out = tmp_path / "out.bvh"
    args = ["convert", str(src), str(out), "--canonical-names", "--joint-map"]
    assert main([*args, str(tmp_path / "map.toml")]) == 0
    assert read_bvh(out).skeleton.names[-1] == "RThumb"


def test_convert_subprocess_truncated_file_exit_2_one_line(tmp_path, walk):
    src = tmp_path / "walk.bvh"
    write_bvh(walk.trim(0, 10), src)
    text = src.read_text()
    src.write_text(text[: len(text) // 2])
    proc = subprocess.run(
        [sys.executable, "-m", "eigmotion", "convert", str(src), str(tmp_path / "o.bvh")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"eigmotion convert: error: {src}:")
    assert not (tmp_path / "o.bvh").exists()


def test_convert_amc_frame_rate_option(tmp_path):
    out = tmp_path / "walk.bvh"
    amc = str(CMU / "amc" / "02_01.amc")
    assert main(["convert", amc, "--asf", str(_asf("02_01")), str(out), "--amc-fps", "60"]) == 0
    got = read_bvh(out)
    assert got.fps == pytest.approx(60) and got.n_frames == 343
