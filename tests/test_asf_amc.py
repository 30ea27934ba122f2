"""CMU/Acclaim ASF/AMC: parsing, the axis baking, known behaviour of real clips, errors."""

from __future__ import annotations

import re

import numpy as np
import pytest

from eigmotion.errors import MotionFormatError
from eigmotion.mocap.amc import parse_amc, read_amc
from eigmotion.mocap.asf import INCH_M, parse_asf, read_asf
from eigmotion.mocap.kinematics import forward_kinematics, rest_points

ASF = """# a small test skeleton
:version 1.10
:name TEST
:units
  mass 1.0
  length 0.45
  angle deg
:documentation
   free text: ignored, even with : inside
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name lfemur
     direction 0 -2 0
     length 10
     axis 0 0 90 XYZ
    dof rx ry rz
    limits (-160.0 20.0)
           (-70.0 70.0)
           (-60.0 70.0)
  end
  begin
     id 2
     name ltibia
     direction 0 -1 0
     length 8
     axis 0 0 0 XYZ
    dof rx
    limits (-10.0 170.0)
  end
  begin
     id 3
     name lowerback
     direction 0 1 0
     length 5
     axis 0 0 0 XYZ
    dof rx ry rz
  end
  begin
     id 4
     name head
     direction 0 1 0
     length 2
     axis 0 0 0 XYZ
  end
:hierarchy
  begin
    root lfemur lowerback
    lfemur ltibia
    lowerback head
  end
"""

AMC = """#!OML:ASF test.asf
:FULLY-SPECIFIED
:DEGREES
1
root 1 2 3 0 90 0
lfemur 0 30 0
ltibia 45
lowerback 0 0 0
2
root 0 0 0 0 0 0
lfemur 0 0 0
ltibia 0
lowerback 90 90 0
"""


def _rx(deg):
    a = np.radians(deg)
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def _ry(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])


def _rz(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def _motion(asf_text=ASF, amc_text=AMC, order="ZXY"):
    return parse_amc(amc_text, parse_asf(asf_text, "test.asf"), "test.amc", order=order)


# -- ASF ---------------------------------------------------------------------------------


def test_read_cmu_asf(cmu_dir):
    asf = read_asf(cmu_dir / "asf" / "02.asf")
    assert (asf.mass, asf.length, asf.angle_unit) == (1.0, 0.45, "deg")
    assert asf.length_unit_m == pytest.approx(INCH_M / 0.45)
    assert asf.root_order == ("TX", "TY", "TZ", "RX", "RY", "RZ") and asf.root_axis == "XYZ"
    assert len(asf.bones) == 30
    names = [b.name for b in asf.bones]
    assert names[:5] == ["lhipjoint", "lfemur", "ltibia", "lfoot", "ltoes"]
    femur = asf.bone("lfemur")
    assert femur.id == 2 and femur.dof == ("rx", "ry", "rz") and femur.axis_order == "XYZ"
    np.testing.assert_allclose(femur.axis_deg, [0, 0, 20])
    np.testing.assert_allclose(femur.limits, [[-160, 20], [-70, 70], [-60, 70]])
    assert femur.length == pytest.approx(7.59371)
    assert np.linalg.norm(femur.direction) == pytest.approx(1.0)
    assert asf.parents["lfemur"] == "lhipjoint" and asf.parents["lowerback"] == "root"
    assert asf.parents["lthumb"] == "lwrist"
    assert asf.bone("lhipjoint").dof == ()


def test_joint_at_bone_start_and_end_sites_at_leaf_tips():
    m = _motion()
    sk = m.skeleton
    assert sk.names == ("root", "lfemur", "ltibia", "lowerback", "head")
    np.testing.assert_allclose(sk.offsets[sk.index("lfemur")], [0, 0, 0])  # starts at root
    np.testing.assert_allclose(sk.offsets[sk.index("ltibia")], [0, -10, 0])  # unit direction
    np.testing.assert_allclose(sk.offsets[sk.index("head")], [0, 5, 0])
    assert sorted(sk.end_sites) == [sk.index("ltibia"), sk.index("head")]
    np.testing.assert_allclose(sk.end_sites[sk.index("ltibia")], [0, -8, 0])
    assert sk.channels[0][:3] == ("Xposition", "Yposition", "Zposition")
    assert sk.channels[sk.index("head")] == ()
    assert sk.channels[sk.index("ltibia")] == ("Zrotation", "Xrotation", "Yrotation")
    assert m.length_unit_m == pytest.approx(INCH_M / 0.45)
    assert m.frame_time_s == pytest.approx(1 / 120) and m.name == "test"


def test_axis_frames_are_baked_into_world_aligned_rotations():
    """Hand-computed ASF kinematics (C M C⁻¹ down the chain) equal the motion's FK."""
    m = _motion()
    pose = forward_kinematics(m, length_unit_m=1.0, ground=False)
    sk = m.skeleton
    # Frame 0: root turned 90° about Y; lfemur's dof ry = 30 turns about its axis
    # frame's y, which C = Rz(90) sends to world -X.
    root_r = _ry(90)
    c = _rz(90)
    femur_local = c @ _ry(30) @ c.T
    np.testing.assert_allclose(femur_local, _rx(-30), atol=1e-12)
    femur_world = root_r @ femur_local
    knee = np.array([1.0, 2.0, 3.0]) + femur_world @ [0, -10, 0]
    np.testing.assert_allclose(pose.positions[0, sk.index("ltibia")], knee, atol=1e-9)
    np.testing.assert_allclose(knee, [1 + 5, 2 - 10 * np.cos(np.radians(30)), 3], atol=1e-9)
    ankle = knee + femur_world @ _rx(45) @ [0, -8, 0]
    np.testing.assert_allclose(pose.end_sites[0, 0], ankle, atol=1e-9)
    # Frame 1: dof rx ry rz compose as Rz @ Ry @ Rx (rx applied first).
    head = pose.positions[1, sk.index("head")]
    np.testing.assert_allclose(head, _rz(0) @ _ry(90) @ _rx(90) @ [0, 5, 0], atol=1e-9)
    np.testing.assert_allclose(head, [5, 0, 0], atol=1e-9)


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "YZX", "ZYX"])
def test_output_euler_order_does_not_change_the_pose(order):
    ref = forward_kinematics(_motion(), ground=False).all_points()
    got = forward_kinematics(_motion(order=order), ground=False).all_points()
    np.testing.assert_allclose(got, ref, atol=1e-9)


def test_radians_and_other_length_units_give_the_same_motion():
    rad_asf = ASF.replace("angle deg", "angle rad").replace(
        "axis 0 0 90 XYZ", f"axis 0 0 {np.pi / 2!r} XYZ"
    )

    def to_rad(line: str) -> str:
        toks = line.split()
        first = 4 if toks[:1] == ["root"] else 1  # root translations stay lengths
        if len(toks) < 2 or toks[0].startswith("#"):
            return line
        return " ".join(toks[:first] + [repr(float(np.radians(float(v)))) for v in toks[first:]])

    rad_amc = "\n".join(to_rad(line) for line in AMC.replace(":DEGREES", ":RADIANS").splitlines())
    deg, rad = _motion(), _motion(rad_asf, rad_amc)
    np.testing.assert_allclose(rad.values, deg.values, atol=1e-9)
    inches = _motion(ASF.replace("length 0.45", "length 1.0"))
    assert inches.length_unit_m == pytest.approx(0.0254)


def test_root_order_line_sets_the_root_value_order():
    asf = ASF.replace("order TX TY TZ RX RY RZ", "order RY TX TY TZ RX RZ")
    amc = AMC.replace("root 1 2 3 0 90 0", "root 90 1 2 3 0 0")
    np.testing.assert_allclose(_motion(asf, amc).values, _motion().values, atol=1e-12)


def test_crlf_comments_and_limits_on_following_lines():
    asf = ASF.replace("limits (-10.0 170.0)", "limits\n     (-10.0 170.0) # knee").replace(
        "\n", "\r\n"
    )
    np.testing.assert_allclose(_motion(asf, AMC.replace("\n", "\r\n")).values, _motion().values)


# -- known behaviour of a real clip ------------------------------------------------------


@pytest.fixture(scope="module")
def walk(cmu_dir):
    motion = read_amc(cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf")
    return motion, forward_kinematics(motion)


def test_cmu_walk_is_an_upright_person_walking_forward(walk):
    motion, pose = walk
    p = pose.positions
    j = motion.skeleton.index
    assert motion.n_frames == 343 and motion.name == "02_01"
    assert np.all(p[:, j("head"), 1] > p[:, j("root"), 1] + 0.3)
    assert np.all(p[:, j("root"), 1] > p[:, j("ltibia"), 1] + 0.2)
    assert np.all(p[:, j("ltibia"), 1] > p[:, j("lfoot"), 1] + 0.2)
    # Walks about 3.4 m towards +Z, hardly sideways.
    path = p[-1, j("root")] - p[0, j("root")]
    assert path[2] > 3.0 and abs(path[0]) < 0.2
    # Its left side is +X: the left hip is on the +X side of the right hip.
    assert np.all(p[:, j("lfemur"), 0] > p[:, j("rfemur"), 0] + 0.1)


def test_cmu_walk_knees_bend_forward_and_elbows_backward(walk):
    motion, pose = walk
    p = pose.positions
    j = motion.skeleton.index
    for side in "lr":
        hip, knee, ankle = (p[:, j(side + b)] for b in ("femur", "tibia", "foot"))
        assert np.all((knee - (hip + ankle) / 2)[:, 2] > 0.01)
        shoulder, elbow, wrist = (p[:, j(side + b)] for b in ("humerus", "radius", "wrist"))
        assert np.all((elbow - (shoulder + wrist) / 2)[:, 2] < -0.01)


def test_cmu_rest_pose_faces_plus_z_left_at_plus_x(walk):
    motion, _ = walk
    pts = rest_points(motion.skeleton) * motion.length_unit_m
    sk = motion.skeleton
    ends = {sk.names[j]: pts[sk.n_joints + k] for k, j in enumerate(sorted(sk.end_sites))}
    assert ends["ltoes"][2] > pts[sk.index("lfoot"), 2] + 0.1  # toes point to +Z
    assert pts[sk.index("lfemur"), 0] > 0.05 and pts[sk.index("rfemur"), 0] < -0.05
    assert 1.5 < np.ptp(pts[:, 1]) < 1.9


# -- errors ------------------------------------------------------------------------------


def _line(text: str, pattern: str) -> int:
    """1-based line of the first match of ``pattern`` (multi-line regex) in ``text``."""
    return text[: re.search(pattern, text, re.MULTILINE).start()].count("\n") + 1


ASF_BROKEN = [
    ("missing :root", lambda t: t.replace(":root", ":rooot"), None, "unknown :rooot|missing"),
    (
        "unknown bone in hierarchy",
        lambda t: t.replace("lfemur ltibia", "lfemur shin"),
        "lfemur shin",
        "'shin'.*does not define",
    ),
    (
        "bone outside hierarchy",
        lambda t: t.replace("    lowerback head\n", ""),
        ":hierarchy",
        "not connected.*head",
    ),
    (
        "two parents",
        lambda t: t.replace("lowerback head", "lowerback head ltibia"),
        "lowerback head ltibia",
        "second parent",
    ),
    (
        "text in a direction",
        lambda t: t.replace("direction 0 -1 0", "direction 0 down 0"),
        "direction 0 down 0",
        "'down'",
    ),
    ("NaN length", lambda t: t.replace("length 8", "length nan"), "length nan", "finite"),
    ("negative length", lambda t: t.replace("length 8", "length -8"), "length -8", ">= 0"),
    (
        "zero direction",
        lambda t: t.replace("direction 0 1 0", "direction 0 0 0", 1),
        "direction 0 0 0",
        "zero or invalid direction",
    ),
    (
        "short direction",
        lambda t: t.replace("direction 0 -1 0", "direction 0 -1"),
        "direction 0 -1\n",
        "needs 3 numbers",
    ),
    (
        "bad axis order",
        lambda t: t.replace("axis 0 0 90 XYZ", "axis 0 0 90 XXY"),
        "axis 0 0 90 XXY",
        "axis order",
    ),
    ("translation dof", lambda t: t.replace("dof rx\n", "dof tx\n"), "dof tx", "unsupported dof"),
    (
        "limits mismatch",
        lambda t: t.replace("           (-60.0 70.0)\n", ""),
        r"limits \(-160",
        "3 dof but 2 limits",
    ),
    ("unknown bone key", lambda t: t.replace("id 2", "colour 2"), "colour 2", "unknown bone key"),
    (
        "block without end",
        lambda t: t.replace("    limits (-10.0 170.0)\n  end\n", "    limits (-10.0 170.0)\n"),
        r"begin\n     id 3",
        "'begin' inside",
    ),
    (
        "no name",
        lambda t: t.replace("     name ltibia\n", ""),
        "  end\n  begin\n     id 3",
        "no 'name'",
    ),
    ("bone called root", lambda t: t.replace("name head", "name root"), "name root", "'root'"),
    (
        "duplicate bone",
        lambda t: t.replace("name head", "name ltibia"),
        "name ltibia\n     direction 0 1 0",
        "duplicate bone",
    ),
    ("unknown units key", lambda t: t.replace("mass 1.0", "weight 1.0"), "weight", "units key"),
    ("bad angle unit", lambda t: t.replace("angle deg", "angle grad"), "angle grad", "'deg' or"),
    ("bad root order", lambda t: t.replace("order TX TY", "order TX TW"), "order TX", "root order"),
    ("no section", lambda t: "lfemur 1 2 3\n" + t, "lfemur 1 2 3", "section keyword"),
    (
        "hierarchy without end",
        lambda t: t.rstrip().rsplit("\n", 1)[0] + "\n",
        None,
        "inside :hierarchy",
    ),
]


@pytest.mark.parametrize(
    "edit, needle, message", [c[1:] for c in ASF_BROKEN], ids=[c[0] for c in ASF_BROKEN]
)
def test_broken_asf_names_file_and_line(tmp_path, edit, needle, message):
    text = edit(ASF)
    path = tmp_path / "broken.asf"
    path.write_text(text)
    with pytest.raises(MotionFormatError, match=message) as info:
        read_asf(path)
    assert info.value.path == str(path)
    expected = len(text.split("\n")) if needle is None else _line(text, needle)
    assert info.value.line == expected, str(info.value)


AMC_BROKEN = [
    ("bone not in the ASF", lambda t: t.replace("ltibia 45", "shin 45"), "shin 45", "'shin'"),
    (
        "too few values",
        lambda t: t.replace("lfemur 0 30 0", "lfemur 0 30"),
        "lfemur 0 30",
        "needs 3 values",
    ),
    (
        "too many root values",
        lambda t: t.replace("root 1 2 3 0 90 0", "root 1 2 3 0 90 0 7"),
        "root 1 2",
        "needs 6 values",
    ),
    ("NaN", lambda t: t.replace("ltibia 45", "ltibia nan"), "ltibia nan", "finite"),
    ("infinity", lambda t: t.replace("ltibia 45", "ltibia -inf"), "ltibia -inf", "finite"),
    ("text in a number", lambda t: t.replace("ltibia 45", "ltibia 4S"), "ltibia 4S", "'4S'"),
    ("truncated", lambda t: t[: t.index("ltibia 0")], None, "frame 2 .*lacks bones"),
    ("missing bone line", lambda t: t.replace("ltibia 45\n", ""), "^2$", "lacks bones ltibia"),
    (
        "bone twice",
        lambda t: t.replace("ltibia 45\n", "ltibia 45\nltibia 45\n"),
        r"(?<=ltibia 45\n)ltibia 45",
        "twice",
    ),
    (
        "values before a frame number",
        lambda t: t.replace("1\nroot", "root", 1),
        "root 1 2",
        "frame number before",
    ),
    ("frame number jumps", lambda t: t.replace("\n2\n", "\n3\n"), "^3$", "expected frame"),
    ("no frames", lambda t: ":FULLY-SPECIFIED\n:DEGREES\n", None, "no frames"),
    (
        "values for a bone without dof",
        lambda t: t.replace("ltibia 45\n", "ltibia 45\nhead 1\n"),
        "head 1",
        "needs 0 values",
    ),
    (
        "header after data",
        lambda t: t + ":DEGREES\n",
        r"(?<=90 90 0\n):DEGREES",
        "after the first frame",
    ),
]


@pytest.mark.parametrize(
    "edit, needle, message", [c[1:] for c in AMC_BROKEN], ids=[c[0] for c in AMC_BROKEN]
)
def test_broken_amc_names_file_and_line(tmp_path, edit, needle, message):
    text = edit(AMC)
    asf_path, amc_path = tmp_path / "test.asf", tmp_path / "broken.amc"
    asf_path.write_text(ASF)
    amc_path.write_text(text)
    with pytest.raises(MotionFormatError, match=message) as info:
        read_amc(amc_path, asf_path)
    assert info.value.path == str(amc_path)
    expected = len(text.split("\n")) if needle is None else _line(text, needle)
    assert info.value.line == expected, str(info.value)


def test_amc_reader_names_the_asf_for_skeleton_errors(tmp_path):
    asf_path, amc_path = tmp_path / "bad.asf", tmp_path / "ok.amc"
    asf_path.write_text(ASF.replace("length 8", "length eight"))
    amc_path.write_text(AMC)
    with pytest.raises(MotionFormatError, match="eight") as info:
        read_amc(amc_path, asf_path)
    assert info.value.path == str(asf_path)
