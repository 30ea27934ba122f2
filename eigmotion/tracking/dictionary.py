"""The posture dictionary (the paper's section 2.2) and the choice of candidates in it.

The postures' vectors and the distances d1, d2 between them are in
:mod:`eigmotion.tracking.postures`.  A dictionary is built from mocap mapped onto the
avatar's (canonical) skeleton (:func:`build_dictionary`, :func:`posture_sequence`) or
from postures already on it (:func:`dictionary_from_sequences`); the tracker's
candidate set around the previous posture is :func:`select_candidates`.

World frame: metres, Y up, the body at rest facing +Z, its left towards +X.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import retarget
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.motion import Motion, Skeleton, standard_channels
from eigmotion.tracking.postures import (
    chain_rotations,
    d1_distance,
    d2_distance,
    mean_heading_deg,
    posture_vectors,
    projected_joints,
    prune_postures,
    relative_joint_positions,
    wrap_deg,
    yaw_rotation,
)

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
        local_rotations: np.ndarray | None = None,
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
        local_rotations : (F, J, 3, 3) float, optional
            The frames' rotations, as :attr:`local_rotations` (e.g. the keypoints
            stage's fitted postures); default: the entries'.

        Returns
        -------
        Motion
            On the skeleton of :attr:`rest_joints` times ``scale`` (metres,
            ``length_unit_m = 1``), channels: root 6, others 3, Euler ZXY.
        """
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
            self.local_rotations[indices] if local_rotations is None else local_rotations,
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
    if avatar is None:
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
