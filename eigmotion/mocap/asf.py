"""Acclaim ASF skeleton files (the CMU Graphics Lab format).

An ASF file describes a skeleton: ``:units``, the ``:root``, one ``begin … end``
block per bone in ``:bonedata`` (its rest ``direction`` in world coordinates, its
``length``, a local ``axis`` frame and the rotational degrees of freedom ``dof``),
and the ``:hierarchy``.  Its motions are AMC files (:mod:`eigmotion.mocap.amc`).

Conventions used here (those of the Acclaim format and of CMU's own tools):

* ``axis ax ay az XYZ`` gives the bone frame ``C = Rz(az) @ Ry(ay) @ Rx(ax)``: the
  letters say in which order the three rotations are applied to a vector (the
  first letter first), the three numbers are always the x, y and z angles
  (:func:`compose_rotations`);
* a bone's ``dof rx ry rz`` values compose the same way, ``M = Rz @ Ry @ Rx``, in
  the order the ``dof`` line lists them;
* the bone's rotation relative to its parent, in world-aligned frames, is
  ``C @ M @ C⁻¹``; its world rotation is the parent's world rotation times this.

The ASF's length unit becomes a motion's ``length_unit_m``: CMU files say
``length 0.45``, meaning a length L in the file is L / 0.45 inches, so one unit is
``0.0254 / 0.45`` m.

Any malformed file raises :class:`~eigmotion.errors.MotionFormatError` naming the
file, the line and what was expected.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError, MotionFormatError
from eigmotion.limits import MAX_JOINTS, MAX_MOTION_FILE_BYTES, check_file_size
from eigmotion.mocap.rotations import axis_rotation, check_euler_order

#: Metres per inch; ASF lengths are inches divided by the ``:units length`` value.
INCH_M = 0.0254

_ROTATION_DOF = ("rx", "ry", "rz")
_ROOT_TOKENS = ("TX", "TY", "TZ", "RX", "RY", "RZ")
#: Any line ending (ASF and AMC files come from every platform).
LINE_BREAK = re.compile(r"\r\n|\r|\n")
_LIMIT = re.compile(r"\(\s*(\S+)\s+(\S+)\s*\)")


@dataclass(frozen=True, eq=False)
class AsfBone:
    """One ``:bonedata`` block of an ASF file.

    Attributes
    ----------
    name : str
    id : int or None
    direction : (3,) float64
        Unit rest direction of the bone in world coordinates.
    length : float
        Bone length in ASF length units.
    axis_deg : (3,) float64
        The x, y, z angles of the bone's axis frame, degrees.
    axis_order : str
        Order in which those rotations apply, e.g. ``"XYZ"``.
    dof : tuple of str
        Degrees of freedom in file order, each ``"rx"``, ``"ry"`` or ``"rz"``.
    limits : (len(dof), 2) float64
        Joint limits in degrees (may be infinite); empty when the file gives none.
    line : int
        Line of the block's ``begin``.
    """

    name: str
    id: int | None
    direction: np.ndarray
    length: float
    axis_deg: np.ndarray
    axis_order: str
    dof: tuple[str, ...]
    limits: np.ndarray
    line: int

    def axis_matrix(self) -> np.ndarray:
        """(3, 3) float64: the bone's axis frame ``C`` (see the module notes)."""
        return compose_rotations(self.axis_order, dict(zip("XYZ", self.axis_deg, strict=True)))


@dataclass(frozen=True, eq=False)
class AsfSkeleton:
    """An ASF skeleton.

    Attributes
    ----------
    name : str
        The ``:name`` line.
    mass : float
        ``:units mass``.
    length : float
        ``:units length``: file lengths are inches divided by this.
    angle_unit : {"deg", "rad"}
        ``:units angle``; angles stored here are already in degrees.
    root_order : tuple of str
        The root's AMC value order, e.g. ``("TX", "TY", "TZ", "RX", "RY", "RZ")``.
    root_axis : str
        Rotation order of ``root_orientation_deg``, e.g. ``"XYZ"``.
    root_position : (3,) float64
        Rest position of the root, ASF length units.
    root_orientation_deg : (3,) float64
        The root's axis frame angles (x, y, z), degrees.
    bones : tuple of AsfBone
        Depth-first hierarchy order (parents before children).
    parents : dict of str to str
        Bone name → parent bone name (``"root"`` for the top bones).
    path : str or None
        The file read, for messages.
    """

    name: str
    mass: float
    length: float
    angle_unit: str
    root_order: tuple[str, ...]
    root_axis: str
    root_position: np.ndarray
    root_orientation_deg: np.ndarray
    bones: tuple[AsfBone, ...]
    parents: dict[str, str]
    path: str | None = None

    @property
    def length_unit_m(self) -> float:
        """Metres per ASF length unit (``0.0254 / length``)."""
        return INCH_M / self.length

    def bone(self, name: str) -> AsfBone:
        """The bone called ``name``; raises ``InvalidParameterError`` naming it."""
        for bone in self.bones:
            if bone.name == name:
                return bone
        raise InvalidParameterError(f"no bone named {name!r} in ASF skeleton {self.path or ''}")

    def root_axis_matrix(self) -> np.ndarray:
        """(3, 3) float64: the root's axis frame from ``orientation`` and ``axis``."""
        return compose_rotations(
            self.root_axis, dict(zip("XYZ", self.root_orientation_deg, strict=True))
        )


def compose_rotations(order: str, angles_deg: dict[str, float | np.ndarray]) -> np.ndarray:
    """Rotations applied in ``order`` (first letter first) → their product matrix.

    ``angles_deg`` maps an axis letter to a scalar or an (F,) array; the result is
    (3, 3) or (F, 3, 3).
    """
    out = None
    for letter in order:
        r = axis_rotation(letter, angles_deg[letter])
        out = r if out is None else r @ out
    if out is None:
        return np.eye(3)
    return out


# -- ASF ---------------------------------------------------------------------------------


def read_asf(path: str | Path) -> AsfSkeleton:
    """Read an ASF skeleton file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    AsfSkeleton

    Raises
    ------
    MotionFormatError
        The file is malformed (message names the file and line).
    FileNotFoundError
    """
    path = Path(path)
    return parse_asf(read_text(path), path)


def read_text(path: Path) -> str:
    """The text of an ASF or AMC file: UTF-8, else Latin-1 (at most
    :data:`~eigmotion.limits.MAX_MOTION_FILE_BYTES`, else InvalidParameterError)."""
    check_file_size(path.stat().st_size, MAX_MOTION_FILE_BYTES, str(path))
    raw = path.read_bytes()
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


class _Bone:
    """A bone block while it is being read."""

    def __init__(self, line: int):
        self.line = line
        self.fields: dict[str, int] = {}
        self.name: str | None = None
        self.id: int | None = None
        self.direction: np.ndarray | None = None
        self.length: float | None = None
        self.axis = np.zeros(3)
        self.axis_order = "XYZ"
        self.dof: tuple[str, ...] = ()
        self.limits: list[tuple[float, float]] = []
        self.limits_line: int | None = None


@dataclass
class _AsfState:
    where: str | None
    name: str = ""
    mass: float = 1.0
    length: float = 1.0
    angle_unit: str = "deg"
    root_order: tuple[str, ...] = _ROOT_TOKENS
    root_axis: str = "XYZ"
    root_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    root_orientation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bones: list[_Bone] = field(default_factory=list)
    current: _Bone | None = None
    children: dict[str, list[str]] = field(default_factory=dict)
    parent_of: dict[str, str] = field(default_factory=dict)
    in_tree: bool = False
    tree_done: bool = False
    sections: dict[str, int] = field(default_factory=dict)

    def error(self, message: str, line: int | None) -> MotionFormatError:
        return MotionFormatError(message, self.where, line)


def parse_asf(text: str, path: str | Path | None = None) -> AsfSkeleton:
    """Parse the text of an ASF file (see :func:`read_asf`).

    Parameters
    ----------
    text : str
    path : str or Path, optional
        For error messages.

    Returns
    -------
    AsfSkeleton
    """
    st = _AsfState(None if path is None else str(path))
    section = None
    lines = LINE_BREAK.split(text)
    for number, raw in enumerate(lines, start=1):
        toks = raw.split("#", 1)[0].split()
        if not toks:
            continue
        if toks[0].startswith(":"):
            section = toks[0][1:].lower()
            if st.current is not None:
                raise st.error(f"bone block opened at line {st.current.line} has no 'end'", number)
            if section in st.sections and section in ("units", "root", "bonedata", "hierarchy"):
                raise st.error(
                    f"second :{section} section (first at line {st.sections[section]})", number
                )
            st.sections[section] = number
            if section == "name":
                st.name = " ".join(toks[1:])
            continue
        if section is None:
            raise st.error(
                f"expected a ':' section keyword such as ':units', found {toks[0]!r}", number
            )
        if section == "units":
            _asf_units(st, toks, number)
        elif section == "root":
            _asf_root(st, toks, number)
        elif section == "bonedata":
            _asf_bonedata(st, toks, raw, number)
        elif section == "hierarchy":
            _asf_hierarchy(st, toks, number)
        # Other sections (documentation, version, skin …) carry nothing we use.
    last = max(len(lines), 1)
    if st.current is not None:
        raise st.error(
            f"the file ends inside the bone block opened at line {st.current.line}", last
        )
    for needed in ("root", "bonedata", "hierarchy"):
        if needed not in st.sections:
            raise st.error(f"missing :{needed} section", last)
    if st.in_tree:
        raise st.error("the file ends inside :hierarchy: expected 'end'", last)
    return _finish_asf(st, last)


def _number(st: _AsfState, token: str, what: str, line: int, finite: bool = True) -> float:
    try:
        value = float(token)
    except ValueError:
        raise st.error(f"expected a number for {what}, found {token!r}", line) from None
    if finite and not math.isfinite(value):
        raise st.error(f"{what} must be a finite number, found {token!r}", line)
    return value


def _numbers(st: _AsfState, toks: list[str], count: int, what: str, line: int) -> np.ndarray:
    if len(toks) != count:
        raise st.error(f"{what} needs {count} numbers, found {len(toks)}", line)
    return np.array([_number(st, t, what, line) for t in toks])


def _order(st: _AsfState, token: str, what: str, line: int) -> str:
    try:
        return check_euler_order(token)
    except InvalidParameterError:
        raise st.error(f"{what} must be an axis order such as XYZ, found {token!r}", line) from None


def _asf_units(st: _AsfState, toks: list[str], line: int) -> None:
    if len(toks) != 2:
        raise st.error(f"a :units line is 'KEY VALUE', found {' '.join(toks)!r}", line)
    key, value = toks[0].lower(), toks[1]
    if key == "mass":
        st.mass = _number(st, value, "the mass unit", line)
    elif key == "length":
        st.length = _number(st, value, "the length unit", line)
        if st.length <= 0:
            raise st.error(f"the length unit must be > 0, found {value!r}", line)
    elif key == "angle":
        unit = value.lower()
        if unit not in ("deg", "rad"):
            raise st.error(f"the angle unit must be 'deg' or 'rad', found {value!r}", line)
        st.angle_unit = unit
    else:
        raise st.error(f"unknown :units key {toks[0]!r}; expected mass, length or angle", line)


def _deg(st: _AsfState, values: np.ndarray, what: str, line: int | None) -> np.ndarray:
    """Angles in the file's unit → degrees; infinities only where the file had them."""
    if st.angle_unit != "rad":
        return values
    with np.errstate(over="ignore"):
        out = np.rad2deg(values)
    if np.any(np.isfinite(values) & ~np.isfinite(out)):
        raise st.error(f"{what} is too large an angle", line)
    return out


def _asf_root(st: _AsfState, toks: list[str], line: int) -> None:
    key, rest = toks[0].lower(), toks[1:]
    if key == "order":
        order = tuple(t.upper() for t in rest)
        bad = [t for t in order if t not in _ROOT_TOKENS]
        if bad or len(set(order)) != len(order) or not order:
            raise st.error(
                f"the root order must list distinct tokens from {' '.join(_ROOT_TOKENS)}, "
                f"found {' '.join(rest)!r}",
                line,
            )
        st.root_order = order
    elif key == "axis":
        if len(rest) != 1:
            raise st.error("the root axis line is 'axis ORDER', e.g. 'axis XYZ'", line)
        st.root_axis = _order(st, rest[0], "the root axis", line)
    elif key == "position":
        st.root_position = _numbers(st, rest, 3, "the root position", line)
    elif key == "orientation":
        st.root_orientation = _deg(
            st, _numbers(st, rest, 3, "the root orientation", line), "the root orientation", line
        )
    else:
        raise st.error(
            f"unknown :root key {toks[0]!r}; expected order, axis, position or orientation", line
        )


_BONE_KEYS = ("id", "name", "direction", "length", "axis", "dof", "limits", "bodymass", "cofmass")


def _asf_bonedata(st: _AsfState, toks: list[str], raw: str, line: int) -> None:
    key = toks[0].lower()
    bone = st.current
    if key == "begin":
        if bone is not None:
            raise st.error(f"'begin' inside the bone block opened at line {bone.line}", line)
        st.current = _Bone(line)
        return
    if bone is None:
        raise st.error(f"expected 'begin' of a bone block, found {toks[0]!r}", line)
    if key == "end":
        _close_bone(st, bone, line)
        st.current = None
        return
    if toks[0].startswith("("):
        if bone.limits_line is None:
            raise st.error("a limits pair outside a 'limits' entry", line)
        _limits(st, bone, raw, line)
        return
    if key not in _BONE_KEYS:
        raise st.error(
            f"unknown bone key {toks[0]!r}; expected one of {', '.join(_BONE_KEYS)}", line
        )
    if key in bone.fields:
        raise st.error(f"second {key!r} in the bone block (first at line {bone.fields[key]})", line)
    bone.fields[key] = line
    rest = toks[1:]
    if key == "id":
        if len(rest) != 1:
            raise st.error("the bone id line is 'id N'", line)
        try:
            bone.id = int(rest[0])
        except ValueError:
            raise st.error(f"the bone id must be an integer, found {rest[0]!r}", line) from None
    elif key == "name":
        if len(rest) != 1:
            raise st.error("the bone name line is 'name NAME' (one word)", line)
        bone.name = rest[0]
    elif key == "direction":
        bone.direction = _numbers(st, rest, 3, "the bone direction", line)
    elif key == "length":
        bone.length = float(_numbers(st, rest, 1, "the bone length", line)[0])
        if bone.length < 0:
            raise st.error(f"the bone length must be >= 0, found {rest[0]!r}", line)
    elif key == "axis":
        if len(rest) != 4:
            raise st.error("the bone axis line is 'axis AX AY AZ ORDER', e.g. '0 0 20 XYZ'", line)
        bone.axis = _deg(
            st, _numbers(st, rest[:3], 3, "the bone axis", line), "the bone axis", line
        )
        bone.axis_order = _order(st, rest[3], "the bone axis order", line)
    elif key == "dof":
        dof = tuple(t.lower() for t in rest)
        bad = [t for t in dof if t not in _ROTATION_DOF]
        if bad:
            raise st.error(
                f"unsupported dof {bad[0]!r}: only rotational dof (rx ry rz) are supported", line
            )
        if len(set(dof)) != len(dof):
            raise st.error(f"the dof line lists an axis twice: {' '.join(rest)!r}", line)
        bone.dof = dof
    elif key == "limits":
        bone.limits_line = line
        after = raw.split("#", 1)[0].split(None, 1)[1:]
        if after:  # the pairs may also start on the next line
            _limits(st, bone, after[0], line)
    # bodymass and cofmass are recorded by some exporters; nothing here needs them.


def _limits(st: _AsfState, bone: _Bone, text: str, line: int) -> None:
    text = text.split("#", 1)[0]
    pairs = _LIMIT.findall(text)
    if not pairs or _LIMIT.sub("", text).strip():
        raise st.error(f"expected limits as '(MIN MAX)' pairs, found {text.strip()!r}", line)
    for lo, hi in pairs:
        bone.limits.append(
            (
                _number(st, lo, "a joint limit", line, finite=False),
                _number(st, hi, "a joint limit", line, finite=False),
            )
        )


def _close_bone(st: _AsfState, bone: _Bone, line: int) -> None:
    for needed in ("name", "direction", "length"):
        if needed not in bone.fields:
            raise st.error(f"the bone block opened at line {bone.line} has no {needed!r}", line)
    if bone.name == "root":
        raise st.error(
            "a bone may not be called 'root' (the name of the root)", bone.fields["name"]
        )
    if any(b.name == bone.name for b in st.bones):
        raise st.error(f"duplicate bone name {bone.name!r}", bone.fields["name"])
    if bone.limits and len(bone.limits) != len(bone.dof):
        raise st.error(
            f"bone {bone.name!r} has {len(bone.dof)} dof but {len(bone.limits)} limits",
            bone.limits_line,
        )
    with np.errstate(over="ignore"):
        norm = float(np.linalg.norm(bone.direction))
    if not np.isfinite(norm) or (norm == 0 and bone.length > 0):
        raise st.error(
            f"bone {bone.name!r} has a zero or invalid direction", bone.fields["direction"]
        )
    if norm > 0:
        bone.direction = bone.direction / norm
    if len(st.bones) + 1 >= MAX_JOINTS:  # the root is a joint too
        raise st.error(f"more than {MAX_JOINTS} joints: larger skeletons are not supported", line)
    st.bones.append(bone)


def _asf_hierarchy(st: _AsfState, toks: list[str], line: int) -> None:
    key = toks[0].lower()
    if key == "begin" and len(toks) == 1:
        if st.in_tree or st.tree_done:
            raise st.error("a second 'begin' in :hierarchy", line)
        st.in_tree = True
        return
    if key == "end" and len(toks) == 1:
        if not st.in_tree:
            raise st.error("'end' without 'begin' in :hierarchy", line)
        st.in_tree = False
        st.tree_done = True
        return
    if not st.in_tree:
        raise st.error(f"expected 'begin' in :hierarchy, found {toks[0]!r}", line)
    if len(toks) < 2:
        raise st.error(f"a hierarchy line is 'PARENT CHILD …', found {toks[0]!r} alone", line)
    known = {b.name for b in st.bones}
    parent, children = toks[0], toks[1:]
    if parent != "root" and parent not in known:
        raise st.error(
            f"the hierarchy names bone {parent!r}, which :bonedata does not define", line
        )
    for child in children:
        if child not in known:
            raise st.error(
                f"the hierarchy names bone {child!r}, which :bonedata does not define", line
            )
        if child in st.parent_of:
            raise st.error(
                f"bone {child!r} is given a second parent ({st.parent_of[child]!r} and {parent!r})",
                line,
            )
        st.parent_of[child] = parent
        st.children.setdefault(parent, []).append(child)


def _finish_asf(st: _AsfState, last: int) -> AsfSkeleton:
    by_name = {b.name: b for b in st.bones}
    ordered: list[str] = []
    stack = list(reversed(st.children.get("root", [])))
    visited = set()
    while stack:
        name = stack.pop()
        if name in visited:  # one parent per bone: only a malformed tree could repeat
            continue
        visited.add(name)
        ordered.append(name)
        stack.extend(reversed(st.children.get(name, [])))
    missing = [b.name for b in st.bones if b.name not in visited]
    if missing:
        line = st.sections.get("hierarchy", last)
        raise st.error(f"bones not connected to the root in :hierarchy: {', '.join(missing)}", line)
    bones = []
    for name in ordered:
        b = by_name[name]
        limits = np.array(b.limits, dtype=np.float64).reshape(-1, 2)
        bones.append(
            AsfBone(
                name=name,
                id=b.id,
                direction=b.direction,
                length=b.length,
                axis_deg=b.axis,
                axis_order=b.axis_order,
                dof=b.dof,
                limits=_deg(st, limits, f"a limit of bone {name!r}", b.limits_line),
                line=b.line,
            )
        )
    return AsfSkeleton(
        name=st.name,
        mass=st.mass,
        length=st.length,
        angle_unit=st.angle_unit,
        root_order=st.root_order,
        root_axis=st.root_axis,
        root_position=st.root_position,
        root_orientation_deg=st.root_orientation,
        bones=tuple(bones),
        parents={name: st.parent_of[name] for name in ordered},
        path=st.where,
    )
