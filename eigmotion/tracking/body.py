"""The body shape model posed in every dictionary posture (the paper's section 2.4.2).

Candidate silhouettes are the body model posed in a candidate posture with its body
centre (root joint) at the person's position ``G``, projected into each camera.  The
meshes of all dictionary postures are computed once, root at the origin, so that a
candidate only costs a rotation about +Y (for entries that are turned copies of one
base posture), a translation and the rasterisation.

Two body models: the skinned avatar (:func:`avatar_bodies`, by default the default
avatar decimated to about 2,000 vertices like the paper's scanned model) and the
capsule proxy body for skeletons without a skinned mesh (:func:`proxy_bodies`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.proxy_body import proxy_body
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.canonical import CANONICAL_JOINTS, canonical_skeleton
from eigmotion.mocap.kinematics import Pose
from eigmotion.tracking.dictionary import PostureDictionary
from eigmotion.tracking.postures import relative_joint_positions, yaw_rotation

#: Triangle count of the default low-poly body (about 2,000 vertices).
DEFAULT_BODY_FACES = 4000


@dataclass(frozen=True, eq=False)
class PostureBodies:
    """Body meshes of every dictionary posture, root at the origin.

    Parameters
    ----------
    faces : (T, 3) int32
        Triangles shared by all postures.
    base_vertices : (B, V, 3) float32
        Vertices per base posture of the dictionary, root at the origin, world axes,
        metres.
    base_index : (N,) int64
        Base posture of each dictionary entry.
    heading_offset_deg : (N,) float64
        Turn about +Y of each entry relative to its base posture, degrees.
    base_joints : (B, J, 3) float64
        Joint positions of each base posture on this body, root at the origin, metres.
    """

    faces: np.ndarray
    base_vertices: np.ndarray
    base_index: np.ndarray
    heading_offset_deg: np.ndarray
    base_joints: np.ndarray

    def __post_init__(self):
        base = np.ascontiguousarray(self.base_vertices, dtype=np.float32)
        if base.ndim != 3 or base.shape[2] != 3:
            raise InvalidParameterError(f"base_vertices must be (B, V, 3), got {base.shape}")
        idx = np.asarray(self.base_index, dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= len(base)):
            raise InvalidParameterError(
                f"base_index must lie in [0, {len(base)}), got [{idx.min()}, {idx.max()}]"
            )
        joints = np.asarray(self.base_joints, dtype=np.float64)
        if joints.ndim != 3 or joints.shape[0] != len(base) or joints.shape[2] != 3:
            raise InvalidParameterError(
                f"base_joints must be ({len(base)}, J, 3), got {joints.shape}"
            )
        object.__setattr__(self, "base_vertices", base)
        object.__setattr__(self, "base_joints", joints)
        object.__setattr__(self, "base_index", idx)
        object.__setattr__(self, "faces", np.asarray(self.faces, dtype=np.int32))
        object.__setattr__(
            self, "heading_offset_deg", np.asarray(self.heading_offset_deg, dtype=np.float64)
        )
        # Corners of each base mesh's box, used to bound a candidate's silhouette.
        lo, hi = base.min(axis=1), base.max(axis=1)
        corners = np.stack(
            [np.where(np.array(bits)[None, :], hi, lo) for bits in np.ndindex(2, 2, 2)], axis=1
        )
        object.__setattr__(self, "_base_corners", corners.astype(np.float64))
        object.__setattr__(self, "_turns", yaw_rotation(self.heading_offset_deg))

    def __len__(self) -> int:
        return len(self.base_index)

    @property
    def n_vertices(self) -> int:
        return self.base_vertices.shape[1]

    def vertices(
        self, indices: np.ndarray, root_position_m: np.ndarray, scale: float = 1.0
    ) -> np.ndarray:
        """(M, V, 3) float32 meshes of entries with the root at a world point, metres.

        Parameters
        ----------
        indices : (M,) int
            Dictionary entries.
        root_position_m : (3,) float
            Where the body centre goes, world metres.
        scale : float
            Uniform scale of the body about its root (a taller or shorter person).
        """
        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        base = self.base_vertices[self.base_index[indices]]
        turns = self._turns[indices].astype(np.float32) * np.float32(scale)
        out = np.matmul(base, np.swapaxes(turns, 1, 2))
        out += np.asarray(root_position_m, dtype=np.float32).reshape(1, 1, 3)
        return out

    def joints(
        self, indices: np.ndarray, root_positions_m: np.ndarray, scale: np.ndarray | float = 1.0
    ) -> np.ndarray:
        """(M, J, 3) float64 joint positions of entries with their roots at given points.

        Parameters
        ----------
        indices : (M,) int
        root_positions_m : (M, 3) or (3,) float
            World metres.
        scale : float or (M,) float
            Uniform scale of the body about its root.
        """
        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        base = self.base_joints[self.base_index[indices]]
        turned = np.einsum("mab,mjb->mja", self._turns[indices], base)
        turned *= np.broadcast_to(np.asarray(scale, dtype=np.float64), (len(indices),))[
            :, None, None
        ]
        return turned + np.asarray(root_positions_m, dtype=np.float64).reshape(-1, 1, 3)

    def box_corners(
        self, indices: np.ndarray, root_position_m: np.ndarray, scale: float = 1.0
    ) -> np.ndarray:
        """(M, 8, 3) float64 corners of boxes enclosing each entry's mesh, metres."""
        indices = np.asarray(indices, dtype=np.int64).reshape(-1)
        corners = self._base_corners[self.base_index[indices]]
        turned = np.einsum("mab,mkb->mka", self._turns[indices], corners) * scale
        return turned + np.asarray(root_position_m, dtype=np.float64).reshape(1, 1, 3)


def _base_entries(dictionary: PostureDictionary) -> np.ndarray:
    """(B,) int64: one entry per base posture (the first with that base)."""
    _, first = np.unique(dictionary.base_index, return_index=True)
    return first


def _base_world_rotations(dictionary: PostureDictionary) -> tuple[np.ndarray, np.ndarray]:
    """World rotations (B, J, 3, 3) of the base postures, with their turn undone."""
    entries = _base_entries(dictionary)
    world = dictionary.world_rotations(entries)
    undo = yaw_rotation(-dictionary.heading_offset_deg[entries])
    world = np.einsum("bxy,bjyz->bjxz", undo, world)
    return entries, world


def avatar_bodies(
    dictionary: PostureDictionary, avatar=None, n_faces: int | None = DEFAULT_BODY_FACES
) -> PostureBodies:
    """Skin an avatar in every base posture of a dictionary.

    Parameters
    ----------
    dictionary : PostureDictionary
    avatar : eigmotion.body.avatar.Avatar, optional
        The body model; default the default avatar.  Its joints must be the
        dictionary's; its bone lengths may differ (e.g. a person's measured height via
        ``Avatar.with_shape``): joints are placed with the avatar's own bone lengths.
    n_faces : int or None
        Decimate the avatar to about this many triangles first; ``None`` keeps it.

    Returns
    -------
    PostureBodies
    """
    if avatar is None:
        avatar = load_default_avatar()
    if tuple(avatar.joint_names) != tuple(dictionary.joint_names):
        raise InvalidParameterError(
            f"avatar {avatar.name!r} has other joints than the dictionary's skeleton"
        )
    if n_faces is not None and n_faces < avatar.n_faces:
        avatar = avatar.decimated(int(n_faces))
    _, world = _base_world_rotations(dictionary)
    joints = relative_joint_positions(world, avatar.joint_positions, dictionary.parents)
    vertices = avatar.skin(world, joints)
    return PostureBodies(
        avatar.faces, vertices, dictionary.base_index, dictionary.heading_offset_deg, joints
    )


def proxy_bodies(dictionary: PostureDictionary, end_sites=None, **kwargs) -> PostureBodies:
    """Capsule proxy bodies (:mod:`eigmotion.body.proxy_body`) in every base posture.

    For skeletons without a skinned mesh.

    Parameters
    ----------
    dictionary : PostureDictionary
    end_sites : dict of int to (3,) float, optional
        Rest offsets of End Sites from their joints, metres (capsules for hands, feet
        and head); default those of :func:`eigmotion.mocap.canonical.canonical_skeleton` when
        the dictionary's joints are the canonical ones, else none.
    **kwargs
        Passed to :func:`eigmotion.body.proxy_body.proxy_body` (radii, tessellation).
    """
    if end_sites is None:
        same = tuple(dictionary.joint_names) == CANONICAL_JOINTS
        end_sites = canonical_skeleton().end_sites if same else {}
    entries, world = _base_world_rotations(dictionary)
    joints = relative_joint_positions(world, dictionary.rest_joints, dictionary.parents)
    end_joints = np.array(sorted(end_sites), dtype=np.int64)
    if len(end_joints):
        offsets = np.stack([np.asarray(end_sites[j], dtype=np.float64) for j in end_joints])
        ends = joints[:, end_joints] + np.einsum("nexy,ey->nex", world[:, end_joints], offsets)
    else:
        ends = np.zeros((len(entries), 0, 3))
    pose = Pose(
        dictionary.joint_names,
        dictionary.parents,
        joints,
        world,
        end_joints,
        ends,
        dictionary.frame_time_s,
    )
    body = proxy_body(pose, **kwargs)
    return PostureBodies(
        body.faces, body.vertices, dictionary.base_index, dictionary.heading_offset_deg, joints
    )
