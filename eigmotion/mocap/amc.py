"""Acclaim AMC motion files with their ASF skeleton, read as a :class:`Motion`.

An AMC file holds, per frame, the values of each bone's ``dof`` (and the root's six
values in the order of the root's ``order`` line) of an ASF skeleton
(:mod:`eigmotion.mocap.asf`, which states the rotation conventions).

:func:`read_amc` turns this into a :class:`~eigmotion.mocap.motion.Motion` with BVH
semantics: one joint per bone, placed at the bone's START (so the joint of
``lfemur`` is the hip), a joint's children offset by its bone's
``direction × length``, an End Site at the tip of each leaf bone, and every local
frame parallel to the world at rest (the axis frames are baked into the
rotations, see :func:`asf_to_skeleton`).  The ASF's length unit becomes
``length_unit_m``.

Any malformed file raises :class:`~eigmotion.errors.MotionFormatError` naming the
file, the line and what was expected.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError, MotionFormatError
from eigmotion.limits import MAX_FRAME_JOINTS, MAX_FRAMES, check_motion_size
from eigmotion.mocap.asf import (
    LINE_BREAK,
    AsfSkeleton,
    compose_rotations,
    read_asf,
    read_text,
)
from eigmotion.mocap.motion import POSITION_CHANNELS, Motion, Skeleton
from eigmotion.mocap.rotations import check_euler_order, matrix_to_euler

_FRAME_NUMBER = re.compile(r"[0-9]+")


def asf_to_skeleton(asf: AsfSkeleton, order: str = "ZXY") -> Skeleton:
    """The BVH-semantics skeleton of an ASF skeleton.

    Parameters
    ----------
    asf : AsfSkeleton
    order : str
        Euler order of the rotation channels, e.g. ``"ZXY"``.

    Returns
    -------
    Skeleton
        Joint 0 ``root`` (3 position and 3 rotation channels), then one joint per
        bone in depth-first order, located at the bone's start; bones with dof get
        3 rotation channels, the others none.  Offsets in ASF length units.
    """
    order = check_euler_order(order)
    rot = tuple(f"{a}rotation" for a in order)
    names = ("root",) + tuple(b.name for b in asf.bones)
    index = {name: i for i, name in enumerate(names)}
    parents = np.array([-1] + [index[asf.parents[b.name]] for b in asf.bones], dtype=np.int64)
    tips = {b.name: b.direction * b.length for b in asf.bones}
    offsets = np.zeros((len(names), 3))
    offsets[0] = asf.root_position
    for j, b in enumerate(asf.bones, start=1):
        parent = asf.parents[b.name]
        offsets[j] = 0.0 if parent == "root" else tips[parent]
    has_children = set(asf.parents.values())
    end_sites = {
        j: tips[b.name] for j, b in enumerate(asf.bones, start=1) if b.name not in has_children
    }
    root_rot = rot if any(t.startswith("R") for t in asf.root_order) else ()
    channels = (POSITION_CHANNELS + root_rot,) + tuple(rot if b.dof else () for b in asf.bones)
    return Skeleton(names, parents, offsets, channels, end_sites)


#: Frame time of the CMU database (120 fps); AMC files do not state their rate.
CMU_FRAME_TIME_S = 1.0 / 120.0


def read_amc(
    amc_path: str | Path,
    asf_path: str | Path,
    order: str = "ZXY",
    frame_time_s: float = CMU_FRAME_TIME_S,
) -> Motion:
    """Read a CMU/Acclaim AMC motion with its ASF skeleton.

    Parameters
    ----------
    amc_path : str or Path
    asf_path : str or Path
    order : str
        Euler order of the output rotation channels.
    frame_time_s : float
        Seconds per frame; AMC files do not state it.  Default 1/120 s, the CMU
        capture rate.

    Returns
    -------
    Motion
        On :func:`asf_to_skeleton`'s skeleton; ``length_unit_m`` from the ASF
        units, named after the AMC file's stem.

    Raises
    ------
    MotionFormatError
        Either file is malformed or they do not match (names file and line).
    InvalidParameterError
        A bad ``order`` or ``frame_time_s``.
    """
    _check_options(order, frame_time_s)
    asf = read_asf(asf_path)
    amc_path = Path(amc_path)
    return parse_amc(read_text(amc_path), asf, amc_path, order, frame_time_s)


def _check_options(order: str, frame_time_s: float) -> str:
    if not (isinstance(frame_time_s, int | float) and math.isfinite(frame_time_s)):
        raise InvalidParameterError(f"frame_time_s must be a number > 0, got {frame_time_s!r}")
    if frame_time_s <= 0:
        raise InvalidParameterError(f"frame_time_s must be > 0 seconds, got {frame_time_s!r}")
    return check_euler_order(order)


def parse_amc(
    text: str,
    asf: AsfSkeleton,
    path: str | Path | None = None,
    order: str = "ZXY",
    frame_time_s: float = CMU_FRAME_TIME_S,
) -> Motion:
    """Parse the text of an AMC file against its skeleton (see :func:`read_amc`).

    Parameters
    ----------
    text : str
    asf : AsfSkeleton
    path : str or Path, optional
        For error messages and the motion's name.
    order : str
        Euler order of the output rotation channels.
    frame_time_s : float
        Seconds per frame.

    Returns
    -------
    Motion
    """
    order = _check_options(order, frame_time_s)
    where = None if path is None else str(path)
    name = "" if path is None else Path(path).stem
    try:  # the frame time and the skeleton, before any frame is read
        check_motion_size(1, len(asf.bones) + 1, frame_time_s, "the motion")
    except InvalidParameterError as exc:
        raise MotionFormatError(str(exc), where) from None
    raw, angle_unit = _read_amc_table(text, asf, where)
    try:
        return _amc_motion(asf, raw, angle_unit, order, frame_time_s, name)
    except InvalidParameterError as exc:
        raise MotionFormatError(str(exc), where) from None


def _read_amc_table(
    text: str, asf: AsfSkeleton, where: str | None
) -> tuple[dict[str, np.ndarray], str]:
    """The AMC values per bone: name → (F, n_dof) float64, and the angle unit."""
    layout: dict[str, tuple[int, int]] = {"root": (0, len(asf.root_order))}
    width = len(asf.root_order)
    for b in asf.bones:
        layout[b.name] = (width, len(b.dof))
        width += len(b.dof)
    required = {name for name, (_, n) in layout.items() if n > 0}
    angle_unit = asf.angle_unit
    rows: list[list[float]] = []
    current: list[float] | None = None
    seen: set[str] = set()
    frame_number = frame_line = 0
    lines = LINE_BREAK.split(text)
    n_joints = len(asf.bones) + 1
    most_frames = min(MAX_FRAMES, MAX_FRAME_JOINTS // n_joints)

    def finish(line: int) -> None:
        missing = required - seen
        if missing:
            raise MotionFormatError(
                f"frame {frame_number} (line {frame_line}) lacks bones "
                f"{', '.join(sorted(missing))}: the file is truncated or lines are missing",
                where,
                line,
            )

    for number, raw in enumerate(lines, start=1):
        toks = raw.split()
        if not toks or toks[0].startswith("#"):
            continue
        head = toks[0]
        if head.startswith(":"):
            if current is not None:
                raise MotionFormatError(
                    f"header keyword {head!r} after the first frame", where, number
                )
            keyword = head[1:].upper()
            if keyword == "RADIANS":
                angle_unit = "rad"
            elif keyword == "DEGREES":
                angle_unit = "deg"
            continue
        if len(toks) == 1 and _FRAME_NUMBER.fullmatch(head):
            value = int(head)
            if current is not None:
                finish(number)
                if value != frame_number + 1:
                    raise MotionFormatError(
                        f"expected frame number {frame_number + 1}, found {value}", where, number
                    )
            frame_number, frame_line = value, number
            if len(rows) >= most_frames:
                raise MotionFormatError(
                    f"more than {most_frames:,} frames of {n_joints} joints: at most "
                    f"{MAX_FRAMES:,} frames and {MAX_FRAME_JOINTS:,} joint poses are supported",
                    where,
                    number,
                )
            current = [0.0] * width
            rows.append(current)
            seen = set()
            continue
        if current is None:
            raise MotionFormatError(
                f"expected a frame number before bone values, found {head!r}", where, number
            )
        if head not in layout:
            raise MotionFormatError(
                f"bone {head!r} is not in the ASF skeleton {asf.path or ''}".rstrip(),
                where,
                number,
            )
        if head in seen:
            raise MotionFormatError(
                f"bone {head!r} appears twice in frame {frame_number}", where, number
            )
        seen.add(head)
        start, n = layout[head]
        if len(toks) - 1 != n:
            what = "the root order" if head == "root" else "its dof"
            raise MotionFormatError(
                f"bone {head!r} needs {n} values ({what}), found {len(toks) - 1}", where, number
            )
        for k, tok in enumerate(toks[1:]):
            try:
                value = float(tok)
            except ValueError:
                raise MotionFormatError(
                    f"expected a number for bone {head!r}, found {tok!r}", where, number
                ) from None
            if not math.isfinite(value):
                raise MotionFormatError(
                    f"bone {head!r}: values must be finite numbers, found {tok!r}", where, number
                )
            current[start + k] = value
    if current is None:
        raise MotionFormatError(
            "no frames: expected a frame number line such as '1'", where, len(lines)
        )
    finish(len(lines))
    table = np.array(rows, dtype=np.float64).reshape(len(rows), width)
    return {name: table[:, s : s + n] for name, (s, n) in layout.items()}, angle_unit


def _amc_motion(
    asf: AsfSkeleton,
    raw: dict[str, np.ndarray],
    angle_unit: str,
    order: str,
    frame_time_s: float,
    name: str,
) -> Motion:
    skeleton = asf_to_skeleton(asf, order)
    n_frames = raw["root"].shape[0]

    def to_deg(angles: np.ndarray) -> np.ndarray:
        if angle_unit != "rad":
            return angles
        with np.errstate(over="ignore"):
            out = np.rad2deg(angles)
        if not np.all(np.isfinite(out)):
            raise InvalidParameterError("an AMC angle is too large to convert to degrees")
        return out

    rotations = np.broadcast_to(np.eye(3), (n_frames, skeleton.n_joints, 3, 3)).copy()
    # Root: translation is absolute; rotation composed in the order line's order.
    root = raw["root"]
    translation = np.broadcast_to(asf.root_position, (n_frames, 3)).copy()
    angles: dict[str, np.ndarray] = {}
    for k, tok in enumerate(asf.root_order):
        if tok.startswith("T"):
            translation[:, "XYZ".index(tok[1])] = root[:, k]
        else:
            angles[tok[1]] = to_deg(root[:, k])
    root_order = "".join(t[1] for t in asf.root_order if t.startswith("R"))
    c_root = asf.root_axis_matrix()
    rotations[:, 0] = c_root @ compose_rotations(root_order, angles) @ c_root.T
    for j, bone in enumerate(asf.bones, start=1):
        if not bone.dof:
            continue
        values = raw[bone.name]
        dof_angles = {d[1].upper(): to_deg(values[:, k]) for k, d in enumerate(bone.dof)}
        dof_order = "".join(d[1].upper() for d in bone.dof)
        c = bone.axis_matrix()
        rotations[:, j] = c @ compose_rotations(dof_order, dof_angles) @ c.T
    values = np.zeros((n_frames, skeleton.n_channels))
    starts = skeleton.channel_start()
    values[:, 0:3] = translation - asf.root_position
    for j in range(skeleton.n_joints):
        chans = skeleton.channels[j]
        rot_cols = [k for k, ch in enumerate(chans) if ch.endswith("rotation")]
        if not rot_cols:
            continue
        euler = matrix_to_euler(rotations[:, j], order)
        for k in rot_cols:
            values[:, starts[j] + k] = euler[:, order.index(chans[k][0])]
    return Motion(skeleton, values, frame_time_s, asf.length_unit_m, name)
