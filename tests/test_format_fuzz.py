"""Mutated BVH, ASF and AMC files: a MotionFormatError or a valid motion, nothing else.

Hypothesis mutates small valid files (truncation, deleted, duplicated, swapped and
inserted lines, tokens replaced by text, NaN, huge numbers or keywords, dropped
braces, stray characters, other line ends) — 1,100 random files per run — and a
deterministic sweep tries every truncation point and every single-line deletion
and duplication of each base file.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from eigmotion.errors import MotionFormatError
from eigmotion.mocap.amc import parse_amc
from eigmotion.mocap.asf import parse_asf
from eigmotion.mocap.bvh import parse_bvh
from eigmotion.mocap.motion import Motion

BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
  JOINT Leg
  {
    OFFSET 2 -1 0
    CHANNELS 4 Xposition Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 -9 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.033333
0 9 0 0 0 0 1 2 3 0.5 4 5 6
0.1 9 0 1 1 1 2 3 4 0.4 5 6 7
0.2 9 0 2 2 2 3 4 5 0.3 6 7 8
"""

ASF = """:version 1.10
:name VICON
:units
  mass 1.0
  length 0.45
  angle deg
:documentation
  small
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name lfemur
     direction 0.34 -0.94 0
     length 7.5
     axis 0 0 20 XYZ
    dof rx ry rz
    limits (-160.0 20.0)
           (-70.0 70.0)
           (-60.0 70.0)
  end
  begin
     id 2
     name ltibia
     direction 0.34 -0.94 0
     length 7.2
     axis 0 0 20 XYZ
    dof rx
    limits (-10.0 170.0)
  end
  begin
     id 3
     name thorax
     direction 0 1 0
     length 3
     axis 0 0 0 XYZ
  end
:hierarchy
  begin
    root lfemur thorax
    lfemur ltibia
  end
"""

AMC = """#!OML:ASF small.asf
:FULLY-SPECIFIED
:DEGREES
1
root 10.4 16.7 -30.1 -2.4 -9.8 -3.0
lfemur -28.0 -1.0 -20.1
ltibia 22.3
2
root 10.5 16.8 -30.0 -2.5 -9.9 -3.1
lfemur -27.0 -1.1 -20.0
ltibia 22.6
3
root 10.6 16.9 -29.9 -2.6 -9.7 -3.2
lfemur -26.0 -1.2 -19.9
ltibia 22.9
"""

ODD_TOKENS = [
    "abc",
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "Infinity",
    "1e400",
    "-1e400",
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "",
    "{",
    "}",
    "{}",
    "-",
    "+",
    ".",
    "1.2.3",
    "0x1F",
    "1_000",
    "\u221e",
    "\u0663",
    "9" * 400,
    "End",
    "Site",
    "JOINT",
    "ROOT",
    "OFFSET",
    "CHANNELS",
    "MOTION",
    "Frames:",
    "Frame",
    "Time:",
    "HIERARCHY",
    "begin",
    "end",
    ":root",
    ":bonedata",
    ":hierarchy",
    ":units",
    "(",
    ")",
    "(1 2)",
    "(-inf inf)",
    "root",
    "lfemur",
    "ltibia",
    "thorax",
    "dof",
    "rx",
    "tx",
    "axis",
    "XYZ",
    "XXY",
    "1",
    "2",
    "4",
    "-1",
    "999999999999",
    "\t",
    "\x00",
    "#",
    "\u00e9",
]


def _lines(text: str) -> list[str]:
    return text.split("\n")


@st.composite
def mutated(draw, base: str) -> str:
    text = base
    for _ in range(draw(st.integers(1, 4))):
        op = draw(
            st.sampled_from(
                [
                    "truncate",
                    "delete",
                    "duplicate",
                    "swap",
                    "token",
                    "insert",
                    "brace",
                    "char",
                    "newline",
                ]
            )
        )
        lines = _lines(text)
        i = draw(st.integers(0, max(len(lines) - 1, 0)))
        if op == "truncate":
            text = text[: draw(st.integers(0, len(text)))]
        elif op == "delete":
            text = "\n".join(lines[:i] + lines[i + 1 :])
        elif op == "duplicate":
            text = "\n".join(lines[: i + 1] + lines[i:])
        elif op == "swap":
            k = draw(st.integers(0, max(len(lines) - 1, 0)))
            lines[i], lines[k] = lines[k], lines[i]
            text = "\n".join(lines)
        elif op == "token":
            spans = [m.span() for m in re.finditer(r"\S+", text)]
            if spans:
                a, b = draw(st.sampled_from(spans))
                new = draw(st.sampled_from(ODD_TOKENS) | st.text(max_size=6))
                text = text[:a] + new + text[b:]
        elif op == "insert":
            new = draw(st.sampled_from(ODD_TOKENS) | st.text(max_size=20))
            text = "\n".join(lines[:i] + [new] + lines[i:])
        elif op == "brace":
            spots = [m.start() for m in re.finditer(r"[{}()]", text)]
            if spots:
                at = draw(st.sampled_from(spots))
                text = text[:at] + text[at + 1 :]
        elif op == "char":
            at = draw(st.integers(0, len(text)))
            text = text[:at] + draw(st.characters()) + text[at:]
        else:
            text = text.replace("\n", draw(st.sampled_from(["\r\n", "\r", "\n\n", " \n"])))
    return text


def _check_bvh(text: str) -> None:
    try:
        motion = parse_bvh(text, "fuzz.bvh")
    except MotionFormatError as exc:
        assert exc.path == "fuzz.bvh"
        return
    _check_motion(motion)


def _check_amc(amc_text: str, asf_text: str = ASF) -> None:
    try:
        motion = parse_amc(amc_text, parse_asf(asf_text, "fuzz.asf"), "fuzz.amc")
    except MotionFormatError as exc:
        assert exc.path in ("fuzz.asf", "fuzz.amc")
        return
    _check_motion(motion)


def _check_motion(motion: Motion) -> None:
    assert isinstance(motion, Motion)
    assert motion.n_frames >= 1 and np.all(np.isfinite(motion.values))


_FUZZ = settings(
    deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much]
)


@settings(_FUZZ, max_examples=500)
@given(mutated(BVH))
def test_mutated_bvh(text):
    _check_bvh(text)


@settings(_FUZZ, max_examples=400)
@given(mutated(AMC))
def test_mutated_amc(text):
    _check_amc(text)


@settings(_FUZZ, max_examples=200)
@given(mutated(ASF))
def test_mutated_asf(text):
    _check_amc(AMC, text)


def test_the_base_files_are_valid():
    assert parse_bvh(BVH).n_frames == 3
    assert parse_amc(AMC, parse_asf(ASF)).n_frames == 3


@pytest.mark.parametrize("name", ["bvh", "amc", "asf"])
def test_every_truncation_deletion_and_duplication(name):
    base = {"bvh": BVH, "amc": AMC, "asf": ASF}[name]
    check = {
        "bvh": _check_bvh,
        "amc": _check_amc,
        "asf": lambda text: _check_amc(AMC, text),
    }[name]
    for cut in range(len(base)):
        check(base[:cut])
    lines = _lines(base)
    for i in range(len(lines)):
        check("\n".join(lines[:i] + lines[i + 1 :]))
        check("\n".join(lines[: i + 1] + lines[i:]))
