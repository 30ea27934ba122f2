"""Keyframed motions authored on a skeleton: keys, smooth interpolation, IK, ground contact.

Some basic motions have no free motion capture (covering the head against a falling
object, falling down, lifting a heavy load, sitting down holding the stomach); they are
authored here as a few key poses and turned into a :class:`~eigmotion.mocap.motion.Motion`.

Conventions (those of :mod:`eigmotion.mocap.motion` and :mod:`eigmotion.mocap.canonical`):

* world: metres, Y up, floor at y = 0; the body at rest faces +Z, its left is +X;
* every joint frame is parallel to the world frame at rest, and a joint's rotation is
  relative to its rest pose, so a key rotation ``(x, y, z)`` of a joint turns the joint
  (and everything below it) about its parent's axes: positive X swings a hanging limb
  backwards and bends the spine forwards, positive Y turns to the body's left, positive Z
  turns +X towards +Y (raises the left arm sideways, lowers the right);
* key rotations are Euler angles in degrees, always written ``(x, y, z)`` and composed
  in the order ``order`` (intrinsic, as BVH channels: ``"ZXY"`` means
  ``R = Rz(z) @ Rx(x) @ Ry(y)``).

The pipeline of :func:`animate`, one stage after the other:

1. keys are completed (a joint or target a key does not mention keeps its value from
   the previous key; the first key starts from rest);
2. joint rotations (as rotation vectors relative to rest), root offsets and IK targets
   are interpolated with monotone piecewise-cubic Hermite splines (PCHIP): C1 smooth,
   never overshooting a key, at rest at every key that is a local extremum;
3. two-bone inverse kinematics moves the limbs that have targets (feet planted on the
   floor, hands on a box or on the body);
4. each frame is lifted or lowered so that its lowest point (a joint, an end site or a
   given skin point, see :func:`body_surface_points`) touches the floor, so nothing
   sinks and something always bears the weight;
5. in the flight phases of jumps and hops, the root follows a ballistic arc instead.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.canonical import (
    CANONICAL_JOINTS,
    canonical_skeleton,
    load_makehuman_rig,
    makehuman_dir,
)
from eigmotion.mocap.kinematics import rest_points
from eigmotion.mocap.motion import Motion, Skeleton
from eigmotion.mocap.rotations import (
    align_vectors,
    check_euler_order,
    euler_to_matrix,
    matrix_to_euler,
)
from eigmotion.synth.keyframes import (
    Key,
    Target,
    interpolate_rotations,
    pchip_interpolate,
    unwrap_rotvecs,
)
from eigmotion.synth.limb_ik import frame_change, solve_limb, unit_vectors

#: Euler order of key rotations unless :func:`animate` is told otherwise.
KEY_EULER_ORDER = "ZXY"

#: Frames per second of authored motions.
DEFAULT_FPS = 30.0

#: Gravity, m/s²: the root of a body in flight falls with this acceleration.
GRAVITY_M_S2 = 9.81


# -- rest geometry ---------------------------------------------------------------------------


def standing_root_height_m(skeleton: Skeleton) -> float:
    """Root height above the floor when the rest pose stands on it (lowest point y = 0).

    Parameters
    ----------
    skeleton : Skeleton
        In metres.

    Returns
    -------
    float
        Metres.
    """
    return float(-rest_points(skeleton)[:, 1].min())


def standing_root_position_m(skeleton: Skeleton) -> np.ndarray:
    """(3,) float: root position, metres, of the rest pose standing at the origin."""
    return np.array([0.0, standing_root_height_m(skeleton), 0.0])


def rest_positions_m(skeleton: Skeleton) -> dict[str, np.ndarray]:
    """Joint name → (3,) rest position, metres, standing at the origin on the floor."""
    pts = rest_points(skeleton)[: skeleton.n_joints] + standing_root_position_m(skeleton)
    return {name: pts[j] for j, name in enumerate(skeleton.names)}


def foot_target(
    joint: str,
    ankle_xz_m: Sequence[float],
    yaw_deg: float = 0.0,
    heel_raise_deg: float = 0.0,
    lift_m: float = 0.0,
    skeleton: Skeleton | None = None,
    order: str = KEY_EULER_ORDER,
) -> Target:
    """Target of one foot standing on the floor anywhere, turned, heel raised or lifted.

    Parameters
    ----------
    joint : str
        The ankle joint (``"LeftFoot"``); its first child is the ball of the foot.
    ankle_xz_m : (2,) float
        Where the ankle is, horizontally, when the foot stands flat, metres (world x, z).
    yaw_deg : float
        The foot's turn about the vertical through the ankle, degrees; positive turns
        the toes (+Z at rest) towards +X.
    heel_raise_deg : float
        The foot pitches heel-up by this angle about the ball of the foot, which stays
        where it is, degrees; key the toe joint by ``(-heel_raise_deg, 0, 0)`` to keep
        the toes flat.
    lift_m : float
        The whole foot is this far above the floor, metres.
    skeleton : Skeleton, optional
        Default :func:`~eigmotion.mocap.canonical.canonical_skeleton`.
    order : str
        Euler order in which the target's ``rotation_deg`` is written (the key order).

    Returns
    -------
    Target
        World target of the ankle with ``rotation_deg`` set.
    """
    skeleton = skeleton or canonical_skeleton()
    order = check_euler_order(order)
    children = skeleton.children(skeleton.index(joint))
    if not children:
        raise InvalidParameterError(f"foot joint {joint!r} has no child (the ball of the foot)")
    rest = rest_positions_m(skeleton)
    ankle = np.array([ankle_xz_m[0], rest[joint][1] + lift_m, ankle_xz_m[1]], dtype=np.float64)
    to_ball = rest[skeleton.names[children[0]]] - rest[joint]
    yaw = euler_to_matrix([0.0, yaw_deg, 0.0], "XYZ")
    pitch = euler_to_matrix([heel_raise_deg, 0.0, 0.0], "XYZ")
    rot = yaw @ pitch
    pos = ankle + yaw @ to_ball - rot @ to_ball
    angles = matrix_to_euler(rot, order)
    xyz = tuple(float(angles[order.index(a)]) for a in "XYZ")
    return Target(tuple(pos), rotation_deg=xyz)


def foot_targets(
    skeleton: Skeleton | None = None,
    extra_width_m: float = 0.0,
    toe_out_deg: float = 0.0,
    heel_raise_deg: float = 0.0,
    shift_m: Sequence[float] = (0.0, 0.0, 0.0),
    feet: tuple[str, str] = ("LeftFoot", "RightFoot"),
    order: str = KEY_EULER_ORDER,
) -> dict[str, Target]:
    """Targets that plant both feet on the floor about their rest places.

    Parameters
    ----------
    skeleton : Skeleton, optional
        Default :func:`~eigmotion.mocap.canonical.canonical_skeleton`.
    extra_width_m : float
        Each foot moves this far outwards (±X) from its rest place, metres.
    toe_out_deg : float
        Each foot turns its toes outwards by this angle about Y, degrees.
    heel_raise_deg : float
        Each foot pitches heel-up by this angle about the ball of the foot (its first
        child joint), which stays on the floor, degrees; key the toe joints by
        ``(-heel_raise_deg, 0, 0)`` to keep the toes flat.
    shift_m : (3,) float
        Moves both feet (e.g. a step back), metres.
    feet : (str, str)
        The left and right ankle joints.
    order : str
        Euler order in which the targets' ``rotation_deg`` are written (the key order).

    Returns
    -------
    dict of str to Target
        Ankle joint → world target with ``rotation_deg`` set (see :func:`foot_target`).
    """
    skeleton = skeleton or canonical_skeleton()
    rest = rest_positions_m(skeleton)
    shift = np.asarray(shift_m, dtype=np.float64)
    out = {}
    for side, joint in zip((1.0, -1.0), feet, strict=True):
        # skeleton.index names a joint the skeleton lacks.
        x, _, z = rest[skeleton.names[skeleton.index(joint)]] + [side * extra_width_m, 0, 0] + shift
        out[joint] = foot_target(
            joint, (x, z), side * toe_out_deg, heel_raise_deg, shift[1], skeleton, order
        )
    return out


def aim_deg(
    rest_vectors: Sequence[Sequence[float]],
    target_vectors: Sequence[Sequence[float]],
    order: str = KEY_EULER_ORDER,
) -> tuple[float, float, float]:
    """Euler angles of the rotation turning rest directions onto wanted directions.

    Handy for a ``Target.rotation_deg`` or a key rotation: e.g. the finger direction
    and the palm normal of a hand at rest onto where they should point.

    Parameters
    ----------
    rest_vectors : (N, 3) float
        Directions at rest (any length; the first is matched exactly when N = 2 and
        the pairs make different angles).
    target_vectors : (N, 3) float
        Where each should point.
    order : str
        Euler order of the result.

    Returns
    -------
    (float, float, float)
        ``(x, y, z)`` degrees, composed in ``order``.
    """
    rest = unit_vectors(np.asarray(rest_vectors, dtype=np.float64).reshape(-1, 3))
    target = unit_vectors(np.asarray(target_vectors, dtype=np.float64).reshape(-1, 3))
    if rest.shape != target.shape:
        raise InvalidParameterError(
            f"aim_deg needs as many target vectors as rest vectors, got {len(rest)} and "
            f"{len(target)}"
        )
    if len(rest) == 2:
        # Exact on the first pair, the second only fixes the turn about it.
        rot = frame_change(rest[:1], rest[1:], target[:1], target[1:])[0]
    else:
        rot = align_vectors(rest, target)
    order = check_euler_order(order)
    angles = matrix_to_euler(rot, order)
    return tuple(float(angles[order.index(a)]) for a in "XYZ")


# -- the engine ---------------------------------------------------------------------------------


def animate(
    keys: Sequence[Key],
    skeleton: Skeleton | None = None,
    fps: float = DEFAULT_FPS,
    order: str = KEY_EULER_ORDER,
    ground: bool = True,
    contact_points_m: Mapping[str, np.ndarray] | None = None,
    name: str = "",
    flights_s: Sequence[tuple[float, float]] = (),
) -> Motion:
    """Turn key poses into a motion.

    Parameters
    ----------
    keys : sequence of Key
        At least two, at strictly increasing times; the motion runs from the first
        key's time to the last one's.
    skeleton : Skeleton, optional
        In metres, local frames world-aligned at rest; default
        :func:`~eigmotion.mocap.canonical.canonical_skeleton`.
    fps : float
        Output frame rate.
    order : str
        Euler order of the key rotations (``"ZXY"``: ``R = Rz @ Rx @ Ry``).
    ground : bool
        Shift every frame vertically so that its lowest point is at y = 0: the lowest
        joint, end site or contact point.
    contact_points_m : mapping of str to (N, 3) float, optional
        Joint name → points on the body surface around that joint, metres, in the
        joint's frame (world-aligned at rest), e.g. :func:`body_surface_points`, so that
        a body lying on the floor rests on its skin rather than on its bones.
    name : str
        The motion's name.
    flights_s : sequence of (float, float)
        ``(take_off, landing)`` times, seconds, of the phases in which nothing touches
        the floor (jumps, hops): in between, the root's height is not set by the floor
        but follows a ballistic arc (gravity :data:`GRAVITY_M_S2`) from its height at
        take-off to its height at landing; its horizontal path and the pose still come
        from the keys.  Within the keys' time span, in order, not overlapping.

    Returns
    -------
    Motion
        On ``skeleton`` with standard channels (root 6, others 3, ``ZXY``), metres
        (``length_unit_m = 1``), ``frame_time_s = 1 / fps``; the root starts standing
        at the origin plus the first key's offset.

    Raises
    ------
    InvalidParameterError
        Fewer than two keys, times not increasing, an unknown joint, a target on a
        joint without two ancestors, overlapping limbs, a bad ``fps``, or flights out
        of order or outside the keys.
    """
    skeleton = skeleton or canonical_skeleton()
    order = check_euler_order(order)
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidParameterError(f"fps must be > 0, got {fps!r}")
    keys = list(keys)
    if len(keys) < 2:
        raise InvalidParameterError(f"animate needs at least 2 keys, got {len(keys)}")
    key_times = np.array([k.time_s for k in keys], dtype=np.float64)
    if np.any(np.diff(key_times) <= 0):
        raise InvalidParameterError(
            f"key times must increase strictly, got {key_times.tolist()} seconds"
        )
    flights = _check_flights(flights_s, key_times[0], key_times[-1])
    rot_k, root_k, targets = _complete_keys(keys, skeleton, order)
    chains = _check_chains(skeleton, targets)

    n_frames = int(np.floor((key_times[-1] - key_times[0]) * fps + 1e-9)) + 1
    times = key_times[0] + np.arange(n_frames) / fps
    local = interpolate_rotations(key_times, rot_k, times)
    root = standing_root_position_m(skeleton) + pchip_interpolate(key_times, root_k, times)

    if chains:
        glob_r, glob_p = _forward(skeleton, local, root)
        # Key poses, for limbs whose target some keys leave out.
        key_local = Rotation.from_rotvec(rot_k.reshape(-1, 3)).as_matrix()
        key_r, key_p = _forward(
            skeleton,
            key_local.reshape(len(keys), -1, 3, 3),
            standing_root_position_m(skeleton) + root_k,
        )
        for end, per_key in chains.items():
            solve_limb(
                skeleton, end, per_key, order, key_times, times, key_r, key_p, glob_r, glob_p, local
            )
    if ground:
        root[:, 1] -= lowest_point_m(skeleton, local, root, contact_points_m)
    for take_off, landing in flights:
        airborne = (times > take_off) & (times < landing)
        t = times[airborne]
        start, stop = np.interp([take_off, landing], times, root[:, 1])
        root[airborne, 1] = (
            start
            + (stop - start) * (t - take_off) / (landing - take_off)
            + 0.5 * GRAVITY_M_S2 * (t - take_off) * (landing - t)
        )
    return Motion.from_local_transforms(
        skeleton, local, root, 1.0 / fps, order="ZXY", length_unit_m=1.0, name=name
    )


def _check_flights(
    flights_s: Sequence[tuple[float, float]], start_s: float, stop_s: float
) -> np.ndarray:
    """(N, 2) take-off and landing times, checked: in order, apart, within the keys."""
    try:
        flights = np.array(flights_s, dtype=np.float64).reshape(-1, 2)
    except (TypeError, ValueError):
        flights = np.full((1, 2), np.nan)
    bounds = flights.ravel()
    ok = (
        np.all(np.isfinite(bounds))
        and np.all(np.diff(bounds) > 0)
        and (len(bounds) == 0 or (bounds[0] >= start_s and bounds[-1] <= stop_s))
    )
    if not ok:
        raise InvalidParameterError(
            f"flights_s must be (take_off, landing) pairs in order, not overlapping, within "
            f"the keys' {start_s}-{stop_s} s, got {flights_s!r}"
        )
    return flights


def lowest_point_m(
    skeleton: Skeleton,
    local_rotations: np.ndarray,
    root_m: np.ndarray,
    contact_points_m: Mapping[str, np.ndarray] | None = None,
) -> np.ndarray:
    """Height of the lowest point of a posed body per frame.

    Parameters
    ----------
    skeleton : Skeleton
        In metres.
    local_rotations : (F, J, 3, 3) float
        Joint rotations relative to the parent (rest = identity).
    root_m : (F, 3) float
        Root positions, metres.
    contact_points_m : mapping of str to (N, 3) float, optional
        Extra surface points per joint, in the joint's frame (see :func:`animate`).

    Returns
    -------
    (F,) float64
        Metres; the minimum over joints, end sites and contact points.
    """
    glob_r, pos = _forward(skeleton, local_rotations, root_m)
    ends = _end_site_positions(skeleton, glob_r, pos)
    lowest = np.minimum(pos[..., 1].min(axis=1), ends[..., 1].min(axis=1))
    for joint, points in (contact_points_m or {}).items():
        j = skeleton.index(joint)
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        y = pos[:, j, None, 1] + np.einsum("fb,nb->fn", glob_r[:, j, 1], pts)
        lowest = np.minimum(lowest, y.min(axis=1))
    return lowest


def body_surface_points(
    exclude: Sequence[str] = ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"),
) -> dict[str, np.ndarray]:
    """Points on the default avatar's skin around each canonical joint.

    For each bone of the bundled MakeHuman body, the vertices it carries most (largest
    skin weight) are reduced to their extremes in 26 directions (the axes, the face
    and the space diagonals of a cube).

    Parameters
    ----------
    exclude : sequence of str
        Joints to leave out.  By default the feet, so that a standing body rests on
        its toe joints as :func:`eigmotion.mocap.kinematics.forward_kinematics` grounds
        every motion (the MakeHuman soles lie about 2 cm below them).

    Returns
    -------
    dict of str to (N, 3) float64
        Joint name → surface points relative to the joint's rest position, metres,
        in its frame (world-aligned at rest); N <= 26.
    """
    return {k: v.copy() for k, v in _body_surface_points().items() if k not in set(exclude)}


@lru_cache(maxsize=1)
def _body_surface_points() -> dict[str, np.ndarray]:
    folder = makehuman_dir()
    vertices = []
    body: set[int] = set()
    group = None
    with open(folder / "base.obj", encoding="utf-8") as fh:
        for line in fh:
            if line.startswith("v "):
                vertices.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("g "):
                group = line.split()[1]
            elif line.startswith("f ") and group == "body":
                body.update(int(t.split("/")[0]) - 1 for t in line.split()[1:])
    # The OBJ is in decimetres, Y up, facing +Z: the world frame of the rig.
    verts = np.asarray(vertices) * 0.1
    table = json.loads((folder / "weights.cmu_mb.json").read_text(encoding="utf-8"))["weights"]
    weights = np.zeros((len(verts), len(CANONICAL_JOINTS)))
    for j, name in enumerate(CANONICAL_JOINTS):
        pairs = np.asarray(table.get(name, []), dtype=np.float64).reshape(-1, 2)
        np.add.at(weights[:, j], pairs[:, 0].astype(np.int64), pairs[:, 1])
    ids = np.array(sorted(body))
    owner = np.argmax(weights[ids], axis=1)
    grid = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)])
    directions = grid[np.any(grid != 0, axis=1)].astype(np.float64)
    rig = load_makehuman_rig()
    out = {}
    for j, name in enumerate(CANONICAL_JOINTS):
        v = verts[ids[owner == j]] - rig[name][0]
        if len(v):
            out[name] = np.unique(v[np.argmax(v @ directions.T, axis=0)], axis=0)
    return out


def _complete_keys(keys: Sequence[Key], skeleton: Skeleton, order: str):
    """Rotation vectors (K, J, 3), root offsets (K, 3) and targets (K dicts) per key."""
    n_joints = skeleton.n_joints
    rot_k = np.zeros((len(keys), n_joints, 3))
    root_k = np.zeros((len(keys), 3))
    targets: list[dict[str, Target | None]] = []
    current = np.zeros((n_joints, 3))
    offset = np.zeros(3)
    held: dict[str, Target | None] = {}
    perm = ["XYZ".index(a) for a in order]
    for i, key in enumerate(keys):
        for joint, angles in key.rotations_deg.items():
            j = _joint(skeleton, joint, key)
            m = euler_to_matrix(np.asarray(angles)[perm], order)
            current[j] = Rotation.from_matrix(m).as_rotvec()
        if key.root_offset_m is not None:
            offset = np.asarray(key.root_offset_m, dtype=np.float64)
        for joint, target in key.targets.items():
            _joint(skeleton, joint, key)
            held[joint] = target
        rot_k[i] = current
        root_k[i] = offset
        targets.append(dict(held))
    return unwrap_rotvecs(rot_k), root_k, targets


def _joint(skeleton: Skeleton, joint: str, key: Key) -> int:
    if joint not in skeleton.names:
        raise InvalidParameterError(
            f"key at {key.time_s} s names joint {joint!r}, which is not in the skeleton; "
            f"known joints: {', '.join(skeleton.names)}"
        )
    return skeleton.names.index(joint)


def _check_chains(
    skeleton: Skeleton, targets: list[dict[str, Target | None]]
) -> dict[str, list[Target | None]]:
    """Limb end joint → its target per key, for limbs that have a target somewhere."""
    chains: dict[str, list[Target | None]] = {}
    for end in sorted({j for t in targets for j, v in t.items() if v is not None}):
        chains[end] = [t.get(end) for t in targets]
    limbs = {}
    for end in chains:
        c = skeleton.index(end)
        b = int(skeleton.parents[c])
        a = int(skeleton.parents[b]) if b >= 0 else -1
        if a < 0:
            raise InvalidParameterError(
                f"IK target on {end!r}: it needs a parent and a grandparent (a two-bone limb)"
            )
        limbs[end] = _subtree(skeleton, a)
    for end, members in limbs.items():
        for other in limbs:
            if other != end and skeleton.index(other) in members:
                raise InvalidParameterError(
                    f"IK limbs of {end!r} and {other!r} overlap; give targets to separate limbs"
                )
        frames = {t.relative_to for t in chains[end] if t is not None}
        if len(frames) > 1:
            raise InvalidParameterError(
                f"targets of {end!r} use several frames {sorted(map(str, frames))}; "
                "use one relative_to for a limb in all keys"
            )
        frame = frames.pop()
        if frame is not None:
            f = skeleton.index(frame)
            if any(f in m for m in limbs.values()):
                raise InvalidParameterError(
                    f"target of {end!r} is relative to {frame!r}, which an IK limb moves; "
                    "use a joint outside every limb"
                )
    return chains


def _subtree(skeleton: Skeleton, joint: int) -> set[int]:
    out = {joint}
    for j in range(joint + 1, skeleton.n_joints):
        if int(skeleton.parents[j]) in out:
            out.add(j)
    return out


def _forward(skeleton: Skeleton, local: np.ndarray, root: np.ndarray):
    """World rotations (F, J, 3, 3) and positions (F, J, 3) in metres."""
    local = np.asarray(local)
    n = local.shape[0]
    glob_r = np.empty_like(local)
    glob_p = np.empty((n, skeleton.n_joints, 3))
    for j in range(skeleton.n_joints):
        p = int(skeleton.parents[j])
        if p < 0:
            glob_r[:, j] = local[:, j]
            glob_p[:, j] = np.broadcast_to(root, (n, 3))
        else:
            glob_r[:, j] = glob_r[:, p] @ local[:, j]
            glob_p[:, j] = glob_p[:, p] + glob_r[:, p] @ skeleton.offsets[j]
    return glob_r, glob_p


def _end_site_positions(skeleton: Skeleton, glob_r: np.ndarray, glob_p: np.ndarray) -> np.ndarray:
    """(F, E, 3) end-site positions, metres."""
    joints = sorted(skeleton.end_sites)
    if not joints:
        return np.zeros((glob_p.shape[0], 0, 3))
    offs = np.stack([skeleton.end_sites[j] for j in joints])
    return glob_p[:, joints] + np.einsum("feab,eb->fea", glob_r[:, joints], offs)
