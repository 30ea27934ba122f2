"""The canonical skeleton: the CMU-style joints of the MakeHuman ``cmu_mb`` rig.

Every motion is mapped onto these joint names before it drives the avatar (see
:mod:`eigmotion.mocap.naming`).  The canonical skeleton's geometry is the default avatar's
rig, turned from the rig file's Blender frame (Z up, -Y forward) into eigmotion's
world frame (metres, Y up, the body facing +Z, its left side towards +X).
"""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from eigmotion.mocap.motion import Skeleton, standard_channels

#: (joint, parent) in parents-first order; the order of the CMU BVH conversions.
CANONICAL_HIERARCHY: tuple[tuple[str, str | None], ...] = (
    ("Hips", None),
    ("LHipJoint", "Hips"),
    ("LeftUpLeg", "LHipJoint"),
    ("LeftLeg", "LeftUpLeg"),
    ("LeftFoot", "LeftLeg"),
    ("LeftToeBase", "LeftFoot"),
    ("RHipJoint", "Hips"),
    ("RightUpLeg", "RHipJoint"),
    ("RightLeg", "RightUpLeg"),
    ("RightFoot", "RightLeg"),
    ("RightToeBase", "RightFoot"),
    ("LowerBack", "Hips"),
    ("Spine", "LowerBack"),
    ("Spine1", "Spine"),
    ("Neck", "Spine1"),
    ("Neck1", "Neck"),
    ("Head", "Neck1"),
    ("LeftShoulder", "Spine1"),
    ("LeftArm", "LeftShoulder"),
    ("LeftForeArm", "LeftArm"),
    ("LeftHand", "LeftForeArm"),
    ("LeftFingerBase", "LeftHand"),
    ("LeftHandFinger1", "LeftFingerBase"),
    ("LThumb", "LeftHand"),
    ("RightShoulder", "Spine1"),
    ("RightArm", "RightShoulder"),
    ("RightForeArm", "RightArm"),
    ("RightHand", "RightForeArm"),
    ("RightFingerBase", "RightHand"),
    ("RightHandFinger1", "RightFingerBase"),
    ("RThumb", "RightHand"),
)

CANONICAL_JOINTS: tuple[str, ...] = tuple(name for name, _ in CANONICAL_HIERARCHY)
CANONICAL_PARENTS: np.ndarray = np.array(
    [-1 if p is None else CANONICAL_JOINTS.index(p) for _, p in CANONICAL_HIERARCHY]
)

#: Blender (x, y, z) → eigmotion (x, z, -y): Z up → Y up, facing +Z.
BLENDER_TO_WORLD = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])


def makehuman_dir() -> Path:
    """Folder of the bundled CC0 MakeHuman assets (``base.obj``, rig, weights)."""
    return Path(str(resources.files("eigmotion") / "data" / "avatar" / "makehuman"))


@lru_cache(maxsize=4)
def load_makehuman_rig(path: str | None = None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Bone head and tail positions of a MakeHuman rig file in the world frame.

    Parameters
    ----------
    path : str, optional
        A ``rig.*.json``; default the bundled ``rig.cmu_mb.json``.

    Returns
    -------
    dict of str to ((3,) float, (3,) float)
        Bone name → (head, tail), metres, Y up.
    """
    path = path or str(makehuman_dir() / "rig.cmu_mb.json")
    data = json.loads(Path(path).read_text())
    out = {}
    for name, bone in data.items():
        head = BLENDER_TO_WORLD @ np.asarray(bone["head"]["default_position"], float)
        tail = BLENDER_TO_WORLD @ np.asarray(bone["tail"]["default_position"], float)
        out[name] = (head, tail)
    return out


def canonical_skeleton(order: str = "ZXY") -> Skeleton:
    """The canonical skeleton with the default avatar's rest geometry (metres).

    Its rest pose is the avatar's (arms down at about 45°); leaf joints carry an End
    Site at their bone's tail.  Channels: root 6, others 3, Euler ``order``.
    """
    rig = load_makehuman_rig()
    heads = np.stack([rig[n][0] for n in CANONICAL_JOINTS])
    offsets = heads.copy()
    offsets[1:] = heads[1:] - heads[CANONICAL_PARENTS[1:]]
    ends = {}
    for j, name in enumerate(CANONICAL_JOINTS):
        if j not in CANONICAL_PARENTS:
            ends[j] = rig[name][1] - rig[name][0]
    return Skeleton(
        CANONICAL_JOINTS,
        CANONICAL_PARENTS,
        offsets,
        standard_channels(len(CANONICAL_JOINTS), order),
        ends,
    )
