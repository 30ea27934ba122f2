"""Retargeting motions of several skeleton families onto the default avatar."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import (
    AvatarAnimation,
    animate_avatar,
    animation_to_motion,
    pose_avatar,
    retarget,
)
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.amc import read_amc
from eigmotion.mocap.bvh import read_bvh, write_bvh
from eigmotion.mocap.canonical import (
    BLENDER_TO_WORLD,
    CANONICAL_JOINTS,
    CANONICAL_PARENTS,
    canonical_skeleton,
    makehuman_dir,
)
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.motion import Motion, Skeleton
from eigmotion.mocap.naming import canonical_names

CMU = Path(__file__).resolve().parents[1] / "database" / "motions" / "cmu"

#: Bones whose direction is matched exactly: (joint, child) pairs of the avatar.
#: Left out: the hip and shoulder offsets (placed by the pelvis and chest frames,
#: with the avatar's own anatomy) and the thumbs (they only set the hand's twist).
DIRECTED_BONES = [
    (CANONICAL_JOINTS[p], c)
    for c, p in zip(CANONICAL_JOINTS[1:], CANONICAL_PARENTS[1:], strict=True)
    if c not in ("LHipJoint", "RHipJoint", "LeftUpLeg", "RightUpLeg", "LThumb", "RThumb")
    and not (CANONICAL_JOINTS[p] == "Spine1" and c != "Neck")
]


def cmu_clip(clip: str, n_frames: int = 240) -> Motion:
    subject = clip.split("_")[0]
    motion = read_amc(CMU / "amc" / f"{clip}.amc", CMU / "asf" / f"{subject}.asf")
    return motion.trim(0, min(n_frames, motion.n_frames))


def smooth_canonical_motion(seed: int, n_frames: int = 40, order: str = "ZXY") -> Motion:
    """A random but smooth motion on the canonical skeleton (metres)."""
    rng = np.random.default_rng(seed)
    sk = canonical_skeleton(order)
    t = np.linspace(0, 1, n_frames)[:, None]
    amp = rng.uniform(-50, 50, (1, sk.n_channels))
    phase = rng.uniform(0, 2 * np.pi, (1, sk.n_channels))
    values = amp * np.sin(2 * np.pi * t + phase)
    values[:, :3] = np.c_[2 * t, 0.9 + 0.05 * np.sin(6 * t), -t]  # root path, metres
    return Motion(sk, values, 1 / 30, 1.0, f"random{seed}")


def bone_cosines(anim: AvatarAnimation, pose, bones) -> dict[str, float]:
    """Smallest cosine over the clip between avatar and source bone directions
    (bones of zero length in the source, like an ASF ``lowerback`` starting at the
    root, are left out)."""
    out = {}
    for parent, child in bones:
        if parent not in anim.source_joints or child not in anim.source_joints:
            continue
        i, k = CANONICAL_JOINTS.index(parent), CANONICAL_JOINTS.index(child)
        a = anim.joint_positions[:, k] - anim.joint_positions[:, i]
        s = (
            pose.positions[:, anim.source_joints[child]]
            - pose.positions[:, anim.source_joints[parent]]
        )
        if np.linalg.norm(s, axis=1).min() < 1e-6:
            continue
        cos = np.sum(a * s, 1) / np.linalg.norm(a, axis=1) / np.linalg.norm(s, axis=1)
        out[f"{parent}->{child}"] = float(cos.min())
    return out


@pytest.fixture(scope="module")
def avatar():
    return load_default_avatar()


# -- the canonical skeleton itself ----------------------------------------------------
@pytest.mark.parametrize("seed, order", [(0, "ZXY"), (1, "XYZ"), (2, "YZX")])
def test_canonical_motion_keeps_every_bone_direction(avatar, seed, order):
    motion = smooth_canonical_motion(seed, order=order)
    anim = retarget(motion, avatar)
    pose = forward_kinematics(motion)
    assert anim.n_frames == motion.n_frames and anim.frame_time_s == motion.frame_time_s
    assert set(anim.source_joints) == set(CANONICAL_JOINTS)
    cosines = bone_cosines(anim, pose, DIRECTED_BONES)
    assert len(cosines) == len(DIRECTED_BONES)
    assert min(cosines.values()) > 1 - 1e-9, min(cosines.items(), key=lambda kv: kv[1])


def test_avatar_own_skeleton_retargets_to_identity(avatar):
    """A motion on the avatar's own skeleton drives it unchanged: no rest alignment,
    world rotations equal to the source's, the rest pose gives the rest mesh."""
    sk = avatar.skeleton()
    rest = Motion(sk, np.zeros((1, sk.n_channels)), 1 / 30, 1.0, "rest")
    anim = retarget(rest, avatar)
    np.testing.assert_allclose(
        anim.joint_rotations[0], np.broadcast_to(np.eye(3), (31, 3, 3)), atol=1e-12
    )
    np.testing.assert_allclose(anim.joint_positions[0], avatar.joint_positions, atol=1e-9)
    np.testing.assert_allclose(pose_avatar(avatar, anim)[0], avatar.vertices, atol=1e-5)
    moving = smooth_canonical_motion(5)
    motion = Motion(sk, moving.values, moving.frame_time_s, 1.0, "moving")
    anim = retarget(motion, avatar)
    np.testing.assert_allclose(
        anim.joint_rotations, forward_kinematics(motion).rotations, atol=1e-9
    )


def test_makehuman_t_pose_lifts_the_arms_level(avatar):
    """MakeHuman's own A→T pose file (bone-local Euler XYZ, rolls from the rig),
    played on the canonical skeleton and retargeted, puts the arms horizontal and
    the hands at shoulder height."""
    root = makehuman_dir()
    rig = json.loads((root / "rig.cmu_mb.json").read_text())
    angles = json.loads((root / "pose.cmu_mb.t-pose.json").read_text())["bone_rotations"]
    world = []
    for j, name in enumerate(CANONICAL_JOINTS):
        head = np.array(rig[name]["head"]["default_position"])
        tail = np.array(rig[name]["tail"]["default_position"])
        y_to_bone = Rotation.align_vectors([tail - head], [[0.0, 1.0, 0.0]])[0].as_matrix()
        bone = (
            Rotation.from_rotvec(
                (tail - head) / np.linalg.norm(tail - head) * rig[name]["roll"]
            ).as_matrix()
            @ y_to_bone
        )
        local = Rotation.from_euler("xyz", angles.get(name, [0, 0, 0])).as_matrix()
        parent = CANONICAL_PARENTS[j]
        world.append((world[parent] if parent >= 0 else np.eye(3)) @ bone @ local @ bone.T)
    world = np.array([BLENDER_TO_WORLD @ w @ BLENDER_TO_WORLD.T for w in world])
    local = world.copy()
    local[1:] = np.swapaxes(world[CANONICAL_PARENTS[1:]], -1, -2) @ world[1:]
    sk = canonical_skeleton()
    motion = Motion.from_local_transforms(sk, local[None], sk.offsets[:1], 1 / 30, length_unit_m=1)
    anim = retarget(motion, avatar)
    joints = anim.joint_positions[0]
    j = avatar.joint_index
    for arm, hand in (("LeftArm", "LeftHand"), ("RightArm", "RightHand")):
        d = joints[j(hand)] - joints[j(arm)]
        assert abs(d[1]) / np.linalg.norm(d) < 0.1  # within ~6° of level
    vertices = pose_avatar(avatar, anim)[0]
    owner = np.argmax(avatar.weights, axis=1)
    for side, sign in (("Left", 1), ("Right", -1)):
        hand = vertices[owner == j(f"{side}Hand")]
        assert sign * hand[:, 0].mean() > 0.6
        assert hand[:, 1].mean() == pytest.approx(joints[j(f"{side}Arm"), 1], abs=0.06)


def test_missing_joints_follow_their_parent(avatar):
    """A skeleton without hand bones: the avatar's hand joints copy the wrist."""
    full = canonical_skeleton()
    drop = {"LeftFingerBase", "LeftHandFinger1", "LThumb"}
    keep = [i for i, n in enumerate(full.names) if n not in drop]
    index = {old: new for new, old in enumerate(keep)}
    sk = Skeleton(
        tuple(full.names[i] for i in keep),
        [index[full.parents[i]] if full.parents[i] >= 0 else -1 for i in keep],
        full.offsets[keep],
        tuple(full.channels[i] for i in keep),
        {index[j]: off for j, off in full.end_sites.items() if j in index},
    )
    source = smooth_canonical_motion(4)
    starts = full.channel_start()
    cols = np.concatenate([starts[i] + np.arange(len(full.channels[i])) for i in keep])
    motion = Motion(sk, source.values[:, cols], source.frame_time_s, 1.0, "no-hand")
    anim = retarget(motion, avatar)
    assert drop.isdisjoint(anim.source_joints)
    hand = anim.joint_rotations[:, avatar.joint_index("LeftHand")]
    for name in drop:
        np.testing.assert_allclose(anim.joint_rotations[:, avatar.joint_index(name)], hand)


# -- real CMU clips (ASF/AMC) ---------------------------------------------------------
@pytest.mark.parametrize("clip", ["02_01", "09_01", "135_04", "02_04"])
def test_cmu_clip_keeps_bone_lengths_and_directions(avatar, clip):
    motion = cmu_clip(clip)
    anim = retarget(motion, avatar)
    child = np.arange(1, avatar.n_joints)
    lengths = np.linalg.norm(
        anim.joint_positions[:, child] - anim.joint_positions[:, avatar.parents[child]], axis=-1
    )
    rest = np.linalg.norm(
        avatar.joint_positions[child] - avatar.joint_positions[avatar.parents[child]], axis=-1
    )
    np.testing.assert_allclose(lengths, np.broadcast_to(rest, lengths.shape), atol=1e-9)
    cosines = bone_cosines(anim, forward_kinematics(motion), DIRECTED_BONES)
    assert len(cosines) >= len(DIRECTED_BONES) - 1  # ASF lowerback starts at the root
    assert min(cosines.values()) > 0.999, min(cosines.items(), key=lambda kv: kv[1])
    rotations = anim.joint_rotations
    np.testing.assert_allclose(
        rotations @ np.swapaxes(rotations, -1, -2),
        np.broadcast_to(np.eye(3), rotations.shape),
        atol=1e-9,
    )


@pytest.mark.parametrize("clip", ["02_01", "16_15"])
def test_cmu_walk_faces_forward_and_stands_on_the_floor(avatar, clip):
    motion = cmu_clip(clip, 360)
    anim = retarget(motion, avatar)
    vertices = pose_avatar(avatar, anim)
    assert vertices[..., 1].min() == pytest.approx(0.0, abs=2e-3)
    # Several frames have a foot on the floor, not just one.
    assert np.mean(vertices[..., 1].min(axis=1) < 0.06) > 0.5
    forward = anim.joint_rotations[:, 0] @ np.array([0.0, 0.0, 1.0])
    velocity = np.gradient(anim.joint_positions[:, 0], axis=0)
    f, v = forward[:, [0, 2]], velocity[:, [0, 2]]
    cos = np.sum(f * v, 1) / np.linalg.norm(f, axis=1) / np.linalg.norm(v, axis=1)
    assert np.median(cos) > 0.9  # walks the way the body faces


def test_root_path_is_scaled_by_hip_height(avatar):
    motion = cmu_clip("02_01")
    anim = retarget(motion, avatar)
    pose = forward_kinematics(motion)
    src = pose.positions[:, 0, [0, 2]]
    dst = anim.joint_positions[:, 0, [0, 2]]
    scale = np.linalg.norm(dst[-1] - dst[0]) / np.linalg.norm(src[-1] - src[0])
    sk_rest = forward_kinematics(
        Motion(motion.skeleton, np.zeros((1, motion.skeleton.n_channels)), 1, motion.length_unit_m),
        ground=True,
    )
    assert scale == pytest.approx(avatar.hip_height_m / sk_rest.positions[0, 0, 1], rel=1e-6)


# -- a BVH file ------------------------------------------------------------------------
def test_bvh_file_retargets_like_its_source(avatar, tmp_path):
    """A CMU clip written as a BVH (CMU BVH joint names, centimetres, no unit stated)
    and read back retargets to the same avatar motion as the ASF/AMC original."""
    motion = cmu_clip("135_04", 120)
    sk = motion.skeleton
    cm = motion.length_unit_m / 0.01
    renamed = Skeleton(
        canonical_names(sk),
        sk.parents,
        sk.offsets * cm,
        sk.channels,
        {j: e * cm for j, e in sk.end_sites.items()},
    )
    values = motion.values.copy()
    values[:, :3] *= cm  # the root's position channels
    path = tmp_path / "135_04.bvh"
    write_bvh(Motion(renamed, values, motion.frame_time_s, None, "135_04"), path)
    from_bvh = read_bvh(path)
    assert from_bvh.length_unit_m is None
    a = retarget(motion, avatar)
    b = retarget(from_bvh, avatar)
    np.testing.assert_allclose(b.joint_positions, a.joint_positions, atol=1e-4)


# -- exporting and errors -------------------------------------------------------------
def test_animation_to_motion_round_trips(avatar):
    anim = retarget(cmu_clip("02_04", 60), avatar)
    motion = animation_to_motion(anim, avatar)
    pose = forward_kinematics(motion, ground=False)
    np.testing.assert_allclose(pose.positions, anim.joint_positions, atol=1e-9)
    np.testing.assert_allclose(pose.rotations, anim.joint_rotations, atol=1e-9)


def test_pose_refuses_an_animation_of_another_body(avatar):
    tall = avatar.with_shape(height_m=1.9)
    anim = retarget(cmu_clip("02_01", 10), tall)
    assert pose_avatar(tall, anim).shape == (10, tall.n_vertices, 3)
    with pytest.raises(InvalidParameterError, match="retarget"):
        pose_avatar(avatar, anim)


def test_animation_checks_its_arrays():
    with pytest.raises(InvalidParameterError, match="joint_positions"):
        AvatarAnimation(("a", "b"), [-1, 0], np.zeros((3, 2, 3)), np.zeros((2, 2, 3, 3)), 0.1, {})
    with pytest.raises(InvalidParameterError, match="frame_time_s"):
        AvatarAnimation(("a",), [-1], np.zeros((1, 1, 3)), np.zeros((1, 1, 3, 3)), 0.0, {})


def test_animate_is_retarget_then_pose(avatar):
    motion = cmu_clip("09_01", 20)
    anim, vertices = animate_avatar(avatar, motion)
    np.testing.assert_array_equal(vertices, pose_avatar(avatar, retarget(motion, avatar)))
    assert anim.name == motion.name
