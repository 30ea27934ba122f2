"""Author the keyframed basic motions and write them as BVH files next to this script.

No free motion capture shows some basic motions (covering the head, falling, lifting a
heavy load, sitting down holding the stomach), and the CMU clips show the others done
one way; these motions and the other ways of doing them (jumps, turns, waves, pick-ups,
punches, kicks, lifts, sitting down, covering the head) are authored on the default avatar's
skeleton (:func:`eigmotion.mocap.canonical.canonical_skeleton`) with
:mod:`eigmotion.synth.authoring`: a few key poses each, interpolated at 30 fps, feet planted
by two-bone IK, every frame resting on the floor except in the flight of a jump or a
running stride.
Motions made of steps key each foot, the hips and the joints on their own times
(tracks) and are sampled into a key per frame; a single step among key poses is keyed
as foot targets (heel up, swing, down flat).

Run from anywhere (the output is the same every time)::

    python database/motions/authored/generate.py            # rewrite the BVHs here
    python database/motions/authored/generate.py --out DIR  # write them elsewhere

Key rotations are Euler degrees ``(x, y, z)`` relative to rest, composed ``ZXY``;
positive x bends the spine forwards and swings a hanging limb backwards, positive z
raises the left arm sideways (lowers the right), positive y turns to the body's left.
Distances are metres; the body stands at the origin facing +Z, its left towards +X.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.spatial.transform import Rotation

from eigmotion.mocap.bvh import write_bvh
from eigmotion.mocap.canonical import canonical_skeleton
from eigmotion.mocap.motion import Motion
from eigmotion.mocap.rotations import euler_to_matrix, matrix_to_euler
from eigmotion.synth.authoring import (
    DEFAULT_FPS,
    aim_deg,
    animate,
    body_surface_points,
    foot_target,
    foot_targets,
    rest_positions_m,
)
from eigmotion.synth.keyframes import Key, Target, unwrap_rotvecs

HERE = Path(__file__).resolve().parent

#: Seat height of the chair for sit_down, metres (a common chair).
SEAT_HEIGHT_M = 0.45
#: Height of the low step sit_down_low_step sits on, metres (a doorstep, a kerb).
LOW_STEP_HEIGHT_M = 0.25

# The left hand at rest, measured on the MakeHuman mesh: wrist → middle fingertip, and
# the palm normal (the palm faces the thigh, slightly down); the right hand mirrors it.
LEFT_FINGERS_REST = (0.24, -0.43, 0.87)
LEFT_PALM_REST = (-0.84, -0.52, -0.15)


def _hand_deg(side: float, fingers, palm) -> tuple[float, float, float]:
    """Rotation of a hand (side +1 left, -1 right) pointing its fingers and palm."""
    mirror = (side, 1.0, 1.0)
    rest = [
        [m * v for m, v in zip(mirror, vec, strict=True)]
        for vec in (LEFT_FINGERS_REST, LEFT_PALM_REST)
    ]
    want = [[m * v for m, v in zip(mirror, vec, strict=True)] for vec in (fingers, palm)]
    return aim_deg(rest, want)


# Arms hanging relaxed at the sides (the rest pose holds them 45° out).
ARMS_DOWN = {
    "LeftArm": (0.0, 0.0, -30.0),
    "RightArm": (0.0, 0.0, 30.0),
    "LeftForeArm": (30.0, 0.0, 0.0),
    "RightForeArm": (30.0, 0.0, 0.0),
}
SPINE_STRAIGHT = {
    "LowerBack": (0.0, 0.0, 0.0),
    "Spine": (0.0, 0.0, 0.0),
    "Spine1": (0.0, 0.0, 0.0),
    "Neck": (0.0, 0.0, 0.0),
    "Head": (0.0, 0.0, 0.0),
}


def _animate(keys: list[Key], name: str) -> Motion:
    return animate(keys, contact_points_m=body_surface_points(), name=name)


def _planted(**kwargs) -> dict[str, Target]:
    return foot_targets(**kwargs)


# -- lift a heavy load -------------------------------------------------------------------------


#: Upper arms holding a load overhead, and holding it at the chest with the elbows down.
LOAD_OVERHEAD = {"LeftArm": (-20, 0, 60), "RightArm": (-20, 0, -60)}
LOAD_AT_CHEST = {"LeftArm": (-45, 0, -25), "RightArm": (-45, 0, 25)}


def _box(y_m: float, z_m: float, half_width_m: float = 0.2) -> dict[str, Target]:
    """Wrist targets gripping a box by its sides, world metres.

    A box on the floor is about 0.4 m tall and gripped near its top edges.
    """
    return {
        "LeftHand": Target((half_width_m, y_m, z_m)),
        "RightHand": Target((-half_width_m, y_m, z_m)),
    }


def pick_up_heavy_box_to_chest() -> Motion:
    """Squat with the knees out, grip a box on the floor, rise slowly with it to the chest."""
    return _animate(
        [
            Key(
                0.0,
                {**ARMS_DOWN, **SPINE_STRAIGHT},
                (0, 0, 0),
                _planted(extra_width_m=0.10, toe_out_deg=15.0),
            ),
            Key(
                0.5,
                {"LowerBack": (12, 0, 0), "Head": (5, 0, 0)},
                (0.0, -0.08, -0.02),
                _box(0.80, 0.32, 0.17),
            ),
            Key(
                1.2,
                {
                    "LowerBack": (30, 0, 0),
                    "Spine": (12, 0, 0),
                    "Neck": (-10, 0, 0),
                    "Head": (-10, 0, 0),
                },
                (0.0, -0.42, -0.14),
                _box(0.38, 0.37, 0.17),
            ),
            Key(1.6, {"LowerBack": (32, 0, 0)}, (0.0, -0.44, -0.15)),
            Key(
                2.5,
                {"LowerBack": (25, 0, 0), "Spine": (8, 0, 0), "Neck": (-5, 0, 0)},
                (0.0, -0.22, -0.08),
                _box(0.62, 0.40, 0.17),
            ),
            Key(
                3.3,
                {
                    "LowerBack": (-6, 0, 0),
                    "Spine": (-2, 0, 0),
                    "Neck": (0, 0, 0),
                    "Head": (0, 0, 0),
                },
                (0.0, -0.01, -0.01),
                _box(1.02, 0.32),
            ),
            Key(3.7, {"LowerBack": (-5, 0, 0)}, (0.0, 0.0, 0.0)),
        ],
        "pick_up_heavy_box_to_chest",
    )


def lift_chest_to_overhead() -> Motion:
    """Holding a box at the chest: dip, press it overhead, hold, lower it to the chest."""
    arms_bent = {"LeftArm": (-20, 0, -10), "RightArm": (-20, 0, 10)}
    return _animate(
        [
            Key(
                0.0, {**arms_bent, **SPINE_STRAIGHT}, (0, 0, 0), {**_planted(), **_box(1.02, 0.30)}
            ),
            Key(0.4, {"LowerBack": (-3, 0, 0)}, (0.0, -0.02, 0.0), _box(1.04, 0.28)),
            Key(0.8, {"LowerBack": (0, 0, 0)}, (0.0, -0.10, -0.02), _box(0.98, 0.28)),
            Key(
                1.4,
                {
                    "LowerBack": (-8, 0, 0),
                    "Spine": (-3, 0, 0),
                    "Neck": (-5, 0, 0),
                    **LOAD_OVERHEAD,
                },
                (0.0, 0.0, 0.0),
                _box(1.78, 0.08),
            ),
            Key(2.0, {"LowerBack": (-7, 0, 0)}, (0.0, 0.0, 0.0), _box(1.80, 0.08)),
            # On the way down the box passes in front of the face, not through the head.
            Key(2.4, {"LowerBack": (-3, 0, 0)}, (0.0, -0.02, 0.0), _box(1.45, 0.40)),
            Key(
                2.8,
                {"LowerBack": (0, 0, 0), "Spine": (0, 0, 0), "Neck": (0, 0, 0), **arms_bent},
                (0.0, -0.04, 0.0),
                _box(1.02, 0.30),
            ),
            Key(3.2, {}, (0.0, 0.0, 0.0), _box(1.02, 0.30)),
        ],
        "lift_chest_to_overhead",
    )


def pick_up_heavy_box_stooping() -> Motion:
    """Wide stance, stoop with a bent back, heave a box from the floor to the waist."""
    return _animate(
        [
            Key(
                0.0,
                {**ARMS_DOWN, **SPINE_STRAIGHT},
                (0, 0, 0),
                _planted(extra_width_m=0.12, toe_out_deg=15.0),
            ),
            Key(
                1.0,
                {
                    "LowerBack": (45, 0, 0),
                    "Spine": (20, 0, 0),
                    "Spine1": (10, 0, 0),
                    "Neck": (-15, 0, 0),
                    "Head": (-10, 0, 0),
                },
                (0.0, -0.26, -0.16),
                _box(0.36, 0.34),
            ),
            Key(1.5, {"LowerBack": (47, 0, 0)}, (0.0, -0.28, -0.17), _box(0.35, 0.34)),
            Key(
                2.5,
                {"LowerBack": (22, 0, 0), "Spine": (8, 0, 0), "Spine1": (4, 0, 0)},
                (0.0, -0.14, -0.10),
                _box(0.64, 0.30),
            ),
            Key(
                3.2,
                {
                    "LowerBack": (-8, 0, 0),
                    "Spine": (-3, 0, 0),
                    "Spine1": (0, 0, 0),
                    "Neck": (0, 0, 0),
                    "Head": (0, 0, 0),
                },
                (0.0, -0.03, 0.0),
                _box(0.88, 0.24),
            ),
            Key(3.6, {"LowerBack": (-6, 0, 0)}, (0.0, -0.02, 0.0), _box(0.89, 0.24)),
        ],
        "pick_up_heavy_box_stooping",
    )


def pick_up_suitcase_one_hand() -> Motion:
    """Squat beside a heavy suitcase, grip its handle with the right hand, stand up with it
    leaning away from the load, the free arm out for balance."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.06)),
            Key(
                0.8,
                {"LowerBack": (28, 0, 10), "Spine": (8, 0, 4), "Head": (10, 0, 0)},
                (-0.07, -0.36, -0.08),
                {"RightHand": Target((-0.34, 0.34, 0.10))},
            ),
            Key(1.2, {"LowerBack": (30, 0, 10)}, (-0.07, -0.37, -0.08)),
            Key(
                2.2,
                {
                    "LowerBack": (2, 0, -8),
                    "Spine": (0, 0, -4),
                    "Head": (0, 0, 4),
                    "LeftArm": (0, 0, 25),
                    "LeftForeArm": (20, 0, 0),
                },
                (0.03, -0.02, 0.0),
                {"RightHand": Target((-0.27, 0.84, 0.03))},
            ),
            Key(2.7, {"LowerBack": (0, 0, -6)}, (0.03, -0.01, 0.0)),
        ],
        "pick_up_suitcase_one_hand",
    )


def lift_table_to_shoulder() -> Motion:
    """Wide stance at a table, lean in and grip a heavy box by its sides at waist height,
    pull it in against the body, dip under it and heave it up to the shoulders."""
    return _animate(
        [
            Key(
                0.0,
                {**ARMS_DOWN, **SPINE_STRAIGHT},
                (0, 0, 0),
                _planted(extra_width_m=0.08, toe_out_deg=10.0),
            ),
            Key(
                0.7,
                {"LowerBack": (22, 0, 0), "Spine": (8, 0, 0), "Head": (5, 0, 0)},
                (0.0, -0.07, -0.06),
                _box(0.86, 0.46),
            ),
            Key(1.1, {"LowerBack": (24, 0, 0)}, (0.0, -0.10, -0.07), _box(0.86, 0.46)),
            Key(
                1.9,
                {"LowerBack": (-4, 0, 0), "Spine": (0, 0, 0), "Head": (0, 0, 0)},
                (0.0, -0.05, -0.01),
                _box(1.0, 0.30),
            ),
            Key(2.4, {"LowerBack": (-6, 0, 0)}, (0.0, -0.13, -0.02), _box(1.06, 0.29)),
            # Elbows down under the box, close to the body.
            Key(
                3.0,
                {
                    "LowerBack": (-8, 0, 0),
                    "Neck": (-5, 0, 0),
                    "LeftArm": (-45, 0, -25),
                    "RightArm": (-45, 0, 25),
                },
                (0.0, 0.0, 0.0),
                _box(1.26, 0.27, 0.19),
            ),
            Key(3.5, {"LowerBack": (-7, 0, 0)}, (0.0, -0.01, 0.0), _box(1.25, 0.27, 0.19)),
        ],
        "lift_table_to_shoulder",
    )


def lift_table_to_shelf() -> Motion:
    """At a table: lean in and grip a box by its sides at waist height, lift it to the
    chest, push it up and forwards onto a shelf above the head, let go, arms down."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.04)),
            Key(
                0.6,
                {"LowerBack": (20, 0, 0), "Spine": (6, 0, 0), "Head": (5, 0, 0)},
                (0.0, -0.06, -0.05),
                _box(0.86, 0.46),
            ),
            Key(1.0, {"LowerBack": (22, 0, 0)}, (0.0, -0.08, -0.06), _box(0.86, 0.46)),
            Key(
                1.6,
                {"LowerBack": (-2, 0, 0), "Spine": (0, 0, 0), "Head": (0, 0, 0), **LOAD_AT_CHEST},
                (0.0, -0.04, 0.0),
                _box(1.08, 0.32),
            ),
            Key(
                2.3,
                {
                    "LowerBack": (-8, 0, 0),
                    "Spine": (-4, 0, 0),
                    "Neck": (-12, 0, 0),
                    **LOAD_OVERHEAD,
                },
                (0.0, 0.0, 0.02),
                _box(1.80, 0.50),
            ),
            Key(2.7, {"LowerBack": (-8, 0, 0)}, (0.0, 0.0, 0.03), _box(1.82, 0.58)),
            Key(
                3.3,
                {**ARMS_DOWN, **SPINE_STRAIGHT},
                (0.0, 0.0, 0.0),
                {"LeftHand": None, "RightHand": None},
            ),
            Key(3.7, {}, (0.0, 0.0, 0.0)),
        ],
        "lift_table_to_shelf",
    )


def lift_bag_onto_overhead_rack() -> Motion:
    """Stow a bag on an overhead rack: holding it by both sides at the hips, dip and
    swing it up to the chest, rise onto the toes pressing it up and forwards onto the
    rack above the head, push it in, let go, heels and arms down."""
    return _animate(
        [
            Key(
                0.0,
                {**ARMS_DOWN, **SPINE_STRAIGHT},
                (0, 0, 0),
                {**_planted(extra_width_m=0.04), **_box(0.86, 0.26, 0.18)},
            ),
            Key(0.4, {"LowerBack": (6, 0, 0)}, (0.0, -0.09, -0.02), _box(0.78, 0.30, 0.18)),
            Key(
                0.9,
                {"LowerBack": (-3, 0, 0), **LOAD_AT_CHEST},
                (0.0, -0.02, 0.0),
                _box(1.22, 0.30, 0.18),
            ),
            Key(
                1.5,
                {
                    "LowerBack": (-8, 0, 0),
                    "Spine": (-4, 0, 0),
                    "Neck": (-12, 0, 0),
                    **LOAD_OVERHEAD,
                },
                (0.0, 0.03, 0.03),
                {**_planted(extra_width_m=0.04, heel_raise_deg=15.0), **_box(1.90, 0.45, 0.18)},
            ),
            Key(1.9, {"LowerBack": (-9, 0, 0)}, (0.0, 0.03, 0.05), _box(1.92, 0.58, 0.18)),
            Key(
                2.6,
                {**ARMS_DOWN, **SPINE_STRAIGHT},
                (0.0, 0.0, 0.0),
                {**_planted(extra_width_m=0.04), "LeftHand": None, "RightHand": None},
            ),
            Key(3.0, {}, (0.0, 0.0, 0.0)),
        ],
        "lift_bag_onto_overhead_rack",
    )


def lift_clean_and_press() -> Motion:
    """Clean and press a heavy box: squat wide and grip it on the floor, stand up with it
    slowly, pull it explosively to the shoulders dipping under it, stand, then dip and
    press it overhead and hold it there."""
    wide = {"extra_width_m": 0.14, "toe_out_deg": 20.0}
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(**wide)),
            Key(
                0.8,
                {
                    "LowerBack": (32, 0, 0),
                    "Spine": (12, 0, 0),
                    "Neck": (-10, 0, 0),
                    "Head": (-10, 0, 0),
                    **_knees_out(15),
                },
                (0.0, -0.42, -0.15),
                _box(0.36, 0.37, 0.17),
            ),
            Key(1.1, {"LowerBack": (33, 0, 0)}, (0.0, -0.44, -0.16), _box(0.35, 0.37, 0.17)),
            Key(
                1.9,
                {
                    "LowerBack": (8, 0, 0),
                    "Spine": (2, 0, 0),
                    "Neck": (0, 0, 0),
                    "Head": (0, 0, 0),
                    **_knees_out(0),
                },
                (0.0, -0.07, -0.04),
                _box(0.70, 0.32, 0.17),
            ),
            Key(
                2.15,
                {"LowerBack": (-5, 0, 0), "Spine": (0, 0, 0), **_toes(15)},
                (0.0, 0.03, 0.02),
                {**_planted(**wide, heel_raise_deg=15.0), **_box(1.02, 0.21, 0.18)},
            ),
            # Catch it at the shoulders, elbows forwards, knees bent.
            Key(
                2.4,
                {
                    "LowerBack": (5, 0, 0),
                    "LeftArm": (-40, 0, -10),
                    "RightArm": (-40, 0, 10),
                    **_toes(0),
                },
                (0.0, -0.15, -0.05),
                {**_planted(**wide), **_box(1.12, 0.24, 0.19)},
            ),
            Key(2.8, {"LowerBack": (-3, 0, 0)}, (0.0, -0.01, 0.0), _box(1.24, 0.24, 0.19)),
            Key(3.0, {"LowerBack": (-2, 0, 0)}, (0.0, -0.08, -0.02), _box(1.22, 0.24, 0.19)),
            # The box goes up in front of the face.
            Key(3.2, {"LowerBack": (-5, 0, 0)}, (0.0, -0.02, 0.0), _box(1.52, 0.24, 0.19)),
            Key(
                3.45,
                {
                    "LowerBack": (-8, 0, 0),
                    "Neck": (-5, 0, 0),
                    **LOAD_OVERHEAD,
                },
                (0.0, 0.0, 0.0),
                _box(1.76, 0.08, 0.2),
            ),
            Key(3.9, {"LowerBack": (-7, 0, 0)}, (0.0, 0.0, 0.0), _box(1.77, 0.08, 0.2)),
        ],
        "lift_clean_and_press",
    )


# -- sit down: holding the stomach, onto a chair, onto the floor -----------------------------


def _stomach(high_m: float = 0.15, low_m: float = 0.05) -> dict[str, Target]:
    """Wrist targets with both hands flat on the belly, in the LowerBack joint's frame.

    The belly's front is 0.17 m ahead of the LowerBack joint in the middle and 0.12 m
    at 0.15 m to the side; the fingers point across it, the palms face it.
    """
    flat = ((-1.0, -0.2, 0.15), (0.0, 0.0, -1.0))
    return {
        "LeftHand": Target((0.15, high_m, 0.105), "LowerBack", _hand_deg(1.0, *flat)),
        "RightHand": Target((-0.15, low_m, 0.105), "LowerBack", _hand_deg(-1.0, *flat)),
    }


def _sit_down(name: str, times_s: tuple[float, ...], hunch_deg: float, stance_m: float) -> Motion:
    """Hands to the stomach, bend forwards and lower onto a seat behind, stay hunched."""
    t = times_s
    seated = (0.0, SEAT_HEIGHT_M + 0.11 - 0.852, -0.40)
    return _animate(
        [
            Key(t[0], {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=stance_m)),
            Key(
                t[1],
                {
                    "Spine": (0.5 * hunch_deg, 0, 0),
                    "Spine1": (0.25 * hunch_deg, 0, 0),
                    "Head": (10, 0, 0),
                    "LeftArm": (-10, 0, -10),
                    "RightArm": (-10, 0, 10),
                },
                (0.0, -0.03, 0.0),
                _stomach(),
            ),
            Key(t[2], {"LowerBack": (25, 0, 0)}, (0.0, -0.10, -0.12), _stomach(0.14, 0.04)),
            Key(t[3], {"LowerBack": (32, 0, 0)}, seated, _stomach(0.14, 0.04)),
            Key(
                t[4],
                {
                    "LowerBack": (0.6 * hunch_deg, 0, 0),
                    "Spine": (0.6 * hunch_deg, 0, 0),
                    "Neck": (10, 0, 0),
                },
                (seated[0], seated[1], seated[2] - 0.03),
                _stomach(0.15, 0.05),
            ),
            Key(t[5], {}, (seated[0], seated[1], seated[2] - 0.03), _stomach(0.15, 0.06)),
        ],
        name,
    )


def sit_down_holding_stomach_slow() -> Motion:
    return _sit_down("sit_down_holding_stomach_slow", (0.0, 0.6, 1.3, 2.4, 3.1, 3.6), 20.0, 0.0)


def sit_down_holding_stomach_fast() -> Motion:
    return _sit_down("sit_down_holding_stomach_fast", (0.0, 0.35, 0.7, 1.3, 1.7, 2.0), 20.0, 0.0)


def sit_down_doubled_over() -> Motion:
    return _sit_down("sit_down_doubled_over", (0.0, 0.7, 1.5, 2.6, 3.3, 3.8), 40.0, 0.08)


def sit_down_hands_on_knees() -> Motion:
    """An ordinary sit onto a 0.45 m seat behind: lean forwards, arms a little forwards
    for balance, lower the hips back onto the seat, sit up with the hands on the knees."""
    seated = (0.0, SEAT_HEIGHT_M + 0.11 - 0.852, -0.40)
    # The left wrist on the thigh just behind the knee (which ends at (0.15, 0.45, -0.03)),
    # world metres, the fingers over the knee; the right hand mirrors it.
    x, y, z = (0.16, 0.57, -0.12)
    on_knee = ((0.0, -0.5, 1.0), (0.0, -1.0, 0.2))
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.02)),
            Key(0.4, {"LowerBack": (8, 0, 0), "Head": (8, 0, 0)}, (0.0, -0.02, -0.01)),
            Key(
                1.0,
                {
                    "LowerBack": (30, 0, 0),
                    "Spine": (8, 0, 0),
                    "Head": (-5, 0, 0),
                    "LeftArm": (-35, 0, -25),
                    "RightArm": (-35, 0, 25),
                },
                (0.0, -0.16, -0.20),
            ),
            Key(1.6, {"LowerBack": (26, 0, 0)}, seated),
            Key(
                2.3,
                {"LowerBack": (8, 0, 0), "Spine": (3, 0, 0), "Head": (0, 0, 0)},
                seated,
                {
                    "LeftHand": Target((x, y, z), None, _hand_deg(1.0, *on_knee)),
                    "RightHand": Target((-x, y, z), None, _hand_deg(-1.0, *on_knee)),
                },
            ),
            Key(2.9, {"LowerBack": (7, 0, 0)}, seated),
        ],
        "sit_down_hands_on_knees",
    )


def sit_down_low_step() -> Motion:
    """Sit on a low step (0.25 m) behind: lean forwards with the arms out for balance,
    lower the hips far down and back onto it, and stay hunched, knees up, the arms
    hanging between the knees."""
    seated = (0.0, LOW_STEP_HEIGHT_M + 0.11 - 0.852, -0.36)
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.04)),
            Key(0.4, {"LowerBack": (10, 0, 0), "Head": (8, 0, 0)}, (0.0, -0.03, -0.01)),
            Key(
                1.1,
                {
                    "LowerBack": (38, 0, 0),
                    "Spine": (10, 0, 0),
                    "Head": (-10, 0, 0),
                    "LeftArm": (-50, 0, -20),
                    "RightArm": (-50, 0, 20),
                    "LeftForeArm": (15, 0, 0),
                    "RightForeArm": (15, 0, 0),
                },
                (0.0, -0.28, -0.20),
            ),
            Key(1.8, {"LowerBack": (40, 0, 0)}, seated),
            Key(
                2.5,
                {
                    "LowerBack": (30, 0, 0),
                    "Spine": (12, 0, 0),
                    "Head": (-5, 0, 0),
                    "LeftArm": (-35, 0, -22),
                    "RightArm": (-35, 0, 22),
                    "LeftForeArm": (55, 0, 0),
                    "RightForeArm": (55, 0, 0),
                },
                seated,
            ),
            Key(3.1, {"LowerBack": (29, 0, 0)}, seated),
        ],
        "sit_down_low_step",
    )


def sit_down_on_the_floor() -> Motion:
    """Sit down on the floor: squat, reach back to the floor with the right hand, lower
    the seat onto the floor behind the feet, knees up, and lean back on both hands."""
    # The buttocks (about 0.11 m under the hip joint) on the floor 0.4 m behind.
    sat = (0.0, 0.11 - 0.852, -0.40)
    behind = ((0.3, 0.0, -1.0), (0.0, -1.0, 0.0))
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=-0.02)),
            Key(
                0.6,
                {
                    "LowerBack": (25, 0, -5),
                    "Spine": (8, -5, 0),
                    "Head": (10, -10, 0),
                    "LeftArm": (-30, 0, 5),
                    **_knees_out(8),
                },
                (-0.02, -0.25, -0.10),
            ),
            Key(
                1.2,
                {"LowerBack": (28, -10, -8), "Spine": (8, -10, 0)},
                (-0.04, -0.52, -0.24),
                {"RightHand": Target((-0.32, 0.07, -0.30), None, _hand_deg(-1.0, *behind))},
            ),
            Key(
                1.8,
                {"LowerBack": (5, -5, -5), "Spine": (0, -5, 0), "Head": (0, 0, 0)},
                sat,
                {
                    "RightHand": Target((-0.30, 0.07, -0.62), None, _hand_deg(-1.0, *behind)),
                    "LeftHand": Target((0.40, 0.25, -0.25)),
                },
            ),
            Key(
                2.4,
                {
                    "LowerBack": (-22, 0, 0),
                    "Spine": (-8, 0, 0),
                    "Head": (15, 0, 0),
                    **_knees_out(5),
                },
                sat,
                {
                    "LeftHand": Target((0.25, 0.07, -0.62), None, _hand_deg(1.0, *behind)),
                    "RightHand": Target((-0.25, 0.07, -0.62), None, _hand_deg(-1.0, *behind)),
                },
            ),
            Key(3.0, {"LowerBack": (-21, 0, 0)}, sat),
        ],
        "sit_down_on_the_floor",
    )


#: Wrist heights on the belly in the slumps with stomach ache, left and right
#: (:func:`_stomach`, metres): high enough for the forearms to clear the thighs.
SLUMP_HANDS_M = (0.18, 0.11)


def _doubling_over(stance_m: float, sunk_m: tuple[float, float, float]) -> list[Key]:
    """The first second of a slump with stomach ache: standing with the feet
    ``stance_m`` apart beyond rest, both hands go to the belly and the back bends over
    them, then the body sinks to the root offset ``sunk_m``, knees out."""
    return [
        Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=stance_m)),
        Key(
            0.4,
            {
                "Spine": (10, 0, 0),
                "Head": (10, 0, 0),
                "LeftArm": (-10, 0, -10),
                "RightArm": (-10, 0, 10),
            },
            (0.0, -0.03, 0.0),
            _stomach(*SLUMP_HANDS_M),
        ),
        Key(
            1.0,
            {"LowerBack": (20, 0, 0), "Spine": (15, 0, 0), **_knees_out(10)},
            sunk_m,
            _stomach(*SLUMP_HANDS_M),
        ),
    ]


def sit_down_squatting() -> Motion:
    """Slump down holding the stomach with no seat: both hands to the belly, bend over
    them and sink into a deep squat on the balls of the feet, knees wide, curled up
    between them."""
    squat = (0.0, -0.47, -0.18)
    hands = _stomach(*SLUMP_HANDS_M)
    return _animate(
        [
            *_doubling_over(0.10, (0.0, -0.24, -0.07)),
            Key(
                1.6,
                {
                    "LowerBack": (22, 0, 0),
                    "Spine": (18, 0, 0),
                    "Neck": (10, 0, 0),
                    **_knees_out(15),
                    **_toes(25),
                },
                squat,
                {**_planted(extra_width_m=0.10, heel_raise_deg=25), **hands},
            ),
            Key(2.2, {"Spine": (25, 0, 0)}, (squat[0], squat[1] - 0.02, squat[2]), hands),
            Key(2.8, {"Spine": (22, 0, 0)}, squat, hands),
        ],
        "sit_down_squatting",
    )


def sit_down_slumping_to_the_floor() -> Motion:
    """Slump down onto the floor with stomach ache: both hands to the belly, bend over
    them and sink into a squat, then sit back onto the floor behind the feet, knees up,
    hunched over the belly."""
    sat = (0.0, 0.11 - 0.852, -0.40)  # the buttocks on the floor 0.4 m behind
    # Seated, the thighs come up: the hands go a little higher on the belly.
    seated_hands = _stomach(SLUMP_HANDS_M[0] + 0.02, SLUMP_HANDS_M[1] + 0.02)
    return _animate(
        [
            *_doubling_over(0.08, (0.0, -0.28, -0.10)),
            Key(
                1.6,
                {"LowerBack": (20, 0, 0), "Spine": (18, 0, 0), **_knees_out(14), **_toes(20)},
                (0.0, -0.52, -0.22),
                {**_planted(extra_width_m=0.08, heel_raise_deg=20), **_stomach(*SLUMP_HANDS_M)},
            ),
            Key(
                2.2,
                {"LowerBack": (-4, 0, 0), "Spine": (18, 0, 0), "Neck": (12, 0, 0), **_toes(0)},
                sat,
                {**_planted(extra_width_m=0.08), **seated_hands},
            ),
            Key(2.9, {"Spine": (21, 0, 0)}, sat, seated_hands),
        ],
        "sit_down_slumping_to_the_floor",
    )


# -- cover the head against a falling object -----------------------------------------------


def _on_head() -> dict[str, Target]:
    """Wrist targets with both hands over the skull, in the Head joint's frame.

    The crown is 0.15 m above the Head joint; the fingers reach across it towards the
    back of the head, the palms face down onto it.
    """
    return {
        "LeftHand": Target(
            (0.085, 0.145, 0.05), "Head", _hand_deg(1.0, (-0.7, 0.0, -0.7), (0.0, -1.0, 0.0))
        ),
        "RightHand": Target(
            (-0.085, 0.13, 0.05), "Head", _hand_deg(-1.0, (-0.7, 0.0, -0.7), (0.0, -1.0, 0.0))
        ),
    }


def _before_face() -> dict[str, Target]:
    """Wrist targets on the way up, in front of the chin, in the Head joint's frame."""
    return {
        "LeftHand": Target((0.16, -0.12, 0.30), "Head"),
        "RightHand": Target((-0.16, -0.12, 0.30), "Head"),
    }


#: Both arms raised to put the hands on the head, the shoulders shrugged up.
ARMS_UP = {
    "LeftArm": (-30, 0, 80),
    "RightArm": (-30, 0, -80),
    "LeftShoulder": (0, 0, 10),
    "RightShoulder": (0, 0, -10),
}


def _cover_head(
    name: str, times_s: tuple[float, ...], root_drop_m: float, bend_deg: float
) -> Motion:
    t = times_s
    crouch = (0.0, -root_drop_m, -0.3 * root_drop_m)
    return _animate(
        [
            Key(t[0], {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.03)),
            Key(t[1], {"Neck": (-10, 0, 0), "Head": (-15, 0, 0)}, (0.0, -0.01, 0.0)),
            Key(
                0.5 * (t[1] + t[2]),
                {"LeftArm": (-50, 0, -10), "RightArm": (-50, 0, 10)},
                (0.0, -0.5 * root_drop_m, -0.15 * root_drop_m),
                _before_face(),
            ),
            Key(
                t[2],
                {
                    **ARMS_UP,
                    "LowerBack": (0.6 * bend_deg, 0, 0),
                    "Spine": (0.3 * bend_deg, 0, 0),
                    "Spine1": (5, 0, 0),
                    "Neck": (15, 0, 0),
                    "Head": (15, 0, 0),
                },
                crouch,
                _on_head(),
            ),
            Key(t[3], {"Spine": (0.3 * bend_deg + 5, 0, 0)}, crouch),
            Key(t[4], {"Spine": (0.3 * bend_deg + 3, 0, 0)}, crouch),
        ],
        name,
    )


def cover_head_standing() -> Motion:
    return _cover_head("cover_head_standing", (0.0, 0.2, 0.55, 1.5, 2.2), 0.04, 10.0)


def cover_head_crouching() -> Motion:
    return _cover_head("cover_head_crouching", (0.0, 0.2, 0.8, 1.8, 2.5), 0.45, 40.0)


def cover_head_stooping() -> Motion:
    return _cover_head("cover_head_stooping", (0.0, 0.15, 0.45, 1.2, 1.8), 0.12, 60.0)


def cover_head_stepping_back() -> Motion:
    """Startled by something falling from above on the left: look up, step back to the
    right with the right foot, leaning away, both forearms crossed over the head."""
    rest = rest_positions_m(canonical_skeleton())
    ankle = rest["RightFoot"][[0, 2]]

    def right(back_m: float, heel_deg: float = 0.0, lift_m: float = 0.0) -> Target:
        """The right foot ``back_m`` behind its place and out to the right, toes out."""
        x, z = ankle[0] - 0.3 * back_m, ankle[1] - back_m
        return foot_target("RightFoot", (x, z), -50.0 * back_m, heel_deg, lift_m)

    crossed = ((1.0, -0.3, 0.2), (0.0, -1.0, 0.0))
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted()),
            Key(0.12, {"Neck": (-10, 10, 0), "Head": (-15, 15, 0)}, (0.0, -0.01, 0.0)),
            Key(
                0.3,
                {"RightToeBase": (-25, 0, 0), "LeftArm": (-50, 0, -10), "RightArm": (-50, 0, 10)},
                (-0.02, -0.03, -0.02),
                {"RightFoot": right(0.0, 25.0), **_before_face()},
            ),
            Key(
                0.42,
                {"RightToeBase": (0, 0, 0), "LowerBack": (5, -5, 5)},
                (-0.06, -0.05, -0.10),
                {"RightFoot": right(0.16, 5.0, 0.06)},
            ),
            Key(
                0.56,
                {
                    **ARMS_UP,
                    "LowerBack": (15, -8, 10),
                    "Spine": (8, -5, 3),
                    "Neck": (15, -15, 0),
                    "Head": (15, -20, 0),
                },
                (-0.13, -0.12, -0.17),
                {
                    "RightFoot": right(0.32),
                    "LeftHand": Target((-0.03, 0.23, 0.06), "Head", _hand_deg(1.0, *crossed)),
                    "RightHand": Target((0.03, 0.25, 0.0), "Head", _hand_deg(-1.0, *crossed)),
                },
            ),
            Key(1.2, {"LowerBack": (18, -8, 11)}, (-0.14, -0.15, -0.19)),
            Key(1.9, {"LowerBack": (17, -8, 10)}, (-0.14, -0.14, -0.19)),
        ],
        "cover_head_stepping_back",
    )


def cover_head_one_arm() -> Motion:
    """Ducking under something falling: the right forearm across the top of the head,
    the left forearm up in front of the face, palm out, knees bent, head down."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.04)),
            Key(0.15, {"Neck": (-10, 0, 0), "Head": (-15, 0, 0)}, (0.0, -0.01, 0.0)),
            # The right hand goes up beside the head, the left one up in front of the chin.
            Key(
                0.35,
                {"RightArm": (-30, 0, -50), "LeftArm": (-50, 0, -10)},
                (0.0, -0.07, -0.03),
                {
                    "RightHand": Target((-0.25, 0.05, 0.10), "Head"),
                    "LeftHand": Target((0.12, -0.12, 0.30), "Head"),
                },
            ),
            Key(
                0.6,
                {
                    "RightArm": (-30, 0, -80),
                    "LeftArm": (-60, 0, -20),
                    "LowerBack": (12, -5, 0),
                    "Spine": (8, -5, 0),
                    "Neck": (5, -5, 0),
                    "Head": (5, -10, 0),
                    "RightShoulder": (0, 0, -10),
                    "LeftShoulder": (0, 0, 5),
                },
                (0.0, -0.14, -0.06),
                {
                    "RightHand": Target(
                        (0.05, 0.2, -0.05),
                        "Head",
                        _hand_deg(-1.0, (-1.0, -0.4, 0.0), (0.0, -1.0, 0.0)),
                    ),
                    "LeftHand": Target(
                        (0.03, 0.08, 0.21), "Head", _hand_deg(1.0, (0.0, 1.0, 0.1), (0.0, 0.0, 1.0))
                    ),
                },
            ),
            Key(1.3, {"LowerBack": (15, -5, 0)}, (0.0, -0.16, -0.07)),
            Key(2.0, {"LowerBack": (14, -5, 0)}, (0.0, -0.15, -0.07)),
        ],
        "cover_head_one_arm",
    )


def cover_head_one_arm_crouching() -> Motion:
    """Crouch away from something falling: look up, the left forearm across the top of
    the head and the right one up in front of the face, sink low with the knees out
    and turn the trunk to the left."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.06)),
            Key(0.15, {"Neck": (-10, 0, 0), "Head": (-15, 0, 0)}, (0.0, -0.01, 0.0)),
            Key(
                0.4,
                {"LeftArm": (-30, 0, 50), "RightArm": (-50, 0, 10), **_knees_out(5)},
                (0.0, -0.12, -0.04),
                {
                    "LeftHand": Target((0.25, 0.05, 0.10), "Head"),
                    "RightHand": Target((-0.12, -0.12, 0.30), "Head"),
                },
            ),
            Key(
                0.75,
                {
                    "LeftArm": (-30, 0, 80),
                    "RightArm": (-60, 0, 20),
                    "LowerBack": (22, 8, 0),
                    "Spine": (10, 6, 0),
                    "Neck": (5, 5, 0),
                    "Head": (5, 10, 0),
                    "LeftShoulder": (0, 0, 10),
                    "RightShoulder": (0, 0, -5),
                    **_knees_out(12),
                },
                (0.0, -0.30, -0.10),
                {
                    "LeftHand": Target(
                        (-0.05, 0.2, -0.05),
                        "Head",
                        _hand_deg(1.0, (1.0, -0.4, 0.0), (0.0, -1.0, 0.0)),
                    ),
                    "RightHand": Target(
                        (-0.03, 0.08, 0.21),
                        "Head",
                        _hand_deg(-1.0, (0.0, 1.0, 0.1), (0.0, 0.0, 1.0)),
                    ),
                },
            ),
            Key(1.4, {"LowerBack": (25, 8, 0)}, (0.0, -0.32, -0.11)),
            Key(2.1, {"LowerBack": (24, 8, 0)}, (0.0, -0.31, -0.11)),
        ],
        "cover_head_one_arm_crouching",
    )


def cover_head_kneeling() -> Motion:
    """Drop and cover: look up, drop onto both knees, curl forwards over them and sit
    back towards the heels, both hands over the head, the elbows in front of the face."""
    kneeling = (0.0, -0.36, 0.36)
    curled = (0.0, -0.46, 0.22)
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.04)),
            Key(0.15, {"Neck": (-10, 0, 0), "Head": (-15, 0, 0)}, (0.0, -0.01, 0.0)),
            Key(
                0.45,
                {"LeftArm": (-50, 0, -10), "RightArm": (-50, 0, 10), **_toes(40)},
                (0.0, -0.16, 0.14),
                {**_planted(extra_width_m=0.04, heel_raise_deg=40), **_before_face()},
            ),
            Key(
                0.8,
                {
                    **ARMS_UP,
                    **_toes(75),
                    "LowerBack": (10, 0, 0),
                    "Spine": (5, 0, 0),
                    "Neck": (15, 0, 0),
                    "Head": (15, 0, 0),
                },
                kneeling,
                {**_planted(extra_width_m=0.04, heel_raise_deg=75), **_on_head()},
            ),
            Key(
                1.4,
                {"Hips": (20, 0, 0), "LowerBack": (30, 0, 0), "Spine": (20, 0, 0)},
                curled,
            ),
            Key(2.1, {"Spine": (23, 0, 0)}, curled),
            Key(2.7, {"Spine": (21, 0, 0)}, curled),
        ],
        "cover_head_kneeling",
    )


def cover_head_kneeling_on_one_knee() -> Motion:
    """Drop and cover on one knee: look up, step the right foot back and go down onto
    the right knee, the left foot planted in front, bend forwards over the left thigh,
    both hands over the head."""
    rest = rest_positions_m(canonical_skeleton())
    ankle = rest["RightFoot"][[0, 2]]

    def back(back_m: float, heel_deg: float = 0.0, lift_m: float = 0.0) -> Target:
        """The right foot ``back_m`` behind its place."""
        return foot_target("RightFoot", (ankle[0], ankle[1] - back_m), 0.0, heel_deg, lift_m)

    kneeling = (-0.02, -0.385, -0.08)
    curled = (-0.02, -0.415, -0.02)
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted()),
            Key(0.15, {"Neck": (-10, 0, 0), "Head": (-15, 0, 0)}, (0.0, -0.01, 0.0)),
            Key(
                0.35,
                {"RightToeBase": (-30, 0, 0), "LeftArm": (-50, 0, -10), "RightArm": (-50, 0, 10)},
                (0.0, -0.06, -0.02),
                {"RightFoot": back(0.0, 30.0), **_before_face()},
            ),
            Key(
                0.55,
                {"RightToeBase": (-40, 0, 0), "LowerBack": (5, 0, 0)},
                (-0.01, -0.22, -0.06),
                {"RightFoot": back(0.28, 40.0, 0.05)},
            ),
            Key(
                0.85,
                {
                    **ARMS_UP,
                    "RightToeBase": (-70, 0, 0),
                    "LowerBack": (15, 0, 0),
                    "Spine": (8, 0, 0),
                    "Neck": (15, 0, 0),
                    "Head": (15, 0, 0),
                },
                kneeling,
                {"RightFoot": back(0.45, 70.0), **_on_head()},
            ),
            Key(1.4, {"LowerBack": (30, 0, 0), "Spine": (18, 0, 0)}, curled),
            Key(2.1, {"Spine": (21, 0, 0)}, curled),
            Key(2.7, {"Spine": (19, 0, 0)}, curled),
        ],
        "cover_head_kneeling_on_one_knee",
    )


# -- fall down ----------------------------------------------------------------------------------


def fall_down_forwards() -> Motion:
    """Knees give way, drop onto the knees, hands break the fall, end lying face down."""
    arms_forward = {"LeftArm": (-50, 0, -35), "RightArm": (-50, 0, 35)}
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted()),
            Key(0.3, {"Head": (20, 0, 0), "LowerBack": (5, 0, 0)}, (0.0, -0.04, 0.02)),
            Key(
                0.8,
                {"LowerBack": (15, 0, 0), **_toes(40), **arms_forward},
                (0.0, -0.30, 0.20),
                {**_planted(heel_raise_deg=40), **_hands_world(0.70, 0.55)},
            ),
            Key(
                1.15,
                {
                    "LowerBack": (20, 0, 0),
                    "Head": (0, 0, 0),
                    **_toes(75),
                    "LeftArm": (-75, 0, -35),
                    "RightArm": (-75, 0, 35),
                },
                (0.0, -0.33, 0.50),
                {**_planted(heel_raise_deg=75), **_hands_world(0.55, 0.90, 0.24)},
            ),
            Key(
                1.5,
                {"Hips": (45, 0, 0), "LowerBack": (15, 0, 0), "Head": (-20, 0, 0)},
                (0.0, -0.50, 0.72),
                _hands_world(0.05, 1.15),
            ),
            Key(
                2.1,
                {
                    "Hips": (86, 0, 0),
                    "LowerBack": (0, 0, 0),
                    "Spine": (-5, 0, 0),
                    "Head": (-10, 60, 0),
                },
                (0.0, -0.72, 0.94),
                _hands_world(0.04, 1.42, 0.30),
            ),
            Key(2.8, {}, (0.0, -0.72, 0.94)),
        ],
        "fall_down_forwards",
    )


def _hands_world(y_m: float, z_m: float, x_m: float = 0.26) -> dict[str, Target]:
    """Wrist targets at (±x, y, z), world metres."""
    return {"LeftHand": Target((x_m, y_m, z_m)), "RightHand": Target((-x_m, y_m, z_m))}


def _toes(heel_raise_deg: float) -> dict[str, tuple[float, float, float]]:
    """Toe rotations that keep the toes flat while the heels are raised."""
    return {
        "LeftToeBase": (-heel_raise_deg, 0.0, 0.0),
        "RightToeBase": (-heel_raise_deg, 0.0, 0.0),
    }


def fall_down_backwards() -> Motion:
    """Lose balance backwards, sit down hard, hands behind, roll onto the back."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted()),
            Key(
                0.35,
                {
                    "LowerBack": (-8, 0, 0),
                    "Head": (-10, 0, 0),
                    "LeftArm": (-50, 0, 10),
                    "RightArm": (-50, 0, -10),
                },
                (0.0, -0.06, -0.04),
            ),
            Key(
                0.8,
                {
                    "LowerBack": (20, 0, 0),
                    "Head": (15, 0, 0),
                    "LeftArm": (30, 0, 10),
                    "RightArm": (30, 0, -10),
                },
                (0.0, -0.42, -0.25),
            ),
            Key(
                1.1,
                {"Hips": (-25, 0, 0), "LowerBack": (15, 0, 0)},
                (0.0, -0.72, -0.42),
                {
                    "LeftFoot": Target((0.18, 0.047, 0.10), rotation_deg=(-10, 0, 0)),
                    "RightFoot": Target((-0.18, 0.047, 0.10), rotation_deg=(-10, 0, 0)),
                    "LeftHand": Target((0.30, 0.05, -0.56)),
                    "RightHand": Target((-0.30, 0.05, -0.56)),
                },
            ),
            Key(
                1.7,
                {
                    "Hips": (-85, 0, 0),
                    "LowerBack": (0, 0, 0),
                    "Head": (5, 0, 0),
                    "LeftArm": (0, 0, 30),
                    "RightArm": (0, 0, -30),
                },
                (0.0, -0.74, -0.55),
                {
                    "LeftFoot": Target((0.20, 0.06, 0.25), rotation_deg=(-30, 0, 0)),
                    "RightFoot": Target((-0.20, 0.06, 0.25), rotation_deg=(-30, 0, 0)),
                    "LeftHand": Target((0.62, 0.04, -0.95)),
                    "RightHand": Target((-0.62, 0.04, -0.95)),
                },
            ),
            Key(
                2.6,
                {"Head": (0, 20, 0)},
                (0.0, -0.74, -0.55),
                {
                    "LeftFoot": Target((0.22, 0.06, 0.27), rotation_deg=(-40, 0, 0)),
                    "RightFoot": Target((-0.22, 0.06, 0.27), rotation_deg=(-40, 0, 0)),
                },
            ),
        ],
        "fall_down_backwards",
    )


def fall_down_sideways() -> Motion:
    """Knees buckle, topple to the left onto hip and hand, end lying on the left side."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted()),
            Key(0.3, {"Head": (10, 0, 10), "LowerBack": (0, 0, -5)}, (0.02, -0.06, 0.0)),
            Key(
                0.75,
                {"Hips": (0, 0, -20), "LowerBack": (10, 0, 5), "LeftArm": (-20, 0, 40)},
                (0.12, -0.40, 0.03),
            ),
            Key(
                1.1,
                {
                    "Hips": (0, 0, -55),
                    "LowerBack": (10, 0, 15),
                    "Head": (0, 0, 20),
                    "LeftUpLeg": (-40, 0, 0),
                    "LeftLeg": (75, 0, 0),
                    "RightUpLeg": (-35, 0, 0),
                    "RightLeg": (60, 0, 0),
                },
                (0.35, -0.62, 0.08),
                {"LeftFoot": None, "RightFoot": None, "LeftHand": Target((0.75, 0.05, 0.15))},
            ),
            Key(
                1.8,
                {
                    "Hips": (0, 0, -90),
                    "LowerBack": (5, 0, 5),
                    "Head": (0, 0, 10),
                    "LeftUpLeg": (-10, 0, 0),
                    "LeftLeg": (20, 0, 0),
                    "RightUpLeg": (-45, 0, 0),
                    "RightLeg": (60, 0, 0),
                    "RightArm": (-30, 0, 35),
                },
                (0.50, -0.70, 0.05),
                {"LeftHand": Target((1.35, 0.05, 0.20))},
            ),
            Key(2.6, {}, (0.50, -0.70, 0.05)),
        ],
        "fall_down_sideways",
    )


# -- motions made of steps: every channel keyed on its own times ----------------------------

#: One channel's keys, ``(time_s, values)`` in time order.  A foot's values are
#: ``(x, z, yaw_deg, heel_raise_deg, lift_m)`` (see :func:`eigmotion.synth.authoring.foot_target`),
#: the root's ``(dx, dy, dz)`` offsets, a joint's ``(x, y, z)`` degrees.
Track = list[tuple[float, tuple[float, ...]]]

#: Half the distance between the ankles standing naturally, metres (the rest pose
#: stands wider, 0.18 m).
STANCE_HALF_WIDTH_M = 0.12

#: Above this lift, metres, a raised heel no longer keeps the toes flat on the floor.
TOES_OFF_FLOOR_M = 0.04


def _interpolator(track: Track, rotation: bool = False) -> Callable[[float], tuple]:
    """A track's value at any time: PCHIP through its keys, held before and after them.

    Joint rotations are interpolated as the engine does, on rotation vectors taking the
    short way round, and given back as ``(x, y, z)`` Euler degrees (order ZXY).
    """
    times = np.array([t for t, _ in track])
    values = np.array([v for _, v in track], dtype=np.float64)
    if rotation:
        matrices = euler_to_matrix(values[:, [2, 0, 1]], "ZXY")
        values = unwrap_rotvecs(Rotation.from_matrix(matrices).as_rotvec())
    curve = PchipInterpolator(times, values, axis=0) if len(track) > 1 else None

    def at(time_s: float) -> tuple:
        value = values[0] if curve is None else curve(np.clip(time_s, times[0], times[-1]))
        if not rotation:
            return tuple(float(v) for v in value)
        z, x, y = matrix_to_euler(Rotation.from_rotvec(value).as_matrix(), "ZXY")
        return (float(x), float(y), float(z))

    return at


def _tracked(
    name: str,
    rotations: dict[str, Track],
    root: Track,
    feet: dict[str, Track],
    flights_s: tuple[tuple[float, float], ...] = (),
) -> Motion:
    """A motion from tracks, sampled into a complete key at every frame.

    Each channel is keyed where it changes, independently of the others (a foot holds
    its place on the floor while the root and the other foot move on).  Keys at every
    frame keep what the tracks say between their keys too: a foot rolling onto its
    ball pivots about it rather than cutting the arc.  The toes stay flat on the floor
    while a heel is raised and the ball of the foot is down.
    """
    end = max(t for track in (*rotations.values(), root, *feet.values()) for t, _ in track)
    times = np.arange(int(np.floor(end * DEFAULT_FPS + 1e-9)) + 1) / DEFAULT_FPS
    joint_at = {joint: _interpolator(track, rotation=True) for joint, track in rotations.items()}
    root_at = _interpolator(root)
    foot_at = {joint: _interpolator(track) for joint, track in feet.items()}
    keys = []
    for t in times:
        rot = {joint: at(t) for joint, at in joint_at.items()}
        targets = {}
        for joint, at in foot_at.items():
            x, z, yaw, heel, lift = at(t)
            targets[joint] = foot_target(joint, (x, z), yaw, heel, lift)
            flat = max(0.0, 1.0 - lift / TOES_OFF_FLOOR_M)
            rot[joint.replace("Foot", "ToeBase")] = (-heel * flat, 0.0, 0.0)
        keys.append(Key(t, rot, root_at(t), targets))
    return animate(keys, contact_points_m=body_surface_points(), name=name, flights_s=flights_s)


def _turned(x: float, z: float, yaw_deg: float) -> tuple[float, float]:
    """A body-frame offset (x left, z forward) of a body turned by ``yaw_deg``, world x, z."""
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    return (float(x * c + z * s), float(-x * s + z * c))


def _footprint(
    side: float, centre_xz: tuple[float, float], yaw_deg: float, half_width_m: float
) -> tuple[float, float, float]:
    """(x, z, yaw) of the left (side +1) or right (-1) foot of a body at ``centre_xz``."""
    dx, dz = _turned(side * half_width_m, 0.0, yaw_deg)
    return (centre_xz[0] + dx, centre_xz[1] + dz, yaw_deg)


def _stand(footprint: tuple[float, float, float]) -> Track:
    """A foot track starting flat on the floor at time 0."""
    return [(0.0, (*footprint, 0.0, 0.0))]


def _step(
    track: Track,
    take_off_s: float,
    land_s: float,
    to: tuple[float, float, float],
    lift_m: float = 0.08,
    heel_deg: float = 30.0,
    roll_s: float = 0.12,
) -> None:
    """Append one step to a foot track: heel up about the ball, swing, put down flat.

    The foot stays where it is until ``take_off_s - roll_s``, rolls onto its ball until
    ``take_off_s``, lifts off mostly upwards, swings ``lift_m`` high and lands flat at
    ``to`` (x, z, yaw) at ``land_s``.
    """
    t0, (x0, z0, yaw0, _, _) = track[-1]
    if take_off_s - roll_s > t0:
        track.append((take_off_s - roll_s, (x0, z0, yaw0, 0.0, 0.0)))
    x1, z1, yaw1 = to

    def swing(fraction: float, heel: float, lift: float) -> tuple[float, ...]:
        x, z, yaw = (a + fraction * (b - a) for a, b in zip((x0, z0, yaw0), to, strict=True))
        return (x, z, yaw, heel, lift)

    swing_s = land_s - take_off_s
    track += [
        (take_off_s, (x0, z0, yaw0, heel_deg, 0.0)),
        (take_off_s + 0.25 * swing_s, swing(0.15, 0.6 * heel_deg, 0.6 * lift_m)),
        (take_off_s + 0.5 * swing_s, swing(0.5, 0.2 * heel_deg, lift_m)),
        (land_s, (x1, z1, yaw1, 0.0, 0.0)),
    ]


#: A planned step: the foot (+1 left, -1 right), take-off and landing times (s), where
#: it lands (x, z, yaw_deg) and how high it swings (m).
Step = tuple[float, float, float, tuple[float, float, float], float]


def _walking(
    name: str,
    steps: list[Step],
    end_s: float,
    half_width_m: float,
    dip_m: tuple[float, float],
    arm_swing_deg: float,
) -> Motion:
    """Steps from standing at the origin facing +Z; hips, heading and arms follow the feet.

    While both feet are down the hips are ``dip_m[0]`` below standing height, between
    the feet (a long step needs the legs to reach apart); over the supporting foot they
    are ``dip_m[1]`` down and a few centimetres to its side.  The pelvis faces the mean
    heading of the feet and the head looks ahead into a turn; the arms swing
    ``arm_swing_deg`` against the legs.  The body ends standing, hips at full height.
    """
    feet = {side: _stand(_footprint(side, (0.0, 0.0), 0.0, half_width_m)) for side in (1.0, -1.0)}
    root: Track = [(0.0, (0.0, 0.0, 0.0))]
    heading: Track = [(0.0, (0.0, 0.0, 0.0))]
    arms = {side: [(0.0, (0.0, 0.0, -side * 30.0))] for side in (1.0, -1.0)}
    for side, take_off, land, to, lift in steps:
        stance = feet[-side][-1][1]
        sx, sz = _turned(-side * 0.3 * half_width_m, 0.0, stance[2])
        root.append((0.5 * (take_off + land), (stance[0] + sx, -dip_m[1], stance[1] + sz)))
        _step(feet[side], take_off, land, to, lift_m=lift)
        between = (0.5 * (stance[0] + to[0]), -dip_m[0], 0.5 * (stance[1] + to[1]))
        root.append((land, between))
        heading.append((land, (0.0, 0.5 * (stance[2] + to[2]), 0.0)))
        for arm in (1.0, -1.0):
            arms[arm].append((land, (arm * side * arm_swing_deg, 0.0, -arm * 30.0)))
    root.append((end_s, (root[-1][1][0], 0.0, root[-1][1][2])))
    # The head turns ahead of the pelvis, by half the turn still to come over a step.
    look = [
        (t, (0.0, 0.5 * (heading[min(i + 1, len(heading) - 1)][1][1] - h[1]), 0.0))
        for i, (t, h) in enumerate(heading)
    ]
    look.append((end_s, (0.0, 0.0, 0.0)))
    rotations = {
        "Hips": heading,
        "Neck": look,
        "LeftArm": arms[1.0],
        "RightArm": arms[-1.0],
        "LeftForeArm": [(0.0, (30.0, 0.0, 0.0))],
        "RightForeArm": [(0.0, (30.0, 0.0, 0.0))],
    }
    return _tracked(name, rotations, root, {"LeftFoot": feet[1.0], "RightFoot": feet[-1.0]})


# -- turn -------------------------------------------------------------------------------------

#: Half the distance between the ankles in a walk, metres.
WALK_HALF_WIDTH_M = 0.09


def _turn_step(side: float, take_off: float, land: float, yaw_deg: float, lift: float) -> Step:
    """A step of a turn on the spot: the foot lands beside the body turned by ``yaw_deg``."""
    return (side, take_off, land, _footprint(side, (0.0, 0.0), yaw_deg, STANCE_HALF_WIDTH_M), lift)


def turn_in_place_90() -> Motion:
    """Turn 90 degrees to the left on the spot in three steps, the head leading."""
    steps = [
        _turn_step(1.0, 0.45, 0.85, 45.0, 0.06),
        _turn_step(-1.0, 0.95, 1.4, 90.0, 0.07),
        _turn_step(1.0, 1.5, 1.85, 90.0, 0.04),
    ]
    return _walking("turn_in_place_90", steps, 2.4, STANCE_HALF_WIDTH_M, (0.015, 0.01), 0.0)


def turn_in_place_180() -> Motion:
    """Turn round to the right on the spot in four steps, the head leading."""
    steps = [
        _turn_step(-1.0, 0.4, 0.8, -55.0, 0.06),
        _turn_step(1.0, 0.9, 1.35, -115.0, 0.07),
        _turn_step(-1.0, 1.45, 1.9, -175.0, 0.07),
        _turn_step(1.0, 2.0, 2.35, -180.0, 0.04),
    ]
    return _walking("turn_in_place_180", steps, 2.9, STANCE_HALF_WIDTH_M, (0.015, 0.01), 0.0)


def turn_walking_180() -> Motion:
    """Walk two steps, turn round to the left in two, walk two steps back and stop."""
    w = WALK_HALF_WIDTH_M
    turn_centre = (0.12, 1.2)
    steps = [
        (-1.0, 0.10, 0.50, _footprint(-1.0, (0.0, 0.45), 0.0, w), 0.08),
        (1.0, 0.58, 0.98, _footprint(1.0, (0.0, 1.0), 0.0, w), 0.08),
        (-1.0, 1.06, 1.46, _footprint(-1.0, (0.1, 1.3), 90.0, w), 0.08),
        (1.0, 1.54, 1.94, _footprint(1.0, turn_centre, 180.0, w), 0.06),
        (-1.0, 2.02, 2.42, _footprint(-1.0, (0.12, 0.7), 180.0, w), 0.08),
        (1.0, 2.50, 2.90, _footprint(1.0, (0.12, 0.2), 180.0, w), 0.08),
        (-1.0, 2.98, 3.33, _footprint(-1.0, (0.12, 0.2), 180.0, w), 0.05),
    ]
    return _walking("turn_walking_180", steps, 3.75, w, (0.045, 0.012), 14.0)


def turn_walking_90() -> Motion:
    """Walk two steps, turn 90 degrees to the left over two, walk on two steps and stop."""
    w = WALK_HALF_WIDTH_M
    steps = [
        (-1.0, 0.10, 0.50, _footprint(-1.0, (0.0, 0.45), 0.0, w), 0.08),
        (1.0, 0.58, 0.98, _footprint(1.0, (0.0, 1.0), 0.0, w), 0.08),
        (-1.0, 1.06, 1.46, _footprint(-1.0, (0.12, 1.45), 40.0, w), 0.08),
        (1.0, 1.54, 1.94, _footprint(1.0, (0.55, 1.62), 90.0, w), 0.07),
        (-1.0, 2.02, 2.42, _footprint(-1.0, (1.1, 1.62), 90.0, w), 0.08),
        (1.0, 2.50, 2.90, _footprint(1.0, (1.65, 1.62), 90.0, w), 0.08),
        (-1.0, 2.98, 3.33, _footprint(-1.0, (1.65, 1.62), 90.0, w), 0.05),
    ]
    return _walking("turn_walking_90", steps, 3.75, w, (0.045, 0.012), 14.0)


def turn_walking_90_brisk() -> Motion:
    """Walk briskly, pivot 90 degrees to the left in one step on the right foot planted
    turned in, walk on three steps and stop."""
    w = WALK_HALF_WIDTH_M
    steps = [
        (-1.0, 0.10, 0.42, _footprint(-1.0, (0.0, 0.55), 0.0, w), 0.08),
        (1.0, 0.46, 0.78, _footprint(1.0, (0.0, 1.15), 0.0, w), 0.08),
        (-1.0, 0.82, 1.14, _footprint(-1.0, (0.05, 1.45), 70.0, w), 0.07),
        (1.0, 1.18, 1.50, _footprint(1.0, (0.45, 1.5), 90.0, w), 0.08),
        (-1.0, 1.54, 1.86, _footprint(-1.0, (1.05, 1.5), 90.0, w), 0.08),
        (1.0, 1.90, 2.22, _footprint(1.0, (1.65, 1.5), 90.0, w), 0.08),
        (-1.0, 2.26, 2.56, _footprint(-1.0, (1.65, 1.5), 90.0, w), 0.05),
    ]
    return _walking("turn_walking_90_brisk", steps, 2.95, w, (0.05, 0.015), 20.0)


# -- jump -------------------------------------------------------------------------------------


#: How far the upper arms hang out from vertical at rest, degrees (the rest pose's A).
REST_ARM_SPREAD_DEG = 41.7


def _arm(side: float, swing_deg: float, spread_deg: float = 12.0) -> tuple[float, float, float]:
    """Upper-arm rotation (side +1 left, -1 right): first in to ``spread_deg`` from
    vertical, then swung about the shoulders' axis, forwards for negative ``swing_deg``
    (-90 points the arm ahead, -180 straight up), backwards for positive."""
    inwards = euler_to_matrix([0.0, 0.0, -side * (REST_ARM_SPREAD_DEG - spread_deg)], "XYZ")
    swing = euler_to_matrix([swing_deg, 0.0, 0.0], "XYZ")
    z, x, y = matrix_to_euler(swing @ inwards, "ZXY")
    return (float(x), float(y), float(z))


def _arms(left_deg: float, right_deg: float, spread_deg: float = 12.0) -> dict[str, tuple]:
    """Both upper arms swung (see :func:`_arm`)."""
    return {
        "LeftArm": _arm(1.0, left_deg, spread_deg),
        "RightArm": _arm(-1.0, right_deg, spread_deg),
    }


def _standing_upright() -> dict[str, tuple]:
    """The arms, back and head of the body standing at rest before a jump."""
    return {
        **_arms(0, 0),
        "LeftForeArm": (30, 0, 0),
        "RightForeArm": (30, 0, 0),
        "LowerBack": (0, 0, 0),
        "Spine": (0, 0, 0),
        "Head": (0, 0, 0),
    }


def _keyed(joints: list[str], keys: list[tuple[float, dict[str, tuple]]]) -> dict[str, Track]:
    """Joint tracks from whole-body keys (time, joint → rotation): each joint is keyed
    where a key names it and interpolated between those keys alone."""
    tracks: dict[str, Track] = {joint: [] for joint in joints}
    for t, rotations in keys:
        for joint, angles in rotations.items():
            tracks[joint].append((t, angles))
    return {joint: track for joint, track in tracks.items() if track}


def jump_forward_standing() -> Motion:
    """Standing broad jump: swing the arms back and crouch, spring forwards off both feet,
    tuck, land on both feet 0.95 m ahead, absorb the landing and stand up."""
    take_off, land = 1.0, 1.45
    w = STANCE_HALF_WIDTH_M
    feet = {}
    for side, joint in ((1.0, "LeftFoot"), (-1.0, "RightFoot")):
        x = side * w
        feet[joint] = [
            (0.0, (x, 0.0, 0.0, 0.0, 0.0)),
            (0.8, (x, 0.0, 0.0, 0.0, 0.0)),
            (take_off, (x, 0.0, 0.0, 45.0, 0.0)),
            (1.22, (x, 0.55, 0.0, 15.0, 0.22)),
            (land, (x, 0.95, 0.0, 0.0, 0.0)),
        ]
    root = [
        (0.0, (0.0, 0.0, 0.0)),
        (0.4, (0.0, -0.06, 0.0)),
        (0.78, (0.0, -0.30, -0.10)),
        (take_off, (0.0, 0.03, 0.20)),
        (1.22, (0.0, -0.02, 0.50)),
        (land, (0.0, -0.14, 0.80)),
        (1.7, (0.0, -0.36, 0.88)),
        (2.4, (0.0, -0.01, 0.95)),
        (2.7, (0.0, 0.0, 0.95)),
    ]
    body = [
        (0.0, _standing_upright()),
        (0.4, {**_arms(-70, -70, 15), "LowerBack": (5, 0, 0)}),
        (
            0.78,
            {
                **_arms(50, 50, 15),
                "LowerBack": (35, 0, 0),
                "Spine": (10, 0, 0),
                "Head": (-20, 0, 0),
                "LeftForeArm": (15, 0, 0),
                "RightForeArm": (15, 0, 0),
            },
        ),
        # The arms swing forwards past the thighs (keys < 180 degrees apart).
        (0.9, {**_arms(-30, -30, 15)}),
        (
            take_off,
            {
                **_arms(-140, -140, 15),
                "LowerBack": (15, 0, 0),
                "Spine": (0, 0, 0),
                "Head": (-10, 0, 0),
            },
        ),
        (1.22, {**_arms(-110, -110, 18), "LowerBack": (25, 0, 0)}),
        (
            land,
            {
                **_arms(-70, -70, 20),
                "LowerBack": (30, 0, 0),
                "Spine": (8, 0, 0),
                "Head": (-15, 0, 0),
                "LeftForeArm": (30, 0, 0),
                "RightForeArm": (30, 0, 0),
            },
        ),
        (1.7, {**_arms(-45, -45, 25), "LowerBack": (40, 0, 0), "Spine": (12, 0, 0)}),
        (2.4, {**_arms(0, 0), "LowerBack": (2, 0, 0), "Spine": (0, 0, 0), "Head": (0, 0, 0)}),
        (2.7, {"LowerBack": (0, 0, 0)}),
    ]
    joints = list(_standing_upright())  # every joint the keys name
    return _tracked("jump_forward_standing", _keyed(joints, body), root, feet, ((take_off, land),))


def jump_hop_one_leg() -> Motion:
    """Lift the right foot behind, hop four times forwards on the left foot, put it down."""
    w = STANCE_HALF_WIDTH_M
    period, flight, advance = 0.6, 0.36, 0.12
    take_offs = [0.85 + period * i for i in range(4)]
    left: Track = [(0.0, (w, 0.0, 0.0, 0.0, 0.0))]
    right: Track = [(0.0, (-w, 0.0, 0.0, 0.0, 0.0)), (0.3, (-w, 0.0, 0.0, 0.0, 0.0))]
    root: Track = [(0.0, (0.0, 0.0, 0.0)), (0.35, (0.07, -0.02, 0.0))]
    arms: list[tuple[float, dict]] = [
        (0.0, {**_arms(0, 0), "LeftForeArm": (30, 0, 0), "RightForeArm": (30, 0, 0)}),
        (0.45, {**_arms(-10, 10, 30), "LeftForeArm": (60, 0, 0), "RightForeArm": (60, 0, 0)}),
    ]
    z = 0.0
    for t in take_offs:
        land = t + flight
        left += [
            (t - 0.12, (w, z, 0.0, 0.0, 0.0)),
            (t, (w, z, 0.0, 35.0, 0.0)),
            (t + 0.5 * flight, (w, z + 0.5 * advance, 0.0, 30.0, 0.0)),
            (land, (w, z + advance, 0.0, 15.0, 0.0)),
            (land + 0.1, (w, z + advance, 0.0, 0.0, 0.0)),
        ]
        right.append((t, (-0.08, z - 0.1, 0.0, 45.0, 0.27)))
        root += [
            (t - 0.12, (0.08, -0.08, z + 0.02)),
            (t, (0.08, 0.03, z + 0.05)),
            (land, (0.08, -0.01, z + advance + 0.01)),
        ]
        arms += [
            (t - 0.12, _arms(5, 20, 30)),
            (t + 0.5 * flight, _arms(-25, -5, 35)),
        ]
        z += advance
    last = take_offs[-1] + flight
    _step(right, last + 0.2, last + 0.5, (-w, z, 0.0), lift_m=0.05, heel_deg=0.0)
    root += [
        (last + 0.15, (0.08, -0.07, z + 0.01)),
        (last + 0.5, (0.02, -0.02, z)),
        (last + 0.75, (0.0, 0.0, z)),
    ]
    arms += [(last + 0.6, {**_arms(0, 0), "LeftForeArm": (30, 0, 0), "RightForeArm": (30, 0, 0)})]
    joints = ["LeftArm", "RightArm", "LeftForeArm", "RightForeArm"]
    flights = tuple((t, t + flight) for t in take_offs)
    return _tracked(
        "jump_hop_one_leg",
        _keyed(joints, arms),
        root,
        {"LeftFoot": left, "RightFoot": right},
        flights,
    )


def jump_hops_both_feet() -> Motion:
    """Three hops forwards on both feet together: crouch with the arms swung back, spring
    up and on with them swinging forwards, land on the balls of the feet, sink, again;
    stand up after the third."""
    w = STANCE_HALF_WIDTH_M
    period, flight, advance = 0.85, 0.4, 0.4
    take_offs = [0.7 + period * i for i in range(3)]
    feet: dict[float, Track] = {s: [(0.0, (s * w, 0.0, 0.0, 0.0, 0.0))] for s in (1.0, -1.0)}
    root: Track = [(0.0, (0.0, 0.0, 0.0)), (0.3, (0.0, -0.03, 0.0))]
    upright = {
        **_arms(0, 0),
        "LeftForeArm": (30, 0, 0),
        "RightForeArm": (30, 0, 0),
        "LowerBack": (0, 0, 0),
        "Head": (0, 0, 0),
    }
    body: list[tuple[float, dict]] = [(0.0, upright)]
    z = 0.0
    for t in take_offs:
        land = t + flight
        for side in (1.0, -1.0):
            feet[side] += [
                (t - 0.1, (side * w, z, 0.0, 0.0, 0.0)),
                (t, (side * w, z, 0.0, 40.0, 0.0)),
                (t + 0.5 * flight, (side * w, z + 0.5 * advance, 0.0, 20.0, 0.08)),
                (land, (side * w, z + advance, 0.0, 15.0, 0.0)),
                (land + 0.12, (side * w, z + advance, 0.0, 0.0, 0.0)),
            ]
        root += [
            (t - 0.25, (0.0, -0.17, z + 0.02)),
            (t, (0.0, 0.0, z + 0.08)),
            (land, (0.0, -0.04, z + advance + 0.02)),
            (land + 0.15, (0.0, -0.15, z + advance + 0.03)),
        ]
        body += [
            (t - 0.25, {**_arms(45, 45, 10), "LowerBack": (25, 0, 0), "Head": (-15, 0, 0)}),
            (t + 0.5 * flight, {**_arms(-70, -70, 10), "LowerBack": (5, 0, 0), "Head": (-5, 0, 0)}),
            (land + 0.15, {**_arms(-15, -15, 10), "LowerBack": (20, 0, 0), "Head": (-12, 0, 0)}),
        ]
        z += advance
    last = take_offs[-1] + flight
    root += [(last + 0.6, (0.0, -0.01, z + 0.02)), (last + 0.9, (0.0, 0.0, z + 0.02))]
    body.append((last + 0.7, upright))
    joints = ["LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LowerBack", "Head"]
    flights = tuple((t, t + flight) for t in take_offs)
    return _tracked(
        "jump_hops_both_feet",
        _keyed(joints, body),
        root,
        {"LeftFoot": feet[1.0], "RightFoot": feet[-1.0]},
        flights,
    )


def jump_running() -> Motion:
    """Three running steps, take off from the right foot driving the left knee up, fly
    0.5 s, land on both feet, absorb the landing and stand up."""
    w = WALK_HALF_WIDTH_M
    take_off, land = 1.16, 1.68
    left = _stand((w, 0.0, 0.0))
    right = _stand((-w, 0.0, 0.0))
    _step(right, 0.10, 0.42, (-w, 0.50, 0.0), lift_m=0.10)
    _step(left, 0.42, 0.68, (w, 1.22, 0.0), lift_m=0.14)
    _step(right, 0.62, 0.90, (-w, 1.95, 0.0), lift_m=0.16)
    right += [(1.02, (-w, 1.95, 0.0, 0.0, 0.0)), (take_off, (-w, 1.95, 0.0, 55.0, 0.0))]
    left += [
        (0.84, (w, 1.22, 0.0, 0.0, 0.0)),
        (0.92, (w, 1.22, 0.0, 35.0, 0.0)),
        (take_off, (w, 2.30, 0.0, 20.0, 0.40)),
        (1.42, (w, 2.85, 0.0, 10.0, 0.32)),
        (land, (0.11, 3.35, 0.0, 0.0, 0.0)),
    ]
    right += [(1.42, (-w, 2.65, 0.0, 30.0, 0.36)), (land, (-0.11, 3.35, 0.0, 0.0, 0.0))]
    root = [
        (0.0, (0.0, 0.0, 0.0)),
        (0.42, (0.0, -0.04, 0.30)),
        (0.62, (0.0, -0.01, 0.80)),
        (0.68, (0.0, -0.03, 0.98)),
        (0.90, (0.0, -0.06, 1.62)),
        (1.02, (0.0, -0.11, 1.95)),
        (take_off, (0.0, 0.0, 2.22)),
        (1.42, (0.0, -0.02, 2.75)),
        (land, (0.0, -0.12, 3.22)),
        (1.92, (0.0, -0.40, 3.32)),
        (2.6, (0.0, -0.01, 3.35)),
        (2.8, (0.0, 0.0, 3.35)),
    ]
    body = [
        (
            0.0,
            {
                **_arms(0, 0),
                "LowerBack": (0, 0, 0),
                "Head": (0, 0, 0),
                "LeftForeArm": (30, 0, 0),
                "RightForeArm": (30, 0, 0),
            },
        ),
        (
            0.42,
            {
                **_arms(25, -30),
                "LowerBack": (8, 0, 0),
                "LeftForeArm": (80, 0, 0),
                "RightForeArm": (80, 0, 0),
            },
        ),
        (0.68, _arms(-35, 30)),
        (0.90, _arms(35, -40)),
        (1.02, {**_arms(30, 10), "LowerBack": (12, 0, 0)}),
        (
            take_off,
            {
                **_arms(-120, -100, 15),
                "LowerBack": (0, 0, 0),
                "Head": (-10, 0, 0),
                "LeftForeArm": (40, 0, 0),
                "RightForeArm": (40, 0, 0),
            },
        ),
        (1.42, {**_arms(-100, -100, 15), "LowerBack": (15, 0, 0)}),
        (
            land,
            {
                **_arms(-70, -70, 20),
                "LowerBack": (30, 0, 0),
                "Head": (-15, 0, 0),
                "LeftForeArm": (30, 0, 0),
                "RightForeArm": (30, 0, 0),
            },
        ),
        (1.92, {**_arms(-45, -45, 25), "LowerBack": (40, 0, 0)}),
        (2.6, {**_arms(0, 0), "LowerBack": (2, 0, 0), "Head": (0, 0, 0)}),
        (2.8, {"LowerBack": (0, 0, 0)}),
    ]
    joints = ["LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LowerBack", "Head"]
    flights = ((0.62, 0.68), (take_off, land))
    return _tracked(
        "jump_running", _keyed(joints, body), root, {"LeftFoot": left, "RightFoot": right}, flights
    )


def jump_vertical_reach() -> Motion:
    """Standing vertical jump reaching for something overhead: swing the arms back and
    dip, spring straight up off both feet, both arms stretched above the head, land on
    the spot, absorb the landing and stand up."""
    take_off, land = 0.95, 1.45
    w = STANCE_HALF_WIDTH_M
    feet = {}
    for side, joint in ((1.0, "LeftFoot"), (-1.0, "RightFoot")):
        x = side * w
        feet[joint] = [
            (0.0, (x, 0.0, 0.0, 0.0, 0.0)),
            (0.8, (x, 0.0, 0.0, 0.0, 0.0)),
            (take_off, (x, 0.0, 0.0, 50.0, 0.0)),
            (1.2, (x, 0.0, 0.0, 30.0, 0.10)),
            (land - 0.05, (x, 0.0, 0.0, 20.0, 0.0)),
            (land + 0.05, (x, 0.0, 0.0, 0.0, 0.0)),
        ]
    root = [
        (0.0, (0.0, 0.0, 0.0)),
        (0.35, (0.0, -0.05, 0.0)),
        (0.75, (0.0, -0.32, -0.06)),
        (take_off, (0.0, 0.04, 0.0)),
        (land, (0.0, -0.04, 0.0)),
        (1.7, (0.0, -0.30, -0.04)),
        (2.35, (0.0, -0.01, 0.0)),
        (2.6, (0.0, 0.0, 0.0)),
    ]
    body = [
        (0.0, _standing_upright()),
        (0.35, {**_arms(-20, -20, 15), "LowerBack": (5, 0, 0)}),
        (
            0.75,
            {
                **_arms(55, 55, 15),
                "LowerBack": (30, 0, 0),
                "Spine": (8, 0, 0),
                "Head": (-15, 0, 0),
                "LeftForeArm": (15, 0, 0),
                "RightForeArm": (15, 0, 0),
            },
        ),
        # The arms swing forwards past the thighs, then all the way up.
        (0.85, {**_arms(-20, -20, 15)}),
        (
            take_off,
            {
                **_arms(-150, -150, 12),
                "LowerBack": (0, 0, 0),
                "Spine": (-3, 0, 0),
                "Head": (-20, 0, 0),
                "LeftForeArm": (5, 0, 0),
                "RightForeArm": (5, 0, 0),
            },
        ),
        (1.2, {**_arms(-170, -170, 10), "LowerBack": (-3, 0, 0)}),
        (
            land,
            {
                **_arms(-100, -100, 20),
                "LowerBack": (15, 0, 0),
                "Spine": (5, 0, 0),
                "Head": (-5, 0, 0),
                "LeftForeArm": (30, 0, 0),
                "RightForeArm": (30, 0, 0),
            },
        ),
        (1.7, {**_arms(-40, -40, 25), "LowerBack": (30, 0, 0), "Spine": (8, 0, 0)}),
        (2.35, {**_arms(0, 0), "LowerBack": (2, 0, 0), "Spine": (0, 0, 0), "Head": (0, 0, 0)}),
        (2.6, {"LowerBack": (0, 0, 0)}),
    ]
    joints = list(_standing_upright())  # every joint the keys name
    return _tracked("jump_vertical_reach", _keyed(joints, body), root, feet, ((take_off, land),))


def jump_hop_in_place() -> Motion:
    """Raise the left knee in front, arms out to the sides for balance, hop three times on
    the spot on the right foot, put the left foot down."""
    w = STANCE_HALF_WIDTH_M
    period, flight = 0.6, 0.36
    take_offs = [0.9 + period * i for i in range(3)]
    right: Track = [(0.0, (-w, 0.0, 0.0, 0.0, 0.0))]
    left: Track = [(0.0, (w, 0.0, 0.0, 0.0, 0.0)), (0.25, (w, 0.0, 0.0, 0.0, 0.0))]
    left.append((0.6, (0.08, 0.16, 0.0, 20.0, 0.30)))
    root: Track = [(0.0, (0.0, 0.0, 0.0)), (0.3, (-0.07, -0.02, 0.0)), (0.6, (-0.08, -0.03, 0.0))]
    arms: list[tuple[float, dict]] = [
        (0.0, {**_arms(0, 0), "LeftForeArm": (30, 0, 0), "RightForeArm": (30, 0, 0)}),
        (0.6, {**_arms(-15, -15, 75), "LeftForeArm": (20, 0, 0), "RightForeArm": (20, 0, 0)}),
    ]
    for t in take_offs:
        land = t + flight
        right += [
            (t - 0.10, (-w, 0.0, 0.0, 0.0, 0.0)),
            (t, (-w, 0.0, 0.0, 35.0, 0.0)),
            (t + 0.5 * flight, (-w, 0.0, 0.0, 25.0, 0.0)),
            (land, (-w, 0.0, 0.0, 10.0, 0.0)),
            (land + 0.08, (-w, 0.0, 0.0, 0.0, 0.0)),
        ]
        root += [
            (t - 0.12, (-0.08, -0.10, 0.0)),
            (t, (-0.08, 0.02, 0.0)),
            (land, (-0.08, -0.02, 0.0)),
        ]
        arms += [
            (t - 0.12, _arms(-5, -5, 65)),
            (t + 0.5 * flight, _arms(-25, -25, 85)),
        ]
    last = take_offs[-1] + flight
    left += [
        (last + 0.15, (0.08, 0.16, 0.0, 20.0, 0.30)),
        (last + 0.4, (0.11, 0.05, 0.0, 5.0, 0.08)),
        (last + 0.55, (w, 0.0, 0.0, 0.0, 0.0)),
    ]
    root += [
        (last + 0.15, (-0.08, -0.08, 0.0)),
        (last + 0.55, (-0.02, -0.02, 0.0)),
        (last + 0.8, (0.0, 0.0, 0.0)),
    ]
    arms += [(last + 0.7, {**_arms(0, 0), "LeftForeArm": (30, 0, 0), "RightForeArm": (30, 0, 0)})]
    joints = ["LeftArm", "RightArm", "LeftForeArm", "RightForeArm"]
    flights = tuple((t, t + flight) for t in take_offs)
    return _tracked(
        "jump_hop_in_place",
        _keyed(joints, arms),
        root,
        {"LeftFoot": left, "RightFoot": right},
        flights,
    )


# -- run --------------------------------------------------------------------------------------

#: Half the distance between the ankles in a run, metres (the feet land nearly in line).
RUN_HALF_WIDTH_M = 0.05


def _elbow(side: float, bend_deg: float) -> tuple[float, float, float]:
    """Forearm rotation (side +1 left, -1 right) bending the elbow ``bend_deg`` so that the
    forearm swings from its rest direction straight towards the front."""
    rest = rest_positions_m(canonical_skeleton())
    prefix = "Left" if side > 0 else "Right"
    down = rest[prefix + "Hand"] - rest[prefix + "ForeArm"]
    hinge = np.cross(down, (0.0, 0.0, 1.0))
    hinge *= np.radians(bend_deg) / np.linalg.norm(hinge)
    z, x, y = matrix_to_euler(Rotation.from_rotvec(hinge).as_matrix(), "ZXY")
    return (float(x), float(y), float(z))


def _running(
    name: str,
    n_steps: int,
    period_s: float,
    contact_s: float,
    stride_m: float,
    kick_m: float,
    reach_m: float,
    lean_deg: float,
    arm_swing_deg: float,
    elbow_deg: float,
) -> Motion:
    """Running at a steady pace, already under way at the first frame and still at the last.

    Step ``i`` lands the left foot (even ``i``) or the right one flat on the floor at
    ``i * period_s`` seconds, ``i * stride_m`` metres ahead, and pushes off from its ball
    ``contact_s`` later; nothing touches the floor until the next step lands.  The
    swinging foot kicks up ``kick_m`` behind, comes through under the knee and is still
    ``reach_m`` up in front as the other foot pushes off.  The hips move ahead at a
    constant ``stride_m / period_s``, lowest at mid-stance; the arms swing
    ``arm_swing_deg`` against the legs, the forearms bent ``elbow_deg`` forwards from
    their rest direction (:func:`_elbow`); the back leans ``lean_deg`` forwards.  The
    clip starts as a foot lands and ends halfway through a stance.
    """
    w = RUN_HALF_WIDTH_M
    speed = stride_m / period_s
    # The hips pass over the stance foot a little after mid-stance: it lands 0.7 and
    # pushes off 1.3 times half the stance's travel away (the raised heel reaches back).
    travel = 0.5 * speed * contact_s
    ahead = 0.3 * travel
    rest = rest_positions_m(canonical_skeleton())
    leg = rest["Hips"][1] - rest["LeftFoot"][1]
    # Low enough at landing for the leg to reach the foot with the knee still bent.
    dip = leg - np.sqrt(leg**2 - (0.7 * travel) ** 2) + 0.02
    swing_s = 2.0 * period_s - contact_s
    flight_s = period_s - contact_s
    feet: dict[float, Track] = {1.0: [], -1.0: []}
    # Two steps before the first frame put both feet where the running already has them.
    for i in range(-2, n_steps + 2):
        side = 1.0 if i % 2 == 0 else -1.0
        land, z = i * period_s, i * stride_m
        push = land + contact_s
        after = z + 2.0 * stride_m
        feet[side] += [
            (land, (side * w, z, 0.0, 0.0, 0.0)),
            (push - 0.5 * contact_s, (side * w, z, 0.0, 0.0, 0.0)),
            (push, (side * w, z, 0.0, 50.0, 0.0)),
            (push + 0.35 * swing_s, (side * w, z + 0.3 * (after - z), 0.0, 70.0, kick_m)),
            # Still high in front as the other foot pushes off, down as the flight ends.
            (push + period_s, (side * w, z + 0.85 * (after - z), 0.0, 5.0, reach_m)),
            (
                push + period_s + 0.6 * flight_s,
                (side * w, z + 0.95 * (after - z), 0.0, 0.0, 0.5 * reach_m),
            ),
        ]
    end_s = (n_steps - 1) * period_s + 0.5 * contact_s

    def at(t: float) -> float:
        """How far ahead the hips are at time ``t``, metres."""
        return speed * (t - 0.5 * contact_s) + ahead

    root: Track = []
    heading: Track = []
    for i in range(-1, n_steps + 1):
        side = 1.0 if i % 2 == 0 else -1.0
        land = i * period_s
        mid = land + 0.5 * contact_s
        root += [
            (land, (0.4 * side * w, -dip, at(land))),
            (mid, (0.6 * side * w, -dip - 0.03, at(mid))),
            (land + contact_s, (0.4 * side * w, -dip, at(land + contact_s))),
        ]
        heading.append((mid, (0.0, -side * 6.0, 0.0)))
    body: list[tuple[float, dict]] = []
    for i in range(-1, n_steps + 1):
        side = 1.0 if i % 2 == 0 else -1.0
        # The arm on the side of the landing foot is back, the other forwards.
        swing = (arm_swing_deg, -arm_swing_deg) if side > 0 else (-arm_swing_deg, arm_swing_deg)
        body.append(
            (
                i * period_s + 0.5 * contact_s,
                {
                    **_arms(*swing, 8.0),
                    "LeftForeArm": _elbow(1.0, elbow_deg + 0.2 * swing[0]),
                    "RightForeArm": _elbow(-1.0, elbow_deg + 0.2 * swing[1]),
                    "LowerBack": (lean_deg, 0, 0),
                    "Spine": (0.3 * lean_deg, 0, 0),
                    "Head": (-0.8 * lean_deg, 0, 0),
                },
            )
        )
    rotations = {
        "Hips": heading,
        **_keyed(
            ["LeftArm", "RightArm", "LeftForeArm", "RightForeArm", "LowerBack", "Spine", "Head"],
            body,
        ),
    }

    def until_end(track: Track) -> Track:
        # The tracks start before the clip and would run on after it; _tracked samples
        # from time 0 to the last key.
        return [(t, v) for t, v in track if t <= end_s + 1e-9]

    flights = tuple((i * period_s + contact_s, (i + 1) * period_s) for i in range(n_steps - 1))
    return _tracked(
        name,
        {joint: until_end(track) for joint, track in rotations.items()},
        until_end(root),
        {"LeftFoot": until_end(feet[1.0]), "RightFoot": until_end(feet[-1.0])},
        flights,
    )


def run_jogging() -> Motion:
    """Jogging, about 2.4 m/s: short strides, the feet kicking up a little behind, arms
    low with the elbows bent."""
    return _running("run_jogging", 5, 0.38, 0.22, 0.9, 0.25, 0.16, 6.0, 28.0, 55.0)


def run_easy() -> Motion:
    """An easy run, about 2.1 m/s: short, quick strides with little flight, the feet
    barely kicking up behind, upright, arms held high and bent, a small swing."""
    return _running("run_easy", 6, 0.36, 0.20, 0.75, 0.20, 0.14, 3.0, 20.0, 80.0)


def run_fast() -> Motion:
    """Running fast, about 3.9 m/s: long strides, the heels kicking high behind, a
    forward lean and a full arm swing."""
    return _running("run_fast", 6, 0.31, 0.16, 1.2, 0.36, 0.20, 12.0, 50.0, 65.0)


# -- wave -------------------------------------------------------------------------------------


def _waving(
    name: str,
    raise_s: float,
    lower_s: float,
    end_s: float,
    period_s: float,
    up: dict[str, tuple],
    sway: tuple[dict[str, tuple], dict[str, tuple]],
    body: dict[str, tuple],
) -> Motion:
    """Stand, raise the arm(s) to ``up`` by ``raise_s``, alternate between the two
    ``sway`` poses every half ``period_s`` until ``lower_s``, lower them by ``end_s``."""
    rest = {**ARMS_DOWN, **SPINE_STRAIGHT}
    keys = [Key(0.0, rest, (0, 0, 0), _planted(extra_width_m=-0.04)), Key(raise_s, {**up, **body})]
    t, i = raise_s + 0.5 * period_s, 0
    while t < lower_s - 0.25 * period_s:
        keys.append(Key(t, sway[i % 2]))
        t, i = t + 0.5 * period_s, i + 1
    keys += [Key(lower_s, up), Key(end_s, rest)]
    return _animate(keys, name)


def wave_right_hand() -> Motion:
    """Greeting: raise the right hand beside the head, elbow bent, wave it side to side."""
    up = {"RightArm": (-15, 0, -80), "RightForeArm": (0, 0, -90), "RightHand": (0, -60, 0)}
    return _waving(
        "wave_right_hand",
        0.6,
        2.45,
        3.0,
        0.42,
        up,
        ({"RightForeArm": (0, 0, -62)}, {"RightForeArm": (0, 0, -100)}),
        {"LowerBack": (0, 0, 3), "Head": (0, -8, 0)},
    )


def wave_left_hand() -> Motion:
    """Hailing someone far off: the left arm straight up, swept wide from side to side."""
    up = {"LeftArm": (-10, 0, 110), "LeftForeArm": (0, 0, 10)}
    return _waving(
        "wave_left_hand",
        0.55,
        2.9,
        3.4,
        0.8,
        up,
        ({"LeftArm": (-10, 0, 128)}, {"LeftArm": (-10, 0, 92)}),
        {"LowerBack": (0, 0, -4), "Neck": (-10, 0, 0), "Head": (-10, 0, 0)},
    )


def _raised(x_deg: float, z_deg: float, elbow_deg: float | None = None) -> dict[str, tuple]:
    """Both arms raised alike: upper arms at ``(x_deg, 0, ±z_deg)``, and forearms at
    ``(0, 0, ±elbow_deg)`` when given (left +, right −)."""
    arms = {"LeftArm": (x_deg, 0, z_deg), "RightArm": (x_deg, 0, -z_deg)}
    if elbow_deg is not None:
        arms |= {"LeftForeArm": (0, 0, elbow_deg), "RightForeArm": (0, 0, -elbow_deg)}
    return arms


def wave_both_hands() -> Motion:
    """Both arms straight up above the head, swaying together from side to side."""
    up = _raised(-5, 115, 15)
    to_left = {"LeftArm": (-5, 0, 100), "RightArm": (-5, 0, -128)}
    to_right = {"LeftArm": (-5, 0, 128), "RightArm": (-5, 0, -100)}
    return _waving(
        "wave_both_hands",
        0.6,
        3.0,
        3.5,
        0.9,
        up,
        (to_left, to_right),
        {"Neck": (-8, 0, 0), "Head": (-8, 0, 0)},
    )


def wave_both_arms_crossing() -> Motion:
    """Signalling for help: both arms raised, swept from out to the sides until the
    wrists cross in front of the forehead, and back, again and again."""
    return _waving(
        "wave_both_arms_crossing",
        0.5,
        3.3,
        3.8,
        1.0,
        _raised(-10, 110, 10),
        (_raised(-15, 158), _raised(-5, 80)),
        {"Neck": (-10, 0, 0), "Head": (-10, 0, 0)},
    )


def wave_big_arcs_right() -> Motion:
    """Waving to someone far away: the right arm almost straight, swung in big arcs
    across the side of the body, from out at shoulder height to above the head."""
    return _waving(
        "wave_big_arcs_right",
        0.5,
        3.35,
        3.9,
        1.1,
        {"RightArm": (-5, 0, -140), "RightForeArm": (0, 0, -8)},
        ({"RightArm": (-5, 0, -152)}, {"RightArm": (-5, 0, -45)}),
        {"LowerBack": (0, 0, 2), "Head": (-5, 0, 0)},
    )


def wave_big_arcs_both() -> Motion:
    """Both arms almost straight, swung together in big arcs from out at shoulder height
    to above the head, where the hands nearly meet, and down again."""
    return _waving(
        "wave_big_arcs_both",
        0.55,
        3.4,
        3.9,
        1.2,
        _raised(-5, 140, 8),
        (_raised(-5, 155), _raised(-5, 45)),
        {"Neck": (-6, 0, 0), "Head": (-6, 0, 0)},
    )


# -- pick up ----------------------------------------------------------------------------------


def _knees_out(turn_deg: float) -> dict[str, tuple[float, float, float]]:
    """Thighs turned outwards about their length, so that bent knees point over the toes
    (the IK bends a leg the way its keyed pose bends)."""
    return {"LeftUpLeg": (0.0, turn_deg, 0.0), "RightUpLeg": (0.0, -turn_deg, 0.0)}


def pick_up_squatting() -> Motion:
    """Squat with the back straight, heels coming up, take a small object from the floor
    with both hands and stand up holding it at the waist."""
    return _animate(
        [
            Key(
                0.0,
                {**ARMS_DOWN, **SPINE_STRAIGHT},
                (0, 0, 0),
                _planted(extra_width_m=0.05, toe_out_deg=15.0),
            ),
            Key(0.35, {"LowerBack": (8, 0, 0), "Head": (15, 0, 0)}, (0.0, -0.08, -0.02)),
            # The hands go down and come up in front of the knees.
            Key(
                0.65,
                {"Hips": (8, 0, 0), "LowerBack": (20, 0, 0), "Spine": (5, 0, 0), **_knees_out(10)},
                (0.0, -0.28, -0.07),
                _hands_world(0.56, 0.42, 0.10),
            ),
            Key(
                0.95,
                {
                    "Hips": (20, 0, 0),
                    "LowerBack": (30, 0, 0),
                    "Spine": (10, 0, 0),
                    "Neck": (-5, 0, 0),
                    **_knees_out(20),
                    **_toes(25),
                },
                (0.0, -0.52, -0.12),
                {
                    **_planted(extra_width_m=0.05, toe_out_deg=15.0, heel_raise_deg=25.0),
                    **_hands_world(0.19, 0.52, 0.09),
                },
            ),
            Key(
                1.25, {"LowerBack": (32, 0, 0)}, (0.0, -0.53, -0.12), _hands_world(0.19, 0.52, 0.08)
            ),
            Key(
                1.6,
                {
                    "Hips": (10, 0, 0),
                    "LowerBack": (18, 0, 0),
                    "Spine": (5, 0, 0),
                    "Neck": (0, 0, 0),
                    **_knees_out(10),
                    **_toes(12),
                },
                (0.0, -0.27, -0.07),
                {
                    **_planted(extra_width_m=0.05, toe_out_deg=15.0, heel_raise_deg=12.0),
                    **_hands_world(0.56, 0.44, 0.08),
                },
            ),
            Key(
                1.95,
                {
                    "Hips": (0, 0, 0),
                    **SPINE_STRAIGHT,
                    "Head": (5, 0, 0),
                    **_knees_out(0),
                    **_toes(0),
                },
                (0.0, -0.01, 0.0),
                {
                    **_planted(extra_width_m=0.05, toe_out_deg=15.0),
                    **_hands_world(0.95, 0.26, 0.07),
                },
            ),
            Key(2.3, {"Head": (0, 0, 0)}, (0.0, 0.0, 0.0), _hands_world(0.94, 0.25, 0.07)),
        ],
        "pick_up_squatting",
    )


def pick_up_bending() -> Motion:
    """Bend from the hips with the legs nearly straight, take a small object from the
    floor with both hands, straighten up holding it at the waist."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=-0.02)),
            Key(0.35, {"Head": (15, 0, 0)}, (0.0, -0.01, 0.0)),
            Key(
                1.0,
                {
                    "Hips": (60, 0, 0),
                    "LowerBack": (38, 0, 0),
                    "Spine": (22, 0, 0),
                    "Spine1": (10, 0, 0),
                    "Neck": (-15, 0, 0),
                    "Head": (-5, 0, 0),
                },
                (0.0, -0.12, -0.20),
                _hands_world(0.19, 0.36, 0.08),
            ),
            Key(1.3, {"Hips": (61, 0, 0)}, (0.0, -0.12, -0.20), _hands_world(0.19, 0.36, 0.07)),
            Key(
                2.2,
                {"Hips": (0, 0, 0), **SPINE_STRAIGHT, "Head": (5, 0, 0)},
                (0.0, -0.01, 0.0),
                _hands_world(0.92, 0.24, 0.07),
            ),
            Key(2.5, {"Head": (0, 0, 0)}, (0.0, 0.0, 0.0), _hands_world(0.92, 0.24, 0.07)),
        ],
        "pick_up_bending",
    )


def pick_up_one_hand() -> Motion:
    """Bend knees and back, reach down with the right hand alone beside the right foot,
    pick something up and stand with it at the side."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.04)),
            # The right hand passes outside the right knee, down and up.
            Key(
                0.45,
                {"Hips": (8, 0, 0), "LowerBack": (22, -4, 3), "Spine": (8, 0, 1), **_knees_out(8)},
                (-0.03, -0.18, -0.06),
                {"RightHand": Target((-0.42, 0.50, 0.16))},
            ),
            Key(
                0.9,
                {
                    "Hips": (20, 0, 0),
                    "LowerBack": (40, -8, 6),
                    "Spine": (18, 0, 3),
                    "Head": (0, 0, 0),
                    "LeftArm": (-35, 0, -25),
                    "LeftForeArm": (40, 0, 0),
                    **_knees_out(15),
                },
                (-0.05, -0.40, -0.14),
                {"RightHand": Target((-0.40, 0.18, 0.28))},
            ),
            Key(1.2, {"LowerBack": (41, -8, 6)}, (-0.05, -0.41, -0.14)),
            Key(
                1.55,
                {
                    "Hips": (8, 0, 0),
                    "LowerBack": (20, -4, 3),
                    "Spine": (8, 0, 1),
                    "LeftArm": (-15, 0, -28),
                    "LeftForeArm": (35, 0, 0),
                    **_knees_out(8),
                },
                (-0.03, -0.17, -0.06),
                {"RightHand": Target((-0.42, 0.55, 0.16))},
            ),
            Key(
                1.9,
                {
                    "Hips": (0, 0, 0),
                    **SPINE_STRAIGHT,
                    **ARMS_DOWN,
                    "Head": (5, 0, 0),
                    **_knees_out(0),
                },
                (0.0, -0.01, 0.0),
                {"RightHand": Target((-0.28, 0.84, 0.14))},
            ),
            Key(2.3, {"Head": (0, 0, 0)}, (0.0, 0.0, 0.0)),
        ],
        "pick_up_one_hand",
    )


def pick_up_reaching_forwards() -> Motion:
    """Bend knees and back deeply and reach far forwards to the floor with the right
    hand, scoop something up towards the feet, rise and hold it up in front of the
    chest, looking at it."""
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=0.03)),
            Key(
                0.4,
                {
                    "Hips": (10, 0, 0),
                    "LowerBack": (25, 0, 0),
                    "Spine": (10, 0, 0),
                    "LeftArm": (-20, 0, -25),
                    **_knees_out(6),
                },
                (0.0, -0.15, -0.08),
                {"RightHand": Target((-0.15, 0.55, 0.40))},
            ),
            Key(
                0.8,
                {
                    "Hips": (25, 0, 0),
                    "LowerBack": (45, 0, 0),
                    "Spine": (20, 0, 0),
                    "Neck": (-10, 0, 0),
                    "LeftArm": (-40, 0, -20),
                    "LeftForeArm": (30, 0, 0),
                    **_knees_out(12),
                },
                (0.0, -0.38, -0.20),
                {"RightHand": Target((-0.12, 0.06, 0.62))},
            ),
            Key(
                1.15,
                {"LowerBack": (46, 0, 0)},
                (0.0, -0.39, -0.21),
                {"RightHand": Target((-0.12, 0.06, 0.50))},
            ),
            Key(
                1.6,
                {
                    "Hips": (8, 0, 0),
                    "LowerBack": (18, 0, 0),
                    "Spine": (6, 0, 0),
                    "Neck": (0, 0, 0),
                    "LeftArm": (-10, 0, -28),
                    **_knees_out(4),
                },
                (0.0, -0.12, -0.05),
                {"RightHand": Target((-0.15, 0.80, 0.35))},
            ),
            Key(
                2.0,
                {
                    "Hips": (0, 0, 0),
                    **SPINE_STRAIGHT,
                    "Head": (12, 0, 0),
                    **_knees_out(0),
                    "LeftArm": (0, 0, -30),
                },
                (0.0, 0.0, 0.0),
                {"RightHand": Target((-0.12, 1.15, 0.40))},
            ),
            Key(
                2.4,
                {"Head": (10, 0, 0)},
                (0.0, 0.0, 0.0),
                {"RightHand": Target((-0.12, 1.16, 0.40))},
            ),
        ],
        "pick_up_reaching_forwards",
    )


def _walking_pick_up(
    name: str,
    steps: list[Step],
    pick: tuple[float, float, float],
    reach: dict[str, tuple],
    root_low_m: tuple[float, float, float],
    end_s: float,
    arm_swing_deg: float = 14.0,
    dip_m: tuple[float, float] = (0.045, 0.012),
    flights_s: tuple[tuple[float, float], ...] = (),
    approach_elbow_deg: float = 0.0,
) -> Motion:
    """Walking (or jogging) up to a small object on the floor and taking it up with the
    right hand in stride, then walking on.

    ``steps`` as :func:`_walking`; the right foot of the step landing at ``pick[0]`` is
    planted beside the object, the body bends over it until ``pick[1]`` (the hand at the
    floor, the left heel coming up behind) and is up again by ``pick[2]``, when the left
    foot has started its step through; ``reach`` is the pose at the bottom (back, arms,
    head) and ``root_low_m`` the hips' offset from standing there.  The right hand
    holds the object at the side afterwards.  ``flights_s`` are the phases of a jogging
    approach with both feet off the floor (see :func:`eigmotion.synth.authoring.animate`),
    ``approach_elbow_deg`` the elbows' bend on the way in (0: hanging as in a walk).
    """
    land_at, bottom, up = pick
    w = WALK_HALF_WIDTH_M
    feet = {side: _stand(_footprint(side, (0.0, 0.0), 0.0, w)) for side in (1.0, -1.0)}
    root: Track = [(0.0, (0.0, 0.0, 0.0))]
    upright = {
        "Hips": (0, 0, 0),
        "LowerBack": (0, 0, 0),
        "Spine": (0, 0, 0),
        "Spine1": (0, 0, 0),
        "Neck": (0, 0, 0),
        "Head": (0, 0, 0),
    }
    arm_keys: list[tuple[float, dict[str, tuple]]] = [
        (0.0, {**_standing_upright(), **upright, "RightHand": (0, 0, 0)})
    ]
    holding = {
        "RightArm": _arm(-1.0, -10.0, 18.0),
        "RightForeArm": (45, 0, 0),
        "RightHand": (0, 0, 0),
    }
    # The forearms on the way in (bent further when jogging) and walking on.
    approach = {
        "LeftForeArm": _elbow(1.0, approach_elbow_deg) if approach_elbow_deg else (30, 0, 0),
        "RightForeArm": _elbow(-1.0, approach_elbow_deg) if approach_elbow_deg else (30, 0, 0),
    }
    walk_arms = {"LeftForeArm": (30, 0, 0)}
    planted = None
    for side, take_off, land, to, lift in steps:
        swing = arm_swing_deg if land <= land_at else 14.0
        stance = feet[-side][-1][1]
        if land_at < take_off < up:
            # The step through out of the bend: the back foot rolls onto its ball as the
            # body goes down, and leaves from it.
            x0, z0, yaw0, _, _ = feet[side][-1][1]
            feet[side] += [
                (land_at + 0.1, (x0, z0, yaw0, 10.0, 0.0)),
                (bottom, (x0, z0, yaw0, 45.0, 0.0)),
            ]
            roll = take_off - bottom
            _step(feet[side], take_off, land, to, lift_m=lift, heel_deg=45.0, roll_s=roll)
        else:
            _step(feet[side], take_off, land, to, lift_m=lift)
        mid = 0.5 * (take_off + land)
        if mid < land_at or mid > up:
            root.append((mid, (stance[0] - side * 0.3 * w, -dip_m[1], stance[1])))
        if land <= land_at or land >= up:
            root.append((land, (0.5 * (stance[0] + to[0]), -dip_m[0], 0.5 * (stance[1] + to[1]))))
            arm_keys.append(
                (
                    land,
                    {
                        **upright,
                        **(approach if land <= land_at else walk_arms),
                        "LeftArm": _arm(1.0, side * swing),
                        **(holding if land > up else {"RightArm": _arm(-1.0, -side * swing)}),
                    },
                )
            )
        if land == land_at:
            planted = to
    low_x, low_y, low_z = root_low_m
    root += [
        (land_at + 0.1, (planted[0] + 0.5 * low_x, 0.4 * low_y, planted[1] + 0.5 * low_z)),
        (bottom, (planted[0] + low_x, low_y, planted[1] + low_z)),
        (bottom + 0.15, (planted[0] + low_x, low_y + 0.01, planted[1] + low_z + 0.02)),
    ]
    root.sort(key=lambda k: k[0])
    arm_keys += [
        (land_at + 0.1, {"LeftArm": _arm(1.0, -10.0), "RightArm": _arm(-1.0, 0.0)}),
        (bottom, reach),
        (bottom + 0.15, {}),
        (
            up,
            {
                **upright,
                "LowerBack": (5, 0, 0),
                "LeftArm": _arm(1.0, -15.0),
                "LeftForeArm": (30, 0, 0),
                **holding,
            },
        ),
    ]
    arm_keys.sort(key=lambda k: k[0])
    root.append((end_s, (root[-1][1][0], 0.0, root[-1][1][2])))
    joints = [
        "Hips",
        "LowerBack",
        "Spine",
        "Spine1",
        "Neck",
        "Head",
        "LeftArm",
        "RightArm",
        "LeftForeArm",
        "RightForeArm",
        "RightHand",
    ]
    return _tracked(
        name,
        _keyed(joints, arm_keys),
        root,
        {"LeftFoot": feet[1.0], "RightFoot": feet[-1.0]},
        flights_s,
    )


def pick_up_walking_in() -> Motion:
    """Walk up to a small object on the floor, plant the right foot beside it and,
    without stopping, bend from the hips and knees and take it up with the right hand
    outside the right foot, the left heel rising behind; straighten up stepping
    through and walk on two steps holding it at the side."""
    w = WALK_HALF_WIDTH_M
    steps = [
        (-1.0, 0.10, 0.50, _footprint(-1.0, (0.0, 0.45), 0.0, w), 0.08),
        (1.0, 0.58, 0.98, _footprint(1.0, (0.0, 1.05), 0.0, w), 0.08),
        (-1.0, 1.06, 1.46, _footprint(-1.0, (0.0, 1.60), 0.0, w), 0.08),
        (1.0, 2.05, 2.50, _footprint(1.0, (0.0, 2.20), 0.0, w), 0.08),
        (-1.0, 2.58, 2.98, _footprint(-1.0, (0.0, 2.75), 0.0, w), 0.08),
        (1.0, 3.06, 3.40, _footprint(1.0, (0.0, 2.75), 0.0, w), 0.05),
    ]
    reach = {
        "Hips": (50, 0, 0),
        "LowerBack": (28, -5, 5),
        "Spine": (14, 0, 3),
        "Spine1": (5, 0, 0),
        "Neck": (-15, 0, 0),
        "Head": (-5, 0, 0),
        "RightArm": _arm(-1.0, -45.0, 20.0),
        "RightForeArm": (5, 0, 0),
        "LeftArm": _arm(1.0, -30.0, 25.0),
        "LeftForeArm": (40, 0, 0),
    }
    return _walking_pick_up(
        "pick_up_walking_in", steps, (1.46, 1.80, 2.35), reach, (-0.03, -0.30, -0.32), 3.8
    )


def pick_up_walking_in_crouching() -> Motion:
    """Walk up to a small object, plant the right foot just past it and sink low on
    bent knees, back fairly upright, the left knee dropping behind, to take it up with
    the right hand beside the right foot; rise stepping through and walk on."""
    w = WALK_HALF_WIDTH_M
    steps = [
        (-1.0, 0.10, 0.50, _footprint(-1.0, (0.0, 0.45), 0.0, w), 0.08),
        (1.0, 0.58, 0.98, _footprint(1.0, (0.0, 1.05), 0.0, w), 0.08),
        (-1.0, 1.06, 1.46, _footprint(-1.0, (0.0, 1.62), 0.0, w), 0.08),
        (1.0, 2.20, 2.65, _footprint(1.0, (0.0, 2.20), 0.0, w), 0.08),
        (-1.0, 2.73, 3.13, _footprint(-1.0, (0.0, 2.75), 0.0, w), 0.08),
        (1.0, 3.21, 3.55, _footprint(1.0, (0.0, 2.75), 0.0, w), 0.05),
    ]
    reach = {
        "Hips": (28, 0, 0),
        "LowerBack": (28, -8, 6),
        "Spine": (10, 0, 4),
        "Spine1": (5, 0, 0),
        "Neck": (-10, 0, 0),
        "Head": (-5, 0, 0),
        "RightArm": _arm(-1.0, -20.0, 25.0),
        "RightForeArm": (10, 0, 0),
        "LeftArm": _arm(1.0, -35.0, 25.0),
        "LeftForeArm": (50, 0, 0),
    }
    return _walking_pick_up(
        "pick_up_walking_in_crouching",
        steps,
        (1.46, 1.90, 2.50),
        reach,
        (-0.03, -0.45, -0.30),
        3.95,
    )


def pick_up_jogging_in() -> Motion:
    """Jog up to a small object on the floor (three strides with both feet off the floor,
    about 2.4 m/s), brake on a last step, plant the right foot beside it and take it up
    with the right hand without stopping, bending from the hips and knees; straighten
    up stepping through and stop, the feet together, holding it at the side."""
    w = WALK_HALF_WIDTH_M
    steps = [
        (-1.0, 0.10, 0.42, _footprint(-1.0, (0.0, 0.40), 0.0, w), 0.10),
        (1.0, 0.58, 0.80, _footprint(1.0, (0.0, 1.15), 0.0, w), 0.14),
        (-1.0, 0.64, 1.14, _footprint(-1.0, (0.0, 1.95), 0.0, w), 0.20),
        (1.0, 1.02, 1.48, _footprint(1.0, (0.0, 2.75), 0.0, w), 0.20),
        (-1.0, 1.36, 1.82, _footprint(-1.0, (0.0, 3.35), 0.0, w), 0.12),
        (1.0, 2.40, 2.85, _footprint(1.0, (0.0, 3.95), 0.0, w), 0.08),
        (-1.0, 2.93, 3.25, _footprint(-1.0, (0.0, 3.95), 0.0, w), 0.05),
    ]
    reach = {
        "Hips": (50, 0, 0),
        "LowerBack": (28, -5, 5),
        "Spine": (14, 0, 3),
        "Spine1": (5, 0, 0),
        "Neck": (-15, 0, 0),
        "Head": (-5, 0, 0),
        "RightArm": _arm(-1.0, -45.0, 20.0),
        "RightForeArm": (5, 0, 0),
        "LeftArm": _arm(1.0, -30.0, 25.0),
        "LeftForeArm": (40, 0, 0),
    }
    return _walking_pick_up(
        "pick_up_jogging_in",
        steps,
        (1.82, 2.15, 2.70),
        reach,
        (-0.03, -0.30, -0.34),
        3.45,
        arm_swing_deg=28.0,
        dip_m=(0.09, 0.04),
        flights_s=((0.64, 0.80), (1.02, 1.14), (1.36, 1.48)),
        approach_elbow_deg=60.0,
    )


# -- punch ------------------------------------------------------------------------------------

#: Time a straight punch takes from the guard to full extension, seconds.
PUNCH_EXTEND_S = 0.17

#: Time a fist takes back from a straight punch to the guard, seconds.
PUNCH_RETRACT_S = 0.24

#: Left wrist in the chest (Spine1) frame, metres: a relaxed guard, fists in front of
#: the chest, and a boxing guard, fists at the chin (the right hand mirrors it).
RELAXED_GUARD = (0.12, 0.10, 0.22)
BOXING_GUARD = (0.10, 0.15, 0.19)

#: Left fist, (fingers, palm) directions in the chest frame: knuckles up and palm in in
#: the guard, palm towards the face at the end of an uppercut.
FIST_GUARD = ((0.0, 1.0, 0.35), (-1.0, 0.0, 0.0))
FIST_UPPERCUT = ((0.0, 1.0, 0.1), (0.0, 0.0, -1.0))

#: Orthodox boxing stance: where the balls of the feet are (world x, z, metres) and
#: which way the feet point (degrees, positive towards the left): the left foot ahead
#: with its toes a little in, the right one behind turned out; the hips between them,
#: a little down, turned to the right.
LEAD_BALL_XZ = (0.10, 0.24)
REAR_BALL_XZ = (-0.15, -0.18)
LEAD_YAW_DEG = -10.0
REAR_YAW_DEG = -45.0
STANCE_ROOT_M = (-0.02, -0.06, 0.0)
STANCE_TURN_DEG = -25.0


def _fists(curl_deg: float = 130.0) -> dict[str, tuple[float, float, float]]:
    """Finger rotations closing both hands into fists: the fingers curl towards the palm
    by ``curl_deg`` at the knuckles, the palm cups a little, the thumb folds in; 0 opens
    the hands again."""
    axis = np.cross(LEFT_FINGERS_REST, LEFT_PALM_REST)
    axis /= np.linalg.norm(axis)
    out = {}
    for left, right, share in (
        ("LeftFingerBase", "RightFingerBase", 0.2),
        ("LeftHandFinger1", "RightHandFinger1", 1.0),
        ("LThumb", "RThumb", 0.4),
    ):
        rotation = Rotation.from_rotvec(np.radians(share * curl_deg) * axis).as_matrix()
        z, x, y = matrix_to_euler(rotation, "ZXY")
        # The right hand mirrors the left: x angles stay, y and z change sign.
        out[left] = (float(x), float(y), float(z))
        out[right] = (float(x), float(-y), float(-z))
    return out


def _guard_arms() -> dict[str, tuple[float, float, float]]:
    """Arm rotations of a guard: the upper arms forwards and in, the elbows down (the
    bend the IK keeps), the hands closed into fists."""
    return {
        "LeftArm": (-35, 0, -30),
        "RightArm": (-35, 0, 30),
        "LeftForeArm": (0, 0, 0),
        "RightForeArm": (0, 0, 0),
        **_fists(),
    }


def _fist(side: float, point_m, fingers_palm=FIST_GUARD) -> Target:
    """Wrist target of the left (side +1) or right (-1) hand in the chest (Spine1) frame;
    the point and the (fingers, palm) directions are given for the left hand, mirrored
    (x negated) for the right."""
    x, y, z = point_m
    return Target((side * x, y, z), "Spine1", _hand_deg(side, *fingers_palm))


def _guard(point_m) -> dict[str, Target]:
    """Both fists at ``point_m`` (chest frame, given for the left hand)."""
    return {"LeftHand": _fist(1.0, point_m), "RightHand": _fist(-1.0, point_m)}


def _straight(side: float, aim) -> dict[str, Target]:
    """Wrist target of a straight punch, palm down: the arm straight from the shoulder
    towards ``aim`` (chest frame, given for the left arm); the elbow keeps a few degrees
    of bend so that the IK knows which way it bends on the way back."""
    rest = rest_positions_m(canonical_skeleton())
    reach = np.linalg.norm(rest["LeftForeArm"] - rest["LeftArm"]) + np.linalg.norm(
        rest["LeftHand"] - rest["LeftForeArm"]
    )
    direction = np.asarray(aim, dtype=np.float64) / np.linalg.norm(aim)
    point = rest["LeftArm"] - rest["Spine1"] + 0.998 * reach * direction
    hand = "LeftHand" if side > 0 else "RightHand"
    return {hand: _fist(side, point, (tuple(direction), (0.0, -1.0, 0.0)))}


def _chest_turn(turn_deg: float, lean_deg: float = 0.0) -> dict[str, tuple[float, float, float]]:
    """The shoulders turned by ``turn_deg`` (positive to the left) over the hips, the
    spine leaning forwards by ``lean_deg``, the head turned back to look ahead."""
    return {
        "LowerBack": (0.5 * lean_deg, 0.35 * turn_deg, 0.0),
        "Spine": (0.3 * lean_deg, 0.35 * turn_deg, 0.0),
        "Spine1": (0.2 * lean_deg, 0.3 * turn_deg, 0.0),
        "Neck": (-0.5 * lean_deg, -0.5 * turn_deg, 0.0),
        "Head": (-0.3 * lean_deg, -0.3 * turn_deg, 0.0),
    }


def _foot_on_ball(
    joint: str, ball_xz: tuple[float, float], yaw_deg: float = 0.0, heel_raise_deg: float = 0.0
) -> Target:
    """Target of a foot whose ball stays at ``ball_xz`` (world x, z, metres) however it
    turns (``yaw_deg``, as :func:`eigmotion.synth.authoring.foot_target`) or raises its heel: a
    pivot on the ball of the foot."""
    rest = rest_positions_m(canonical_skeleton())
    to_ball = rest[joint.replace("Foot", "ToeBase")] - rest[joint]
    dx, dz = _turned(to_ball[0], to_ball[2], yaw_deg)
    return foot_target(joint, (ball_xz[0] - dx, ball_xz[1] - dz), yaw_deg, heel_raise_deg)


def _boxing_feet(
    lead_turn_deg: float = 0.0,
    lead_heel_deg: float = 0.0,
    rear_turn_deg: float = 0.0,
    rear_heel_deg: float = 0.0,
) -> dict[str, Target]:
    """Both feet in the orthodox stance, each turned on its ball from its stance
    heading by ``*_turn_deg`` with its heel raised by ``*_heel_deg``."""
    lead_yaw, rear_yaw = LEAD_YAW_DEG + lead_turn_deg, REAR_YAW_DEG + rear_turn_deg
    return {
        "LeftFoot": _foot_on_ball("LeftFoot", LEAD_BALL_XZ, lead_yaw, lead_heel_deg),
        "RightFoot": _foot_on_ball("RightFoot", REAR_BALL_XZ, rear_yaw, rear_heel_deg),
    }


def _stance(root_shift_m=(0.0, 0.0, 0.0)) -> tuple[float, float, float]:
    """Root offset of the boxing stance, shifted by ``root_shift_m`` (metres)."""
    return tuple(float(a + b) for a, b in zip(STANCE_ROOT_M, root_shift_m, strict=True))


#: Hips and spine in the boxing guard: side-on, the shoulders a little further round,
#: leaning a little forwards.
BOXING_GUARD_BODY = {"Hips": (0, STANCE_TURN_DEG, 0), **_chest_turn(-10, 6)}


def _into_boxing_guard(guard_time_s: float) -> list[Key]:
    """The first keys of a boxing motion: standing in the orthodox stance, knees a little
    bent, arms down, and by ``guard_time_s`` in the guard, turned side-on."""
    return [
        Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, _stance(), _boxing_feet()),
        Key(guard_time_s, {**_guard_arms(), **BOXING_GUARD_BODY}, _stance(), _guard(BOXING_GUARD)),
    ]


def punch_straight_alternating() -> Motion:
    """From a relaxed guard, the feet where they stand, four straight punches at head
    height, left, right, left, right, the shoulders turning into each."""
    keys = [
        Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted(extra_width_m=-0.02)),
        Key(0.5, _guard_arms(), (0.0, -0.03, 0.0), _guard(RELAXED_GUARD)),
    ]
    # A hit every 13 frames from frame 39 to frame 78 of 92: the hits fall on the frames
    # of an 8-frame contact sheet.
    for i, side in enumerate((1.0, -1.0, 1.0, -1.0)):
        hit = (39 + 13 * i) / DEFAULT_FPS
        keys += [
            Key(hit - PUNCH_EXTEND_S, {}, (0.0, -0.03, 0.0)),
            Key(
                hit,
                {"Hips": (0, -5 * side, 0), **_chest_turn(-22 * side, 4)},
                (0.0, -0.04, 0.03),
                _straight(side, (-0.22, 0.05, 1.0)),
            ),
            Key(
                hit + PUNCH_RETRACT_S,
                {"Hips": (0, 0, 0), **_chest_turn(0)},
                (0.0, -0.03, 0.0),
                _guard(RELAXED_GUARD),
            ),
        ]
    keys.append(Key(91 / DEFAULT_FPS, {}, (0.0, -0.02, 0.0)))
    return _animate(keys, "punch_straight_alternating")


def punch_jab_cross() -> Motion:
    """Boxing: from the orthodox guard a left jab and a right cross, twice; in the cross
    the weight goes onto the front foot and the rear heel turns out as the hips turn."""
    keys = _into_boxing_guard(0.4)
    for t in (0.6, 1.6):
        jab = t + PUNCH_EXTEND_S
        cross = jab + 0.2 + PUNCH_EXTEND_S + 0.03
        keys += [
            Key(t, {}, _stance()),
            Key(
                jab,
                {"Hips": (0, STANCE_TURN_DEG - 5, 0), **_chest_turn(-22, 8)},
                _stance((0.01, -0.01, 0.04)),
                _straight(1.0, (-0.25, 0.12, 1.0)),
            ),
            Key(jab + 0.2, BOXING_GUARD_BODY, _stance(), {"LeftHand": _fist(1.0, BOXING_GUARD)}),
            Key(
                cross,
                {"Hips": (0, 10, 0), **_chest_turn(15, 10), "RightToeBase": (-35, 0, 0)},
                _stance((0.03, -0.03, 0.10)),
                {
                    **_straight(-1.0, (-0.12, 0.10, 1.0)),
                    **_boxing_feet(rear_turn_deg=30, rear_heel_deg=35),
                },
            ),
            Key(
                cross + PUNCH_RETRACT_S + 0.06,
                {**BOXING_GUARD_BODY, "RightToeBase": (0, 0, 0)},
                _stance(),
                {"RightHand": _fist(-1.0, BOXING_GUARD), **_boxing_feet()},
            ),
        ]
    keys.append(Key(keys[-1].time_s + 0.4, {}, _stance((0.0, 0.01, 0.0))))
    return _animate(keys, "punch_jab_cross")


def punch_hooks() -> Motion:
    """Boxing: from the orthodox guard a left hook, back to the guard, a right hook; the
    elbow comes up level with the fist, the body turns the fist across, the foot on the
    punching side turns on its ball."""
    hook = (0.28, 0.09, 0.34)
    across = ((-0.5, 0.0, 0.85), (0.0, -1.0, 0.0))
    wound_up = (0.2, 0.1, 0.2)
    back = {**BOXING_GUARD_BODY, **_guard_arms()}
    return _animate(
        [
            *_into_boxing_guard(0.4),
            Key(
                0.7,
                {"Hips": (0, STANCE_TURN_DEG + 5, 0), **_chest_turn(5, 6)},
                _stance((0.02, -0.03, 0.03)),
                {"LeftHand": _fist(1.0, wound_up)},
            ),
            Key(
                0.9,
                {
                    "Hips": (0, STANCE_TURN_DEG - 10, 0),
                    **_chest_turn(-15, 8),
                    "LeftArm": (0, -25, 45),
                    "LeftToeBase": (-20, 0, 0),
                },
                _stance((0.0, -0.04, 0.02)),
                {
                    "LeftHand": _fist(1.0, hook, across),
                    **_boxing_feet(lead_turn_deg=-35, lead_heel_deg=20),
                },
            ),
            Key(
                1.2,
                {**back, "LeftToeBase": (0, 0, 0)},
                _stance(),
                {"LeftHand": _fist(1.0, BOXING_GUARD), **_boxing_feet()},
            ),
            Key(
                1.5,
                {"Hips": (0, STANCE_TURN_DEG - 8, 0), **_chest_turn(-25, 6)},
                _stance((-0.01, -0.03, -0.01)),
                {"RightHand": _fist(-1.0, wound_up)},
            ),
            Key(
                1.7,
                {
                    "Hips": (0, 15, 0),
                    **_chest_turn(25, 8),
                    "RightArm": (0, 25, -45),
                    "RightToeBase": (-35, 0, 0),
                },
                _stance((0.03, -0.04, 0.08)),
                {
                    "RightHand": _fist(-1.0, hook, across),
                    **_boxing_feet(rear_turn_deg=35, rear_heel_deg=35),
                },
            ),
            Key(
                2.05,
                {**back, "RightToeBase": (0, 0, 0)},
                _stance(),
                {"RightHand": _fist(-1.0, BOXING_GUARD), **_boxing_feet()},
            ),
            Key(2.45, {}, _stance((0.0, 0.01, 0.0))),
        ],
        "punch_hooks",
    )


def punch_uppercuts() -> Motion:
    """Boxing: from the orthodox guard a right uppercut, then a left one: dip and turn
    towards the punching side, the fist drops to the chest, then the legs drive up, the
    body turns and the fist rises in front of the chin, palm towards the face."""
    dropped = ((0.0, 0.3, 1.0), (0.0, 1.0, 0.0))
    chin = (0.05, 0.2, 0.38)
    return _animate(
        [
            *_into_boxing_guard(0.4),
            Key(
                0.75,
                {"Hips": (0, STANCE_TURN_DEG - 10, 0), **_chest_turn(-25, 12)},
                _stance((-0.03, -0.09, -0.02)),
                {"RightHand": _fist(-1.0, (0.12, -0.04, 0.22), dropped)},
            ),
            Key(
                0.97,
                {"Hips": (0, 5, 0), **_chest_turn(15, 2), "RightToeBase": (-30, 0, 0)},
                _stance((0.03, 0.0, 0.06)),
                {
                    "RightHand": _fist(-1.0, chin, FIST_UPPERCUT),
                    **_boxing_feet(rear_turn_deg=30, rear_heel_deg=30),
                },
            ),
            Key(
                1.3,
                {**BOXING_GUARD_BODY, "RightToeBase": (0, 0, 0)},
                _stance(),
                {"RightHand": _fist(-1.0, BOXING_GUARD), **_boxing_feet()},
            ),
            Key(
                1.55,
                {"Hips": (0, STANCE_TURN_DEG + 10, 0), **_chest_turn(5, 12)},
                _stance((0.03, -0.09, 0.02)),
                {"LeftHand": _fist(1.0, (0.14, -0.04, 0.22), dropped)},
            ),
            Key(
                1.77,
                {
                    "Hips": (0, STANCE_TURN_DEG - 15, 0),
                    **_chest_turn(-30, 2),
                    "LeftToeBase": (-20, 0, 0),
                },
                _stance((0.0, 0.0, 0.03)),
                {
                    "LeftHand": _fist(1.0, chin, FIST_UPPERCUT),
                    **_boxing_feet(lead_turn_deg=-30, lead_heel_deg=20),
                },
            ),
            Key(
                2.1,
                {**BOXING_GUARD_BODY, "LeftToeBase": (0, 0, 0)},
                _stance(),
                {"LeftHand": _fist(1.0, BOXING_GUARD), **_boxing_feet()},
            ),
            Key(2.5, {}, _stance((0.0, 0.01, 0.0))),
        ],
        "punch_uppercuts",
    )


def punch_stepping_in() -> Motion:
    """From standing, fists up, step forwards with the left foot and throw a straight
    right as it lands, the rear heel coming up and the hips turning in; then the fist
    comes back and the hands go down."""
    rest = rest_positions_m(canonical_skeleton())
    ankle = rest["LeftFoot"][[0, 2]]
    rear_ball = tuple(rest["RightToeBase"][[0, 2]])

    def lead(forward_m: float, heel_deg: float = 0.0, lift_m: float = 0.0) -> Target:
        """The left foot ``forward_m`` on, turning its toes a little in as it goes."""
        x, z = ankle[0] - 0.1 * forward_m, ankle[1] + forward_m
        return foot_target("LeftFoot", (x, z), -25.0 * forward_m, heel_deg, lift_m)

    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted()),
            Key(0.45, _guard_arms(), (0.0, -0.03, 0.0), _guard(RELAXED_GUARD)),
            Key(0.6, {"LeftToeBase": (0, 0, 0)}, (0.01, -0.04, 0.02), {"LeftFoot": lead(0.0)}),
            Key(
                0.72,
                {"LeftToeBase": (-25, 0, 0)},
                (-0.01, -0.04, 0.07),
                {"LeftFoot": lead(0.0, 25.0)},
            ),
            Key(
                0.84,
                {"LeftToeBase": (0, 0, 0), "Hips": (0, -5, 0), **_chest_turn(-10, 4)},
                (-0.01, -0.04, 0.15),
                {"LeftFoot": lead(0.22, 5.0, 0.07)},
            ),
            Key(
                0.98,
                {"Hips": (0, 18, 0), **_chest_turn(22, 12), "RightToeBase": (-30, 0, 0)},
                (0.03, -0.08, 0.28),
                {
                    "LeftFoot": lead(0.45),
                    "RightFoot": _foot_on_ball("RightFoot", rear_ball, 20.0, 30.0),
                    **_straight(-1.0, (-0.15, 0.08, 1.0)),
                },
            ),
            Key(1.1, {}, (0.03, -0.08, 0.29)),
            Key(
                1.4,
                {"Hips": (0, 5, 0), **_chest_turn(0, 4), "RightToeBase": (0, 0, 0)},
                (0.02, -0.06, 0.25),
                {
                    "RightHand": _fist(-1.0, RELAXED_GUARD),
                    "RightFoot": _foot_on_ball("RightFoot", rear_ball, 20.0, 0.0),
                },
            ),
            Key(
                2.1,
                {**ARMS_DOWN, "Hips": (0, 5, 0), **_chest_turn(0), **_fists(0.0)},
                (0.02, -0.02, 0.24),
                {"LeftHand": None, "RightHand": None},
            ),
            Key(2.4, {}, (0.02, -0.01, 0.24)),
        ],
        "punch_stepping_in",
    )


def punch_lunging() -> Motion:
    """Lunge punch (oi-zuki): fists up, step the right foot far forwards into a long, low
    front stance and drive a straight right as it lands, the left fist pulled back to
    the hip; hold, bring the fist back, arms down, still in the stance."""
    rest = rest_positions_m(canonical_skeleton())
    ankle = rest["RightFoot"][[0, 2]]

    def front(forward_m: float, heel_deg: float = 0.0, lift_m: float = 0.0) -> Target:
        """The right foot ``forward_m`` on, drawn in under the body as it passes."""
        x, z = ankle[0] + 0.04 * forward_m, ankle[1] + forward_m
        return foot_target("RightFoot", (x, z), 10.0 * forward_m, heel_deg, lift_m)

    lunge = (0.0, -0.17, 0.42)
    hip_fist = _fist(1.0, (0.17, -0.32, 0.02), ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)))
    return _animate(
        [
            Key(0.0, {**ARMS_DOWN, **SPINE_STRAIGHT}, (0, 0, 0), _planted()),
            Key(0.4, _guard_arms(), (0.0, -0.05, 0.0), _guard(RELAXED_GUARD)),
            Key(
                0.58,
                {"RightToeBase": (-25, 0, 0)},
                (0.01, -0.07, 0.06),
                {"RightFoot": front(0.0, 25.0)},
            ),
            Key(
                0.76,
                {"RightToeBase": (0, 0, 0), **_chest_turn(-10, 4)},
                (0.02, -0.10, 0.22),
                {"RightFoot": front(0.38, 5.0, 0.09)},
            ),
            Key(
                0.95,
                {"Hips": (0, 10, 0), **_chest_turn(25, 8)},
                lunge,
                {
                    "RightFoot": front(0.80),
                    "LeftHand": hip_fist,
                    **_straight(-1.0, (0.1, 0.05, 1.0)),
                },
            ),
            Key(1.3, {}, (lunge[0], lunge[1] - 0.01, lunge[2])),
            Key(
                1.7,
                {"Hips": (0, 0, 0), **_chest_turn(0, 6)},
                lunge,
                {"RightHand": _fist(-1.0, RELAXED_GUARD), "LeftHand": _fist(1.0, RELAXED_GUARD)},
            ),
            Key(
                2.3,
                {**ARMS_DOWN, **_chest_turn(0), **_fists(0.0)},
                (0.0, -0.12, 0.40),
                {"LeftHand": None, "RightHand": None},
            ),
            Key(2.6, {}, (0.0, -0.11, 0.40)),
        ],
        "punch_lunging",
    )


# -- kick -------------------------------------------------------------------------------------

#: Seconds from the kicking foot leaving the floor to the knee up (the chamber), from
#: there to the leg out (the hit), back to the chamber, and down to the floor.  The CMU
#: front and roundhouse kicks (135_04, 135_07) take 0.7-0.8 s from the foot leaving
#: the floor to its setting down, the hit 0.3-0.4 s after it leaves.
KICK_CHAMBER_S = 0.22
KICK_EXTEND_S = 0.12
KICK_RETRACT_S = 0.15
KICK_DOWN_S = 0.22

#: The right thigh at rest, hip to knee (body frame: x left, y up, z forward).
RIGHT_THIGH_REST = tuple(
    rest_positions_m(canonical_skeleton())["RightLeg"]
    - rest_positions_m(canonical_skeleton())["RightUpLeg"]
)


def _body_deg(yaw_deg: float, lean_deg: float = 0.0, roll_deg: float = 0.0) -> tuple:
    """Rotation ``(x, y, z)`` of a body part leaning forwards by ``lean_deg`` and rolling
    by ``roll_deg`` about its own forward axis (positive raises the left side) and then
    turned by ``yaw_deg`` about the vertical (positive to the left)."""
    m = (
        euler_to_matrix([0.0, yaw_deg, 0.0], "XYZ")
        @ euler_to_matrix([lean_deg, 0.0, 0.0], "XYZ")
        @ euler_to_matrix([0.0, 0.0, roll_deg], "XYZ")
    )
    z, x, y = matrix_to_euler(m, "ZXY")
    return (float(x), float(y), float(z))


def _kick_body(
    yaw_deg: float,
    lean_deg: float = 0.0,
    roll_deg: float = 0.0,
    chest_deg: float = 0.0,
    back_deg: float = 6.0,
) -> dict[str, tuple[float, float, float]]:
    """Hips turned by ``yaw_deg`` (from facing +Z), leaning forwards ``lean_deg`` and
    rolled ``roll_deg`` (negative lifts the right hip, the kicking one); the shoulders
    turned ``chest_deg`` further over them and leaning ``back_deg`` forwards; the head
    turned back to look where the body faced at the start, at the target."""
    look = -(yaw_deg + chest_deg)
    return {
        "Hips": _body_deg(yaw_deg, lean_deg, roll_deg),
        "LowerBack": (0.5 * back_deg, 0.35 * chest_deg, -0.3 * roll_deg),
        "Spine": (0.3 * back_deg, 0.35 * chest_deg, -0.2 * roll_deg),
        "Spine1": (0.2 * back_deg, 0.3 * chest_deg, 0.0),
        "Neck": (-0.5 * back_deg - 0.3 * lean_deg, 0.5 * look, -0.2 * roll_deg),
        "Head": (-0.3 * back_deg, 0.4 * look, -0.2 * roll_deg),
    }


def _right_leg(
    thigh, kneecap, knee_deg: float, foot_deg: float = 0.0, toes_deg: float = 0.0
) -> dict[str, tuple[float, float, float]]:
    """Rotations of the right leg in the hips' frame (x left, y up, z forward): the thigh
    pointing along ``thigh``, the kneecap facing ``kneecap`` (turned about the thigh only),
    the knee bent ``knee_deg``, the foot pointed ``foot_deg`` (negative pulls the toes up,
    a heel or a sole leading) and the toes bent ``toes_deg`` (negative up, onto the ball)."""
    return {
        "RightUpLeg": aim_deg([RIGHT_THIGH_REST, (0.0, 0.0, 1.0)], [thigh, kneecap]),
        "RightLeg": (knee_deg, 0.0, 0.0),
        "RightFoot": (foot_deg, 0.0, 0.0),
        "RightToeBase": (toes_deg, 0.0, 0.0),
    }


#: The right leg standing at the back of the orthodox stance (the IK plants the foot,
#: this sets the way the knee bends).
REAR_LEG_STANDING = _right_leg((0.0, -1.0, 0.05), (0.0, 0.0, 1.0), 10.0)


def _support(turn_deg: float = 0.0, heel_deg: float = 0.0) -> dict[str, Target]:
    """The left foot, the standing one, turned on its ball by ``turn_deg`` from its
    stance heading (positive to the left), heel up by ``heel_deg``."""
    return {"LeftFoot": _foot_on_ball("LeftFoot", LEAD_BALL_XZ, LEAD_YAW_DEG + turn_deg, heel_deg)}


def _rear_foot(heel_deg: float = 0.0) -> dict[str, Target]:
    """The right foot on the floor at the back of the orthodox stance, heel up by
    ``heel_deg`` (on its ball)."""
    return {"RightFoot": _foot_on_ball("RightFoot", REAR_BALL_XZ, REAR_YAW_DEG, heel_deg)}


#: One phase of a kick: the body (:func:`_kick_body`), the kicking leg
#: (:func:`_right_leg`), the root's shift from the stance (metres) and the standing
#: foot's turn and heel raise (degrees).
KickPhase = tuple[dict, dict, tuple[float, float, float], float, float]


def _rear_leg_kick(
    name: str, chamber: KickPhase, hit: KickPhase, rechamber: KickPhase | None = None
) -> Motion:
    """A kick with the rear (right) leg from the orthodox guard: settle in the guard,
    weight onto the front foot and the rear heel up, knee up (``chamber``), leg out
    (``hit``), knee back (``rechamber``, default the chamber), the foot down where it
    started, back in the guard; the standing foot pivots on its ball as each phase
    turns it.  Times from :data:`KICK_CHAMBER_S` and the rest."""
    rechamber = rechamber or chamber
    guard_body = _kick_body(STANCE_TURN_DEG, chest_deg=-10.0)
    lift = 0.75
    times = np.cumsum([lift, KICK_CHAMBER_S, KICK_EXTEND_S, KICK_RETRACT_S])
    keys = [
        *_into_boxing_guard(0.4),
        Key(0.6, {**REAR_LEG_STANDING, **guard_body}, _stance(), {**_rear_foot(), **_support()}),
        Key(
            lift,
            _kick_body(STANCE_TURN_DEG + 5.0, chest_deg=-10.0),
            _stance((0.05, -0.02, 0.07)),
            {**_rear_foot(heel_deg=35.0), **_support()},
        ),
    ]
    for t, (body, leg, shift, turn, heel) in zip(times[1:], (chamber, hit, rechamber), strict=True):
        keys.append(
            Key(
                t,
                {**body, **leg, "LeftToeBase": (-heel, 0.0, 0.0)},
                _stance(shift),
                {"RightFoot": None, **_support(turn, heel)},
            )
        )
    down = times[-1] + KICK_DOWN_S
    keys += [
        Key(
            down - 0.07,
            {**_kick_body(STANCE_TURN_DEG + 10.0, chest_deg=-10.0), **REAR_LEG_STANDING},
            _stance((0.04, -0.01, 0.05)),
            {"RightFoot": _foot_on_ball("RightFoot", REAR_BALL_XZ, REAR_YAW_DEG, 20.0)},
        ),
        Key(
            down,
            {"LeftToeBase": (0.0, 0.0, 0.0)},
            _stance((0.02, -0.02, 0.02)),
            {**_rear_foot(), **_support()},
        ),
        Key(down + 0.35, guard_body, _stance()),
        Key(down + 0.7, {}, _stance((0.0, 0.01, 0.0))),
    ]
    return _animate(keys, name)


def kick_front_snap() -> Motion:
    """Front snap kick with the rear leg: the knee comes up in front, the lower leg
    snaps out at waist height striking with the ball of the foot (toes pulled back) and
    snaps back; the hips square up, the standing foot turns out a little."""
    chamber = _right_leg((0.05, 0.05, 1.0), (0.0, 1.0, 0.0), 120.0, 35.0, -40.0)
    hit = _right_leg((0.05, 0.12, 1.0), (0.0, 1.0, 0.0), 8.0, 40.0, -40.0)
    return _rear_leg_kick(
        "kick_front_snap",
        (_kick_body(-5.0, 0.0, -5.0, -10.0, 2.0), chamber, (0.07, -0.03, 0.12), -15.0, 0.0),
        (_kick_body(0.0, -8.0, -5.0, -10.0, -4.0), hit, (0.07, -0.02, 0.14), -20.0, 10.0),
    )


def kick_push() -> Motion:
    """Push kick (teep) with the rear leg: the knee comes up high to the chest, the hips
    drive forwards as the leg pushes straight out with the sole, toes up, the body
    leaning back; the leg comes back bent and down."""
    chamber = _right_leg((0.05, 0.25, 1.0), (0.0, 1.0, -0.2), 125.0, -10.0, 0.0)
    hit = _right_leg((0.02, 0.1, 1.0), (0.0, 1.0, 0.0), 5.0, -15.0, 0.0)
    return _rear_leg_kick(
        "kick_push",
        (_kick_body(-5.0, -5.0, -3.0, -10.0, 0.0), chamber, (0.07, -0.02, 0.10), -15.0, 0.0),
        (_kick_body(0.0, -18.0, -3.0, -5.0, -6.0), hit, (0.06, -0.03, 0.22), -20.0, 0.0),
    )


def kick_roundhouse() -> Motion:
    """Roundhouse kick with the rear leg: the body turns over the standing foot, which
    pivots on its ball until the heel points at the target, the hip turns over (the
    kicking hip above the other), the knee comes up sideways and the shin whips round
    horizontally at chest height, striking with the instep; back the same way."""
    chamber = _right_leg((-1.0, 0.15, 0.45), (0.0, 0.2, 1.0), 125.0, 40.0)
    hit = _right_leg((-1.0, 0.25, 0.2), (0.0, 0.2, 1.0), 8.0, 45.0)
    rechamber = _right_leg((-1.0, 0.1, 0.4), (0.0, 0.2, 1.0), 120.0, 40.0)
    return _rear_leg_kick(
        "kick_roundhouse",
        (_kick_body(45.0, 0.0, -20.0, -35.0, 4.0), chamber, (0.08, -0.02, 0.12), 50.0, 20.0),
        (_kick_body(85.0, 0.0, -38.0, -45.0, 2.0), hit, (0.08, -0.04, 0.12), 95.0, 20.0),
        (_kick_body(70.0, 0.0, -30.0, -40.0, 4.0), rechamber, (0.08, -0.03, 0.12), 80.0, 20.0),
    )


def kick_side() -> Motion:
    """Side kick with the rear leg: the knee comes up across the front of the body, the
    body turns side-on over the standing foot (pivoting on its ball, heel towards the
    target), leans away and thrusts the leg straight out sideways at waist height, the
    heel leading, the foot's edge horizontal; it comes back bent and down."""
    chamber = _right_leg((-0.35, 0.35, 0.85), (0.0, 0.8, 0.6), 130.0, -10.0)
    hit = _right_leg((-1.0, 0.15, 0.15), (0.0, 0.1, 1.0), 4.0, -20.0)
    return _rear_leg_kick(
        "kick_side",
        (_kick_body(50.0, 0.0, -10.0, -30.0, 4.0), chamber, (0.08, -0.03, 0.10), 60.0, 15.0),
        (_kick_body(85.0, 0.0, -40.0, -40.0, 0.0), hit, (0.07, -0.04, 0.10), 110.0, 15.0),
        (_kick_body(70.0, 0.0, -20.0, -35.0, 4.0), chamber, (0.08, -0.03, 0.10), 90.0, 15.0),
    )


def kick_low() -> Motion:
    """Low kick with the rear leg: a short roundhouse at thigh height, the body turning
    half round over the standing foot and the shin swinging in almost straight to the
    side of the target's thigh; back and down."""
    chamber = _right_leg((-0.9, -0.2, 0.5), (0.0, 0.4, 1.0), 90.0, 30.0)
    hit = _right_leg((-1.0, -0.12, 0.25), (0.0, 0.4, 1.0), 12.0, 35.0)
    return _rear_leg_kick(
        "kick_low",
        (_kick_body(25.0, 5.0, -12.0, -25.0, 8.0), chamber, (0.07, -0.05, 0.10), 30.0, 15.0),
        (_kick_body(55.0, 5.0, -22.0, -40.0, 8.0), hit, (0.07, -0.06, 0.10), 60.0, 15.0),
    )


def kick_axe() -> Motion:
    """Axe kick with the rear leg: the straight leg swings up outside the body to above
    head height, passes over in front and chops straight down with the heel; the foot
    comes down ahead into the other stance (right foot in front)."""
    land_ball = (-0.06, 0.52)
    up = _right_leg((-0.55, 0.45, 0.7), (0.3, 0.3, 1.0), 12.0, 10.0)
    top = _right_leg((-0.15, 0.85, 0.5), (0.0, 0.5, 1.0), 5.0, -10.0)
    chop = _right_leg((-0.02, -0.1, 1.0), (0.0, 1.0, 0.1), 8.0, -15.0)
    guard_body = _kick_body(STANCE_TURN_DEG, chest_deg=-10.0)
    switched = _kick_body(-STANCE_TURN_DEG + 10.0, chest_deg=10.0)
    lift = 0.75
    t_up, t_top, t_chop = lift + 0.2, lift + 0.36, lift + 0.52
    return _animate(
        [
            *_into_boxing_guard(0.4),
            Key(
                0.6,
                {**REAR_LEG_STANDING, **guard_body},
                _stance(),
                {**_rear_foot(), **_support()},
            ),
            Key(
                lift,
                _kick_body(STANCE_TURN_DEG + 5.0, chest_deg=-10.0),
                _stance((0.05, -0.02, 0.07)),
                {**_rear_foot(heel_deg=35.0), **_support()},
            ),
            Key(
                t_up,
                {**_kick_body(0.0, -5.0, -8.0, -10.0, 0.0), **up},
                _stance((0.08, -0.03, 0.10)),
                {"RightFoot": None, **_support(-15.0)},
            ),
            Key(
                t_top,
                {**_kick_body(0.0, -15.0, -5.0, -5.0, -5.0), **top},
                _stance((0.07, -0.02, 0.12)),
            ),
            Key(
                t_chop,
                {**_kick_body(-5.0, 5.0, -3.0, -5.0, 8.0), **chop},
                _stance((0.05, -0.06, 0.16)),
            ),
            Key(
                t_chop + 0.12,
                {
                    **_kick_body(-8.0, 3.0, 0.0, 0.0, 6.0),
                    **_right_leg((-0.02, -0.9, 0.45), (0.0, 0.3, 1.0), 15.0),
                },
                _stance((0.0, -0.06, 0.22)),
                {"RightFoot": _foot_on_ball("RightFoot", land_ball, 5.0)},
            ),
            Key(t_chop + 0.5, switched, _stance((0.0, -0.04, 0.28))),
            Key(t_chop + 0.9, {}, _stance((0.0, -0.03, 0.28))),
        ],
        "kick_axe",
    )


MOTIONS: dict[str, Callable[[], Motion]] = {
    "lift_chest_to_overhead": lift_chest_to_overhead,
    "lift_table_to_shoulder": lift_table_to_shoulder,
    "lift_clean_and_press": lift_clean_and_press,
    "lift_table_to_shelf": lift_table_to_shelf,
    "lift_bag_onto_overhead_rack": lift_bag_onto_overhead_rack,
    "sit_down_holding_stomach_slow": sit_down_holding_stomach_slow,
    "sit_down_holding_stomach_fast": sit_down_holding_stomach_fast,
    "sit_down_doubled_over": sit_down_doubled_over,
    "sit_down_hands_on_knees": sit_down_hands_on_knees,
    "sit_down_on_the_floor": sit_down_on_the_floor,
    "sit_down_low_step": sit_down_low_step,
    "sit_down_squatting": sit_down_squatting,
    "sit_down_slumping_to_the_floor": sit_down_slumping_to_the_floor,
    "cover_head_standing": cover_head_standing,
    "cover_head_crouching": cover_head_crouching,
    "cover_head_stooping": cover_head_stooping,
    "cover_head_stepping_back": cover_head_stepping_back,
    "cover_head_one_arm": cover_head_one_arm,
    "cover_head_kneeling": cover_head_kneeling,
    "cover_head_kneeling_on_one_knee": cover_head_kneeling_on_one_knee,
    "cover_head_one_arm_crouching": cover_head_one_arm_crouching,
    "fall_down_forwards": fall_down_forwards,
    "fall_down_backwards": fall_down_backwards,
    "fall_down_sideways": fall_down_sideways,
    "turn_in_place_90": turn_in_place_90,
    "turn_in_place_180": turn_in_place_180,
    "turn_walking_180": turn_walking_180,
    "turn_walking_90": turn_walking_90,
    "turn_walking_90_brisk": turn_walking_90_brisk,
    "jump_forward_standing": jump_forward_standing,
    "jump_hop_one_leg": jump_hop_one_leg,
    "jump_running": jump_running,
    "jump_hop_in_place": jump_hop_in_place,
    "jump_hops_both_feet": jump_hops_both_feet,
    "jump_vertical_reach": jump_vertical_reach,
    "run_jogging": run_jogging,
    "run_fast": run_fast,
    "run_easy": run_easy,
    "wave_right_hand": wave_right_hand,
    "wave_left_hand": wave_left_hand,
    "wave_both_hands": wave_both_hands,
    "wave_both_arms_crossing": wave_both_arms_crossing,
    "wave_big_arcs_right": wave_big_arcs_right,
    "wave_big_arcs_both": wave_big_arcs_both,
    "pick_up_squatting": pick_up_squatting,
    "pick_up_bending": pick_up_bending,
    "pick_up_one_hand": pick_up_one_hand,
    "pick_up_reaching_forwards": pick_up_reaching_forwards,
    "pick_up_heavy_box_to_chest": pick_up_heavy_box_to_chest,
    "pick_up_heavy_box_stooping": pick_up_heavy_box_stooping,
    "pick_up_suitcase_one_hand": pick_up_suitcase_one_hand,
    "pick_up_walking_in": pick_up_walking_in,
    "pick_up_walking_in_crouching": pick_up_walking_in_crouching,
    "pick_up_jogging_in": pick_up_jogging_in,
    "punch_straight_alternating": punch_straight_alternating,
    "punch_jab_cross": punch_jab_cross,
    "punch_hooks": punch_hooks,
    "punch_uppercuts": punch_uppercuts,
    "punch_stepping_in": punch_stepping_in,
    "punch_lunging": punch_lunging,
    "kick_front_snap": kick_front_snap,
    "kick_push": kick_push,
    "kick_roundhouse": kick_roundhouse,
    "kick_side": kick_side,
    "kick_low": kick_low,
    "kick_axe": kick_axe,
}


def build_all() -> dict[str, Motion]:
    """Every authored motion, by name (the BVH file stem)."""
    return {name: make() for name, make in MOTIONS.items()}


def write_all(out_dir: Path) -> list[Path]:
    """Write every authored motion as ``out_dir/<name>.bvh``; returns the paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, motion in build_all().items():
        path = out_dir / f"{name}.bvh"
        write_bvh(motion, path)
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE, help="output folder (default: here)")
    args = parser.parse_args(argv)
    for path in write_all(args.out):
        sys.stdout.write(f"{path}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
