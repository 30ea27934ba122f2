"""Keyframe engine (eigmotion.synth.authoring) and the authored basic motions it produces."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from eigmotion.errors import EigmotionError, InvalidParameterError
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.canonical import CANONICAL_JOINTS, canonical_skeleton
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.rotations import euler_to_matrix
from eigmotion.synth.authoring import (
    GRAVITY_M_S2,
    aim_deg,
    animate,
    body_surface_points,
    foot_target,
    foot_targets,
    lowest_point_m,
    rest_positions_m,
    standing_root_height_m,
)
from eigmotion.synth.keyframes import Key, Target
from eigmotion.synth.limb_ik import two_bone_ik

REPO = Path(__file__).resolve().parents[1]
AUTHORED = REPO / "database" / "motions" / "authored"

#: Motions in which both feet stay planted from start to end: those of these labels
#: but the ones that step.
PLANTED_PREFIXES = ("lift_", "sit_down_", "cover_head_", "pick_up_", "wave_")
STEPPING = (
    "cover_head_stepping_back",
    "cover_head_kneeling_on_one_knee",
    "pick_up_walking_in",
    "pick_up_walking_in_crouching",
    "pick_up_jogging_in",
)

#: Motions with phases in which nothing touches the floor: jumps, runs and a pick-up
#: jogged up to.
FLYING_PREFIXES = ("jump_", "run_", "pick_up_jogging_")

#: Labels with authored motions.
AUTHORED_LABELS = (
    "lift",
    "sit_down",
    "cover_head",
    "fall_down",
    "run",
    "jump",
    "turn",
    "wave",
    "pick_up",
    "punch",
    "kick",
)

#: A foot point this close to the floor touches it, metres.
TOUCHING_M = 0.02


def _load_generator():
    spec = importlib.util.spec_from_file_location("authored_generate", AUTHORED / "generate.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def generator():
    return _load_generator()


@pytest.fixture(scope="module")
def regenerated(generator, tmp_path_factory):
    out = tmp_path_factory.mktemp("authored")
    return {p.stem: p for p in generator.write_all(out)}


@pytest.fixture(scope="module")
def authored_poses():
    """FK of every shipped authored BVH, not re-grounded (the file's own floor)."""
    out = {}
    for path in sorted(AUTHORED.glob("*.bvh")):
        motion = read_bvh(path)
        out[path.stem] = (motion, forward_kinematics(motion, ground=False))
    return out


@pytest.fixture(scope="module")
def skeleton():
    return canonical_skeleton()


def _joint(pose, name):
    return pose.positions[:, pose.names.index(name)]


# -- the shipped files ---------------------------------------------------------------------------


def test_every_generated_motion_is_shipped(generator):
    shipped = {p.stem for p in AUTHORED.glob("*.bvh")}
    assert shipped == set(generator.MOTIONS)


def test_shipped_bvhs_equal_a_fresh_generation(regenerated):
    """Running generate.py reproduces the shipped BVH files."""
    assert regenerated
    for name, fresh_path in regenerated.items():
        shipped = read_bvh(AUTHORED / f"{name}.bvh")
        fresh = read_bvh(fresh_path)
        assert shipped.skeleton.names == fresh.skeleton.names
        np.testing.assert_allclose(shipped.skeleton.offsets, fresh.skeleton.offsets, atol=1e-6)
        assert shipped.n_frames == fresh.n_frames
        assert shipped.frame_time_s == pytest.approx(fresh.frame_time_s)
        # Compare rotations, not Euler angles (equal rotations may have other angles).
        np.testing.assert_allclose(
            shipped.local_rotations(), fresh.local_rotations(), atol=1e-5, err_msg=name
        )
        np.testing.assert_allclose(
            shipped.local_translations(), fresh.local_translations(), atol=1e-5, err_msg=name
        )


def test_authored_durations_and_rate(authored_poses):
    for name, (motion, _) in authored_poses.items():
        assert 1.5 <= motion.duration_s <= 4.0, name
        assert motion.fps == pytest.approx(30.0), name
        assert motion.skeleton.names == CANONICAL_JOINTS


@pytest.mark.parametrize("label", AUTHORED_LABELS)
def test_several_variations_per_label(generator, label):
    names = [n for n in generator.MOTIONS if n.startswith(label + "_")]
    assert 2 <= len(names) <= 10


def test_nothing_sinks_below_the_floor(authored_poses):
    for name, (_, pose) in authored_poses.items():
        assert pose.all_points()[..., 1].min() >= -0.01, name


def _feet_points(pose):
    names = ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase")
    joints = [pose.names.index(n) for n in names]
    ends = [i for i, j in enumerate(pose.end_site_joints) if pose.names[j] in names]
    return np.concatenate([pose.positions[:, joints], pose.end_sites[:, ends]], axis=1)


def _airborne(pose):
    """(F,) bool: no joint or end site within TOUCHING_M of the floor."""
    return pose.all_points()[..., 1].min(axis=1) > TOUCHING_M


def test_feet_on_the_floor_while_standing(authored_poses):
    """Standing phase: the hips above 0.5 m, i.e. the legs bear the weight; only the
    flight of a jump or a running (jogging) stride leaves the floor."""
    for name, (_, pose) in authored_poses.items():
        standing = _joint(pose, "Hips")[:, 1] > 0.5
        assert standing[0], name
        flying = _airborne(pose) & standing
        assert not flying.any() or name.startswith(FLYING_PREFIXES), name
        lowest_foot = _feet_points(pose)[standing & ~flying, :, 1].min(axis=1)
        assert lowest_foot.max() <= TOUCHING_M, name


def _runs(mask):
    """[start, stop) of each run of True in a (F,) bool array."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2], strict=True))


def test_jumps_and_runs_fly_under_gravity(authored_poses):
    """In flight the hips fall with g: second differences of their height -g dt²."""
    checked = 0
    for name, (motion, pose) in authored_poses.items():
        if not name.startswith(FLYING_PREFIXES):
            continue
        flights = [(a, b) for a, b in _runs(_airborne(pose)) if b - a >= 3]
        assert flights, name
        for a, b in flights:
            accel = np.diff(_joint(pose, "Hips")[a:b, 1], 2) / motion.frame_time_s**2
            np.testing.assert_allclose(accel, -GRAVITY_M_S2, atol=0.05, err_msg=name)
        checked += 1
    assert checked >= 6


def test_feet_on_the_floor_do_not_slide(authored_poses):
    """While the legs bear the weight, the ball of a foot on the floor stays put (it
    may roll up onto it, swing and land elsewhere)."""
    for name, (_, pose) in authored_poses.items():
        standing = _joint(pose, "Hips")[:, 1] > 0.5
        for foot in ("LeftToeBase", "RightToeBase"):
            ball = _joint(pose, foot)
            for a, b in _runs((ball[:, 1] < 0.003) & standing):
                drift = np.linalg.norm(ball[a:b, [0, 2]] - ball[a, [0, 2]], axis=1).max()
                assert drift < 0.012, (name, foot, int(a), int(b), drift)


def test_knees_bend_forwards_within_their_range(authored_poses):
    """The knee stays in front of the hip-ankle line and bends at most 140 degrees."""
    for name, (_, pose) in authored_poses.items():
        for side in ("Left", "Right"):
            hip, knee, ankle = (_joint(pose, side + n) for n in ("UpLeg", "Leg", "Foot"))
            axis = (ankle - hip) / np.linalg.norm(ankle - hip, axis=1, keepdims=True)
            off = (knee - hip) - np.sum((knee - hip) * axis, axis=1, keepdims=True) * axis
            thigh_forward = pose.rotations[:, pose.names.index(side + "UpLeg"), :, 2]
            assert np.sum(off * thigh_forward, axis=1).min() > -0.005, (name, side)
            thigh, shin = knee - hip, ankle - knee
            cos = np.sum(thigh * shin, axis=1) / (
                np.linalg.norm(thigh, axis=1) * np.linalg.norm(shin, axis=1)
            )
            assert np.degrees(np.arccos(np.clip(cos, -1, 1))).max() <= 140.0, (name, side)


@pytest.mark.parametrize("prefix", PLANTED_PREFIXES)
def test_planted_feet_do_not_slide(authored_poses, prefix):
    checked = 0
    for name, (_, pose) in authored_poses.items():
        if not name.startswith(prefix) or name in STEPPING:
            continue
        # The ball of the foot: a heel may come up about it (squatting deep).
        for foot in ("LeftToeBase", "RightToeBase"):
            xz = _joint(pose, foot)[:, [0, 2]]
            assert np.linalg.norm(xz - xz[0], axis=1).max() < 0.01, (name, foot)
        checked += 1
    assert checked >= 2


def _segment_distance(points, a, b):
    ab = b - a
    t = np.clip(np.sum((points - a) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[..., None] * ab), axis=-1)


def test_hands_stay_outside_the_torso(authored_poses):
    """Hand joints keep >= 9 cm from the spine line (the belly is 12-17 cm in front)."""
    spine = ("Hips", "LowerBack", "Spine", "Spine1", "Neck")
    for name, (_, pose) in authored_poses.items():
        for hand in ("LeftHand", "LeftFingerBase", "RightHand", "RightFingerBase"):
            p = _joint(pose, hand)
            d = min(
                _segment_distance(p, _joint(pose, a), _joint(pose, b)).min()
                for a, b in zip(spine[:-1], spine[1:], strict=True)
            )
            assert d >= 0.09, (name, hand, d)


def _segment_to_segment(a0, a1, b0, b1, samples=21):
    """(F,) distance between segments a0-a1 and b0-b1 (sampled along the first)."""
    return np.min(
        [_segment_distance(a0 + s * (a1 - a0), b0, b1) for s in np.linspace(0.0, 1.0, samples)],
        axis=0,
    )


def test_arms_do_not_pass_through_the_legs(authored_poses):
    """Forearm and hand bones keep >= 6 cm from the thigh and shin bones."""
    for name, (_, pose) in authored_poses.items():
        for arm in ("Left", "Right"):
            for a, b in (("ForeArm", "Hand"), ("Hand", "FingerBase")):
                for leg in ("Left", "Right"):
                    for c, d in (("UpLeg", "Leg"), ("Leg", "Foot")):
                        d_min = _segment_to_segment(
                            _joint(pose, arm + a),
                            _joint(pose, arm + b),
                            _joint(pose, leg + c),
                            _joint(pose, leg + d),
                        ).min()
                        assert d_min >= 0.06, (name, arm + a, leg + c, d_min)


def test_hands_stay_outside_the_head(authored_poses):
    for name, (_, pose) in authored_poses.items():
        head = pose.rotations[:, pose.names.index("Head")]
        centre = _joint(pose, "Head") + np.einsum("fab,b->fa", head, [0.0, 0.08, 0.03])
        for hand in ("LeftHand", "RightHand"):
            assert np.linalg.norm(_joint(pose, hand) - centre, axis=1).min() >= 0.09, name


@pytest.mark.parametrize(
    "name",
    ["sit_down_holding_stomach_slow", "sit_down_holding_stomach_fast", "sit_down_doubled_over"],
)
def test_sitting_ends_on_a_chair_with_hands_on_the_stomach(authored_poses, generator, name):
    _, pose = authored_poses[name]
    hips = _joint(pose, "Hips")[-1]
    # The buttocks (about 0.11 m under the hip joint) rest at seat height.
    assert hips[1] - 0.11 == pytest.approx(generator.SEAT_HEIGHT_M, abs=0.03)
    lower_back = pose.rotations[-1, pose.names.index("LowerBack")]
    for hand in ("LeftHand", "RightHand"):
        local = lower_back.T @ (_joint(pose, hand)[-1] - _joint(pose, "LowerBack")[-1])
        assert 0.05 <= local[2] <= 0.2 and -0.05 <= local[1] <= 0.25, (hand, local)


@pytest.mark.parametrize(
    "name", ["cover_head_standing", "cover_head_crouching", "cover_head_stepping_back"]
)
def test_cover_head_ends_with_both_hands_on_the_crown(authored_poses, name):
    _, pose = authored_poses[name]
    crown = pose.end_sites[-1, list(pose.end_site_joints).index(pose.names.index("Head"))]
    for hand in ("LeftHand", "RightHand"):
        assert np.linalg.norm(_joint(pose, hand)[-1] - crown) < 0.15


@pytest.mark.parametrize(
    "name", ["fall_down_forwards", "fall_down_backwards", "fall_down_sideways"]
)
def test_falls_end_lying_on_the_floor(authored_poses, name):
    _, pose = authored_poses[name]
    assert _joint(pose, "Head")[0, 1] > 1.4
    assert _joint(pose, "Head")[-1, 1] < 0.5
    assert _joint(pose, "Hips")[-1, 1] < 0.3


def test_cover_head_one_arm_over_the_crown_the_other_before_the_face(authored_poses):
    _, pose = authored_poses["cover_head_one_arm"]
    crown = pose.end_sites[-1, list(pose.end_site_joints).index(pose.names.index("Head"))]
    assert np.linalg.norm(_joint(pose, "RightHand")[-1] - crown) < 0.15
    head = pose.rotations[-1, pose.names.index("Head")]
    face = head.T @ (_joint(pose, "LeftHand")[-1] - _joint(pose, "Head")[-1])
    assert face[2] >= 0.15 and abs(face[0]) <= 0.1 and abs(face[1]) <= 0.15, face


#: Straight punches: the motion and the arm that throws them.
STRAIGHT_PUNCHES = [
    ("punch_straight_alternating", "Left"),
    ("punch_straight_alternating", "Right"),
    ("punch_jab_cross", "Left"),
    ("punch_jab_cross", "Right"),
    ("punch_stepping_in", "Right"),
]


@pytest.mark.parametrize(("name", "side"), STRAIGHT_PUNCHES)
def test_straight_punches_hit_with_the_arm_straight_and_fast(authored_poses, name, side):
    """At each hit (the wrist at 97 % of the arm's length from the shoulder, no lower
    than 15 cm under it) the elbow is straight to within 10 degrees, and the wrist got
    there from half the arm's length in 0.1-0.25 s."""
    motion, pose = authored_poses[name]
    shoulder, elbow, wrist = (_joint(pose, side + n) for n in ("Arm", "ForeArm", "Hand"))
    length = np.linalg.norm(elbow[0] - shoulder[0]) + np.linalg.norm(wrist[0] - elbow[0])
    reach = np.linalg.norm(wrist - shoulder, axis=1) / length
    out = (reach >= 0.97) & (wrist[:, 1] >= shoulder[:, 1] - 0.15)
    hits = [a for a, _ in _runs(out)]
    assert hits, (name, side)
    upper, fore = shoulder - elbow, wrist - elbow
    cos = np.sum(upper * fore, axis=1) / (
        np.linalg.norm(upper, axis=1) * np.linalg.norm(fore, axis=1)
    )
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    for hit in hits:
        assert angle[hit : hit + 3].max() >= 170.0, (name, side, hit)
        start = np.flatnonzero(reach[:hit] <= 0.5)[-1]
        assert 0.1 <= (hit - start) * motion.frame_time_s <= 0.25, (name, side, hit, start)


@pytest.mark.parametrize(
    ("name", "top_m"), [("lift_table_to_shoulder", 1.15), ("lift_clean_and_press", 1.65)]
)
def test_heavy_lifts_end_high_from_a_wide_stance(authored_poses, name, top_m):
    """A heavy load ends at the shoulders or overhead (a pick-up ends at the waist),
    lifted with the feet wider apart than at rest (0.36 m between the ankles)."""
    _, pose = authored_poses[name]
    for hand in ("LeftHand", "RightHand"):
        assert _joint(pose, hand)[-1, 1] >= top_m, hand
    stance = np.linalg.norm(_joint(pose, "LeftFoot")[0] - _joint(pose, "RightFoot")[0])
    assert stance >= 0.45


def test_sitting_down_normally_ends_with_the_hands_on_the_knees(authored_poses, generator):
    _, pose = authored_poses["sit_down_hands_on_knees"]
    assert _joint(pose, "Hips")[-1, 1] - 0.11 == pytest.approx(generator.SEAT_HEIGHT_M, abs=0.03)
    for side in ("Left", "Right"):
        to_knee = _joint(pose, side + "Hand")[-1] - _joint(pose, side + "Leg")[-1]
        assert np.linalg.norm(to_knee) < 0.2 and to_knee[1] > 0.05, side


def test_sitting_on_the_floor_ends_on_the_seat_feet_and_hands(authored_poses):
    _, pose = authored_poses["sit_down_on_the_floor"]
    # The buttocks (about 0.11 m under the hip joint) on the floor, knees up.
    assert _joint(pose, "Hips")[-1, 1] - 0.11 == pytest.approx(0.0, abs=0.03)
    for side in ("Left", "Right"):
        assert _joint(pose, side + "Foot")[-1, 1] <= 0.07, side
        assert _joint(pose, side + "Leg")[-1, 1] >= 0.3, side
        assert _joint(pose, side + "Hand")[-1, 1] <= 0.1, side


# -- the engine ----------------------------------------------------------------------------------


def test_rest_keys_stand_on_the_floor(skeleton):
    motion = animate([Key(0.0), Key(1.0)], skeleton, fps=30.0)
    assert motion.n_frames == 31
    assert motion.length_unit_m == 1.0
    pose = forward_kinematics(motion, ground=False)
    assert pose.all_points()[..., 1].min(axis=1) == pytest.approx(np.zeros(31), abs=1e-9)
    np.testing.assert_allclose(pose.rotations, np.broadcast_to(np.eye(3), pose.rotations.shape))
    assert _joint(pose, "Hips")[:, 1] == pytest.approx(standing_root_height_m(skeleton))


@pytest.mark.parametrize("order", ["ZXY", "XYZ", "YZX"])
@pytest.mark.parametrize("fps", [24.0, 30.0, 60.0])
def test_interpolation_passes_through_the_keys(skeleton, order, fps):
    angles = {"LowerBack": (30.0, 10.0, -5.0), "LeftArm": (-40.0, 20.0, 35.0)}
    keys = [Key(0.0), Key(0.5, angles), Key(1.5, {"LowerBack": (0, 0, 0)})]
    motion = animate(keys, skeleton, fps=fps, order=order, ground=False)
    frame = round(0.5 * fps)
    local = motion.local_rotations()[frame]
    perm = ["XYZ".index(a) for a in order]
    for joint, xyz in angles.items():
        want = euler_to_matrix(np.asarray(xyz)[perm], order)
        np.testing.assert_allclose(local[skeleton.index(joint)], want, atol=1e-6)


def test_interpolation_does_not_overshoot(skeleton):
    keys = [
        Key(0.0),
        Key(0.4, {"LeftLeg": (60, 0, 0)}),
        Key(0.9, {}),
        Key(1.5, {"LeftLeg": (0, 0, 0)}),
    ]
    motion = animate(keys, skeleton, ground=False)
    knee = motion.local_rotations()[:, skeleton.index("LeftLeg")]
    angle = np.degrees(Rotation.from_matrix(knee).magnitude())
    assert angle.max() <= 60.0 + 1e-6
    assert angle[0] == pytest.approx(0.0, abs=1e-6) and angle[-1] == pytest.approx(0.0, abs=1e-6)


def test_unnamed_joints_hold_their_previous_rotation(skeleton):
    keys = [Key(0.0, {"Head": (20, 0, 0)}), Key(1.0, {"Spine": (10, 0, 0)})]
    motion = animate(keys, skeleton, ground=False)
    head = motion.local_rotations()[:, skeleton.index("Head")]
    np.testing.assert_allclose(head, np.broadcast_to(head[0], head.shape), atol=1e-9)


@pytest.mark.parametrize("drop_m", [0.1, 0.3, 0.45])
def test_planted_feet_stay_while_the_hips_go_down(skeleton, drop_m):
    feet = foot_targets(skeleton, extra_width_m=0.05, toe_out_deg=10.0)
    keys = [
        Key(0.0, targets=feet),
        Key(1.0, {}, (0.0, -drop_m, -0.3 * drop_m)),
        Key(2.0, {}, (0, 0, 0)),
    ]
    pose = forward_kinematics(animate(keys, skeleton), ground=False)
    for foot, target in feet.items():
        np.testing.assert_allclose(
            _joint(pose, foot), np.broadcast_to(target.position_m, (pose.n_frames, 3)), atol=2e-3
        )
    hips = _joint(pose, "Hips")[:, 1]
    assert hips.min() == pytest.approx(standing_root_height_m(skeleton) - drop_m, abs=0.02)
    # The knees bend forwards, never backwards.
    for knee, hip in (("LeftLeg", "LeftUpLeg"), ("RightLeg", "RightUpLeg")):
        assert np.all(_joint(pose, knee)[:, 2] >= _joint(pose, hip)[:, 2] - 0.01)


@pytest.mark.parametrize("frame", [None, "Spine1", "Head"])
def test_hand_targets_are_reached(skeleton, frame):
    target = (0.2, -0.1, 0.35) if frame else (0.25, 1.2, 0.35)
    keys = [
        Key(0.0, {"LowerBack": (0, 0, 0)}),
        Key(1.0, {"LowerBack": (20, 0, 0)}, targets={"LeftHand": Target(target, frame)}),
        Key(1.5, {}),
    ]
    pose = forward_kinematics(animate(keys, skeleton, ground=False), ground=False)
    hand = _joint(pose, "LeftHand")[30]
    if frame is None:
        want = np.asarray(target)
    else:
        j = pose.names.index(frame)
        want = pose.positions[30, j] + pose.rotations[30, j] @ np.asarray(target)
    np.testing.assert_allclose(hand, want, atol=2e-3)
    # The untargeted arm is untouched by IK.
    assert _joint(pose, "RightHand")[0] == pytest.approx(rest_positions_m(skeleton)["RightHand"])


def test_target_rotation_sets_the_end_joint_orientation(skeleton):
    feet = foot_targets(skeleton, heel_raise_deg=40.0)
    keys = [Key(0.0, targets=foot_targets(skeleton)), Key(1.0, {}, (0, -0.1, 0), feet)]
    pose = forward_kinematics(animate(keys, skeleton, ground=False), ground=False)
    foot = pose.rotations[-1, pose.names.index("LeftFoot")]
    np.testing.assert_allclose(foot, euler_to_matrix([40.0, 0.0, 0.0], "XYZ"), atol=1e-6)


def test_heel_raise_pivots_about_the_ball_of_the_foot(skeleton):
    rest = rest_positions_m(skeleton)
    for heel_deg in (0.0, 30.0, 75.0):
        target = foot_targets(skeleton, heel_raise_deg=heel_deg)["LeftFoot"]
        rot = euler_to_matrix(np.asarray(target.rotation_deg)[[2, 0, 1]], "ZXY")
        ball = np.asarray(target.position_m) + rot @ (rest["LeftToeBase"] - rest["LeftFoot"])
        np.testing.assert_allclose(ball, rest["LeftToeBase"], atol=1e-9)


@pytest.mark.parametrize("yaw_deg", [0.0, 35.0, -120.0, 180.0])
def test_foot_target_turns_about_the_ankle_and_pivots_about_the_ball(skeleton, yaw_deg):
    rest = rest_positions_m(skeleton)
    to_ball = rest["LeftToeBase"] - rest["LeftFoot"]
    flat = foot_target("LeftFoot", (0.3, -0.4), yaw_deg, skeleton=skeleton)
    np.testing.assert_allclose(flat.position_m, [0.3, rest["LeftFoot"][1], -0.4], atol=1e-12)
    balls = []
    for heel_deg, lift_m in ((0.0, 0.0), (30.0, 0.0), (60.0, 0.0), (30.0, 0.1)):
        target = foot_target("LeftFoot", (0.3, -0.4), yaw_deg, heel_deg, lift_m, skeleton)
        rot = euler_to_matrix(np.asarray(target.rotation_deg)[[2, 0, 1]], "ZXY")
        balls.append(np.asarray(target.position_m) + rot @ to_ball - [0.0, lift_m, 0.0])
        # The toes point along the turned heading, pitched down by the heel raise.
        toes = rot @ [0.0, 0.0, 1.0]
        heading = np.degrees(np.arctan2(toes[0], toes[2]))
        assert (heading - yaw_deg + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-9)
        assert np.degrees(np.arcsin(-toes[1])) == pytest.approx(heel_deg, abs=1e-9)
    np.testing.assert_allclose(balls, np.broadcast_to(balls[0], (4, 3)), atol=1e-12)


def test_foot_targets_are_foot_target_either_side(skeleton):
    rest = rest_positions_m(skeleton)
    feet = foot_targets(skeleton, extra_width_m=0.05, toe_out_deg=10.0, shift_m=(0, 0, 0.2))
    for side, joint in ((1.0, "LeftFoot"), (-1.0, "RightFoot")):
        x = rest[joint][0] + side * 0.05
        one = foot_target(joint, (x, rest[joint][2] + 0.2), side * 10.0, skeleton=skeleton)
        np.testing.assert_allclose(feet[joint].position_m, one.position_m, atol=1e-12)
        np.testing.assert_allclose(feet[joint].rotation_deg, one.rotation_deg, atol=1e-9)


def test_flights_follow_a_ballistic_arc(skeleton):
    take_off, landing = 0.3, 0.7
    motion = animate([Key(0.0), Key(1.0)], skeleton, flights_s=[(take_off, landing)])
    t = np.arange(motion.n_frames) * motion.frame_time_s
    height = np.where(
        (t > take_off) & (t < landing),
        0.5 * GRAVITY_M_S2 * (t - take_off) * (landing - t),
        0.0,
    )
    root = motion.local_translations()[:, 0, 1]
    np.testing.assert_allclose(root, standing_root_height_m(skeleton) + height, atol=1e-9)


def test_flights_join_take_off_and_landing_heights(skeleton):
    keys = [Key(0.0), Key(0.5, {}, (0.0, -0.2, 0.0)), Key(1.0, {}, (0.0, 0.0, 0.0))]
    grounded = animate(keys, skeleton, ground=False).local_translations()[:, 0, 1]
    flying = animate(keys, skeleton, ground=False, flights_s=[(0.2, 0.8)])
    root = flying.local_translations()[:, 0, 1]
    t = np.arange(len(root)) / 30.0
    outside = (t <= 0.2) | (t >= 0.8)
    np.testing.assert_allclose(root[outside], grounded[outside], atol=1e-12)
    accel = np.diff(root[(t > 0.2) & (t < 0.8)], 2) * 30.0**2
    np.testing.assert_allclose(accel, -GRAVITY_M_S2, atol=1e-6)


@pytest.mark.parametrize(
    "flights",
    [
        [(0.5, 0.4)],
        [(0.2, 0.6), (0.5, 0.8)],
        [(-0.1, 0.5)],
        [(0.5, 1.5)],
        [(0.1,)],
        [(0.1, float("nan"))],
        "soon",
    ],
)
def test_bad_flights_raise(skeleton, flights):
    with pytest.raises(InvalidParameterError, match="flights_s"):
        animate([Key(0.0), Key(1.0)], skeleton, flights_s=flights)


def test_ground_puts_the_lowest_point_on_the_floor(skeleton):
    points = body_surface_points()
    keys = [Key(0.0), Key(1.0, {"Hips": (80, 0, 0)}, (0.0, -0.6, 0.5))]
    motion = animate(keys, skeleton, contact_points_m=points)
    local = motion.local_rotations()
    root = motion.local_translations()[:, 0]
    np.testing.assert_allclose(lowest_point_m(skeleton, local, root, points), 0.0, atol=1e-9)
    # Lying face down, the chest rests on its skin, above the spine joints.
    pose = forward_kinematics(motion, ground=False)
    assert _joint(pose, "Spine1")[-1, 1] > 0.05


def test_body_surface_points():
    points = body_surface_points()
    assert set(points) <= set(CANONICAL_JOINTS)
    assert "LeftFoot" not in points and "Head" in points
    for joint, pts in points.items():
        assert pts.ndim == 2 and pts.shape[1] == 3 and 1 <= len(pts) <= 26, joint
        assert np.abs(pts).max() < 0.5, joint
    # The crown lies about 0.15 m above the Head joint.
    assert points["Head"][:, 1].max() == pytest.approx(0.152, abs=0.01)


def test_two_bone_ik_keeps_bone_lengths(rng):
    a = rng.normal(size=(50, 3))
    b = a + rng.normal(size=(50, 3)) * 0.3
    c = b + rng.normal(size=(50, 3)) * 0.3
    l1 = np.linalg.norm(b - a, axis=1)
    l2 = np.linalg.norm(c - b, axis=1)
    reach = rng.uniform(np.abs(l1 - l2) + 0.01, l1 + l2 - 0.01)
    direction = rng.normal(size=(50, 3))
    t = a + direction / np.linalg.norm(direction, axis=1, keepdims=True) * reach[:, None]
    mid, end = two_bone_ik(a, b, c, t)
    np.testing.assert_allclose(end, t, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(mid - a, axis=1), l1, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(end - mid, axis=1), l2, atol=1e-9)


def test_two_bone_ik_out_of_reach_points_at_the_target():
    a, b, c = np.zeros((1, 3)), np.array([[0, -0.4, 0.0]]), np.array([[0, -0.8, 0.0]])
    mid, end = two_bone_ik(a, b, c, np.array([[0.0, 0.0, 2.0]]), pole_hint=[0.0, -1.0, 0.0])
    np.testing.assert_allclose(end, [[0, 0, 0.8]], atol=1e-6)
    np.testing.assert_allclose(mid, [[0, 0, 0.4]], atol=1e-3)


def test_aim_deg_turns_vectors_onto_targets():
    rest = [(0.24, -0.43, 0.87), (-0.84, -0.52, -0.15)]
    want = [(-1.0, 0.0, 0.0), (0.0, 0.0, -1.0)]
    for order in ("ZXY", "XYZ"):
        xyz = aim_deg(rest, want, order)
        rot = euler_to_matrix(np.asarray(xyz)[["XYZ".index(a) for a in order]], order)
        np.testing.assert_allclose(
            rot @ np.asarray(rest[0]) / np.linalg.norm(rest[0]), want[0], atol=1e-9
        )


# -- errors ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("keys", "match"),
    [
        ([Key(0.0)], "at least 2 keys"),
        ([Key(0.0), Key(0.0)], "increase strictly"),
        ([Key(1.0), Key(0.5)], "increase strictly"),
        ([Key(0.0, {"Tail": (1, 2, 3)}), Key(1.0)], "Tail"),
        ([Key(0.0, targets={"Hips": Target((0, 1, 0))}), Key(1.0)], "two-bone limb"),
        (
            [
                Key(0.0, targets={"LeftHand": Target((0, 1, 0)), "LeftForeArm": Target((0, 1, 0))}),
                Key(1.0),
            ],
            "overlap",
        ),
        (
            [
                Key(0.0, targets={"LeftHand": Target((0, 1, 0), "Spine")}),
                Key(1.0, targets={"LeftHand": Target((0, 1, 0), "Head")}),
            ],
            "several frames",
        ),
        (
            [
                Key(
                    0.0,
                    targets={
                        "LeftHand": Target((0, 1, 0), "RightHand"),
                        "RightHand": Target((0, 1, 0)),
                    },
                ),
                Key(1.0),
            ],
            "IK limb moves",
        ),
    ],
)
def test_bad_keys_raise(skeleton, keys, match):
    with pytest.raises(InvalidParameterError, match=match):
        animate(keys, skeleton)


@pytest.mark.parametrize(
    "make",
    [
        lambda: Key(float("nan")),
        lambda: Key(0.0, {"Head": (1, 2)}),
        lambda: Key(0.0, {"Head": (1, 2, float("inf"))}),
        lambda: Key(0.0, root_offset_m=(0, 1)),
        lambda: Key(0.0, targets={"LeftHand": (0, 1, 0)}),
        lambda: Target((0, 1)),
        lambda: Target((0, 1, 0), rotation_deg=(0, float("nan"), 0)),
        lambda: animate([Key(0.0), Key(1.0)], fps=0.0),
        lambda: animate([Key(0.0), Key(1.0)], order="XXY"),
    ],
)
def test_bad_values_raise_project_errors(make):
    with pytest.raises(EigmotionError):
        make()
