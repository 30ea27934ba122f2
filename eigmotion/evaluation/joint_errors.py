"""Joint position errors against the development set's truth: MPJPE, PA-MPJPE,
left/right swaps and heading flips.

The truth has the development set's 21 joints (``joints.json``: ``pelvis``, ``l_hip``,
…); an estimate has its own skeleton's names.  :data:`JOINT_ALIASES` says which
estimated joint stands for which true one (the names ``shared/eval/score.py`` matches),
:func:`match_joints` pairs them up.  Positions are metres, errors millimetres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.rotations import similarity_align

#: Development-set joint name -> names an estimate may give the same joint.
JOINT_ALIASES = {
    "l_hip": ("LeftUpLeg", "LeftHip", "lfemur", "l_hip"),
    "r_hip": ("RightUpLeg", "RightHip", "rfemur", "r_hip"),
    "l_knee": ("LeftLeg", "LeftKnee", "ltibia", "l_knee"),
    "r_knee": ("RightLeg", "RightKnee", "rtibia", "r_knee"),
    "l_ankle": ("LeftFoot", "LeftAnkle", "lfoot", "l_ankle"),
    "r_ankle": ("RightFoot", "RightAnkle", "rfoot", "r_ankle"),
    "l_shoulder": ("LeftArm", "lhumerus", "l_shoulder"),
    "r_shoulder": ("RightArm", "rhumerus", "r_shoulder"),
    "l_elbow": ("LeftForeArm", "lradius", "l_elbow"),
    "r_elbow": ("RightForeArm", "rradius", "r_elbow"),
    "l_wrist": ("LeftHand", "lwrist", "l_wrist"),
    "r_wrist": ("RightHand", "rwrist", "r_wrist"),
    "head": ("Head", "head"),
}

#: The 13 joints the two-camera MPJPE is the mean over.
TRACKING_JOINTS = tuple(JOINT_ALIASES)

#: The 12 limb joints the single-camera PA-MPJPE is the mean over.
LIMB_JOINTS = tuple(j for j in JOINT_ALIASES if j != "head")

#: The root joint, and the names an estimate may give it.
ROOT_JOINT = "pelvis"
ROOT_ALIASES = ("Hips", "hips", "root", "pelvis")

#: Errors of the heading above this count as a heading flip, degrees.
HEADING_FLIP_DEG = 90.0


def find_joint(names: Sequence[str], aliases: Sequence[str]) -> int | None:
    """The index in ``names`` of the first of ``aliases`` found there, else None."""
    return next((list(names).index(a) for a in aliases if a in names), None)


def match_joints(
    names: Sequence[str],
    positions: np.ndarray,
    true_names: Sequence[str],
    truth: np.ndarray,
    joints: Sequence[str],
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """The estimated and true positions of ``joints`` (those both have), frame by frame.

    Parameters
    ----------
    names : sequence of str
        The estimate's joint names.
    positions : (F, J, 3) float
        The estimate, metres.
    true_names : sequence of str
        The truth's joint names (``joints.json``).
    truth : (F', J', 3) float
        The truth, metres.
    joints : sequence of str
        True joint names wanted (keys of :data:`JOINT_ALIASES`).

    Returns
    -------
    estimate, truth : (min(F, F'), K, 3) float64
        The ``K`` joints found in both, in the order of ``joints``.
    matched : tuple of str
        Their true names.

    Raises
    ------
    InvalidParameterError
        No joint in common.
    """
    n = min(len(positions), len(truth))
    est, true, matched = [], [], []
    for joint in joints:
        k = find_joint(names, JOINT_ALIASES.get(joint, (joint,)))
        if k is not None and joint in true_names:
            est.append(positions[:n, k])
            true.append(truth[:n, list(true_names).index(joint)])
            matched.append(joint)
    if not matched:
        raise InvalidParameterError(
            f"the estimate's joints ({', '.join(names)}) match none of {', '.join(joints)}"
        )
    return (
        np.stack(est, 1).astype(np.float64),
        np.stack(true, 1).astype(np.float64),
        tuple(matched),
    )


def pa_mpjpe_per_frame(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(F,) mm: each frame's mean joint error after its own similarity alignment.

    Parameters
    ----------
    estimate, truth : (F, K, 3) float, metres
    """
    return np.array(
        [
            np.linalg.norm(similarity_align(e, t) - t, axis=-1).mean() * 1000.0
            for e, t in zip(estimate, truth, strict=True)
        ]
    )


def pa_mpjpe_per_clip(estimate: np.ndarray, truth: np.ndarray) -> float:
    """The mean joint error, mm, after one similarity alignment for the whole clip
    (each frame's joints centred on their mean first, as ``score.py`` does).

    Parameters
    ----------
    estimate, truth : (F, K, 3) float, metres
    """
    e = estimate - estimate.mean(1, keepdims=True)
    t = truth - truth.mean(1, keepdims=True)
    aligned = similarity_align(e.reshape(-1, 3), t.reshape(-1, 3)).reshape(t.shape)
    return float(np.linalg.norm(aligned - t, axis=-1).mean() * 1000.0)


def joint_errors_mm(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(F, K) mm: each joint's distance from the truth, no alignment."""
    return np.linalg.norm(estimate - truth, axis=-1) * 1000.0


def mirror_index(joints: Sequence[str]) -> np.ndarray:
    """(K,) int: for each joint, the index of its other-side twin (``l_`` ↔ ``r_``),
    itself for a joint without one."""
    joints = list(joints)
    twin = {"l_": "r_", "r_": "l_"}
    return np.array(
        [
            joints.index(twin[j[:2]] + j[2:]) if j[:2] in twin and twin[j[:2]] + j[2:] in joints
            else i
            for i, j in enumerate(joints)
        ]
    )  # fmt: skip


def swapped_frames(estimate: np.ndarray, truth: np.ndarray, joints: Sequence[str]) -> np.ndarray:
    """(F,) bool: frames whose mean joint error is lower with the estimate's left and
    right joints swapped than as estimated."""
    as_is = joint_errors_mm(estimate, truth).mean(1)
    swapped = joint_errors_mm(estimate[:, mirror_index(joints)], truth).mean(1)
    return swapped < as_is


def heading_deg(positions: np.ndarray, joints: Sequence[str]) -> np.ndarray:
    """(F,) degrees: the body's heading about the vertical (Y up), from the hips and
    shoulders; 0 = facing +Z, 90 = facing +X.

    The body's left-to-right axis is ``(l_hip - r_hip) + (l_shoulder - r_shoulder)``
    (the pairs among ``joints``); facing is that axis turned 90° about the vertical
    (+X left of a body facing +Z).

    Raises
    ------
    InvalidParameterError
        Neither the hips nor the shoulders among ``joints``.
    """
    joints = list(joints)
    across = np.zeros(positions.shape[:1] + (3,))
    pairs = [(f"l_{p}", f"r_{p}") for p in ("hip", "shoulder")]
    found = [(left, right) for left, right in pairs if left in joints and right in joints]
    if not found:
        raise InvalidParameterError("a heading needs the hips or the shoulders")
    for left, right in found:
        across += positions[:, joints.index(left)] - positions[:, joints.index(right)]
    return np.rad2deg(np.arctan2(-across[:, 2], across[:, 0]))


def heading_error_deg(estimate: np.ndarray, truth: np.ndarray, joints: Sequence[str]) -> np.ndarray:
    """(F,) degrees in [0, 180]: how far the estimated heading is off the true one."""
    diff = heading_deg(estimate, joints) - heading_deg(truth, joints)
    return np.abs((diff + 180.0) % 360.0 - 180.0)


@dataclass(frozen=True)
class TrackingErrors:
    """A tracked clip's errors against the truth.

    Attributes
    ----------
    joints : tuple of str
        The true joints compared.
    per_joint_mm : (K,) float
        Each joint's mean error over the frames, mm.
    mpjpe_mm : float
        The mean over frames and joints, mm.
    root_mm : float or None
        The pelvis's mean error, mm (None when the estimate has no root joint).
    swaps, heading_flips, frames : int
        Frames with left and right swapped (:func:`swapped_frames`), frames whose
        heading is off by more than :data:`HEADING_FLIP_DEG`, frames compared.
    """

    joints: tuple[str, ...]
    per_joint_mm: np.ndarray
    mpjpe_mm: float
    root_mm: float | None
    swaps: int
    heading_flips: int
    frames: int

    def to_json(self) -> dict:
        return {
            "mpjpe_mm": round(self.mpjpe_mm, 2),
            "per_joint_mm": {j: round(float(e), 2) for j, e in
                             zip(self.joints, self.per_joint_mm, strict=True)},
            "root_mm": None if self.root_mm is None else round(self.root_mm, 2),
            "swaps": self.swaps,
            "heading_flips": self.heading_flips,
            "frames": self.frames,
        }  # fmt: skip


def tracking_errors(
    names: Sequence[str],
    positions: np.ndarray,
    true_names: Sequence[str],
    truth: np.ndarray,
) -> TrackingErrors:
    """MPJPE per joint and overall over :data:`TRACKING_JOINTS`, the root's error, and
    the frames with left/right swapped or the heading flipped.

    Parameters
    ----------
    names : sequence of str
    positions : (F, J, 3) float
        The estimate, world metres (the truth's frame).
    true_names : sequence of str
    truth : (F, 21, 3) float
        The truth at the same frames, metres.
    """
    est, true, joints = match_joints(names, positions, true_names, truth, TRACKING_JOINTS)
    errors = joint_errors_mm(est, true)
    root = find_joint(names, ROOT_ALIASES)
    root_mm = None
    if root is not None and ROOT_JOINT in true_names:
        n = len(est)
        root_true = truth[:n, list(true_names).index(ROOT_JOINT)]
        root_mm = float(np.linalg.norm(positions[:n, root] - root_true, axis=-1).mean() * 1000)
    flips = heading_error_deg(est, true, joints) > HEADING_FLIP_DEG
    return TrackingErrors(
        joints,
        errors.mean(0),
        float(errors.mean()),
        root_mm,
        int(swapped_frames(est, true, joints).sum()),
        int(flips.sum()),
        len(est),
    )
