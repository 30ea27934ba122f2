"""The posture dictionary (the paper's section 2.2) and the posture distances d1, d2.

A posture is the set of joint rotations of the canonical skeleton (the avatar's): each
joint's rotation relative to its parent, relative to the rest pose (joint frames are
world-aligned at rest, see :mod:`eigmotion.mocap.motion`).  For comparisons a posture is
written as one vector ``r`` in degrees:

* ``r[0]`` — the heading: the yaw of the body's forward axis (+Z at rest) about +Y,
  in (-180, 180];
* ``r[1:4]`` — the rest of the root's rotation (its tilt, the root rotation with the
  heading taken out) as a rotation vector (axis × angle);
* then, per joint of :attr:`PostureDictionary.vector_joints`, the rotation vector of
  its local rotation.

The paper's posture difference (its equation 1) is ``d1(a, b) = max_i |r_ai - r_bi|``,
degrees, with the heading difference wrapped into [0, 180].  Rotation vectors are
continuous for rotations below 180°, which joint rotations relative to the rest pose
stay within for human motion; the heading is the one angle that goes all the way
round, hence its separate, wrapped component.

The paper's second distance (its equation 2), ``d2(a, b)``, is the largest distance
between matching joints of the two postures (root at the origin) after a parallel
projection onto a camera's image plane, metres; over several cameras, the largest.

World frame: metres, Y up, the body at rest facing +Z, its left towards +X.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.motion import Motion

#: Joints left out of the posture vector by default: fingers and thumbs hardly change
#: a silhouette, and their noisy capture would keep near-identical postures apart.
DEFAULT_EXCLUDED_JOINTS = (
    "LeftFingerBase",
    "LeftHandFinger1",
    "LThumb",
    "RightFingerBase",
    "RightHandFinger1",
    "RThumb",
)

#: Version of the ``.npz`` layout written by :meth:`PostureDictionary.save`.
DICTIONARY_FORMAT = 1


# -- rotations <-> posture vectors ------------------------------------------------------


def yaw_rotation(angle_deg: np.ndarray) -> np.ndarray:
    """Rotations about +Y; ``angle_deg`` (...,) → (..., 3, 3) float64."""
    a = np.deg2rad(np.asarray(angle_deg, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    out = np.zeros(a.shape + (3, 3))
    out[..., 0, 0] = c
    out[..., 0, 2] = s
    out[..., 1, 1] = 1.0
    out[..., 2, 0] = -s
    out[..., 2, 2] = c
    return out


def heading_deg(root_rotations: np.ndarray) -> np.ndarray:
    """Heading of the body, degrees in (-180, 180].

    Parameters
    ----------
    root_rotations : (..., 3, 3) float
        World rotations of the root relative to its rest orientation.

    Returns
    -------
    (...,) float64
        Angle about +Y from +Z towards +X of the rotated forward axis (+Z).
    """
    r = np.asarray(root_rotations, dtype=np.float64)
    return np.rad2deg(np.arctan2(r[..., 0, 2], r[..., 2, 2]))


def wrap_deg(angle_deg: np.ndarray) -> np.ndarray:
    """Angles wrapped into (-180, 180], degrees."""
    a = np.asarray(angle_deg, dtype=np.float64)
    return 180.0 - np.mod(180.0 - a, 360.0)


def posture_vectors(local_rotations: np.ndarray, joint_ids: Sequence[int]) -> np.ndarray:
    """Posture vectors ``r`` (see the module docstring) of stacked postures.

    Parameters
    ----------
    local_rotations : (N, J, 3, 3) float
        Joint rotations relative to the parent joint (the root's: to the world),
        relative to the rest pose; joint 0 is the root.
    joint_ids : sequence of int
        Non-root joints whose rotations enter the vector, in order.

    Returns
    -------
    (N, 4 + 3 * len(joint_ids)) float64, degrees.
    """
    rot = np.asarray(local_rotations, dtype=np.float64)
    if rot.ndim != 4 or rot.shape[2:] != (3, 3):
        raise InvalidParameterError(f"local_rotations must be (N, J, 3, 3), got {rot.shape}")
    n = rot.shape[0]
    joint_ids = np.asarray(joint_ids, dtype=np.int64)
    if np.any(joint_ids <= 0) or np.any(joint_ids >= rot.shape[1]):
        raise InvalidParameterError(f"joint_ids must lie in [1, {rot.shape[1]}), got {joint_ids}")
    yaw = heading_deg(rot[:, 0])
    tilt = np.einsum("nba,nbc->nac", yaw_rotation(yaw), rot[:, 0])  # Ry(-yaw) @ root
    out = np.empty((n, 4 + 3 * len(joint_ids)))
    out[:, 0] = yaw
    out[:, 1:4] = np.rad2deg(Rotation.from_matrix(tilt).as_rotvec())
    if len(joint_ids):
        rv = Rotation.from_matrix(rot[:, joint_ids].reshape(-1, 3, 3)).as_rotvec()
        out[:, 4:] = np.rad2deg(rv).reshape(n, -1)
    return out


def d1_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The paper's posture difference d1, degrees, broadcasting over leading axes.

    Parameters
    ----------
    a, b : (..., D) float
        Posture vectors (:func:`posture_vectors`); the heading ``[..., 0]`` is compared
        modulo 360°.

    Returns
    -------
    (...,) float64
        ``max_i |a_i - b_i|``, degrees.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    heading = np.abs(wrap_deg(a[..., 0] - b[..., 0]))
    rest = np.abs(a[..., 1:] - b[..., 1:]).max(axis=-1, initial=0.0)
    return np.maximum(heading, rest)


def d1_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(M, K) float64: d1 between every row of ``a`` (M, D) and of ``b`` (K, D), degrees."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return d1_distance(a[:, None, :], b[None, :, :])


def projected_joints(joint_positions: np.ndarray, view_rotations: np.ndarray) -> np.ndarray:
    """Parallel projection of root-relative joints onto each camera's image plane.

    Parameters
    ----------
    joint_positions : (N, J, 3) float
        Joint positions relative to the root, world axes, metres.
    view_rotations : (C, 3, 3) float
        World → camera rotations ``R`` of the cameras.

    Returns
    -------
    (N, C, J, 2) float64
        Camera x (right) and y (down) coordinates, metres.
    """
    p = np.asarray(joint_positions, dtype=np.float64)
    r = np.asarray(view_rotations, dtype=np.float64).reshape(-1, 3, 3)[:, :2]
    n, j = p.shape[0], p.shape[1]
    flat = p.reshape(-1, 3) @ r.reshape(-1, 3).T  # (N J, C 2)
    return flat.reshape(n, j, len(r), 2).transpose(0, 2, 1, 3)


def d2_distance(projected_a: np.ndarray, projected_b: np.ndarray) -> np.ndarray:
    """The paper's d2, metres: the largest projected joint distance over joints and cameras.

    Parameters
    ----------
    projected_a, projected_b : (..., C, J, 2) float
        From :func:`projected_joints`, broadcasting over leading axes.

    Returns
    -------
    (...,) float64
    """
    diff = np.asarray(projected_a) - np.asarray(projected_b)
    return np.sqrt(np.max(np.sum(diff * diff, axis=-1), axis=(-2, -1)))


def prune_postures(vectors: np.ndarray, threshold_deg: float) -> np.ndarray:
    """Indices of postures kept after dropping near-duplicates (d1 below a threshold).

    Greedy in the given order: a posture is kept unless a posture already kept is
    within ``threshold_deg`` of it (d1 < threshold).

    Parameters
    ----------
    vectors : (N, D) float
        Posture vectors, degrees.
    threshold_deg : float
        ≥ 0; 0 keeps every posture.

    Returns
    -------
    (K,) int64, increasing.
    """
    vectors = np.asarray(vectors, dtype=np.float64)
    if not (np.isfinite(threshold_deg) and threshold_deg >= 0):
        raise InvalidParameterError(f"threshold_deg must be >= 0, got {threshold_deg!r}")
    n = len(vectors)
    if threshold_deg == 0 or n == 0:
        return np.arange(n, dtype=np.int64)
    kept = np.empty((n, vectors.shape[1]))
    ids = []
    for i in range(n):
        if ids and d1_distance(kept[: len(ids)], vectors[i]).min() < threshold_deg:
            continue
        kept[len(ids)] = vectors[i]
        ids.append(i)
    return np.asarray(ids, dtype=np.int64)


def chain_rotations(local_rotations: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """World rotations (N, J, 3, 3) from local ones (N, J, 3, 3) along a joint tree."""
    local_rotations = np.asarray(local_rotations, dtype=np.float64)
    out = np.empty_like(local_rotations)
    for j, p in enumerate(parents):
        out[:, j] = local_rotations[:, j] if p < 0 else out[:, p] @ local_rotations[:, j]
    return out


def relative_joint_positions(
    world_rotations: np.ndarray, rest_joints: np.ndarray, parents: np.ndarray
) -> np.ndarray:
    """(N, J, 3) joint positions with the root at the origin, metres.

    Parameters
    ----------
    world_rotations : (N, J, 3, 3) float
        World rotation of each joint relative to its rest orientation.
    rest_joints : (J, 3) float
        Rest joint positions, metres (bone lengths come from these).
    parents : (J,) int
    """
    rest_joints = np.asarray(rest_joints, dtype=np.float64)
    out = np.zeros(world_rotations.shape[:2] + (3,))
    for j, p in enumerate(parents):
        if p >= 0:
            out[:, j] = out[:, p] + world_rotations[:, p] @ (rest_joints[j] - rest_joints[p])
    return out


# -- the dictionary ---------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PostureDictionary:
    """Postures of the canonical skeleton, with what the tracker needs of each.

    Entries come from base postures (pruned mocap frames), each possibly turned to
    several headings; entries of one base posture share its body mesh.

    Parameters
    ----------
    joint_names : tuple of str
        The skeleton's joints, parents first (the canonical joints).
    parents : (J,) int64
    rest_joints : (J, 3) float64
        Rest joint positions of the skeleton the postures were measured on, metres.
    local_rotations : (N, J, 3, 3) float64
        Per entry, each joint's rotation relative to its parent and to the rest pose
        (the root's relative to the world: it holds the heading).
    vector_joints : tuple of str
        Non-root joints entering the posture vectors.
    vectors : (N, 4 + 3 K) float64
        Posture vectors, degrees (module docstring).
    joint_positions : (N, J, 3) float64
        Joint positions with the root (body centre) at the origin, world axes, metres.
    body_height_m : (N,) float64
        Height ``H_b`` of the root above the floor, metres.
    base_index : (N,) int64
        The base posture of each entry.
    heading_offset_deg : (N,) float64
        The turn about +Y applied to the base posture, degrees.
    motion_names : tuple of str
        Source motions.
    source_motion, source_frame : (N,) int64
        Where each entry's base posture was taken from.
    frame_time_s : float
        Frame time of the sources (of the first one when they differ), seconds.
    """

    joint_names: tuple[str, ...]
    parents: np.ndarray
    rest_joints: np.ndarray
    local_rotations: np.ndarray
    vector_joints: tuple[str, ...]
    vectors: np.ndarray
    joint_positions: np.ndarray
    body_height_m: np.ndarray
    base_index: np.ndarray
    heading_offset_deg: np.ndarray
    motion_names: tuple[str, ...]
    source_motion: np.ndarray
    source_frame: np.ndarray
    frame_time_s: float

    def __post_init__(self):
        n = len(self.local_rotations)
        j = len(self.joint_names)
        shapes = {
            "parents": (j,),
            "rest_joints": (j, 3),
            "local_rotations": (n, j, 3, 3),
            "vectors": (n, 4 + 3 * len(self.vector_joints)),
            "joint_positions": (n, j, 3),
            "body_height_m": (n,),
            "base_index": (n,),
            "heading_offset_deg": (n,),
            "source_motion": (n,),
            "source_frame": (n,),
        }
        for key, shape in shapes.items():
            arr = np.asarray(getattr(self, key))
            if arr.shape != shape:
                raise InvalidParameterError(
                    f"posture dictionary: {key} has shape {arr.shape}, expected {shape}"
                )
            arr = arr.astype(np.int64 if key in _INT_FIELDS else np.float64, copy=False)
            arr.setflags(write=False)
            object.__setattr__(self, key, arr)
        if n == 0:
            raise InvalidParameterError("posture dictionary: no postures")

    def __len__(self) -> int:
        return len(self.vectors)

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def n_base(self) -> int:
        """Number of base postures (meshes to pose)."""
        return int(self.base_index.max()) + 1

    def world_rotations(self, indices: np.ndarray | None = None) -> np.ndarray:
        """(M, J, 3, 3) world rotations (relative to rest) of the chosen entries."""
        local = self.local_rotations if indices is None else self.local_rotations[indices]
        return chain_rotations(local, self.parents)

    def joints_at(self, indices: np.ndarray, root_positions_m: np.ndarray) -> np.ndarray:
        """(M, J, 3) world joint positions, metres, with each root at a given point.

        Parameters
        ----------
        indices : (M,) int
        root_positions_m : (M, 3) or (3,) float
        """
        indices = np.asarray(indices, dtype=np.int64)
        root = np.asarray(root_positions_m, dtype=np.float64).reshape(-1, 1, 3)
        return self.joint_positions[indices] + root

    def to_motion(
        self,
        indices: np.ndarray,
        root_positions_m: np.ndarray,
        frame_time_s: float,
        name: str = "tracked",
        scale: float = 1.0,
    ) -> Motion:
        """A motion on the canonical skeleton playing the chosen entries in turn.

        Parameters
        ----------
        indices : (F,) int
            Entries, one per output frame.
        root_positions_m : (F, 3) float
            Root (body centre) position per frame, world metres.
        frame_time_s : float
            Seconds per output frame.
        name : str
        scale : float
            Uniform scale of the skeleton (the tracker's ``body_scale_``).

        Returns
        -------
        Motion
            On the skeleton of :attr:`rest_joints` times ``scale`` (metres,
            ``length_unit_m = 1``), channels: root 6, others 3, Euler ZXY.
        """
        from eigmotion.mocap.motion import Skeleton, standard_channels

        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        root = np.asarray(root_positions_m, dtype=np.float64).reshape(len(indices), 3)
        offsets = self.rest_joints.copy()
        offsets[1:] -= self.rest_joints[self.parents[1:]]
        offsets *= float(scale)
        skeleton = Skeleton(
            self.joint_names, self.parents, offsets, standard_channels(self.n_joints)
        )
        return Motion.from_local_transforms(
            skeleton,
            self.local_rotations[indices],
            root,
            frame_time_s,
            length_unit_m=1.0,
            name=name,
        )

    def subset(self, indices: np.ndarray) -> PostureDictionary:
        """The dictionary restricted to some entries (base postures renumbered)."""
        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        _, base_index = np.unique(self.base_index[indices], return_inverse=True)
        return PostureDictionary(
            self.joint_names,
            self.parents,
            self.rest_joints,
            self.local_rotations[indices],
            self.vector_joints,
            self.vectors[indices],
            self.joint_positions[indices],
            self.body_height_m[indices],
            base_index.reshape(-1),
            self.heading_offset_deg[indices],
            self.motion_names,
            self.source_motion[indices],
            self.source_frame[indices],
            self.frame_time_s,
        )

    # -- persistence ---------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the dictionary as a plain ``.npz`` (numbers and strings only)."""
        path = Path(path)
        arrays = {key: np.asarray(getattr(self, key)) for key in _ARRAY_FIELDS}
        np.savez_compressed(
            path,
            format_version=np.int64(DICTIONARY_FORMAT),
            joint_names=np.array(self.joint_names),
            vector_joints=np.array(self.vector_joints, dtype=str),
            motion_names=np.array(self.motion_names, dtype=str),
            frame_time_s=np.float64(self.frame_time_s),
            **arrays,
        )
        return path

    @classmethod
    def load(cls, path: str | Path) -> PostureDictionary:
        """Read a dictionary written by :meth:`save`."""
        path = Path(path)
        try:
            data = np.load(path, allow_pickle=False)
        except FileNotFoundError:
            raise InvalidParameterError(f"{path}: dictionary file not found") from None
        except (OSError, ValueError) as exc:
            raise InvalidParameterError(f"{path}: not a posture dictionary: {exc}") from None
        with data:
            missing = [k for k in (*_ARRAY_FIELDS, "format_version") if k not in data.files]
            if missing:
                raise InvalidParameterError(f"{path}: not a posture dictionary (lacks {missing})")
            if int(data["format_version"]) != DICTIONARY_FORMAT:
                raise InvalidParameterError(
                    f"{path}: dictionary format {int(data['format_version'])}, expected "
                    f"{DICTIONARY_FORMAT}; rebuild it"
                )
            return cls(
                joint_names=tuple(str(s) for s in data["joint_names"]),
                vector_joints=tuple(str(s) for s in data["vector_joints"]),
                motion_names=tuple(str(s) for s in data["motion_names"]),
                frame_time_s=float(data["frame_time_s"]),
                **{key: data[key] for key in _ARRAY_FIELDS},
            )


_INT_FIELDS = ("parents", "base_index", "source_motion", "source_frame")
_ARRAY_FIELDS = (
    "parents",
    "rest_joints",
    "local_rotations",
    "vectors",
    "joint_positions",
    "body_height_m",
    "base_index",
    "heading_offset_deg",
    "source_motion",
    "source_frame",
)


@dataclass(frozen=True, eq=False)
class PostureSequence:
    """Postures of one motion on an avatar's skeleton, frame by frame.

    Parameters
    ----------
    joint_names : tuple of str
    parents : (J,) int64
    rest_joints : (J, 3) float64
        The avatar's rest joint positions, metres.
    world_rotations : (F, J, 3, 3) float64
        Each joint's world rotation relative to its rest orientation.
    root_positions : (F, 3) float64
        Root position per frame, world metres (feet on the floor).
    frame_time_s : float
    name : str
    """

    joint_names: tuple[str, ...]
    parents: np.ndarray
    rest_joints: np.ndarray
    world_rotations: np.ndarray
    root_positions: np.ndarray
    frame_time_s: float
    name: str = ""

    @property
    def n_frames(self) -> int:
        return len(self.world_rotations)

    def local_rotations(self) -> np.ndarray:
        """(F, J, 3, 3): rotations relative to the parent (root: to the world)."""
        world = self.world_rotations
        out = world.copy()
        for j, p in enumerate(self.parents):
            if p >= 0:
                out[:, j] = np.swapaxes(world[:, p], -1, -2) @ world[:, j]
        return out


def posture_sequence(motion: Motion, avatar=None, mapping: dict | None = None) -> PostureSequence:
    """A motion mapped onto the avatar's (canonical) skeleton.

    Parameters
    ----------
    motion : Motion
        Any skeleton :func:`eigmotion.mocap.naming.canonical_joint_map` can map.
    avatar : eigmotion.body.avatar.Avatar, optional
        Default: :func:`eigmotion.body.avatar.load_default_avatar`.
    mapping : dict, optional
        Extra source → canonical joint names (see :mod:`eigmotion.mocap.naming`).

    Returns
    -------
    PostureSequence
    """
    from eigmotion.body.retarget import retarget

    if avatar is None:
        from eigmotion.body.avatar import load_default_avatar

        avatar = load_default_avatar()
    anim = retarget(motion, avatar, mapping)
    return PostureSequence(
        tuple(avatar.joint_names),
        np.asarray(avatar.parents),
        np.asarray(avatar.joint_positions, dtype=np.float64),
        np.asarray(anim.joint_rotations, dtype=np.float64),
        np.asarray(anim.joint_positions, dtype=np.float64)[:, 0],
        float(anim.frame_time_s),
        motion.name,
    )


def mean_heading_deg(root_rotations: np.ndarray) -> float:
    """Circular mean of the heading over frames, degrees."""
    h = np.deg2rad(heading_deg(root_rotations))
    return float(np.rad2deg(np.arctan2(np.sin(h).mean(), np.cos(h).mean())))


def _check_vector_joints(joint_names: Sequence[str], exclude: Sequence[str]) -> tuple[int, ...]:
    unknown = sorted(set(exclude) - set(joint_names))
    if unknown:
        raise InvalidParameterError(f"exclude_joints names unknown joints {unknown}")
    return tuple(j for j, n in enumerate(joint_names) if j > 0 and n not in set(exclude))


def dictionary_from_sequences(
    sequences: Sequence[PostureSequence],
    threshold_deg: float = 5.0,
    headings_deg: Sequence[float] = (0.0,),
    face_forward: bool = False,
    exclude_joints: Sequence[str] = DEFAULT_EXCLUDED_JOINTS,
) -> PostureDictionary:
    """Build a posture dictionary from postures already on the avatar's skeleton.

    Parameters
    ----------
    sequences : sequence of PostureSequence
        All on one skeleton.
    threshold_deg : float
        Near-duplicate threshold of d1, degrees (0 keeps every frame, in order).
    headings_deg : sequence of float
        Turns about +Y applied to every base posture (each gives one entry), degrees;
        ``(0,)`` keeps the recorded headings.  A set of turns makes the dictionary
        cover people walking in other directions than the recorded ones.
    face_forward : bool
        First turn each sequence so that its mean heading is +Z.
    exclude_joints : sequence of str
        Joints left out of the posture vectors (still posed).

    Returns
    -------
    PostureDictionary
    """
    if not sequences:
        raise InvalidParameterError("no motions to build a posture dictionary from")
    first = sequences[0]
    for seq in sequences[1:]:
        if tuple(seq.joint_names) != tuple(first.joint_names) or not np.allclose(
            seq.rest_joints, first.rest_joints
        ):
            raise InvalidParameterError(
                f"motion {seq.name!r} is on another skeleton than {first.name!r}; map all "
                "motions onto one avatar"
            )
    headings = np.asarray(list(headings_deg), dtype=np.float64).reshape(-1)
    if headings.size == 0 or not np.all(np.isfinite(headings)):
        raise InvalidParameterError(f"headings_deg must be finite angles, got {headings_deg!r}")
    joint_ids = _check_vector_joints(first.joint_names, exclude_joints)
    parents = np.asarray(first.parents)
    locals_, positions, heights, src_m, src_f = [], [], [], [], []
    for m, seq in enumerate(sequences):
        world = np.asarray(seq.world_rotations, dtype=np.float64)
        root = np.asarray(seq.root_positions, dtype=np.float64)
        if face_forward:
            turn = yaw_rotation(-mean_heading_deg(world[:, 0]))
            world = turn @ world
        local = PostureSequence(
            seq.joint_names, parents, seq.rest_joints, world, root, seq.frame_time_s
        ).local_rotations()
        locals_.append(local)
        positions.append(relative_joint_positions(world, first.rest_joints, parents))
        heights.append(root[:, 1])
        src_m.append(np.full(len(world), m))
        src_f.append(np.arange(len(world)))
    local = np.concatenate(locals_)
    rel = np.concatenate(positions)
    height = np.concatenate(heights)
    src_m = np.concatenate(src_m)
    src_f = np.concatenate(src_f)
    keep = prune_postures(posture_vectors(local, joint_ids), threshold_deg)
    local, rel, height, src_m, src_f = (
        local[keep],
        rel[keep],
        height[keep],
        src_m[keep],
        src_f[keep],
    )
    n_base = len(keep)
    turns = yaw_rotation(headings)  # (H, 3, 3)
    # Entries ordered heading-major within each base posture: base b, heading h.
    entry_local = np.repeat(local[:, None], len(headings), axis=1)  # (B, H, J, 3, 3)
    entry_local[:, :, 0] = np.einsum("hab,nbc->nhac", turns, local[:, 0])
    entry_pos = np.einsum("hab,njb->nhja", turns, rel)
    entry_local = entry_local.reshape(-1, *local.shape[1:])
    entry_pos = entry_pos.reshape(-1, *rel.shape[1:])
    return PostureDictionary(
        joint_names=tuple(first.joint_names),
        parents=parents,
        rest_joints=np.asarray(first.rest_joints, dtype=np.float64),
        local_rotations=entry_local,
        vector_joints=tuple(first.joint_names[j] for j in joint_ids),
        vectors=posture_vectors(entry_local, joint_ids),
        joint_positions=entry_pos,
        body_height_m=np.repeat(height, len(headings)),
        base_index=np.repeat(np.arange(n_base), len(headings)),
        heading_offset_deg=np.tile(headings, n_base),
        motion_names=tuple(s.name for s in sequences),
        source_motion=np.repeat(src_m, len(headings)),
        source_frame=np.repeat(src_f, len(headings)),
        frame_time_s=float(first.frame_time_s),
    )


def build_dictionary(
    motions: Sequence[Motion],
    avatar=None,
    mapping: dict | None = None,
    threshold_deg: float = 5.0,
    headings_deg: Sequence[float] = (0.0,),
    face_forward: bool = False,
    exclude_joints: Sequence[str] = DEFAULT_EXCLUDED_JOINTS,
) -> PostureDictionary:
    """Build a posture dictionary from mocap.

    Each motion is mapped onto the avatar's canonical skeleton
    (:func:`eigmotion.body.retarget.retarget`, which maps joint names with
    :func:`eigmotion.mocap.naming.canonical_joint_map`), its frames become postures, and
    near-duplicates (d1 below ``threshold_deg``) are pruned.

    Parameters
    ----------
    motions : sequence of Motion
    avatar : eigmotion.body.avatar.Avatar, optional
        Whose skeleton the postures live on; default the default avatar.
    mapping : dict, optional
        Extra joint-name mapping for the motions' skeletons.
    threshold_deg, headings_deg, face_forward, exclude_joints :
        See :func:`dictionary_from_sequences`.

    Returns
    -------
    PostureDictionary
    """
    if not motions:
        raise InvalidParameterError("no motions to build a posture dictionary from")
    sequences = [posture_sequence(m, avatar, mapping) for m in motions]
    return dictionary_from_sequences(
        sequences, threshold_deg, headings_deg, face_forward, exclude_joints
    )


def dictionary_from_motion(motion: Motion, avatar=None, mapping: dict | None = None):
    """Every frame of one motion, in order, as a dictionary (no pruning, no turns).

    For aligning a known motion to a clip frame by frame: entry ``i`` is frame ``i``.
    """
    return build_dictionary([motion], avatar, mapping, threshold_deg=0.0)


def _angle_closeness(
    vectors_a: np.ndarray, vectors_b: np.ndarray, max_d1_deg: float, max_heading_deg: float | None
) -> np.ndarray:
    """``d1 / T_d1``, or with the heading apart ``max(d1' / T_d1, |Δheading| / T_h)``
    where d1' leaves the heading out."""
    if max_heading_deg is None:
        return d1_distance(vectors_a, vectors_b) / max_d1_deg
    body = np.abs(vectors_a[..., 1:] - vectors_b[..., 1:]).max(axis=-1, initial=0.0)
    heading = np.abs(wrap_deg(vectors_a[..., 0] - vectors_b[..., 0]))
    return np.maximum(body / max_d1_deg, heading / max_heading_deg)


def select_candidates(
    dictionary: PostureDictionary,
    previous: int,
    view_rotations: np.ndarray,
    max_d1_deg: float,
    max_d2_m: float,
    max_candidates: int,
    max_heading_deg: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's candidate set M around the previous posture, nearest first.

    ``M = {m : d1(p, m) < max_d1_deg and d2(p, m) < max_d2_m}``, sorted by the
    closeness ``max(d1 / max_d1_deg, d2 / max_d2_m)`` (the previous posture itself
    first), cut after ``max_candidates`` (the paper's ``T_n``).

    Parameters
    ----------
    dictionary : PostureDictionary
    previous : int
        Entry of the previous posture ``p``.
    view_rotations : (C, 3, 3) float
        World → camera rotations of the cameras in use (for d2).
    max_d1_deg, max_d2_m : float
        ``T_d1`` (degrees) and ``T_d2`` (metres).
    max_candidates : int
        ``T_n``.
    max_heading_deg : float, optional
        Give the heading its own threshold ``T_h``, degrees: d1 is then taken over the
        other components, and the closeness is ``max(d1 / T_d1, |Δheading| / T_h,
        d2 / T_d2)``.  A larger ``T_h`` than ``T_d1`` lets turned copies of nearby
        postures into the candidates, so that turns are followed.

    Returns
    -------
    indices : (M,) int64
        Dictionary entries, nearest first.
    closeness : (M,) float64
        Their closeness to ``p`` (< 1).
    """
    vectors = dictionary.vectors
    ref = vectors[previous]
    heading_limit = max_d1_deg if max_heading_deg is None else max_heading_deg
    # The heading difference alone already bounds the closeness: a cheap first cut.
    near = np.flatnonzero(np.abs(wrap_deg(vectors[:, 0] - ref[0])) < heading_limit)
    closeness = _angle_closeness(vectors[near], ref, max_d1_deg, max_heading_deg)
    ok = closeness < 1.0
    near, closeness = near[ok], closeness[ok]
    proj = projected_joints(dictionary.joint_positions[near], view_rotations)
    ref_proj = projected_joints(dictionary.joint_positions[previous][None], view_rotations)
    closeness = np.maximum(closeness, d2_distance(proj, ref_proj) / max_d2_m)
    ok = closeness < 1.0
    near, closeness = near[ok], closeness[ok]
    order = np.lexsort((near, closeness))[:max_candidates]
    return near[order], closeness[order]


def closeness_matrix(
    dictionary: PostureDictionary,
    a: np.ndarray,
    b: np.ndarray,
    view_rotations: np.ndarray,
    max_d1_deg: float,
    max_d2_m: float,
    max_heading_deg: float | None = None,
) -> np.ndarray:
    """(M, K) float64: the closeness of :func:`select_candidates` between entries a and b."""
    va = dictionary.vectors[a][:, None, :]
    vb = dictionary.vectors[b][None, :, :]
    pa = projected_joints(dictionary.joint_positions[a], view_rotations)
    pb = projected_joints(dictionary.joint_positions[b], view_rotations)
    d2 = d2_distance(pa[:, None], pb[None, :])
    return np.maximum(_angle_closeness(va, vb, max_d1_deg, max_heading_deg), d2 / max_d2_m)
