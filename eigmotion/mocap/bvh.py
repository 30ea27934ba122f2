"""BVH (Biovision Hierarchy) motion files: read and write.

A BVH file holds a joint hierarchy (``HIERARCHY``: ``ROOT``/``JOINT`` blocks with an
``OFFSET``, a ``CHANNELS`` list and optional ``End Site``) and a frame table
(``MOTION``: ``Frames:``, ``Frame Time:``, one line of channel values per frame).
The reader keeps the file's semantics, which are :class:`~eigmotion.mocap.motion.Motion`'s:

* a joint's translation relative to its parent is ``OFFSET`` plus its position
  channels (any joint may have position channels, any subset of axes);
* its rotation is the product of its rotation channels in the order they are
  listed, intrinsic (``Zrotation Xrotation Yrotation`` → ``R = Rz @ Rx @ Ry``),
  in degrees;
* ``Frame Time`` is seconds per frame.

The length unit is not stated in BVH files; :func:`read_bvh` leaves
``length_unit_m`` unset so that :func:`eigmotion.mocap.kinematics.forward_kinematics`
detects it from the skeleton's height.

Any malformed file raises :class:`~eigmotion.errors.MotionFormatError` naming the
file, the line and what was expected; no other exception escapes the reader.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError, MotionFormatError
from eigmotion.limits import (
    MAX_BVH_OUTPUT_BYTES,
    MAX_JOINTS,
    MAX_MOTION_FILE_BYTES,
    check_file_size,
    check_motion_size,
)
from eigmotion.mocap.motion import ALL_CHANNELS, Motion, Skeleton

#: Channel names as they may be spelt in a file (any case) → canonical spelling.
_CHANNEL_SPELLING = {name.lower(): name for name in ALL_CHANNELS}

_TOKEN = re.compile(r"[{}]|[^\s{}]+")
_LINE_BREAK = re.compile(r"\r\n|\r|\n")
_VALID_NAME = re.compile(r"[^\s{}]+")


@dataclass
class _Joint:
    """A joint while the hierarchy is being read."""

    name: str
    parent: int
    line: int
    offset: tuple[float, float, float] | None = None
    channels: tuple[str, ...] = ()
    channels_line: int | None = None
    end_site: tuple[float, float, float] | None = None
    children: list[int] = field(default_factory=list)


class _Tokens:
    """Tokens of the hierarchy section with their 1-based line numbers."""

    def __init__(self, lines: list[str], path: str | None):
        self.items: list[tuple[str, int]] = []
        for number, line in enumerate(lines, start=1):
            self.items.extend((tok, number) for tok in _TOKEN.findall(line))
        self.pos = 0
        self.path = path
        self.last_line = max(len(lines), 1)

    def error(self, message: str, line: int | None = None) -> MotionFormatError:
        return MotionFormatError(message, self.path, line)

    def next(self, expected: str) -> tuple[str, int]:
        """The next token; ``expected`` says what should come, for the message."""
        if self.pos >= len(self.items):
            raise self.error(f"the hierarchy ends early: expected {expected}", self.last_line)
        item = self.items[self.pos]
        self.pos += 1
        return item

    def keyword(self, word: str) -> int:
        tok, line = self.next(f"{word!r}")
        if tok != word:
            raise self.error(f"expected {word!r}, found {tok!r}", line)
        return line

    def number(self, what: str) -> float:
        tok, line = self.next(what)
        return _parse_float(tok, what, self.path, line)

    def offset(self, what: str) -> tuple[float, float, float]:
        return tuple(self.number(f"{what} {axis}") for axis in "xyz")


def _parse_float(token: str, what: str, path: str | None, line: int) -> float:
    try:
        value = float(token)
    except ValueError:
        raise MotionFormatError(
            f"expected a number for {what}, found {token!r}", path, line
        ) from None
    if not math.isfinite(value):
        raise MotionFormatError(f"{what} must be a finite number, found {token!r}", path, line)
    return value


def read_bvh(path: str | Path) -> Motion:
    """Read a BVH file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Motion
        Named after the file stem, ``length_unit_m=None`` (detected later from the
        skeleton's height), ``frame_time_s`` from ``Frame Time``.

    Raises
    ------
    MotionFormatError
        The file is not a valid BVH file (the message names the file and line).
    FileNotFoundError
        The file does not exist.
    InvalidParameterError
        The file is larger than :data:`~eigmotion.limits.MAX_MOTION_FILE_BYTES`.
    """
    path = Path(path)
    check_file_size(path.stat().st_size, MAX_MOTION_FILE_BYTES, str(path))
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        # Joint names are the only free text; old exporters wrote Latin-1.
        text = raw.decode("latin-1")
    return parse_bvh(text, path)


def parse_bvh(text: str, path: str | Path | None = None) -> Motion:
    """Parse the text of a BVH file.

    Parameters
    ----------
    text : str
        The whole file; LF, CRLF or CR line ends, spaces or tabs.
    path : str or Path, optional
        Used in error messages and for the motion's name (its stem).

    Returns
    -------
    Motion
        Joints in the file's depth-first order; ``values`` (F, C) float64 in the
        file's channel order (translations in file units, rotations in degrees).

    Raises
    ------
    MotionFormatError
        Also for a motion beyond the size limits of :mod:`eigmotion.limits` (joints,
        frames, frame time), found from the header before the frames are read.
    """
    where = None if path is None else str(path)
    name = "" if path is None else Path(path).stem
    lines = _LINE_BREAK.split(text)
    motion_line = next(
        (i for i, line in enumerate(lines) if line.split()[:1] == ["MOTION"]), len(lines)
    )
    tokens = _Tokens(lines[:motion_line], where)
    joints = _parse_hierarchy(tokens)
    if motion_line == len(lines):
        raise MotionFormatError(
            "missing MOTION section: expected a line 'MOTION' after the hierarchy",
            where,
            len(lines),
        )
    if lines[motion_line].split() != ["MOTION"]:
        raise MotionFormatError(
            "the MOTION line must hold only the word MOTION", where, motion_line + 1
        )
    skeleton = _build_skeleton(joints, where)
    values, frame_time_s = _parse_frames(
        lines, motion_line + 1, skeleton.n_channels, skeleton.n_joints, where
    )
    try:
        return Motion(skeleton, values, frame_time_s, None, name)
    except InvalidParameterError as exc:
        raise MotionFormatError(str(exc), where) from None


def _parse_hierarchy(tokens: _Tokens) -> list[_Joint]:
    """Read HIERARCHY and the ROOT block; returns joints in depth-first order."""
    tok, line = tokens.next("'HIERARCHY'")
    if tok != "HIERARCHY":
        raise tokens.error(f"a BVH file starts with 'HIERARCHY', found {tok!r}", line)
    tok, line = tokens.next("'ROOT'")
    if tok != "ROOT":
        raise tokens.error(f"expected 'ROOT' after HIERARCHY, found {tok!r}", line)
    joints: list[_Joint] = []
    seen: dict[str, int] = {}
    _open_joint(tokens, joints, seen, parent=-1, line=line)
    stack = [0]
    while stack:
        current = joints[stack[-1]]
        tok, line = tokens.next(f"'}}' closing joint {current.name!r} (line {current.line})")
        if tok == "OFFSET":
            if current.offset is not None:
                raise tokens.error(f"joint {current.name!r} has a second OFFSET", line)
            if current.children or current.end_site is not None:
                raise tokens.error(
                    f"the OFFSET of joint {current.name!r} must come before its children", line
                )
            current.offset = tokens.offset(f"the OFFSET of {current.name!r}")
        elif tok == "CHANNELS":
            if current.channels_line is not None:
                raise tokens.error(f"joint {current.name!r} has a second CHANNELS line", line)
            if current.children or current.end_site is not None:
                raise tokens.error(
                    f"the CHANNELS of joint {current.name!r} must come before its children", line
                )
            current.channels = _parse_channels(tokens, current.name, line)
            current.channels_line = line
        elif tok == "JOINT":
            _require_offset(tokens, current)
            stack.append(_open_joint(tokens, joints, seen, parent=stack[-1], line=line))
            current.children.append(stack[-1])
        elif tok == "End":
            _require_offset(tokens, current)
            site, site_line = tokens.next("'Site' after 'End'")
            if site.lower() != "site":
                raise tokens.error(f"expected 'End Site', found 'End {site}'", site_line)
            if current.end_site is not None:
                raise tokens.error(f"joint {current.name!r} has a second End Site", line)
            tokens.keyword("{")
            tokens.keyword("OFFSET")
            current.end_site = tokens.offset(f"the End Site OFFSET of {current.name!r}")
            tokens.keyword("}")
        elif tok == "}":
            _require_offset(tokens, current)
            stack.pop()
        elif tok == "ROOT":
            raise tokens.error(
                "a second ROOT inside the hierarchy: only one skeleton per file is supported",
                line,
            )
        else:
            raise tokens.error(
                f"expected OFFSET, CHANNELS, JOINT, End Site or '}}' in joint "
                f"{current.name!r}, found {tok!r}",
                line,
            )
    if tokens.pos < len(tokens.items):
        tok, line = tokens.items[tokens.pos]
        raise tokens.error(
            f"expected 'MOTION' after the ROOT block closed, found {tok!r} "
            "(a second ROOT or an extra '}'?)",
            line,
        )
    return joints


def _open_joint(
    tokens: _Tokens, joints: list[_Joint], seen: dict[str, int], parent: int, line: int
) -> int:
    name, name_line = tokens.next("a joint name")
    if name in "{}":
        raise tokens.error(f"expected a joint name, found {name!r}", name_line)
    if name in seen:
        raise tokens.error(
            f"duplicate joint name {name!r} (first defined at line {seen[name]})", name_line
        )
    if len(joints) >= MAX_JOINTS:
        raise tokens.error(
            f"more than {MAX_JOINTS} joints: larger skeletons are not supported", name_line
        )
    seen[name] = name_line
    tokens.keyword("{")
    joints.append(_Joint(name, parent, name_line))
    return len(joints) - 1


def _require_offset(tokens: _Tokens, joint: _Joint) -> None:
    if joint.offset is None:
        raise tokens.error(
            f"joint {joint.name!r} (line {joint.line}) has no OFFSET before its end or children",
            joint.line,
        )


def _parse_channels(tokens: _Tokens, joint: str, line: int) -> tuple[str, ...]:
    tok, count_line = tokens.next("the channel count")
    try:
        count = int(tok)
    except ValueError:
        raise tokens.error(
            f"expected the channel count of {joint!r} (an integer 0-6), found {tok!r}", count_line
        ) from None
    if not 0 <= count <= len(ALL_CHANNELS):
        raise tokens.error(
            f"joint {joint!r} declares {count} channels; expected 0 to {len(ALL_CHANNELS)}",
            count_line,
        )
    channels = []
    for _ in range(count):
        tok, ch_line = tokens.next(f"{count} channel names for {joint!r}")
        spelled = _CHANNEL_SPELLING.get(tok.lower())
        if spelled is None:
            raise tokens.error(
                f"unknown channel {tok!r} for joint {joint!r}; expected one of "
                f"{', '.join(ALL_CHANNELS)}",
                ch_line,
            )
        if spelled in channels:
            raise tokens.error(f"joint {joint!r} lists channel {spelled} twice", ch_line)
        channels.append(spelled)
    return tuple(channels)


def _build_skeleton(joints: list[_Joint], where: str | None) -> Skeleton:
    try:
        return Skeleton(
            tuple(j.name for j in joints),
            np.array([j.parent for j in joints], dtype=np.int64),
            np.array([j.offset for j in joints], dtype=np.float64).reshape(-1, 3),
            tuple(j.channels for j in joints),
            {i: j.end_site for i, j in enumerate(joints) if j.end_site is not None},
        )
    except InvalidParameterError as exc:
        raise MotionFormatError(f"invalid skeleton: {exc}", where) from None


def _parse_frames(
    lines: list[str], start: int, n_channels: int, n_joints: int, where: str | None
) -> tuple[np.ndarray, float]:
    """Read ``Frames:``, ``Frame Time:`` and the frame lines from ``lines[start:]``;
    the motion's size is checked against :mod:`eigmotion.limits` before the frames."""
    body = [(i + 1, line.split()) for i, line in enumerate(lines[start:], start=start)]
    body = [(number, toks) for number, toks in body if toks]
    if not body:
        raise MotionFormatError("the file ends after MOTION: expected 'Frames: N'", where, start)
    number, toks = body[0]
    if len(toks) != 2 or toks[0] != "Frames:":
        raise MotionFormatError(
            f"expected 'Frames: N' after MOTION, found {' '.join(toks)!r}", where, number
        )
    try:
        n_frames = int(toks[1])
    except ValueError:
        raise MotionFormatError(
            f"the frame count must be an integer, found {toks[1]!r}", where, number
        ) from None
    if n_frames < 1:
        raise MotionFormatError(
            f"Frames: {n_frames}: a motion needs at least one frame", where, number
        )
    frames_line = number
    if len(body) < 2:
        raise MotionFormatError(
            "the file ends after 'Frames:': expected 'Frame Time: SECONDS'", where, frames_line
        )
    number, toks = body[1]
    if len(toks) != 3 or toks[:2] != ["Frame", "Time:"]:
        raise MotionFormatError(
            f"expected 'Frame Time: SECONDS', found {' '.join(toks)!r}", where, number
        )
    frame_time_s = _parse_float(toks[2], "the frame time", where, number)
    if frame_time_s <= 0:
        raise MotionFormatError(
            f"the frame time must be > 0 seconds, found {toks[2]!r}", where, number
        )
    try:
        check_motion_size(n_frames, n_joints, frame_time_s, "the motion")
    except InvalidParameterError as exc:
        raise MotionFormatError(str(exc), where, frames_line) from None
    rows = body[2:]
    if n_channels == 0:
        # A skeleton without channels has empty frame lines, skipped above.
        if rows:
            raise MotionFormatError(
                f"the skeleton has no channels but a frame line holds {len(rows[0][1])} values",
                where,
                rows[0][0],
            )
        return np.zeros((n_frames, 0)), frame_time_s
    if len(rows) < n_frames:
        last = rows[-1][0] if rows else number
        raise MotionFormatError(
            f"expected {n_frames} frame lines ('Frames:' at line {frames_line}), "
            f"found {len(rows)}: the file is truncated",
            where,
            last,
        )
    if len(rows) > n_frames:
        raise MotionFormatError(
            f"more frame lines than 'Frames: {n_frames}' (line {frames_line}) declares",
            where,
            rows[n_frames][0],
        )
    values = np.empty((n_frames, n_channels))
    for f, (number, toks) in enumerate(rows):
        if len(toks) != n_channels:
            hint = (
                " (is the file truncated?)" if f == n_frames - 1 and len(toks) < n_channels else ""
            )
            raise MotionFormatError(
                f"frame {f} has {len(toks)} values; the hierarchy declares {n_channels} "
                f"channels{hint}",
                where,
                number,
            )
        try:
            values[f] = [float(t) for t in toks]
        except ValueError:
            bad = next(t for t in toks if not _is_float(t))
            raise MotionFormatError(
                f"expected a number in frame {f}, found {bad!r}", where, number
            ) from None
    finite = np.isfinite(values)
    if not finite.all():
        f, c = np.argwhere(~finite)[0]
        raise MotionFormatError(
            f"frame {f}, channel {c}: values must be finite numbers, found {rows[f][1][c]!r}",
            where,
            rows[f][0],
        )
    return values, frame_time_s


def _is_float(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


# -- writing ---------------------------------------------------------------------------


_POSITIONS = ("Xposition", "Yposition", "Zposition")


def root_position_in_channels(motion: Motion) -> Motion:
    """The same motion with a zero root ``OFFSET`` and the root's position in channels.

    BVH readers disagree on a root that has both: this reader (and the BVH
    definition) adds the position channels to the ``OFFSET``, while Blender's
    importer and bvhio take the channels as the whole position and drop the
    ``OFFSET``.  With a zero root ``OFFSET`` every reader places the body the same.

    Parameters
    ----------
    motion : Motion

    Returns
    -------
    Motion
        ``motion`` itself when its root ``OFFSET`` is zero and the root has all three
        or no position channels; otherwise a motion whose root ``OFFSET`` is zero and
        whose root channels are ``Xposition Yposition Zposition`` followed by its
        rotation channels in their order, the positions holding ``OFFSET`` plus the
        old position channels (file units).  Joint positions are the same for every
        frame; other joints are untouched.
    """
    sk = motion.skeleton
    root_channels = sk.channels[0]
    n_positions = sum(ch.endswith("position") for ch in root_channels)
    if not sk.offsets[0].any() and n_positions in (0, 3):
        return motion
    start = sk.channel_start()[0]
    old = motion.values[:, start : start + len(root_channels)]
    position = np.broadcast_to(sk.offsets[0], (motion.n_frames, 3)).copy()
    rotations = []
    for k, ch in enumerate(root_channels):
        if ch.endswith("position"):
            position[:, "XYZ".index(ch[0])] += old[:, k]
        else:
            rotations.append(k)
    new_root = np.concatenate([position, old[:, rotations]], axis=1)
    values = np.concatenate(
        [motion.values[:, :start], new_root, motion.values[:, start + len(root_channels) :]],
        axis=1,
    )
    offsets = sk.offsets.copy()
    offsets[0] = 0.0
    channels = (_POSITIONS + tuple(root_channels[k] for k in rotations),) + tuple(sk.channels[1:])
    skeleton = Skeleton(sk.names, sk.parents, offsets, channels, sk.end_sites)
    return motion.replace(skeleton=skeleton, values=values)


def format_bvh(motion: Motion, precision: int = 6) -> str:
    """The text of a BVH file holding ``motion``.

    Parameters
    ----------
    motion : Motion
        Joint names must be non-empty and free of whitespace and braces.
    precision : int
        Digits after the decimal point for offsets and channel values; the default
        keeps every value to within 5e-7 (degrees or length units).

    Returns
    -------
    str
        LF line ends, tab indentation.  Joints are written depth-first (a skeleton
        stored in another parents-first order is re-ordered, channels with it);
        ``Frame Time`` is written with full float precision.  The root is written
        with a zero ``OFFSET`` and its whole position in its position channels
        (:func:`root_position_in_channels`), the convention Blender's and bvhio's
        readers share; the joint positions are unchanged.

    Raises
    ------
    InvalidParameterError
        A joint name that cannot be written, a bad ``precision``, or a text larger
        than :data:`~eigmotion.limits.MAX_BVH_OUTPUT_BYTES` (checked before writing).
    """
    if isinstance(precision, bool) or not isinstance(precision, int | np.integer):
        raise InvalidParameterError(f"precision must be an integer >= 0, got {precision!r}")
    if not 0 <= precision <= 17:
        raise InvalidParameterError(f"precision must be in 0..17 digits, got {precision}")
    motion = root_position_in_channels(motion)
    sk = motion.skeleton
    for name in sk.names:
        if not _VALID_NAME.fullmatch(name):
            raise InvalidParameterError(
                f"joint name {name!r} cannot be written to BVH: it must be non-empty and "
                "hold no whitespace or braces"
            )
    # Each value takes at most sign, digits, point and separator (channel values
    # beyond 1e9 are estimated by their own width); the hierarchy is indented by depth.
    magnitude = float(np.max(np.abs(motion.values), initial=1.0))
    per_value = precision + 4 + len(f"{magnitude:.0f}")
    depth = np.zeros(sk.n_joints, dtype=np.int64)
    for j in range(1, sk.n_joints):
        depth[j] = depth[sk.parents[j]] + 1
    expected = motion.values.size * per_value + int(depth.sum() + sk.n_joints) * 6 * 4
    if expected > MAX_BVH_OUTPUT_BYTES:
        raise InvalidParameterError(
            f"the BVH text would take about {expected / 2**20:,.0f} MiB; at most "
            f"{MAX_BVH_OUTPUT_BYTES / 2**20:,.0f} MiB are written (trim or resample the motion)"
        )
    num = f"{{:.{precision}f}}"

    def vec(v: np.ndarray) -> str:
        return " ".join(num.format(float(x)) for x in v)

    out = ["HIERARCHY"]
    order: list[int] = []
    # Iterative depth-first walk; ("close", j) entries close a joint's block.
    stack: list[tuple[str, int, int]] = [("open", 0, 0)]
    while stack:
        action, j, depth = stack.pop()
        pad = "\t" * depth
        if action == "close":
            if j in sk.end_sites:
                out += [
                    f"{pad}\tEnd Site",
                    f"{pad}\t{{",
                    f"{pad}\t\tOFFSET {vec(sk.end_sites[j])}",
                    f"{pad}\t}}",
                ]
            out.append(f"{pad}}}")
            continue
        order.append(j)
        out.append(f"{pad}{'ROOT' if j == 0 else 'JOINT'} {sk.names[j]}")
        out.append(f"{pad}{{")
        out.append(f"{pad}\tOFFSET {vec(sk.offsets[j])}")
        chans = sk.channels[j]
        out.append(f"{pad}\tCHANNELS {len(chans)}" + "".join(f" {c}" for c in chans))
        stack.append(("close", j, depth))
        stack.extend(("open", c, depth + 1) for c in reversed(sk.children(j)))
    starts = sk.channel_start()
    columns = np.concatenate(
        [np.arange(starts[j], starts[j] + len(sk.channels[j])) for j in order]
    ).astype(np.int64)
    out += ["MOTION", f"Frames: {motion.n_frames}", f"Frame Time: {float(motion.frame_time_s)!r}"]
    row = " ".join([f"%.{precision}f"] * len(columns))
    values = motion.values[:, columns]
    out.extend(row % tuple(v) for v in values.tolist())
    return "\n".join(out) + "\n"


def write_bvh(motion: Motion, path: str | Path, precision: int = 6) -> None:
    """Write ``motion`` to a BVH file (see :func:`format_bvh`).

    Parameters
    ----------
    motion : Motion
    path : str or Path
        Overwritten if it exists.
    precision : int
        Digits after the decimal point.
    """
    text = format_bvh(motion, precision)
    Path(path).write_text(text, encoding="utf-8", newline="\n")
