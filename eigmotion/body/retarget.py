"""Retargeting: drive the avatar's skeleton with a motion of another skeleton.

Rest poses differ between skeletons (a CMU ASF skeleton stands in a T-pose, the
MakeHuman avatar in an A-pose; bone lengths and axes differ too), so local Euler
angles are never copied.  Instead, for each avatar joint ``j`` mapped to a source
joint:

1. the source's forward kinematics gives the joint's world rotation ``G_j(t)``
   relative to the source rest pose (a :class:`~eigmotion.mocap.motion.Motion`'s local
   frames are world-aligned at rest);
2. a constant rest alignment ``Q_j`` turns the avatar's rest bone directions onto
   the source's.  The directions run from the joint to its first non-coincident
   mapped descendants (or to its End Site).  The first one (the bone itself) is
   matched exactly by the smallest rotation applied after a reference alignment —
   the parent's, so that the twist about a limb is handed down the chain (elbow
   and knee hinges stay consistent), or, for a bone leaving a branching joint (an
   upper arm after its collar bone, a thigh after its hip bone), the branching
   joint's, so that a collar bone placed differently does not twist the arm.
   Further directions set the twist about the first: at the hips and the chest the
   left-right vector (hip joints, shoulder joints) fixes the facing, at the hands
   the thumb.  A bone that starts at its parent's own joint (the hip bones leave
   the pelvis joint) moves rigidly with its parent;
3. the avatar bone's world rotation is ``A_j(t) = G_j(t) Q_j``: every bone points
   where the source's points, with the source's twist.

Avatar joints with no source joint follow their parent.  Joint positions come from
the avatar's own bone lengths; the root follows the source's hip path scaled by the
ratio of the hip heights (so stride lengths fit the avatar's legs), and the whole
clip is lifted so that the lowest skinned point over the clip touches y = 0.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from eigmotion.body.avatar import Avatar
from eigmotion.errors import InvalidParameterError, SkeletonMappingError
from eigmotion.mocap.kinematics import detect_length_unit, forward_kinematics
from eigmotion.mocap.motion import Motion, Skeleton
from eigmotion.mocap.naming import canonical_joint_map
from eigmotion.mocap.rotations import rotation_between

#: Joints whose facing is fixed by a left-right vector: joint → (left, right).
LEFT_RIGHT_JOINTS = {
    "Hips": ("LeftUpLeg", "RightUpLeg"),
    "Spine1": ("LeftArm", "RightArm"),
}

#: Points closer than this (metres) count as coincident when finding bone directions.
COINCIDENT_M = 1e-4

#: Directions within this sine of each other count as collinear (no twist
#: information in them): about 3°.
COLLINEAR_SINE = 0.05


@dataclass(frozen=True, eq=False)
class AvatarAnimation:
    """A motion retargeted onto an avatar's skeleton.

    Attributes
    ----------
    joint_names : tuple of str
        The avatar's joints (canonical names for the MakeHuman avatar).
    parents : (J,) int64
    joint_positions : (F, J, 3) float64
        World joint positions, metres, Y up; the lowest skinned point of the clip is
        on y = 0.
    joint_rotations : (F, J, 3, 3) float64
        World rotation of each avatar bone relative to its rest orientation.
    frame_time_s : float
        Seconds per frame.
    source_joints : dict of str to int
        Avatar joint → index of the source joint that drove it (unmapped joints,
        which followed their parent, are absent).
    name : str
    """

    joint_names: tuple[str, ...]
    parents: np.ndarray
    joint_positions: np.ndarray
    joint_rotations: np.ndarray
    frame_time_s: float
    source_joints: dict[str, int]
    name: str = ""

    def __post_init__(self):
        n_j = len(self.joint_names)
        pos = np.asarray(self.joint_positions, dtype=np.float64)
        rot = np.asarray(self.joint_rotations, dtype=np.float64)
        n_f = pos.shape[0] if pos.ndim == 3 else -1
        if pos.shape != (n_f, n_j, 3) or rot.shape != (n_f, n_j, 3, 3):
            raise InvalidParameterError(
                f"animation {self.name!r}: joint_positions {pos.shape} and joint_rotations "
                f"{rot.shape} must be (F, {n_j}, 3) and (F, {n_j}, 3, 3)"
            )
        if not (np.isfinite(self.frame_time_s) and self.frame_time_s > 0):
            raise InvalidParameterError(f"frame_time_s must be > 0, got {self.frame_time_s!r}")
        object.__setattr__(self, "joint_names", tuple(self.joint_names))
        object.__setattr__(self, "parents", np.asarray(self.parents, dtype=np.int64))
        object.__setattr__(self, "joint_positions", pos)
        object.__setattr__(self, "joint_rotations", rot)

    @property
    def n_frames(self) -> int:
        return self.joint_positions.shape[0]

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time_s


def retarget(
    motion: Motion,
    avatar: Avatar,
    mapping: Mapping[str, str | None] | None = None,
    length_unit_m: float | None = None,
    up_axis: str = "y",
) -> AvatarAnimation:
    """Retarget a motion of any (human-like) skeleton onto an avatar.

    Parameters
    ----------
    motion : Motion
        The source motion (BVH, ASF/AMC or canonical skeleton).
    avatar : Avatar
        The body to drive; its joints are canonical joints.
    mapping : dict of str to (str or None), optional
        Source joint name → canonical joint name (``None``: ignore that joint),
        passed to :func:`eigmotion.mocap.naming.canonical_joint_map`, which otherwise
        recognises the usual naming families (CMU ASF and BVH, exporters …).
    length_unit_m : float, optional
        Metres per source length unit (default: the motion's, else detected).
    up_axis : {"y", "z"}
        The source's up axis.

    Returns
    -------
    AvatarAnimation
        Same frame count and frame time as ``motion``.

    Raises
    ------
    SkeletonMappingError
        The source has no joint for the avatar's root.
    """
    sk = motion.skeleton
    joint_map = {
        name: int(src)
        for name, src in canonical_joint_map(sk, mapping).items()
        if name in avatar.joint_names
    }
    root_name = avatar.joint_names[0]
    if root_name not in joint_map:
        raise SkeletonMappingError(
            f"motion {motion.name!r}: no source joint maps to the avatar root "
            f"{root_name!r}; pass mapping={{'<source joint>': {root_name!r}}}"
        )
    unit = length_unit_m or motion.length_unit_m or detect_length_unit(sk, up_axis)
    pose = forward_kinematics(motion, length_unit_m=unit, up_axis=up_axis, ground=True)
    src_joints, src_ends = _source_rest(sk, unit, up_axis)
    align = rest_alignment(avatar, src_joints, src_ends, joint_map)

    n_f, n_j = motion.n_frames, avatar.n_joints
    rotations = np.empty((n_f, n_j, 3, 3))
    positions = np.empty((n_f, n_j, 3))
    src_root = joint_map[root_name]
    # Hip height over the lowest rest joint or End Site (NaN: joints without one).
    src_hip_height = src_joints[src_root, 1] - np.nanmin(
        np.concatenate([src_joints[:, 1], src_ends[:, 1]])
    )
    if not src_hip_height > 0:
        raise InvalidParameterError(
            f"motion {motion.name!r}: its root joint {sk.names[src_root]!r} is not above "
            "the rest skeleton's lowest point; cannot scale its path to the avatar"
        )
    scale = avatar.hip_height_m / src_hip_height
    positions[:, 0] = scale * pose.positions[:, src_root]
    offsets = avatar.joint_positions - avatar.joint_positions[avatar.parents]
    for j, name in enumerate(avatar.joint_names):
        parent = avatar.parents[j]
        if name in joint_map:
            rotations[:, j] = pose.rotations[:, joint_map[name]] @ align[j]
        else:
            rotations[:, j] = rotations[:, parent]
        if parent >= 0:
            positions[:, j] = positions[:, parent] + rotations[:, parent] @ offsets[j]
    support = avatar.skin(rotations, positions, avatar.support_vertex_ids)
    positions[..., 1] -= support[..., 1].min()
    return AvatarAnimation(
        avatar.joint_names,
        avatar.parents,
        positions,
        rotations,
        motion.frame_time_s,
        joint_map,
        motion.name,
    )


def pose_avatar(avatar: Avatar, animation: AvatarAnimation) -> np.ndarray:
    """Skinned vertices of a retargeted animation.

    Parameters
    ----------
    avatar : Avatar
        The body to skin.
    animation : AvatarAnimation
        From :func:`retarget` onto ``avatar`` (or one with the same joints and bone
        lengths).

    Returns
    -------
    (F, V, 3) float32
        Vertices per frame, metres.

    Raises
    ------
    InvalidParameterError
        The animation's joints are not the avatar's, or its bones are not as long.
    """
    if tuple(animation.joint_names) != avatar.joint_names:
        raise InvalidParameterError(
            f"animation joints {list(animation.joint_names)[:4]}… do not match the "
            f"avatar's {list(avatar.joint_names)[:4]}…"
        )
    child = np.arange(1, avatar.n_joints)
    rest = np.linalg.norm(
        avatar.joint_positions[child] - avatar.joint_positions[avatar.parents[child]], axis=-1
    )
    first = animation.joint_positions[0]
    posed = np.linalg.norm(first[child] - first[avatar.parents[child]], axis=-1)
    worst = int(np.argmax(np.abs(posed - rest)))
    if abs(posed[worst] - rest[worst]) > 1e-3:
        raise InvalidParameterError(
            f"animation {animation.name!r} has bone {avatar.joint_names[child[worst]]!r} "
            f"{posed[worst]:.4f} m long, avatar {avatar.name!r} {rest[worst]:.4f} m: it was "
            "retargeted onto another body shape; retarget it onto this avatar"
        )
    return avatar.skin(animation.joint_rotations, animation.joint_positions)


def animate_avatar(
    avatar: Avatar,
    motion: Motion,
    mapping: dict[str, str | None] | None = None,
    length_unit_m: float | None = None,
    up_axis: str = "y",
) -> tuple[AvatarAnimation, np.ndarray]:
    """Retarget ``motion`` onto ``avatar`` and skin it.

    Shorthand for ``anim = retarget(motion, avatar, ...); (anim, pose_avatar(avatar,
    anim))``; see :func:`retarget` for the parameters.

    Returns
    -------
    animation : AvatarAnimation
    vertices : (F, V, 3) float32
        Skinned vertices per frame, metres.
    """
    anim = retarget(motion, avatar, mapping, length_unit_m=length_unit_m, up_axis=up_axis)
    return anim, pose_avatar(avatar, anim)


def _source_rest(sk: Skeleton, unit: float, up_axis: str) -> tuple[np.ndarray, np.ndarray]:
    """Rest joints (J, 3) and end sites (J, 3; NaN where none) in metres, Y up."""
    rest = Motion(sk, np.zeros((1, sk.n_channels)), 1.0, unit)
    pose = forward_kinematics(rest, length_unit_m=unit, up_axis=up_axis, ground=False)
    joints = pose.positions[0]
    ends = np.full_like(joints, np.nan)
    ends[pose.end_site_joints] = pose.end_sites[0]
    return joints, ends


def rest_alignment(
    avatar: Avatar,
    source_joints: np.ndarray,
    source_end_sites: np.ndarray,
    joint_map: Mapping[str, int],
) -> np.ndarray:
    """Constant rotations ``Q_j`` turning the avatar's rest bones onto the source's.

    Parameters
    ----------
    avatar : Avatar
    source_joints : (S, 3) float
        Source rest joint positions, metres, Y up.
    source_end_sites : (S, 3) float
        Source rest End Site per joint, NaN where a joint has none.
    joint_map : dict of str to int
        Avatar joint name → source joint index (other names are ignored).

    Returns
    -------
    (J, 3, 3) float64
        ``Q_j @ (avatar rest direction) ≈ (source rest direction)`` for each bone;
        an unmapped joint gets its parent's.
    """
    names = avatar.joint_names
    index = {n: i for i, n in enumerate(names)}
    children = [[] for _ in names]
    for j in range(1, len(names)):
        children[avatar.parents[j]].append(j)
    a_pos = avatar.joint_positions
    src = {index[n]: s for n, s in joint_map.items() if n in index}

    def distinct(j: int, c: int) -> list[int]:
        """First descendants of j through child c apart from j in both skeletons."""
        if c in src:
            far_a = np.linalg.norm(a_pos[c] - a_pos[j]) > COINCIDENT_M
            far_s = np.linalg.norm(source_joints[src[c]] - source_joints[src[j]]) > COINCIDENT_M
            if far_a and far_s:
                return [c]
        return [d for g in children[c] for d in distinct(j, g)]

    def pair(j: int, targets: list[int]) -> tuple[np.ndarray, np.ndarray]:
        return (
            a_pos[targets].mean(axis=0) - a_pos[j],
            source_joints[[src[t] for t in targets]].mean(axis=0) - source_joints[src[j]],
        )

    out = np.empty((len(names), 3, 3))
    for j, name in enumerate(names):
        parent = avatar.parents[j]
        parent_q = np.eye(3) if j == 0 else out[parent]
        rigid_with_parent = j > 0 and np.linalg.norm(a_pos[j] - a_pos[parent]) <= COINCIDENT_M
        if j not in src or rigid_with_parent:
            # A bone branching from its parent's own head (the hip bones leave the
            # pelvis joint) is part of the parent's rigid body: aligning it on its
            # own would swing it onto the source's (differently placed) hip offset
            # and hand a spurious twist down the leg.
            out[j] = parent_q
            continue
        targets = [d for c in children[j] for d in distinct(j, c)]
        pairs = []
        left_right = LEFT_RIGHT_JOINTS.get(name)
        if left_right and all(index.get(n) in src for n in left_right):
            left, right = index[left_right[0]], index[left_right[1]]
            sides = _subtree(children, left) | _subtree(children, right)
            up = [t for t in targets if not (_subtree(children, t) & sides or t in sides)]
            if up:
                pairs.append(pair(j, up))
            pairs.append(
                (
                    a_pos[left] - a_pos[right],
                    source_joints[src[left]] - source_joints[src[right]],
                )
            )
        else:
            pairs.extend(pair(j, [t]) for t in targets)
        if not pairs:
            tip = source_end_sites[src[j]]
            tail = avatar.bone_tails[j] - a_pos[j]
            if np.all(np.isfinite(tip)) and np.linalg.norm(tail) > COINCIDENT_M:
                pairs.append((tail, tip - source_joints[src[j]]))
        pairs = [
            (a, b)
            for a, b in pairs
            if np.linalg.norm(a) > COINCIDENT_M and np.linalg.norm(b) > COINCIDENT_M
        ]
        # Twist is handed down a limb from bone to bone, but not through a bone that
        # leaves a branching joint (collar bone, hip bone, first spine and neck
        # bones): the upper arm's twist is relative to the chest, not to the collar
        # bone, whose rest direction may differ a lot between skeletons.
        grand = avatar.parents[parent] if j > 0 else -1
        reference = out[grand] if grand >= 0 and len(children[grand]) > 1 else parent_q
        out[j] = _fit_rotation(pairs, reference, parent_q)
    return out


def _subtree(children: list[list[int]], j: int) -> set[int]:
    out = {j}
    for c in children[j]:
        out |= _subtree(children, c)
    return out


def _fit_rotation(
    pairs: list[tuple[np.ndarray, np.ndarray]], reference_q: np.ndarray, parent_q: np.ndarray
) -> np.ndarray:
    """Rotation taking avatar rest directions onto source rest directions.

    The first (primary) direction is matched exactly by the smallest rotation after
    the reference alignment (the parent's or the branching joint's), which keeps
    the reference's twist about the bone.  Further directions, when they are not
    collinear with the primary one in both skeletons, set the twist about it: the
    angle that best turns their components perpendicular to the primary direction
    onto the source's.  No direction at all: the parent's alignment.
    """
    if not pairs:
        return parent_q
    a = np.array([p[0] / np.linalg.norm(p[0]) for p in pairs])
    b = np.array([p[1] / np.linalg.norm(p[1]) for p in pairs])
    swing = rotation_between(reference_q @ a[0], b[0]) @ reference_q
    if len(pairs) < 2 or _spread(a) <= COLLINEAR_SINE or _spread(b) <= COLLINEAR_SINE:
        return swing
    axis = b[0]
    moved = a[1:] @ swing.T
    u = moved - np.outer(moved @ axis, axis)
    v = b[1:] - np.outer(b[1:] @ axis, axis)
    sin = float(np.sum(np.cross(u, v) @ axis))
    cos = float(np.sum(u * v))
    if np.hypot(sin, cos) < 1e-12:
        return swing
    return Rotation.from_rotvec(axis * np.arctan2(sin, cos)).as_matrix() @ swing


def _spread(units: np.ndarray) -> float:
    """Largest sine between any two of the unit vectors (N, 3)."""
    cross = np.cross(units[:, None, :], units[None, :, :])
    return float(np.linalg.norm(cross, axis=-1).max())


def animation_to_motion(animation: AvatarAnimation, avatar: Avatar, order: str = "ZXY") -> Motion:
    """The retargeted animation as a motion on the avatar's skeleton (for BVH export).

    Parameters
    ----------
    animation : AvatarAnimation
    avatar : Avatar
        The avatar it was retargeted onto (gives the rest offsets and End Sites).
    order : str
        Euler order of the rotation channels.

    Returns
    -------
    Motion
        On :meth:`Avatar.skeleton`, metres (``length_unit_m = 1``); its forward
        kinematics without grounding reproduces ``animation.joint_positions``.
    """
    if tuple(animation.joint_names) != avatar.joint_names:
        raise InvalidParameterError(
            f"animation {animation.name!r} is not on avatar {avatar.name!r}'s joints"
        )
    rot = animation.joint_rotations
    local = rot.copy()
    parents = avatar.parents
    local[:, 1:] = np.swapaxes(rot[:, parents[1:]], -1, -2) @ rot[:, 1:]
    return Motion.from_local_transforms(
        avatar.skeleton(order),
        local,
        animation.joint_positions[:, 0],
        animation.frame_time_s,
        order=order,
        length_unit_m=1.0,
        name=animation.name,
    )
