"""Mirror images of motions: left and right swapped.

:func:`mirror_motion` reflects a :class:`~eigmotion.mocap.motion.Motion` across the
body's sagittal plane, pairing joints by name
(:func:`eigmotion.mocap.naming.mirror_partners`) and checking the rest pose
(:func:`eigmotion.mocap.kinematics.rest_points`) faces +Z.
"""

from __future__ import annotations

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.kinematics import rest_points
from eigmotion.mocap.motion import Motion, Skeleton
from eigmotion.mocap.naming import mirror_partners


def mirror_motion(motion: Motion) -> Motion:
    """``motion`` reflected across the body's sagittal plane: left and right swapped.

    A person waving with the left hand becomes one waving with the right.  Joints
    swap with their partner on the other side (by name,
    :func:`eigmotion.mocap.naming.mirror_partners`); the skeleton becomes its mirror
    image across its rest sagittal plane ``x = 0`` (at rest every skeleton faces
    +Z, its left towards +X): each joint takes its partner's offset, end site and
    channels with x negated.  The motion is reflected across the vertical plane
    through the root at the first frame that holds the body's forward direction
    there, so the copy starts where the original starts, facing the same way.
    Mirroring twice gives the original back.

    Parameters
    ----------
    motion : Motion
        Any skeleton whose joint names say their side, facing +Z at rest.

    Returns
    -------
    Motion
        Same joint names, channel layout per side, frame rate, length unit and
        name; joint positions (metres, Y up) are the reflection of the original's.

    Raises
    ------
    InvalidParameterError
        No joint name says its side, the sides are built differently, or the rest
        pose's left and right joints do not lie apart along x.
    """
    sk = motion.skeleton
    partner = np.asarray(mirror_partners(sk))
    rest = rest_points(sk)[: sk.n_joints]
    sides = rest - rest[partner]
    if np.abs(sides[:, 0]).sum() <= np.linalg.norm(sides[:, 1:], axis=1).sum():
        raise InvalidParameterError(
            f"cannot mirror {motion.name or 'the motion'}: the rest pose's left and right "
            "joints do not lie apart along x (the body must face +Z at rest)"
        )
    flip = np.diag([-1.0, 1.0, 1.0])
    mirror_sk = Skeleton(
        sk.names,
        sk.parents,
        sk.offsets[partner] @ flip,
        tuple(sk.channels[p] for p in partner),
        {
            int(j): flip @ sk.end_sites[int(p)]
            for j, p in enumerate(partner)
            if int(p) in sk.end_sites
        },
    )
    local_r = motion.local_rotations()
    local_t = motion.local_translations()
    # The world plane: vertical, through the first root position, its normal the
    # body's left (the rest +X axis turned by the first root rotation) made level.
    left = local_r[0, 0, :, 0] * [1.0, 0.0, 1.0]
    n = np.linalg.norm(left)
    normal = left / n if n > 1e-9 else np.array([1.0, 0.0, 0.0])
    world = np.eye(3) - 2.0 * np.outer(normal, normal)
    rot = flip @ local_r[:, partner] @ flip
    rot[:, 0] = world @ local_r[:, 0] @ flip
    trans = local_t[:, partner] @ flip
    root = local_t[:, 0]
    trans[:, 0] = root[0] + (root - root[0]) @ world
    blank = motion.replace(skeleton=mirror_sk, values=np.zeros((1, mirror_sk.n_channels)))
    return blank.with_local_transforms(rot, trans)
