"""BVH read/write: round trips, channel semantics, an independent parser, errors."""

from __future__ import annotations

from pathlib import Path

import bvhio
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from eigmotion.errors import InvalidParameterError, MotionFormatError
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.bvh import (
    format_bvh,
    parse_bvh,
    read_bvh,
    root_position_in_channels,
    write_bvh,
)
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.motion import ALL_CHANNELS, Motion, Skeleton
from eigmotion.mocap.rotations import euler_to_matrix

SMALL = """HIERARCHY
ROOT Hips
{
\tOFFSET 1.0 2.0 3.0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0.0 10.0 0.0
\t\tCHANNELS 2 Xrotation Zrotation
\t\tJOINT Arm
\t\t{
\t\t\tOFFSET 5.0 0.0 0.0
\t\t\tCHANNELS 4 Yposition Yrotation Xrotation Zrotation
\t\t\tEnd Site
\t\t\t{
\t\t\t\tOFFSET 0.0 0.0 4.0
\t\t\t}
\t\t}
\t}
\tJOINT Leg
\t{
\t\tOFFSET 0.0 -8.0 0.0
\t\tCHANNELS 0
\t}
}
MOTION
Frames: 2
Frame Time: 0.04
0.5 0.0 -1.0 10.0 20.0 30.0 40.0 50.0 2.0 60.0 70.0 80.0
0.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0 0.0
"""


def _rot(order: str, *angles: float) -> np.ndarray:
    return euler_to_matrix(np.array(angles, dtype=float), order)


# -- reading -----------------------------------------------------------------------------


@pytest.mark.parametrize("newline", ["\n", "\r\n", "\r"])
@pytest.mark.parametrize("indent", ["\t", "    ", ""])
def test_line_ends_and_indentation_do_not_matter(newline, indent):
    text = SMALL.replace("\t", indent).replace("\n", newline)
    m = parse_bvh(text, "small.bvh")
    assert m.skeleton.names == ("Hips", "Chest", "Arm", "Leg")
    assert m.skeleton.channels[1] == ("Xrotation", "Zrotation")
    assert m.skeleton.channels[3] == ()
    assert m.n_frames == 2 and m.frame_time_s == pytest.approx(0.04)
    assert m.name == "small" and m.length_unit_m is None
    np.testing.assert_array_equal(m.skeleton.end_sites[2], [0.0, 0.0, 4.0])


def test_channel_semantics_offset_plus_position_and_intrinsic_order():
    """World positions computed by hand from the BVH rules equal forward kinematics."""
    m = parse_bvh(SMALL)
    pose = forward_kinematics(m, length_unit_m=1.0, ground=False)
    r_hips = _rot("ZXY", 10.0, 20.0, 30.0)
    t_hips = np.array([1.0 + 0.5, 2.0, 3.0 - 1.0])  # OFFSET + position channels
    r_chest = r_hips @ _rot("XZY", 40.0, 50.0, 0.0)
    t_chest = t_hips + r_hips @ [0.0, 10.0, 0.0]
    # A position channel on a non-root joint adds to its offset, in the parent frame.
    t_arm = t_chest + r_chest @ [5.0, 2.0, 0.0]
    r_arm = r_chest @ _rot("YXZ", 60.0, 70.0, 80.0)
    end = t_arm + r_arm @ [0.0, 0.0, 4.0]
    np.testing.assert_allclose(pose.positions[0, 0], t_hips, atol=1e-12)
    np.testing.assert_allclose(pose.positions[0, 1], t_chest, atol=1e-12)
    np.testing.assert_allclose(pose.positions[0, 2], t_arm, atol=1e-12)
    np.testing.assert_allclose(pose.end_sites[0, 0], end, atol=1e-12)
    np.testing.assert_allclose(pose.positions[0, 3], t_hips + r_hips @ [0, -8.0, 0], atol=1e-12)
    # Frame 1 is the rest pose: joints at the summed offsets.
    np.testing.assert_allclose(pose.positions[1, 2], [6.0, 12.0, 3.0], atol=1e-12)


def test_read_bvh_names_motion_after_file(tmp_path):
    path = tmp_path / "walk_01.bvh"
    path.write_text(SMALL)
    m = read_bvh(path)
    assert m.name == "walk_01"
    with pytest.raises(FileNotFoundError):
        read_bvh(tmp_path / "missing.bvh")


def test_channel_names_any_case_and_end_site_spelling():
    text = SMALL.replace("Xrotation Zrotation", "XROTATION zrotation").replace(
        "End Site", "End site"
    )
    m = parse_bvh(text)
    assert m.skeleton.channels[1] == ("Xrotation", "Zrotation")
    assert 2 in m.skeleton.end_sites


def test_braces_on_the_joint_line():
    text = SMALL.replace("JOINT Chest\n\t{", "JOINT Chest {").replace("ROOT Hips\n{", "ROOT Hips {")
    m = parse_bvh(text)
    assert m.skeleton.names == ("Hips", "Chest", "Arm", "Leg")


# -- round trips -------------------------------------------------------------------------

_NAME = st.from_regex(r"[A-Za-z_][A-Za-z0-9_:.\-]{0,10}", fullmatch=True)


@st.composite
def motions(draw) -> Motion:
    n = draw(st.integers(1, 7))
    parents = [-1] + [draw(st.integers(0, j - 1)) for j in range(1, n)]
    names = draw(st.lists(_NAME, min_size=n, max_size=n, unique=True))
    channels = []
    for _ in range(n):
        perm = draw(st.permutations(ALL_CHANNELS))
        channels.append(tuple(perm[: draw(st.integers(0, 6))]))
    coord = st.floats(-500, 500, allow_nan=False, allow_infinity=False)
    offsets = draw(st.lists(st.tuples(coord, coord, coord), min_size=n, max_size=n))
    ends = draw(st.dictionaries(st.integers(0, n - 1), st.tuples(coord, coord, coord)))
    sk = Skeleton(tuple(names), np.array(parents), np.array(offsets), tuple(channels), ends)
    n_frames = draw(st.integers(1, 4))
    value = st.floats(-1000, 1000, allow_nan=False, allow_infinity=False)
    values = draw(
        st.lists(
            st.lists(value, min_size=sk.n_channels, max_size=sk.n_channels),
            min_size=n_frames,
            max_size=n_frames,
        )
    )
    frame_time_s = draw(st.floats(1e-4, 1.0))
    return Motion(sk, np.array(values).reshape(n_frames, sk.n_channels), frame_time_s, None, "m")


def _by_joint(m: Motion) -> dict[str, dict[str, np.ndarray]]:
    starts = m.skeleton.channel_start()
    return {
        name: {ch: m.values[:, starts[j] + k] for k, ch in enumerate(m.skeleton.channels[j])}
        for j, name in enumerate(m.skeleton.names)
    }


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(motions())
def test_write_read_round_trip_keeps_every_channel(m):
    again = parse_bvh(format_bvh(m))
    assert set(again.skeleton.names) == set(m.skeleton.names)
    assert again.frame_time_s == m.frame_time_s
    # The root comes back with a zero OFFSET and its position in its channels.
    np.testing.assert_array_equal(again.skeleton.offsets[0], 0.0)
    m = root_position_in_channels(m)
    ours, theirs = _by_joint(m), _by_joint(again)
    for name in m.skeleton.names:
        assert list(theirs[name]) == list(ours[name])  # same channels, same order
        for ch in ours[name]:
            np.testing.assert_allclose(theirs[name][ch], ours[name][ch], rtol=0, atol=1e-6)
    # Same hierarchy and geometry, joint by joint.
    for j, name in enumerate(m.skeleton.names):
        k = again.skeleton.index(name)
        p, q = m.skeleton.parents[j], again.skeleton.parents[k]
        assert (p < 0 and q < 0) or m.skeleton.names[p] == again.skeleton.names[q]
        np.testing.assert_allclose(again.skeleton.offsets[k], m.skeleton.offsets[j], atol=1e-6)
        assert (j in m.skeleton.end_sites) == (k in again.skeleton.end_sites)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(motions())
def test_written_root_has_zero_offset_and_the_same_joint_positions(m):
    again = parse_bvh(format_bvh(m))
    root = again.skeleton.index(m.skeleton.names[0])
    assert root == 0
    np.testing.assert_array_equal(again.skeleton.offsets[0], 0.0)
    positions = [ch for ch in again.skeleton.channels[0] if ch.endswith("position")]
    assert sorted(positions) in ([], ["Xposition", "Yposition", "Zposition"])
    # The rotation channels of the root keep their order.
    rotations = [ch for ch in again.skeleton.channels[0] if ch.endswith("rotation")]
    assert rotations == [ch for ch in m.skeleton.channels[0] if ch.endswith("rotation")]
    index = [again.skeleton.index(n) for n in m.skeleton.names]
    ours = forward_kinematics(m, length_unit_m=1.0, ground=False)
    theirs = forward_kinematics(again, length_unit_m=1.0, ground=False)
    # Angles are written to 1e-6 degrees; lever arms reach a few thousand units.
    np.testing.assert_allclose(theirs.positions[:, index], ours.positions, atol=1e-3)


def test_old_files_with_a_root_offset_read_as_the_rewritten_ones(tmp_path):
    """A file with a non-zero root OFFSET (as written before) and its rewrite agree."""
    old = parse_bvh(SMALL)
    assert old.skeleton.offsets[0].any()
    path = tmp_path / "rewritten.bvh"
    write_bvh(old, path)
    assert "ROOT Hips\n{\n\tOFFSET 0.000000 0.000000 0.000000\n" in path.read_text()
    new = read_bvh(path)
    np.testing.assert_allclose(
        forward_kinematics(new, length_unit_m=1.0, ground=False).positions,
        forward_kinematics(old, length_unit_m=1.0, ground=False).positions,
        atol=1e-9,
    )
    # Written again, the file does not change.
    assert format_bvh(new) == path.read_text()


def test_a_root_without_position_channels_gets_them_for_its_offset():
    sk = Skeleton(
        ("a", "b"), [-1, 0], np.array([[1.0, 2.0, 3.0], [0, 1.0, 0]]), (("Yrotation",), ())
    )
    m = Motion(sk, np.array([[90.0], [0.0]]), 0.1)
    again = parse_bvh(format_bvh(m))
    assert again.skeleton.channels[0] == ("Xposition", "Yposition", "Zposition", "Yrotation")
    np.testing.assert_allclose(again.values, [[1, 2, 3, 90], [1, 2, 3, 0]])
    # Already in the convention: nothing to change.
    assert root_position_in_channels(again) is again


def test_write_bvh_file_and_precision(tmp_path, rng):
    m = parse_bvh(SMALL)
    m = m.replace(values=m.values + rng.uniform(-1, 1, size=m.values.shape) * 1e-3)
    path = tmp_path / "out.bvh"
    write_bvh(m, path)
    expected = root_position_in_channels(m).values
    np.testing.assert_allclose(read_bvh(path).values, expected, atol=5e-7)
    coarse = parse_bvh(format_bvh(m, precision=1))
    assert np.abs(coarse.values - expected).max() > 1e-4
    with pytest.raises(InvalidParameterError, match="precision"):
        format_bvh(m, precision=-1)


def test_writer_refuses_names_it_cannot_write():
    m = parse_bvh(SMALL)
    bad = m.replace(skeleton=m.skeleton.renamed(["Hips", "Left Arm", "Arm", "Leg"]))
    with pytest.raises(InvalidParameterError, match="Left Arm"):
        format_bvh(bad)


def test_breadth_first_skeleton_is_written_depth_first():
    # Joint order 0, 1, 2, 3 is parents-first but not depth-first (2 is a child of 0).
    sk = Skeleton(
        ("a", "b", "c", "d"),
        [-1, 0, 0, 1],
        np.eye(4, 3),
        (("Xposition", "Zrotation"), ("Xrotation",), ("Yrotation",), ("Zrotation",)),
    )
    m = Motion(sk, np.array([[1.0, 2.0, 3.0, 4.0, 5.0]]), 0.1)
    again = parse_bvh(format_bvh(m))
    assert again.skeleton.names == ("a", "b", "d", "c")
    # The root's OFFSET (1, 0, 0) moves into its position channels, now all three.
    np.testing.assert_allclose(again.values, [[2.0, 0.0, 0.0, 2.0, 3.0, 5.0, 4.0]])
    np.testing.assert_allclose(
        forward_kinematics(again, 1.0, ground=False).positions[:, [0, 1, 3, 2]],
        forward_kinematics(m, 1.0, ground=False).positions,
        atol=1e-9,
    )


# -- an independent parser -------------------------------------------------------------


def _bvhio_positions(path: Path) -> tuple[list[str], np.ndarray]:
    """World joint positions per frame as the ``bvhio`` package computes them."""
    root = bvhio.readAsHierarchy(str(path))
    layout = [joint for joint, _, _ in root.layout()]
    n_frames = root.getKeyframeRange()[1] + 1
    out = np.empty((n_frames, len(layout), 3))
    for f in range(n_frames):
        root.loadPose(f)
        out[f] = [list(joint.PositionWorld) for joint in layout]
    return [joint.Name for joint in layout], out


def test_converted_cmu_clip_matches_bvhio(tmp_path, cmu_dir):
    """bvhio reads our BVH of a CMU clip to the same joint positions (metres)."""
    m = read_amc(cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf").trim(0, 40)
    path = tmp_path / "02_01.bvh"
    write_bvh(m, path)
    names, theirs = _bvhio_positions(path)
    ours_motion = read_bvh(path)
    unit = m.length_unit_m  # bvhio works in file units; compare in metres
    pose = forward_kinematics(ours_motion, length_unit_m=unit, ground=False)
    index = [ours_motion.skeleton.index(n) for n in names]
    err_m = np.abs(theirs * unit - pose.positions[:, index]).max()
    assert err_m < 1e-4
    # And both agree with the motion before it was written.
    direct = forward_kinematics(m, ground=False).positions
    np.testing.assert_allclose(pose.positions, direct, atol=1e-5)


def test_bvhio_reads_a_written_root_offset_where_we_do(tmp_path):
    """bvhio drops a root OFFSET beside position channels; written files have none."""
    m = parse_bvh(SMALL)
    # Keep the root's position channels only, so that bvhio reads every other joint as we do.
    sk = m.skeleton
    channels = (
        sk.channels[0],
        ("Xrotation", "Zrotation"),
        ("Yrotation", "Xrotation", "Zrotation"),
        (),
    )
    keep = [0, 1, 2, 3, 4, 5, 6, 7, 9, 10, 11]
    m = Motion(
        Skeleton(sk.names, sk.parents, sk.offsets, channels, sk.end_sites), m.values[:, keep], 0.04
    )
    path = tmp_path / "written.bvh"
    write_bvh(m, path)
    names, theirs = _bvhio_positions(path)
    pose = forward_kinematics(m, length_unit_m=1.0, ground=False)
    index = [m.skeleton.index(n) for n in names]
    np.testing.assert_allclose(theirs, pose.positions[:, index], atol=1e-4)


def test_bvhio_position_channels_replace_the_offset(tmp_path):
    """bvhio reads position channels as replacing OFFSET; ours adds them (as BVH means).

    Zeroing the offsets on axes that have position channels makes the two readings
    equal, which checks every other part (rotation orders, partial channels,
    position channels on a non-root joint) against the independent parser.
    """
    path = tmp_path / "small.bvh"
    path.write_text(SMALL)
    names, theirs = _bvhio_positions(path)
    m = read_bvh(path)
    offsets = m.skeleton.offsets.copy()
    for j, chans in enumerate(m.skeleton.channels):
        for ch in chans:
            if ch.endswith("position"):
                offsets[j, "XYZ".index(ch[0])] = 0.0
    sk = m.skeleton
    same = m.replace(skeleton=Skeleton(sk.names, sk.parents, offsets, sk.channels, sk.end_sites))
    pose = forward_kinematics(same, length_unit_m=1.0, ground=False)
    index = [m.skeleton.index(n) for n in names]
    np.testing.assert_allclose(theirs, pose.positions[:, index], atol=1e-4)
    plain = forward_kinematics(m, length_unit_m=1.0, ground=False)
    assert np.abs(plain.positions[:, 0] - pose.positions[:, 0]).max() == pytest.approx(3.0)


# -- errors ------------------------------------------------------------------------------


def _replace(old: str, new: str, count: int = 1):
    def edit(text: str) -> str:
        assert old in text
        return text.replace(old, new, count)

    return edit


BROKEN = [
    ("truncated in the hierarchy", lambda t: t[: t.index("JOINT Arm")], 10, "ends early"),
    ("truncated frames", lambda t: t[: t.rstrip().rindex("\n") + 1], 29, "truncated"),
    ("truncated mid-line", lambda t: t[: t.rindex("0.0 " * 8)], 30, "3 values.*truncated"),
    ("no HIERARCHY", _replace("HIERARCHY\n", ""), 1, "starts with 'HIERARCHY'"),
    ("no ROOT", _replace("ROOT Hips", "Hips"), 2, "expected 'ROOT'"),
    ("no MOTION", _replace("MOTION\n", ""), 26, "expected 'MOTION'"),
    ("empty file", lambda t: "", 1, "ends early"),
    ("short frame line", _replace(" 80.0\n", "\n"), 29, "has 11 values"),
    ("long frame line", _replace(" 80.0\n", " 80.0 1.0\n"), 29, "has 13 values"),
    ("fewer frames than Frames:", _replace("Frames: 2", "Frames: 3"), 30, "expected 3 frame"),
    ("more frames than Frames:", _replace("Frames: 2", "Frames: 1"), 30, "more frame lines"),
    ("NaN value", _replace("40.0 50.0", "nan 50.0"), 29, "finite"),
    ("infinite value", _replace("40.0 50.0", "1e999 50.0"), 29, "finite"),
    ("text in a value", _replace("40.0 50.0", "forty 50.0"), 29, "'forty'"),
    ("text in an OFFSET", _replace("OFFSET 0.0 10.0 0.0", "OFFSET 0.0 ten 0.0"), 8, "'ten'"),
    ("NaN in an OFFSET", _replace("OFFSET 5.0 0.0 0.0", "OFFSET nan 0.0 0.0"), 12, "finite"),
    ("unknown channel", _replace("Yposition Yrotation", "Wposition Yrotation"), 13, "Wposition"),
    ("channel count too big", _replace("CHANNELS 2", "CHANNELS 9"), 9, "9 channels"),
    ("channel count not a number", _replace("CHANNELS 2", "CHANNELS two"), 9, "'two'"),
    ("channel listed twice", _replace("Xrotation Zrotation", "Xrotation Xrotation"), 9, "twice"),
    ("missing closing brace", _replace("\t}\n}\nMOTION", "\t}\nMOTION"), 24, "closing joint"),
    ("extra closing brace", _replace("}\nMOTION", "}\n}\nMOTION"), 26, "extra '}'"),
    ("missing opening brace", _replace("JOINT Leg\n\t{", "JOINT Leg"), 21, "expected '{'"),
    ("zero frames", _replace("Frames: 2", "Frames: 0"), 27, "at least one frame"),
    ("negative frames", _replace("Frames: 2", "Frames: -4"), 27, "at least one frame"),
    ("frame count not a number", _replace("Frames: 2", "Frames: two"), 27, "integer"),
    ("no Frame Time", _replace("Frame Time: 0.04\n", ""), 28, "Frame Time"),
    ("zero Frame Time", _replace("Frame Time: 0.04", "Frame Time: 0"), 28, "> 0"),
    ("NaN Frame Time", _replace("Frame Time: 0.04", "Frame Time: nan"), 28, "finite"),
    ("duplicate joint name", _replace("JOINT Leg", "JOINT Arm"), 20, "duplicate joint name"),
    ("second ROOT", _replace("}\nMOTION", "}\nROOT X\n{\nOFFSET 0 0 0\n}\nMOTION"), 26, "ROOT"),
    ("no OFFSET", _replace("\t\tOFFSET 0.0 -8.0 0.0\n", ""), 20, "no OFFSET"),
    ("End Site without OFFSET", _replace("OFFSET 0.0 0.0 4.0", "0.0 0.0 4.0"), 16, "'OFFSET'"),
    ("stray word", _replace("\tCHANNELS 0", "\tCHANNELS 0 oops"), 23, "'oops'"),
]


@pytest.mark.parametrize("edit, line, message", [b[1:] for b in BROKEN], ids=[b[0] for b in BROKEN])
def test_broken_files_name_file_line_and_expectation(tmp_path, edit, line, message):
    path = tmp_path / "broken.bvh"
    path.write_text(edit(SMALL))
    with pytest.raises(MotionFormatError, match=message) as info:
        read_bvh(path)
    assert info.value.path == str(path)
    assert info.value.line == line, str(info.value)
    assert str(info.value).startswith(f"{path}:{line}: ")
