"""Author the keyframed basic motions and write them as BVH files next to this script.

No free motion capture shows these motions, so they are authored on the default
avatar's skeleton (:func:`eigmotion.canonical.canonical_skeleton`) with
:mod:`eigmotion.authoring`: a few key poses each, interpolated at 30 fps, feet planted
by two-bone IK, every frame resting on the floor.

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

from eigmotion.authoring import (
    Key,
    Target,
    aim_deg,
    animate,
    body_surface_points,
    foot_targets,
)
from eigmotion.bvh import write_bvh
from eigmotion.motion import Motion

HERE = Path(__file__).resolve().parent

#: Seat height of the chair for sit_down, metres (a common chair).
SEAT_HEIGHT_M = 0.45

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


def _box(y_m: float, z_m: float, half_width_m: float = 0.2) -> dict[str, Target]:
    """Wrist targets gripping a box by its sides, world metres.

    A box on the floor is about 0.4 m tall and gripped near its top edges.
    """
    return {
        "LeftHand": Target((half_width_m, y_m, z_m)),
        "RightHand": Target((-half_width_m, y_m, z_m)),
    }


def lift_floor_to_chest() -> Motion:
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
        "lift_floor_to_chest",
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
                    "LeftArm": (-20, 0, 60),
                    "RightArm": (-20, 0, -60),
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


def lift_floor_to_waist_stoop() -> Motion:
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
        "lift_floor_to_waist_stoop",
    )


# -- sit down holding the stomach ------------------------------------------------------------


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


ARMS_UP = {"LeftArm": (-30, 0, 80), "RightArm": (-30, 0, -80)}


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
                    "LeftShoulder": (0, 0, 10),
                    "RightShoulder": (0, 0, -10),
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


MOTIONS: dict[str, Callable[[], Motion]] = {
    "lift_floor_to_chest": lift_floor_to_chest,
    "lift_chest_to_overhead": lift_chest_to_overhead,
    "lift_floor_to_waist_stoop": lift_floor_to_waist_stoop,
    "sit_down_holding_stomach_slow": sit_down_holding_stomach_slow,
    "sit_down_holding_stomach_fast": sit_down_holding_stomach_fast,
    "sit_down_doubled_over": sit_down_doubled_over,
    "cover_head_standing": cover_head_standing,
    "cover_head_crouching": cover_head_crouching,
    "cover_head_stooping": cover_head_stooping,
    "fall_down_forwards": fall_down_forwards,
    "fall_down_backwards": fall_down_backwards,
    "fall_down_sideways": fall_down_sideways,
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
