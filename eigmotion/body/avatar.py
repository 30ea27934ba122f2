"""The avatar: a skinned body mesh on the canonical skeleton.

The default avatar is the CC0 MakeHuman base mesh (group ``body`` of ``base.obj``,
quads split into triangles) rigged with the ``cmu_mb`` skeleton and its linear-blend
skin weights.  It standardises body shape: every motion drives the same body before
it is filmed by the virtual cameras.  :meth:`Avatar.with_shape` varies height and girth
to stand in for different people, :meth:`Avatar.decimated` gives a low-poly copy for
fast silhouettes.

World frame: metres, Y up, the soles on the floor y = 0, the body facing +Z with its
left side towards +X (see :mod:`eigmotion.imaging.cameras`).  Rest pose: MakeHuman's A-pose
(arms about 45° down, elbows slightly bent).

Skinning is linear blend skinning: a rest vertex ``v`` goes to
``v' = sum_j w_vj (A_j (v - r_j) + p_j)`` where ``r_j`` is joint ``j``'s rest
position, ``A_j`` its world rotation relative to the rest pose and ``p_j`` its posed
position.  The per-joint 3×4 transforms of a batch of frames are blended and applied
by one sparse matrix product (see :meth:`Avatar.skin`).

Retargeting a motion onto an avatar and skinning it is
:mod:`eigmotion.body.retarget` (:func:`~eigmotion.body.retarget.animate_avatar`,
:func:`~eigmotion.body.retarget.pose_avatar`); garments are put on by
:func:`eigmotion.body.garments.dress`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from eigmotion.body.makehuman_files import (
    OBJ_UNIT_M,
    group_mesh,
    read_obj,
    read_weights,
    rig_joint_positions,
)
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.canonical import CANONICAL_JOINTS, CANONICAL_PARENTS, makehuman_dir
from eigmotion.mocap.motion import Skeleton, standard_channels

#: The OBJ group that is the body (the others are helper geometry and joint cubes).
BODY_GROUP = "body"

#: How strongly ``girth`` acts on the flesh around each bone (1 = fully).  Head,
#: hands and feet change little with body girth; a full gain there would also push
#: the soles through the floor and swell the skull.
GIRTH_GAIN = {
    "Head": 0.15,
    "Neck": 0.6,
    "Neck1": 0.5,
    "LeftFoot": 0.2,
    "RightFoot": 0.2,
    "LeftToeBase": 0.1,
    "RightToeBase": 0.1,
    "LeftHand": 0.3,
    "RightHand": 0.3,
    "LeftFingerBase": 0.2,
    "RightFingerBase": 0.2,
    "LeftHandFinger1": 0.1,
    "RightHandFinger1": 0.1,
    "LThumb": 0.2,
    "RThumb": 0.2,
}

#: Neighbour-averaging passes over the girth displacement field.
GIRTH_SMOOTHING_ITERATIONS = 20

#: Frames skinned per sparse product.  Small batches keep the (V, 3 * chunk) result
#: in cache while it is rearranged into (chunk, V, 3), the costlier half of the work.
SKIN_CHUNK_FRAMES = 16

#: Default face count of :meth:`Avatar.decimated` (about 2,000 vertices, the size of
#: the body model of the silhouette tracker).
DEFAULT_LOW_POLY_FACES = 4000


def check_body_shape(height_m: float | None, girth: float) -> None:
    """Raise :class:`InvalidParameterError` unless ``height_m`` (metres, or ``None`` for
    the avatar's own) lies in [0.5, 2.5] and ``girth`` in [0.7, 1.8] (see
    :meth:`Avatar.with_shape`)."""
    if not (np.isfinite(girth) and 0.7 <= girth <= 1.8):
        raise InvalidParameterError(f"girth must lie in [0.7, 1.8], got {girth!r}")
    if height_m is not None and not (np.isfinite(height_m) and 0.5 <= height_m <= 2.5):
        raise InvalidParameterError(f"height_m must lie in [0.5, 2.5] metres, got {height_m!r}")


@dataclass(frozen=True, eq=False)
class Avatar:
    """A body mesh skinned to a skeleton (by default the canonical one).

    Arrays are stored read-only: avatars are shared (the default one is cached).

    Parameters
    ----------
    vertices : (V, 3) float32
        Rest-pose vertices, metres, Y up, feet on y = 0, facing +Z.
    faces : (T, 3) int32
        Triangles, counter-clockwise seen from outside.
    joint_names : tuple of str
        Joint names, parents first (the canonical joints for the MakeHuman avatar).
    parents : (J,) int64
        Parent index per joint, -1 for the root.
    joint_positions : (J, 3) float64
        Rest positions of the joints (bone heads), metres.
    bone_tails : (J, 3) float64
        Rest positions of the bones' tails, metres; a leaf joint's tail is its End
        Site.  Used for girth variation and as end sites of :meth:`skeleton`.
    weights : (V, J) float32
        Skin weights, non-negative, each row summing to 1.
    name : str
    """

    vertices: np.ndarray
    faces: np.ndarray
    joint_names: tuple[str, ...]
    parents: np.ndarray
    joint_positions: np.ndarray
    bone_tails: np.ndarray
    weights: np.ndarray
    name: str = "avatar"

    def __post_init__(self):
        arrays = {
            "vertices": np.asarray(self.vertices, dtype=np.float32),
            "faces": np.asarray(self.faces, dtype=np.int32),
            "parents": np.asarray(self.parents, dtype=np.int64),
            "joint_positions": np.asarray(self.joint_positions, dtype=np.float64),
            "bone_tails": np.asarray(self.bone_tails, dtype=np.float64),
            "weights": np.asarray(self.weights, dtype=np.float32),
        }
        object.__setattr__(self, "joint_names", tuple(self.joint_names))
        n_v, n_j = len(arrays["vertices"]), len(self.joint_names)
        expected = {
            "vertices": (n_v, 3),
            "faces": (len(arrays["faces"]), 3),
            "parents": (n_j,),
            "joint_positions": (n_j, 3),
            "bone_tails": (n_j, 3),
            "weights": (n_v, n_j),
        }
        for key, arr in arrays.items():
            if arr.shape != expected[key] or arr.ndim != len(expected[key]):
                raise InvalidParameterError(
                    f"avatar {self.name!r}: {key} has shape {arr.shape}, expected "
                    f"{expected[key]} (V = {n_v} vertices, J = {n_j} joints)"
                )
        if n_v == 0 or len(arrays["faces"]) == 0:
            raise InvalidParameterError(f"avatar {self.name!r}: the mesh is empty")
        faces = arrays["faces"]
        if faces.min() < 0 or faces.max() >= n_v:
            raise InvalidParameterError(
                f"avatar {self.name!r}: face indices must lie in [0, {n_v}), got "
                f"[{faces.min()}, {faces.max()}]"
            )
        parents = arrays["parents"]
        if parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, n_j)):
            raise InvalidParameterError(
                f"avatar {self.name!r}: joints must be ordered parents-first with one root at 0"
            )
        w = arrays["weights"]
        row_sums = w.sum(axis=1)
        if np.any(w < 0) or not np.allclose(row_sums, 1.0, atol=1e-4):
            bad = int(np.argmax(np.abs(row_sums - 1.0) + (w < 0).any(axis=1)))
            raise InvalidParameterError(
                f"avatar {self.name!r}: skin weights must be >= 0 and sum to 1 per vertex; "
                f"vertex {bad} sums to {row_sums[bad]:.6f}"
            )
        for key, arr in arrays.items():
            if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
                raise InvalidParameterError(f"avatar {self.name!r}: {key} must be finite")
            if arr.flags.writeable:  # maybe the caller's array: freeze a copy, not it
                arr = arr.copy()
                arr.setflags(write=False)
            object.__setattr__(self, key, arr)

    # -- basic facts ---------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        return self.vertices.shape[0]

    @property
    def n_faces(self) -> int:
        return self.faces.shape[0]

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def height_m(self) -> float:
        """Rest-pose height: top of the head above the floor, metres."""
        return float(self.vertices[:, 1].max() - self.vertices[:, 1].min())

    @property
    def hip_height_m(self) -> float:
        """Rest height of the root joint above the lowest skeleton point, metres.

        Measured on the skeleton (joints and bone tails), as a motion's hip height is,
        so that the two can be compared when retargeting.
        """
        pts = np.concatenate([self.joint_positions, self.bone_tails])
        return float(self.joint_positions[0, 1] - pts[:, 1].min())

    def joint_index(self, name: str) -> int:
        """Index of joint ``name``; raises ``InvalidParameterError`` naming it."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise InvalidParameterError(f"avatar {self.name!r} has no joint {name!r}") from None

    def skeleton(self, order: str = "ZXY") -> Skeleton:
        """The avatar's rest skeleton (metres, joint frames world-aligned at rest).

        The root offset is the root's rest position, so forward kinematics without
        grounding puts the joints exactly on :attr:`joint_positions`; leaf joints carry
        an End Site at their bone tail.  Channels: root 6, others 3, Euler ``order``.
        """
        offsets = self.joint_positions.copy()
        offsets[1:] -= self.joint_positions[self.parents[1:]]
        leaves = np.setdiff1d(np.arange(self.n_joints), self.parents[1:])
        ends = {int(j): self.bone_tails[j] - self.joint_positions[j] for j in leaves}
        return Skeleton(
            self.joint_names,
            self.parents,
            offsets,
            standard_channels(self.n_joints, order),
            ends,
        )

    # -- skinning ------------------------------------------------------------------
    @cached_property
    def _blend_matrix(self):
        """(V, 4J) float32 CSR matrix: ``P[v, 4j + k] = w_vj * (v_x, v_y, v_z, 1)[k]``.

        With the per-joint 3×4 transforms of F frames stacked as a (4J, 3F) matrix,
        ``P @ M`` is the skinned mesh of every frame: one sparse product does both the
        blending of the transforms and their application (a vertex has ~2 influences,
        so P is ~95 % zeros).
        """
        # Lazy: a query imports this module (through retrieval.build) and never skins.
        from scipy import sparse

        rows, cols = np.nonzero(self.weights)
        w = self.weights[rows, cols]
        homog = np.concatenate([self.vertices, np.ones((self.n_vertices, 1), np.float32)], 1)
        data = (w[:, None] * homog[rows]).reshape(-1)
        out_rows = np.repeat(rows, 4)
        out_cols = (4 * cols[:, None] + np.arange(4)).reshape(-1)
        return sparse.csr_matrix(
            (data.astype(np.float32), (out_rows, out_cols)),
            shape=(self.n_vertices, 4 * self.n_joints),
        )

    def skin(
        self,
        joint_rotations: np.ndarray,
        joint_positions: np.ndarray,
        vertex_ids: np.ndarray | None = None,
    ) -> np.ndarray:
        """Linear blend skinning of a batch of frames.

        Parameters
        ----------
        joint_rotations : (F, J, 3, 3) float
            World rotation of each joint relative to its rest orientation.
        joint_positions : (F, J, 3) float
            World position of each joint, metres.
        vertex_ids : (N,) int, optional
            Skin only these vertices (default all).

        Returns
        -------
        (F, V, 3) float32 or (F, N, 3) float32
            Posed vertices, metres.
        """
        rot = np.asarray(joint_rotations, dtype=np.float64)
        pos = np.asarray(joint_positions, dtype=np.float64)
        n_f = rot.shape[0] if rot.ndim == 4 else -1
        if rot.shape != (n_f, self.n_joints, 3, 3) or pos.shape != (n_f, self.n_joints, 3):
            raise InvalidParameterError(
                f"joint_rotations {rot.shape} and joint_positions {pos.shape} must be "
                f"(F, {self.n_joints}, 3, 3) and (F, {self.n_joints}, 3)"
            )
        blend = self._blend_matrix
        if vertex_ids is not None:
            vertex_ids = np.asarray(vertex_ids, dtype=np.int64).reshape(-1)
            if vertex_ids.size and (vertex_ids.min() < 0 or vertex_ids.max() >= self.n_vertices):
                raise InvalidParameterError(
                    f"vertex_ids must lie in [0, {self.n_vertices}), got "
                    f"[{vertex_ids.min()}, {vertex_ids.max()}]"
                )
            blend = blend[vertex_ids]
        transforms = skinning_transforms(rot, pos, self.joint_positions)
        # (F, J, 3, 4) -> (J, 4, F, 3) -> (4J, 3F): row 4j + k, column 3f + r.
        stacked = transforms.astype(np.float32).transpose(1, 3, 0, 2)
        out = np.empty((n_f, blend.shape[0], 3), dtype=np.float32)
        for start in range(0, n_f, SKIN_CHUNK_FRAMES):
            stop = min(start + SKIN_CHUNK_FRAMES, n_f)
            m = stacked[:, :, start:stop].reshape(4 * self.n_joints, 3 * (stop - start))
            flat = blend @ m  # (V, 3 * chunk)
            out[start:stop] = flat.reshape(-1, stop - start, 3).transpose(1, 0, 2)
        return out

    @cached_property
    def support_vertex_ids(self) -> np.ndarray:
        """(N,) int64: vertices that can be the lowest point of a posed body.

        The convex-hull vertices of each bone's vertex group (vertices whose largest
        weight is on that bone): a rigidly moving part touches the floor with one of
        its hull vertices, and skinning is close to rigid within a group.  About a
        fifth of the mesh (2,833 of 13,380 vertices for the default avatar), so
        finding the floor contact of a clip is cheap.
        """
        # Lazy: scipy.spatial costs a query, which imports this module, ~0.14 s.
        from scipy.spatial import ConvexHull, QhullError

        owner = np.argmax(self.weights, axis=1)
        ids = []
        for j in range(self.n_joints):
            group = np.flatnonzero(owner == j)
            if len(group) < 8:
                ids.append(group)
                continue
            try:
                hull = ConvexHull(self.vertices[group].astype(np.float64))
                ids.append(group[hull.vertices])
            except QhullError:  # a flat or degenerate group: keep it whole
                ids.append(group)
        return np.unique(np.concatenate(ids)).astype(np.int64)

    # -- variations ----------------------------------------------------------------
    def with_shape(self, height_m: float | None = None, girth: float = 1.0) -> Avatar:
        """A body of another height and girth, standing in for another person.

        Girth pushes every vertex away from (``girth > 1``) or towards the axes of the
        bones that carry it: each bone's flesh is scaled radially about the bone
        segment (head to tail), the displacements blended with the skin weights, so
        the body stays smooth across joints; head, hands and feet change less (see
        :data:`GIRTH_GAIN`).  The joints do not move.  The body is then put back on
        the floor and scaled uniformly (joints included) to ``height_m``.

        Parameters
        ----------
        height_m : float, optional
            Rest height, metres, in [0.5, 2.5]; default unchanged.
        girth : float
            Radial scale of the flesh about the bones, in [0.7, 1.8]; 1 = unchanged.

        Returns
        -------
        Avatar
        """
        check_body_shape(height_m, girth)
        vertices = self.vertices.astype(np.float64)
        if girth != 1.0:
            vertices = vertices + (girth - 1.0) * self._radial_offsets()
        joints = self.joint_positions.copy()
        tails = self.bone_tails.copy()
        floor = vertices[:, 1].min()
        for arr in (vertices, joints, tails):
            arr[:, 1] -= floor
        if height_m is not None:
            scale = height_m / vertices[:, 1].max()
            vertices, joints, tails = vertices * scale, joints * scale, tails * scale
        label = f"{self.name}-h{height_m if height_m is not None else self.height_m:.2f}"
        return Avatar(
            vertices.astype(np.float32),
            self.faces,
            self.joint_names,
            self.parents,
            joints,
            tails,
            self.weights,
            f"{label}-g{girth:.2f}",
        )

    def _radial_offsets(self) -> np.ndarray:
        """(V, 3) float64: ``sum_j gain_j w_vj (v - closest point of bone j)``, metres."""
        rows, cols = np.nonzero(self.weights)
        v = self.vertices[rows].astype(np.float64)
        head, tail = self.joint_positions[cols], self.bone_tails[cols]
        axis = tail - head
        length_sq = np.maximum(np.sum(axis * axis, axis=1), 1e-12)
        t = np.clip(np.sum((v - head) * axis, axis=1) / length_sq, 0.0, 1.0)
        closest = head + t[:, None] * axis
        gain = np.array([GIRTH_GAIN.get(n, 1.0) for n in self.joint_names])[cols]
        w = self.weights[rows, cols].astype(np.float64) * gain
        out = np.zeros((self.n_vertices, 3))
        np.add.at(out, rows, w[:, None] * (v - closest))
        # The nearest point of a bone jumps where one bone's segment ends and the
        # next begins (knees, shoulders); averaging over mesh neighbours a few times
        # irons the creases out without shrinking the field noticeably.
        neighbours = self._neighbour_mean
        for _ in range(GIRTH_SMOOTHING_ITERATIONS):
            out = 0.5 * out + 0.5 * (neighbours @ out)
        return out

    @cached_property
    def _neighbour_mean(self):
        """(V, V) CSR matrix averaging each vertex's mesh neighbours."""
        # Lazy: a query imports this module (through retrieval.build) and never skins.
        from scipy import sparse

        edges = np.concatenate(
            [self.faces[:, [0, 1]], self.faces[:, [1, 2]], self.faces[:, [2, 0]]]
        )
        edges = np.concatenate([edges, edges[:, ::-1]]).astype(np.int64)
        adj = sparse.csr_matrix(
            (np.ones(len(edges)), (edges[:, 0], edges[:, 1])),
            shape=(self.n_vertices, self.n_vertices),
        )
        adj.data[:] = 1.0  # duplicate edges were summed
        degree = np.maximum(np.asarray(adj.sum(axis=1)).ravel(), 1.0)
        return sparse.diags(1.0 / degree) @ adj

    def decimated(self, n_faces: int = DEFAULT_LOW_POLY_FACES) -> Avatar:
        """A low-poly copy for fast silhouettes (quadric edge-collapse decimation).

        Decimation is ``fast_simplification`` (the library behind trimesh's
        ``simplify_quadric_decimation``).  Each low-poly vertex takes the mean skin
        weights of the original vertices collapsed into it, so the weights stay smooth
        and normalised.  Joints are unchanged.

        Parameters
        ----------
        n_faces : int
            Target triangle count, in [200, current count).  About 2 vertices per
            face-pair: 4,000 faces give ~2,000 vertices.

        Returns
        -------
        Avatar
        """
        if not (isinstance(n_faces, int | np.integer) and 200 <= n_faces < self.n_faces):
            raise InvalidParameterError(
                f"n_faces must be an integer in [200, {self.n_faces}), got {n_faces!r}"
            )
        import fast_simplification

        # Writable copies: the extension refuses read-only arrays.
        points = self.vertices.astype(np.float64)
        faces = self.faces.copy()
        _, _, collapses = fast_simplification.simplify(
            points, faces, target_count=int(n_faces), return_collapses=True
        )
        new_points, new_faces, mapping = fast_simplification.replay_simplification(
            points, faces.copy(), collapses
        )
        mapping = np.asarray(mapping, dtype=np.int64)
        n_new = len(new_points)
        weights = np.zeros((n_new, self.n_joints))
        np.add.at(weights, mapping, self.weights)
        weights /= weights.sum(axis=1, keepdims=True)
        return Avatar(
            np.asarray(new_points, dtype=np.float32),
            np.asarray(new_faces, dtype=np.int32).reshape(-1, 3),
            self.joint_names,
            self.parents,
            self.joint_positions,
            self.bone_tails,
            weights.astype(np.float32),
            f"{self.name}-{len(new_faces)}f",
        )


def skinning_transforms(
    joint_rotations: np.ndarray, joint_positions: np.ndarray, rest_positions: np.ndarray
) -> np.ndarray:
    """Per-joint 3×4 skinning matrices ``[A_j | p_j - A_j r_j]``.

    Parameters
    ----------
    joint_rotations : (F, J, 3, 3) float
        World rotations relative to the rest pose.
    joint_positions : (F, J, 3) float
        Posed joint positions, metres.
    rest_positions : (J, 3) float
        Rest joint positions, metres.

    Returns
    -------
    (F, J, 3, 4) float64
        Maps a homogeneous rest point to its position when rigidly carried by joint j.
    """
    rot = np.asarray(joint_rotations, dtype=np.float64)
    out = np.empty(rot.shape[:-1] + (4,))
    out[..., :3] = rot
    out[..., 3] = joint_positions - np.einsum("fjab,jb->fja", rot, rest_positions)
    return out


# -- loading -----------------------------------------------------------------------
def load_avatar(
    obj_path: str | Path,
    rig_path: str | Path,
    weights_path: str | Path,
    group: str = BODY_GROUP,
    unit_m: float = OBJ_UNIT_M,
    name: str = "avatar",
) -> Avatar:
    """Load a MakeHuman-style avatar on the canonical skeleton.

    Parameters
    ----------
    obj_path : str or Path
        Mesh, Y up, facing +Z, in units of ``unit_m`` metres.
    rig_path : str or Path
        ``rig.*.json`` with every canonical bone; the bone ends are placed on the
        OBJ's helper cubes (see :func:`rig_joint_positions`).
    weights_path : str or Path
        ``weights.*.json`` with every canonical bone, indices into the OBJ's vertices.
    group : str
        The OBJ group that is the body.
    unit_m : float
        Metres per OBJ unit.
    name : str

    Returns
    -------
    Avatar
        Standing on y = 0 (the mesh and the rig shifted together).
    """
    obj = read_obj(obj_path)
    vertices, faces, kept = group_mesh(obj, group)
    heads, tails = rig_joint_positions(rig_path, obj, CANONICAL_JOINTS, unit_m)
    weights = read_weights(weights_path, CANONICAL_JOINTS, kept, len(obj.vertices))
    lift = np.array([0.0, -vertices[:, 1].min(), 0.0])
    return Avatar(
        ((vertices + lift) * unit_m).astype(np.float32),
        faces,
        CANONICAL_JOINTS,
        CANONICAL_PARENTS,
        (heads + lift) * unit_m,
        (tails + lift) * unit_m,
        weights,
        name,
    )


@lru_cache(maxsize=1)
def load_default_avatar() -> Avatar:
    """The bundled CC0 MakeHuman body (13,380 vertices, 26,756 triangles), cached.

    Returns
    -------
    Avatar
        About 1.67 m tall, on the canonical skeleton, in MakeHuman's A-pose.
    """
    root = makehuman_dir()
    return load_avatar(
        root / "base.obj",
        root / "rig.cmu_mb.json",
        root / "weights.cmu_mb.json",
        name="makehuman",
    )
