"""The continuous pose refined frame by frame with the pose network's 2D keypoints.

The silhouette tells the posture only up to what its outline shows: an arm in front
of the body, the left leg from the right, the body's heading.  The pose landmark
network (:mod:`eigmotion.pose.keypoints`) places the limb joints in the image, left
and right told apart.  Starting from the continuous pose's aligned reference posture
(:mod:`eigmotion.pose.continuous_pose`), each clip frame's avatar is turned and its
limbs bent so that its joints, seen by the matched view's camera, fall on the
network's landmarks:

1. **Camera and trust.** The clip's camera stands at azimuth 0 (on +Z) at the view's
   elevation and is far from the person (weak perspective): a joint ``X`` (metres) is
   seen at ``s · Π X + t`` pixels, ``Π`` the camera's right and down axes, the scale
   ``s`` and offset ``t`` fitted per frame (weighted least squares over the 12 limb
   joints).  A frame whose landmarks fit the reference only at a scale off the clip's
   median by more than ``scale_band`` (the network lost the person: its landmarks
   bunched or scattered) carries no weight; such frames, whose residual divided by a
   tiny ``s²`` is huge, would otherwise decide the mirror image and heading of the
   whole clip.
   When the reference already lies on the landmarks (the median over frames of its
   mean joint miss is under ``agreement_m`` metres, about the network's own error on
   a body it sees well), the landmarks cannot tell more than the silhouettes did: the
   continuous pose is returned unchanged.
2. **Mirror image and heading.** The silhouette does not tell a body seen from the
   front from its mirror image seen from behind: the reference or its mirror image
   (``mirror``), whichever lays its joints better on the keypoints, is kept for the
   whole clip.  The whole body is turned about the vertical through its root by the
   angle (every ``heading_step_deg`` around the circle) that best lays its joints on
   the landmarks, chosen for all frames at once (dynamic programming) with a cost for
   turning away from the reference (``heading_weight``) and for changing between
   frames (``heading_change_weight``).
3. **Trunk and limbs.** The trunk (the lower back, from the hips' middle to the
   shoulders'), then the upper arms, forearms, thighs and shins are bent in turn.
   Each bone keeps its length ``L``; its direction ``u`` (a unit vector searched among
   ``directions`` spread evenly over the sphere, and the bone's own direction, kept
   exactly when it is best) minimises, per frame::

       w |Π L u - b / s|²  +  prior L² |u - u_ref|²  +  smooth L² |u - ū|²

   with ``b`` the network's 2D bone (far landmark minus near landmark, pixels),
   ``w`` the smaller visibility of its ends, ``u_ref`` the reference's direction and
   ``ū`` the mean direction of the neighbouring frames (``smooth``: a few passes, each
   frame against its neighbours' previous answer), all in square metres.  Optionally
   ``world_weight L² |u - u_world|²`` pulls toward the bone of the network's world
   landmarks, turned into the scene's axes.
4. **Rotations.** Each bone's new direction is the smallest turn of the joint's world
   rotation from the old one; the local rotations follow, and forward kinematics gives
   the joints.
5. **Part of the way to the network's posture.** The fit and the network's own 3D posture
   (its world landmarks) err in different ways, so a point between them is nearer the
   truth than either (``docs/tracker.md``).  In each frame the network's 12 limb
   landmarks are brought onto the fitted joints by the similarity (rotation, scale,
   shift) that fits them best, which leaves the fit's heading, place and size as they
   are; each joint's target lies ``network_share`` of the way to its landmark, the
   targets are smoothed over time (a Gaussian of ``network_smooth_s``), and the trunk
   and limbs are turned toward them as in step 4, each bone keeping its length.
   Applied alone to the continuous pose (:func:`toward_network`: steps 1 to 4
   skipped, the silhouettes' heading kept) it is the ``world`` cue.

The output keeps the continuous pose's skeleton, joint set and axes; its root is raised
or lowered in each frame so that the lowest joint lies as high as in the continuous
pose, which stands on the floor.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from numbers import Integral, Real
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from scipy.ndimage import gaussian_filter1d

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.mirror import mirror_motion
from eigmotion.mocap.rotations import axis_rotation, rotation_between, similarity_align
from eigmotion.validation import Interval, Options, validate_params

if TYPE_CHECKING:
    from eigmotion.pose.keypoints import ClipKeypoints

_NOT_NEGATIVE = Interval(Real, 0.0, None, noun="")

#: Bones bent, parents first: (joint turned, the joints whose mean is the bone's far
#: end, those whose mean is its near end, the network's landmarks of the far end and
#: of the near end).  The trunk is the lower back turned so that the shoulders' middle
#: lies over the hips' middle as the landmarks say.
BONES = (
    ("LowerBack", ("LeftArm", "RightArm"), ("LeftUpLeg", "RightUpLeg"), (11, 12), (23, 24)),
    ("LeftArm", ("LeftForeArm",), ("LeftArm",), (13,), (11,)),
    ("LeftForeArm", ("LeftHand",), ("LeftForeArm",), (15,), (13,)),
    ("RightArm", ("RightForeArm",), ("RightArm",), (14,), (12,)),
    ("RightForeArm", ("RightHand",), ("RightForeArm",), (16,), (14,)),
    ("LeftUpLeg", ("LeftLeg",), ("LeftUpLeg",), (25,), (23,)),
    ("LeftLeg", ("LeftFoot",), ("LeftLeg",), (27,), (25,)),
    ("RightUpLeg", ("RightLeg",), ("RightUpLeg",), (26,), (24,)),
    ("RightLeg", ("RightFoot",), ("RightLeg",), (28,), (26,)),
)

#: The avatar's joints of the 12 limb joints, and the network's landmark of each.
LIMB_PAIRS = (
    ("LeftArm", 11), ("RightArm", 12), ("LeftForeArm", 13), ("RightForeArm", 14),
    ("LeftHand", 15), ("RightHand", 16), ("LeftUpLeg", 23), ("RightUpLeg", 24),
    ("LeftLeg", 25), ("RightLeg", 26), ("LeftFoot", 27), ("RightFoot", 28),
)  # fmt: skip


@dataclass(frozen=True)
class KeypointFitConfig:
    """How the continuous pose is refined with 2D keypoints.

    Parameters
    ----------
    prior : float
        Weight of the pull toward the reference's bone direction (≥ 0), per square
        metre of the 2D residual.
    smooth : float
        Weight of the pull toward the neighbouring frames' directions (≥ 0).
    smooth_passes : int
        Passes of that pull (≥ 0).
    world_weight : float
        Weight of the pull toward the network's world-landmark bone (≥ 0; 0: unused).
    min_visibility : float
        Landmarks less visible than this carry no weight, in [0, 1].
    heading_step_deg : float
        Step of the heading search around the circle, degrees (> 0).
    heading_weight : float
        Cost of turning by ``a`` from the reference: ``heading_weight (1 - cos a)``,
        square metres per joint.
    heading_change_weight : float
        Cost of a change of heading between frames, square metres per radian.
    directions : int
        Bone directions searched, spread over the sphere (≥ 100).
    rounds : int
        Passes over the trunk and limbs, the scale refitted to the posture before each
        (≥ 1).
    mirror : bool
        Also try the reference's mirror image (left and right swapped), kept for the
        whole clip when its joints lie better on the keypoints: a silhouette seen from
        behind is that of the mirrored body seen from the front.
    scale_band : float
        A frame whose landmarks fit the reference at a scale ``s`` with
        ``|log(s / median s)| > log(1 + scale_band)`` carries no weight (> 0; ``inf``:
        every frame counts).
    agreement_m : float
        When the median over frames of the reference's mean joint miss from the
        landmarks (visibility-weighted, metres, after the scale and offset fit) is
        below this, the pose is kept as it is (≥ 0; 0: always fitted).
    network_share : float
        Share of the way each fitted limb joint is moved toward the network's world
        landmark of it, the network's posture first brought onto the fitted one frame
        by frame (rotation, scale and shift), in [0, 1]; 0: not moved.
    network_smooth_s : float
        Standard deviation over time of the Gaussian that smooths those targets,
        seconds (≥ 0; 0: not smoothed).
    """

    prior: float = 0.3
    smooth: float = 0.3
    smooth_passes: int = 3
    world_weight: float = 0.3
    min_visibility: float = 0.0
    heading_step_deg: float = 10.0
    heading_weight: float = 0.01
    heading_change_weight: float = 0.2
    directions: int = 4000
    rounds: int = 1
    mirror: bool = True
    scale_band: float = 0.5
    agreement_m: float = 0.08
    network_share: float = 0.7
    network_smooth_s: float = 0.05

    #: The valid values of each parameter (see :mod:`eigmotion.validation`).
    _parameter_constraints: ClassVar[dict] = {
        "prior": _NOT_NEGATIVE,
        "smooth": _NOT_NEGATIVE,
        "smooth_passes": Interval(Integral, 0, None),
        "world_weight": _NOT_NEGATIVE,
        "min_visibility": Interval(Real, 0.0, 1.0),
        "heading_step_deg": Interval(Real, 0.0, 180.0, closed="right", noun=""),
        "heading_weight": _NOT_NEGATIVE,
        "heading_change_weight": _NOT_NEGATIVE,
        "directions": Interval(Integral, 100, None),
        "rounds": Interval(Integral, 1, None),
        "mirror": Options(bool, (True, False)),
        "scale_band": Interval(Real, 0.0, None, closed="neither", noun=""),
        "agreement_m": _NOT_NEGATIVE,
        "network_share": Interval(Real, 0.0, 1.0),
        "network_smooth_s": _NOT_NEGATIVE,
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints)


def sphere_directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    y = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - y**2)
    phi = np.pi * (3.0 - np.sqrt(5.0)) * k
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], 1)


def camera_axes(elevation_deg: float) -> np.ndarray:
    """(2, 3): the image's right and down axes, in the scene, of a camera on +Z at
    ``elevation_deg`` above the horizon looking at the person."""
    e = np.deg2rad(elevation_deg)
    return np.array([[1.0, 0.0, 0.0], [0.0, -np.cos(e), np.sin(e)]])


def _global_rotations(local: np.ndarray, parents: np.ndarray) -> np.ndarray:
    out = np.empty_like(local)
    for j, p in enumerate(parents):
        out[:, j] = local[:, j] if p < 0 else out[:, p] @ local[:, j]
    return out


def _fit_view(
    points: np.ndarray, target: np.ndarray, weights: np.ndarray, axes: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weak-perspective scale and offset per frame and its weighted squared residual.

    points : (..., K, 3) metres; target : (..., K, 2) pixels; weights : (..., K).
    Returns s (...), t (..., 2), cost (...) in square metres (residual / s²)."""
    proj = points @ axes.T
    wsum = np.maximum(weights.sum(-1, keepdims=True), 1e-9)
    pm = (weights[..., None] * proj).sum(-2) / wsum
    tm = (weights[..., None] * target).sum(-2) / wsum
    a, b = proj - pm[..., None, :], target - tm[..., None, :]
    s = (weights[..., None] * a * b).sum((-1, -2)) / np.maximum(
        (weights[..., None] * a * a).sum((-1, -2)), 1e-12
    )
    s = np.maximum(s, 1e-6)
    residual = ((s[..., None, None] * a - b) ** 2).sum(-1)
    cost = (weights * residual).sum(-1) / s**2
    return s, tm - s[..., None] * pm, cost


@dataclass(frozen=True)
class ReferenceMiss:
    """How the reference's limb joints lie on the landmarks, per frame.

    Attributes
    ----------
    scale_off : (F,) float64
        ``|log(s / median s)|`` of the weak-perspective scale ``s`` fitted per frame
        (the median over frames with a visible landmark; 0 in frames without).
    frame_miss_m : (F,) float64
        Visibility-weighted mean distance between the reference's projected joints and
        the landmarks, metres (pixels divided by ``s``; 0 without a visible landmark).
    """

    scale_off: np.ndarray
    frame_miss_m: np.ndarray


def reference_miss(
    points: np.ndarray, image: np.ndarray, visibility: np.ndarray, axes: np.ndarray
) -> ReferenceMiss:
    """The reference's agreement with the landmarks (:class:`ReferenceMiss`).

    points : (F, K, 3) joints, metres; image : (F, K, 2) landmarks, pixels;
    visibility : (F, K) weights; axes : (2, 3) the camera's right and down axes."""
    scale, offset, _ = _fit_view(points, image, visibility, axes)
    seen = visibility.sum(1) > 0
    typical = np.median(scale[seen]) if seen.any() else 1.0
    scale_off = np.where(seen, np.abs(np.log(scale / typical)), 0.0)
    drawn = scale[:, None, None] * (points @ axes.T) + offset[:, None]
    miss = np.linalg.norm(drawn - image, axis=-1) / scale[:, None]
    frame_miss = (visibility * miss).sum(1) / np.maximum(visibility.sum(1), 1e-9)
    return ReferenceMiss(scale_off, np.where(seen, frame_miss, 0.0))


def _headings(
    costs: np.ndarray, angles: np.ndarray, change_weight: float
) -> tuple[np.ndarray, float]:
    """(F,) index into ``angles`` minimising the summed (F, A) costs plus
    ``change_weight`` times the angle changed between frames (Viterbi), and that
    minimum."""
    diff = np.abs(angles[:, None] - angles[None])
    diff = np.minimum(diff, 2 * np.pi - diff) * change_weight
    total = costs[0].copy()
    back = np.zeros(costs.shape, np.int64)
    for f in range(1, len(costs)):
        step = total[:, None] + diff
        back[f] = step.argmin(0)
        total = step.min(0) + costs[f]
    path = np.empty(len(costs), np.int64)
    path[-1] = int(total.argmin())
    for f in range(len(costs) - 1, 0, -1):
        path[f - 1] = back[f, path[f]]
    return path, float(total.min())


def _mirror_image(motion):
    """The motion with left and right swapped (:func:`eigmotion.mocap.mirror.
    mirror_motion`) on its own skeleton, or ``None`` when the skeleton is not its own
    mirror image (within a centimetre) or cannot be mirrored."""
    try:
        mirrored = mirror_motion(motion)
    except InvalidParameterError:
        return None
    if np.abs(mirrored.skeleton.offsets - motion.skeleton.offsets).max() > 0.01:
        return None
    return motion.with_local_transforms(mirrored.local_rotations(), mirrored.local_translations())


def _toward_network(motion, local_r, local_t, keypoints, config, fps: float) -> np.ndarray:
    """Local rotations (F, J, 3, 3) with the trunk and limbs (:data:`BONES`, parents
    first) turned toward the network's posture (step 5 of the module's description).

    In each frame where the network found the person, its world landmarks of the 12
    limb joints are brought onto the fitted joints (:func:`~eigmotion.mocap.rotations.
    similarity_align`), and each fitted joint's target lies ``network_share`` of the
    way to its landmark; the targets are smoothed over time (``network_smooth_s``), and
    each bone keeps its length and turns toward its target direction.  Frames where
    the network found no one keep their posture.
    """
    sk = motion.skeleton
    index = {n: i for i, n in enumerate(sk.names)}
    parents = np.asarray(sk.parents)
    joints = [index[name] for name, _ in LIMB_PAIRS]
    marks = [m for _, m in LIMB_PAIRS]
    local_r = local_r.copy()

    def current_positions() -> tuple[np.ndarray, np.ndarray]:
        moved = motion.with_local_transforms(local_r, local_t)
        points = forward_kinematics(moved, length_unit_m=1.0, ground=False).positions
        return _global_rotations(local_r, parents), points

    rotations, points = current_positions()
    network = keypoints.world_m[:, marks]
    seen = keypoints.found & np.isfinite(network).all(axis=(1, 2))
    target = points - points[:, :1]
    for f in np.flatnonzero(seen):
        aligned = similarity_align(network[f], target[f, joints])
        target[f, joints] += config.network_share * (aligned - target[f, joints])
    if config.network_smooth_s > 0 and len(target) > 1:
        target = gaussian_filter1d(target, config.network_smooth_s * fps, axis=0, mode="nearest")
    for joint_name, far, near, _, _ in BONES:
        j = index[joint_name]
        far_j, near_j = [index[n] for n in far], [index[n] for n in near]
        bone = points[:, far_j].mean(1) - points[:, near_j].mean(1)
        wanted = target[:, far_j].mean(1) - target[:, near_j].mean(1)
        turn = np.flatnonzero(seen & (np.linalg.norm(wanted, axis=-1) > 1e-9))
        swing = rotation_between(bone[turn], wanted[turn])
        local_r[turn, j] = np.swapaxes(rotations[turn, parents[j]], -1, -2) @ (
            swing @ rotations[turn, j]
        )
        rotations, points = current_positions()
    return local_r


def _refitted(pose, motion, local_r: np.ndarray, local_t: np.ndarray, started: float):
    """``pose`` with ``motion`` posed by new local rotations (F, J, 3, 3), the root raised
    or lowered in each frame so that the lowest joint lies as high as in ``pose``: the
    silhouettes stood the body on the floor, and a leg bent or straightened by the fit
    must not sink it into the floor or lift it off.  ``timings_s["keypoints_fit"]`` the
    wall time since ``started`` (``time.perf_counter``), seconds."""
    positions = forward_kinematics(
        motion.with_local_transforms(local_r, local_t), length_unit_m=1.0, ground=False
    ).positions
    # the root's translation moves every joint alike: no second forward kinematics
    rise = pose.positions[..., 1].min(1) - positions[..., 1].min(1)
    local_t = local_t.copy()
    local_t[:, 0, 1] += rise
    positions[..., 1] += rise[:, None]
    moved = motion.with_local_transforms(local_r, local_t)
    timings = dict(pose.timings_s)
    timings["keypoints_fit"] = time.perf_counter() - started
    return dataclasses.replace(pose, motion=moved, positions=positions, timings_s=timings)


def _check_pair(pose, keypoints: ClipKeypoints) -> None:
    """InvalidParameterError unless the keypoints are of the pose's frames and its
    skeleton has every joint :data:`BONES` turns."""
    if keypoints.n_frames != pose.n_frames:
        raise InvalidParameterError(
            f"keypoints of {keypoints.n_frames} frames for a pose of {pose.n_frames}"
        )
    names = pose.motion.skeleton.names
    missing = [n for b in BONES for n in (b[0], *b[1], *b[2]) if n not in names]
    if missing:
        raise InvalidParameterError(f"the pose's skeleton lacks {', '.join(sorted(set(missing)))}")


def toward_network(pose, keypoints: ClipKeypoints, config: KeypointFitConfig | None = None):
    """The continuous pose with its trunk and limbs moved toward the pose network's own
    3D posture: step 5 of the module's description alone (the ``world`` cue).

    The heading, the place on the floor, the size and the bone lengths stay the pose's:
    the network's posture is brought onto it frame by frame, so only the bones'
    directions change, and the root is raised or lowered so that the lowest joint lies
    as high as before.

    Parameters
    ----------
    pose : eigmotion.pose.continuous_pose.ContinuousPose
        On the default avatar's skeleton (its joint names: ``LeftArm`` …).
    keypoints : ClipKeypoints
        The pose network's answer for the same clip frames.
    config : KeypointFitConfig, optional
        Its ``network_share`` and ``network_smooth_s`` apply.

    Returns
    -------
    ContinuousPose
        The same skeleton, frames and axes; ``timings_s["keypoints_fit"]`` the step's
        wall time, seconds.

    Raises
    ------
    InvalidParameterError
        Frame counts differ, or the skeleton lacks a limb joint.
    """
    config = config or KeypointFitConfig()
    started = time.perf_counter()
    _check_pair(pose, keypoints)
    motion = pose.motion
    local_t = motion.local_translations()
    local_r = _toward_network(
        motion, motion.local_rotations(), local_t, keypoints, config, pose.fps
    )
    return _refitted(pose, motion, local_r, local_t, started)


def fit_keypoints(pose, keypoints: ClipKeypoints, config: KeypointFitConfig | None = None):
    """The continuous pose with its heading and limbs fitted to the 2D keypoints.

    Parameters
    ----------
    pose : eigmotion.pose.continuous_pose.ContinuousPose
        On the default avatar's skeleton (its joint names: ``LeftArm`` …).
    keypoints : ClipKeypoints
        The pose network's answer for the same clip frames.
    config : KeypointFitConfig, optional

    Returns
    -------
    ContinuousPose
        The same skeleton, frames and axes; ``timings_s["keypoints_fit"]`` the fit's
        wall time, seconds.

    Raises
    ------
    InvalidParameterError
        Frame counts differ, or the skeleton lacks a limb joint.
    """
    config = config or KeypointFitConfig()
    started = time.perf_counter()
    _check_pair(pose, keypoints)
    motion = pose.motion
    sk = motion.skeleton
    index = {n: i for i, n in enumerate(sk.names)}
    axes = camera_axes(pose.elevation_deg)
    image = np.nan_to_num(keypoints.image_px)
    vis = np.where(keypoints.visibility >= config.min_visibility, keypoints.visibility, 0.0)
    vis[~keypoints.found] = 0.0

    parents = np.asarray(sk.parents)
    joints = [index[name] for name, _ in LIMB_PAIRS]
    marks = [m for _, m in LIMB_PAIRS]

    # 1. which frames the landmarks are trusted in, and whether they tell anything new
    reference = forward_kinematics(motion, length_unit_m=1.0, ground=False).positions
    miss = reference_miss(reference[:, joints], image[:, marks], vis[:, marks], axes)
    odd = miss.scale_off > np.log1p(config.scale_band)
    vis[odd] = 0.0
    kept = vis[:, marks].sum(1) > 0
    if not kept.any() or np.median(miss.frame_miss_m[kept]) < config.agreement_m:
        timings = dict(pose.timings_s)
        timings["keypoints_fit"] = time.perf_counter() - started
        return dataclasses.replace(pose, timings_s=timings)

    # 2. heading about the vertical through the root, of the posture or its mirror image
    angles = np.deg2rad(np.arange(-180.0, 180.0, config.heading_step_deg))
    turns = axis_rotation("Y", np.rad2deg(angles))  # (A, 3, 3)
    best = None
    for candidate in (motion, _mirror_image(motion) if config.mirror else None):
        if candidate is None:
            continue
        positions = forward_kinematics(candidate, length_unit_m=1.0, ground=False).positions
        rel = positions[:, joints] - positions[:, :1]
        turned = np.einsum("aij,fkj->faki", turns, rel)
        _, _, cost = _fit_view(turned, image[:, None, marks], vis[:, None, marks], axes)
        cost = cost + config.heading_weight * len(joints) * (1.0 - np.cos(angles))[None]
        path, total = _headings(cost, angles, config.heading_change_weight)
        if best is None or total < best[0]:
            best = (total, candidate, angles[path])
    _, motion, heading = best
    local_r = motion.local_rotations()
    local_t = motion.local_translations()
    turn = axis_rotation("Y", np.rad2deg(heading))
    local_r[:, 0] = turn @ local_r[:, 0]

    def current_positions() -> tuple[np.ndarray, np.ndarray]:
        rotations = _global_rotations(local_r, parents)
        moved = motion.with_local_transforms(local_r, local_t)
        points = forward_kinematics(moved, length_unit_m=1.0, ground=False).positions
        return rotations, points

    for _ in range(config.rounds):
        rotations, points = current_positions()
        scale, _, _ = _fit_view(points[:, joints], image[:, marks], vis[:, marks], axes)
        scale = np.where(vis[:, marks].sum(1) > 0, scale, np.nan)
        scale = np.nan_to_num(scale, nan=np.nanmedian(scale) if np.isfinite(scale).any() else 1.0)
        directions = sphere_directions(config.directions)
        to_scene = np.stack([axes[0], axes[1], np.cross(axes[0], axes[1])])  # camera -> rows

        # 3. limbs, parents first
        for joint_name, far, near, far_marks, near_marks in BONES:
            j = index[joint_name]
            far_j, near_j = [index[n] for n in far], [index[n] for n in near]
            bone = points[:, far_j].mean(1) - points[:, near_j].mean(1)
            length = np.linalg.norm(bone, axis=-1).mean()
            u_ref = bone / np.maximum(np.linalg.norm(bone, axis=-1, keepdims=True), 1e-9)
            far_m, near_m = list(far_marks), list(near_marks)
            drawn = image[:, far_m].mean(1) - image[:, near_m].mean(1)
            target = drawn / scale[:, None]  # metres
            w = np.minimum(vis[:, far_m].min(1), vis[:, near_m].min(1))
            # the searched directions and, last, the bone's own: kept exactly when best
            candidates = np.concatenate(
                [np.broadcast_to(directions, (len(u_ref), *directions.shape)), u_ref[:, None]], 1
            )  # (F, N + 1, 3)
            miss_m = length * (candidates @ axes.T) - target[:, None]
            data = w[:, None] * (miss_m**2).sum(-1)
            along_ref = np.einsum("fk,fnk->fn", u_ref, candidates)
            fixed = data - 2 * config.prior * length**2 * along_ref
            if config.world_weight > 0:
                world = keypoints.world_m[:, far_m].mean(1) - keypoints.world_m[:, near_m].mean(1)
                world = np.nan_to_num(world @ to_scene)
                norm = np.linalg.norm(world, axis=-1, keepdims=True)
                u_world = np.where(norm > 1e-6, world / np.maximum(norm, 1e-9), 0.0)
                along_world = np.einsum("fk,fnk->fn", u_world, candidates)
                fixed -= 2 * config.world_weight * w[:, None] * length**2 * along_world
            frames = np.arange(len(u_ref))
            chosen = fixed.argmin(1)
            for _ in range(config.smooth_passes if config.smooth > 0 else 0):
                u = candidates[frames, chosen]
                neighbours = np.zeros_like(u)
                neighbours[1:] += u[:-1]
                neighbours[:-1] += u[1:]
                along = np.einsum("fk,fnk->fn", neighbours, candidates)
                chosen = (fixed - 2 * config.smooth * length**2 * along).argmin(1)
            swing = rotation_between(u_ref, candidates[frames, chosen])
            new_global = swing @ rotations[:, j]
            parent_global = rotations[:, parents[j]]
            local_r[:, j] = np.swapaxes(parent_global, -1, -2) @ new_global
            rotations, points = current_positions()

    # 5. part of the way to the network's own posture, brought onto the fitted one
    if config.network_share > 0:
        local_r = _toward_network(motion, local_r, local_t, keypoints, config, pose.fps)

    # the output, as the continuous pose's, standing as high
    return _refitted(pose, motion, local_r, local_t, started)
