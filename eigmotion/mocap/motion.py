"""The one motion type every reader produces and every stage consumes.

A :class:`Motion` is a :class:`Skeleton` plus a frame-by-channel table, exactly as a
BVH file holds it: translations in the skeleton's length unit, rotations in degrees,
each joint's rotation channels composed in the order they are listed (intrinsic, so
``Zrotation Xrotation Yrotation`` means ``R = Rz @ Rx @ Ry``).  A joint's local
transform maps its own frame into its parent's: ``x_parent = R_j @ x_j + t_j`` with
``t_j = offset_j + (position channels)``.  At rest (all channels zero) every joint
frame is parallel to the world frame, as in BVH; readers of other formats (ASF/AMC)
bake their bone axes into the rotations so that this holds.

World conventions (after :mod:`eigmotion.mocap.kinematics`): metres, Y up.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.limits import check_motion_size
from eigmotion.mocap.rotations import (
    check_euler_order,
    euler_to_matrix,
    matrix_to_euler,
    slerp_matrices,
)

POSITION_CHANNELS = ("Xposition", "Yposition", "Zposition")
ROTATION_CHANNELS = ("Xrotation", "Yrotation", "Zrotation")
ALL_CHANNELS = POSITION_CHANNELS + ROTATION_CHANNELS


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A joint hierarchy with rest offsets and per-joint channel lists.

    Parameters
    ----------
    names : tuple of str
        Joint names, unique, parents before children (index 0 is the root).
    parents : (J,) int
        Parent index per joint, -1 for the root.
    offsets : (J, 3) float
        Rest offset of each joint from its parent, in the skeleton's length unit.
    channels : tuple of tuple of str
        Per joint, its channel names in file order, each one of ``ALL_CHANNELS``.
    end_sites : dict of int to (3,) float
        Offsets of End Site markers, keyed by the joint that carries them.
    """

    names: tuple[str, ...]
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_sites: dict[int, np.ndarray] = field(default_factory=dict)

    def __post_init__(self):
        names = tuple(self.names)
        parents = np.asarray(self.parents, dtype=np.int64)
        offsets = np.asarray(self.offsets, dtype=np.float64).reshape(-1, 3)
        channels = tuple(tuple(c) for c in self.channels)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(
            self,
            "end_sites",
            {int(k): np.asarray(v, dtype=np.float64).reshape(3) for k, v in self.end_sites.items()},
        )
        n = len(names)
        if n == 0:
            raise InvalidParameterError("a skeleton needs at least one joint")
        if len(set(names)) != n:
            dup = sorted({x for x in names if names.count(x) > 1})
            raise InvalidParameterError(f"duplicate joint names {dup}")
        if parents.shape != (n,) or offsets.shape != (n, 3) or len(channels) != n:
            raise InvalidParameterError(
                f"skeleton arrays disagree: {n} names, parents {parents.shape}, "
                f"offsets {offsets.shape}, {len(channels)} channel lists"
            )
        if parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, n)):
            raise InvalidParameterError("joints must be ordered parents-first with one root at 0")
        for name, chans in zip(names, channels, strict=True):
            bad = [c for c in chans if c not in ALL_CHANNELS]
            if bad or len(set(chans)) != len(chans):
                raise InvalidParameterError(f"joint {name!r}: bad channel list {list(chans)}")
        if not np.all(np.isfinite(offsets)):
            raise InvalidParameterError("skeleton offsets must be finite")

    # -- structure -------------------------------------------------------------
    @property
    def n_joints(self) -> int:
        return len(self.names)

    @property
    def n_channels(self) -> int:
        return sum(len(c) for c in self.channels)

    def index(self, name: str) -> int:
        """Index of joint ``name``; raises ``InvalidParameterError`` naming it."""
        try:
            return self.names.index(name)
        except ValueError:
            raise InvalidParameterError(f"no joint named {name!r} in skeleton") from None

    def children(self, joint: int) -> list[int]:
        return [int(c) for c in np.flatnonzero(self.parents == joint)]

    def channel_start(self) -> np.ndarray:
        """(J,) int: column of each joint's first channel in the motion table."""
        counts = np.array([len(c) for c in self.channels], dtype=np.int64)
        return np.concatenate([[0], np.cumsum(counts)[:-1]])

    def rotation_order(self, joint: int) -> str | None:
        """The joint's Euler order from its rotation channels (``None`` if it has none).

        A joint with fewer than three rotation channels gets the missing axes
        appended, so that writing back into its channels is well defined.
        """
        axes = "".join(c[0] for c in self.channels[joint] if c.endswith("rotation"))
        if not axes:
            return None
        return axes + "".join(a for a in "XYZ" if a not in axes)

    def with_channels(self, channels: Sequence[Sequence[str]]) -> Skeleton:
        return Skeleton(self.names, self.parents, self.offsets, channels, self.end_sites)

    def renamed(self, names: Sequence[str]) -> Skeleton:
        return Skeleton(tuple(names), self.parents, self.offsets, self.channels, self.end_sites)

    def scaled(self, factor: float) -> Skeleton:
        return Skeleton(
            self.names,
            self.parents,
            self.offsets * factor,
            self.channels,
            {k: v * factor for k, v in self.end_sites.items()},
        )


def standard_channels(n_joints: int, order: str = "ZXY") -> tuple[tuple[str, ...], ...]:
    """Root: 3 positions + 3 rotations; others: 3 rotations, in ``order``."""
    order = check_euler_order(order)
    rot = tuple(f"{a}rotation" for a in order)
    return (POSITION_CHANNELS + rot,) + (rot,) * (n_joints - 1)


@dataclass(frozen=True, eq=False)
class Motion:
    """A skeleton animated over frames.

    Parameters
    ----------
    skeleton : Skeleton
    values : (F, C) float
        Channel values per frame, columns in skeleton channel order; translations in
        the skeleton's length unit, rotations in degrees.
    frame_time_s : float
        Seconds per frame (> 0).
    length_unit_m : float or None
        Metres per length unit of the skeleton, or ``None`` when unknown (then
        :func:`eigmotion.mocap.kinematics.detect_length_unit` guesses it).
    name : str
        A label for messages and outputs.
    """

    skeleton: Skeleton
    values: np.ndarray
    frame_time_s: float
    length_unit_m: float | None = None
    name: str = ""

    def __post_init__(self):
        values = np.asarray(self.values, dtype=np.float64)
        if values.ndim == 1 and self.skeleton.n_channels == values.size:
            values = values.reshape(1, -1)
        object.__setattr__(self, "values", values)
        if values.ndim != 2 or values.shape[1] != self.skeleton.n_channels:
            raise InvalidParameterError(
                f"motion values have shape {values.shape}; expected (n_frames, "
                f"{self.skeleton.n_channels}) for this skeleton"
            )
        if not np.all(np.isfinite(values)):
            frame = int(np.flatnonzero(~np.all(np.isfinite(values), axis=1))[0])
            raise InvalidParameterError(f"motion values are not finite (first at frame {frame})")
        if not (np.isfinite(self.frame_time_s) and self.frame_time_s > 0):
            raise InvalidParameterError(f"frame_time_s must be > 0, got {self.frame_time_s!r}")
        check_motion_size(
            values.shape[0], self.skeleton.n_joints, float(self.frame_time_s), self._what()
        )
        if self.length_unit_m is not None and not (
            np.isfinite(self.length_unit_m) and self.length_unit_m > 0
        ):
            raise InvalidParameterError(f"length_unit_m must be > 0, got {self.length_unit_m!r}")

    def _what(self) -> str:
        return f"motion {self.name!r}" if self.name else "the motion"

    # -- basic facts -------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return self.values.shape[0]

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time_s

    @property
    def duration_s(self) -> float:
        return self.n_frames * self.frame_time_s

    def replace(self, **changes) -> Motion:
        fields = dict(
            skeleton=self.skeleton,
            values=self.values,
            frame_time_s=self.frame_time_s,
            length_unit_m=self.length_unit_m,
            name=self.name,
        )
        fields.update(changes)
        return Motion(**fields)

    # -- channels <-> local transforms ---------------------------------------------
    def local_rotations(self) -> np.ndarray:
        """(F, J, 3, 3) float64: each joint's rotation relative to its parent."""
        sk = self.skeleton
        out = np.broadcast_to(np.eye(3), (self.n_frames, sk.n_joints, 3, 3)).copy()
        starts = sk.channel_start()
        for j in range(sk.n_joints):
            order = sk.rotation_order(j)
            if order is None:
                continue
            angles = np.zeros((self.n_frames, 3))
            for k, ch in enumerate(sk.channels[j]):
                if ch.endswith("rotation"):
                    angles[:, order.index(ch[0])] = self.values[:, starts[j] + k]
            out[:, j] = euler_to_matrix(angles, order)
        return out

    def local_translations(self) -> np.ndarray:
        """(F, J, 3) float64: offset plus position channels, in length units."""
        sk = self.skeleton
        out = np.broadcast_to(sk.offsets, (self.n_frames, sk.n_joints, 3)).copy()
        starts = sk.channel_start()
        for j in range(sk.n_joints):
            for k, ch in enumerate(sk.channels[j]):
                if ch.endswith("position"):
                    out[:, j, "XYZ".index(ch[0])] += self.values[:, starts[j] + k]
        return out

    def with_local_transforms(
        self, rotations: np.ndarray, translations: np.ndarray | None = None, **changes
    ) -> Motion:
        """A motion on the same skeleton and channel layout from local transforms.

        Parameters
        ----------
        rotations : (F, J, 3, 3) float
            Local rotations; joints without rotation channels must be identity.
        translations : (F, J, 3) float, optional
            Local translations (offset included); only axes that have position
            channels are kept.  Default: the current ones when F is unchanged, else
            the offsets.
        **changes
            Other fields to replace (``frame_time_s``, ``name`` …).
        """
        sk = self.skeleton
        rotations = np.asarray(rotations, dtype=np.float64)
        n = rotations.shape[0]
        if rotations.shape != (n, sk.n_joints, 3, 3):
            raise InvalidParameterError(
                f"rotations have shape {rotations.shape}; expected (F, {sk.n_joints}, 3, 3)"
            )
        if translations is None:
            translations = (
                self.local_translations()
                if n == self.n_frames
                else np.broadcast_to(sk.offsets, (n, sk.n_joints, 3))
            )
        values = np.zeros((n, sk.n_channels))
        starts = sk.channel_start()
        for j in range(sk.n_joints):
            order = sk.rotation_order(j)
            angles = None if order is None else matrix_to_euler(rotations[:, j], order)
            for k, ch in enumerate(sk.channels[j]):
                axis = "XYZ".index(ch[0])
                if ch.endswith("position"):
                    values[:, starts[j] + k] = translations[:, j, axis] - sk.offsets[j, axis]
                else:
                    values[:, starts[j] + k] = angles[:, order.index(ch[0])]
        return self.replace(values=values, **changes)

    @classmethod
    def from_local_transforms(
        cls,
        skeleton: Skeleton,
        rotations: np.ndarray,
        root_translation: np.ndarray,
        frame_time_s: float,
        order: str = "ZXY",
        length_unit_m: float | None = None,
        name: str = "",
    ) -> Motion:
        """Build a motion with standard channels (root 6, others 3) in ``order``.

        Parameters
        ----------
        skeleton : Skeleton
            Its channel lists are replaced by :func:`standard_channels`.
        rotations : (F, J, 3, 3) float
        root_translation : (F, 3) float
            Root position per frame in length units (the root offset included).
        """
        sk = skeleton.with_channels(standard_channels(skeleton.n_joints, order))
        rotations = np.asarray(rotations, dtype=np.float64)
        n = rotations.shape[0]
        translations = np.broadcast_to(sk.offsets, (n, sk.n_joints, 3)).copy()
        translations[:, 0] = np.asarray(root_translation, dtype=np.float64).reshape(n, 3)
        blank = cls(sk, np.zeros((1, sk.n_channels)), frame_time_s, length_unit_m, name)
        return blank.with_local_transforms(rotations, translations)

    # -- time ----------------------------------------------------------------------
    def trim(self, start: int, stop: int | None = None) -> Motion:
        """Frames ``[start, stop)`` (Python slice semantics, negative allowed)."""
        stop = self.n_frames if stop is None else stop
        idx = range(self.n_frames)[start:stop]
        if len(idx) == 0:
            raise InvalidParameterError(
                f"frame range [{start}, {stop}) is empty for a motion of {self.n_frames} frames"
            )
        return self.replace(values=self.values[idx.start : idx.stop])

    def resample(self, fps: float) -> Motion:
        """Resample to ``fps`` frames per second (slerp rotations, lerp translations).

        The first frame is kept; the last output frame is the last one at or before
        the original end time.  The result's size is checked against
        :mod:`eigmotion.limits` before it is computed.
        """
        if not (np.isfinite(fps) and fps > 0):
            raise InvalidParameterError(f"fps must be > 0, got {fps!r}")
        if self.n_frames == 1:
            return self.replace(frame_time_s=1.0 / fps)
        end_t = (self.n_frames - 1) * self.frame_time_s
        n_out = int(min(np.floor(end_t * fps + 1e-9), 2**62)) + 1
        check_motion_size(
            n_out, self.skeleton.n_joints, 1.0 / fps, f"{self._what()} resampled to {fps:g} fps"
        )
        src = np.arange(n_out) / fps / self.frame_time_s
        i0 = np.clip(np.floor(src).astype(np.int64), 0, self.n_frames - 1)
        i1 = np.minimum(i0 + 1, self.n_frames - 1)
        w = src - i0
        rot = self.local_rotations()
        trans = self.local_translations()
        j = self.skeleton.n_joints
        r0 = rot[i0].reshape(-1, 3, 3)
        r1 = rot[i1].reshape(-1, 3, 3)
        r = slerp_matrices(r0, r1, np.repeat(w, j)).reshape(n_out, j, 3, 3)
        t = trans[i0] * (1 - w)[:, None, None] + trans[i1] * w[:, None, None]
        return self.with_local_transforms(r, t, frame_time_s=1.0 / fps)
