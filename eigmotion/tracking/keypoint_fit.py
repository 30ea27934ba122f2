"""The tracker's skeleton fitted to the joints triangulated from the pose network's
landmarks (:mod:`eigmotion.tracking.triangulation`): the two-camera keypoints stage.

Each estimate starts from the silhouette tracker's posture of that frame, at the
tracker's body scale, and is moved bone by bone, parents first, every move a rigid turn
of a joint's whole subtree (so every bone keeps its length):

1. root: the body is shifted so that the midpoint of its hips lies on the
   triangulated one (both hips trusted), then turned about it to fit the trusted hips
   and shoulders best (least squares, at least three of them; not when that turn
   exceeds :data:`MAX_ROOT_TURN_DEG`);
2. spine: the upper body (from ``LowerBack``) turns so that the midpoint of the
   shoulders points at the triangulated one; each clavicle turns its shoulder toward
   the triangulated shoulder;
3. limbs: hip toward knee, knee toward ankle, shoulder toward elbow, elbow toward
   wrist; the neck turns the head toward the triangulated head (mid-ears).

A bone turns only where its child's triangulated joint is trusted; elsewhere the
tracker's posture stands.  The triangulated joints are smoothed first by a centred
(1, 2, 1) filter over the frames where they are trusted (no lag).

The same fit smooths a track with or without triangulated joints: the joints' paths
over the clip are smoothed by a Gaussian (:func:`gaussian_over_time`) and every
estimate is fitted to them once more, all joints trusted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eigmotion.tracking.dictionary import PostureDictionary
from eigmotion.tracking.triangulation import KEYPOINT_JOINTS

#: (joint whose subtree turns, joint it turns toward): spine and clavicles, then limbs.
BONES = (
    ("LeftShoulder", "LeftArm"),
    ("RightShoulder", "RightArm"),
    ("LeftUpLeg", "LeftLeg"),
    ("LeftLeg", "LeftFoot"),
    ("RightUpLeg", "RightLeg"),
    ("RightLeg", "RightFoot"),
    ("LeftArm", "LeftForeArm"),
    ("LeftForeArm", "LeftHand"),
    ("RightArm", "RightForeArm"),
    ("RightForeArm", "RightHand"),
    ("Neck", "Head"),
)

#: The root turns at most this far, degrees: a larger turn is taken for a mistake of
#: the landmarks (the silhouettes' heading stands).
MAX_ROOT_TURN_DEG = 60.0

#: The joints the root's turn is fitted to.
TORSO = ("LeftUpLeg", "RightUpLeg", "LeftArm", "RightArm")


@dataclass(frozen=True, eq=False)
class FittedPoses:
    """The tracker's postures fitted to triangulated joints.

    Attributes
    ----------
    joints_m : (E, J, 3) float64
        Joint positions per estimate, world metres (the dictionary's joints).
    local_rotations : (E, J, 3, 3) float64
        Each joint's rotation relative to its parent and to the rest pose (the root's
        relative to the world), as :attr:`PostureDictionary.local_rotations`.
    trusted : (E, K) bool or None
        Which of :data:`~eigmotion.tracking.triangulation.KEYPOINT_JOINTS` were
        trusted per estimate; None where no triangulated joints were given (the paths
        smoothed alone).
    """

    joints_m: np.ndarray
    local_rotations: np.ndarray
    trusted: np.ndarray | None

    @property
    def root_positions_m(self) -> np.ndarray:
        """(E, 3) the root joint per estimate, world metres."""
        return self.joints_m[:, 0]


def smooth_targets(positions: np.ndarray) -> np.ndarray:
    """(F, K, 3) joints smoothed over time by a centred (1, 2, 1) filter over the
    frames where each is trusted (finite); untrusted frames stay NaN."""
    positions = np.asarray(positions, dtype=np.float64)
    seen = np.isfinite(positions).all(axis=-1)
    values = np.where(seen[..., None], positions, 0.0)
    weights = seen.astype(np.float64) * 2.0
    total = values * 2.0
    total[1:] += values[:-1]
    total[:-1] += values[1:]
    weights[1:] += seen[:-1]
    weights[:-1] += seen[1:]
    out = total / np.maximum(weights, 1e-12)[..., None]
    out[~seen] = np.nan
    return out


def gaussian_over_time(positions: np.ndarray, sigma: float) -> np.ndarray:
    """(F, K, 3) joints smoothed over time by a Gaussian of ``sigma`` frames (cut at
    3 sigma).  Beyond the first and last frames the path is continued by its point
    reflection through them, so that a joint moving at a steady speed keeps its path to
    the ends; frames where some joint is not finite are bridged linearly for the others
    and stay as they are."""
    positions = np.asarray(positions, dtype=np.float64)
    seen = np.isfinite(positions).all(axis=(1, 2))
    if sigma <= 0 or seen.sum() < 2:
        return positions.copy()
    n = len(positions)
    frames = np.flatnonzero(seen)
    flat = positions[seen].reshape(len(frames), -1)
    path = np.stack([np.interp(np.arange(n), frames, c) for c in flat.T], axis=1)
    reach = min(int(np.ceil(3.0 * sigma)), n - 1)
    before = 2.0 * path[0] - path[reach:0:-1]
    after = 2.0 * path[-1] - path[-2 : -reach - 2 : -1]
    padded = np.concatenate([before, path, after])
    kernel = np.exp(-0.5 * (np.arange(-reach, reach + 1) / sigma) ** 2)
    kernel /= kernel.sum()
    smooth = sum(k * padded[j : j + n] for j, k in enumerate(kernel))
    out = positions.copy()
    out[seen] = smooth.reshape(positions.shape)[seen]
    return out


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3, 3) the smallest rotation taking direction ``a`` (3,) to direction ``b`` (3,)."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-9:  # opposite: half a turn about any axis across a
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2.0 * np.outer(axis, axis) - np.eye(3)
    skew = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + skew + skew @ skew / (1.0 + c)


def best_rotation(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(3, 3) the rotation R minimising ``sum |R s_i - t_i|²`` (Kabsch), for (N, 3)
    vectors ``source`` and ``target``."""
    u, _, vt = np.linalg.svd(source.T @ target)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def _subtrees(parents: np.ndarray) -> np.ndarray:
    """(J, J) bool: row j marks j and every joint below it (parents come first)."""
    n = len(parents)
    below = np.eye(n, dtype=bool)
    for j in range(n - 1, 0, -1):
        below[parents[j]] |= below[j]
    return below


class KeypointFitter:
    """Fits postures of a dictionary's skeleton to triangulated joints.

    Parameters
    ----------
    dictionary : PostureDictionary
        Its joint names must include those of :data:`BONES` and :data:`TORSO`.
    """

    def __init__(self, dictionary: PostureDictionary):
        names = list(dictionary.joint_names)
        self.dictionary = dictionary
        self._subtree = _subtrees(dictionary.parents)
        self._joint = {name: names.index(name) for name in {*TORSO, *np.ravel(BONES)}}
        self._joint["LowerBack"] = names.index("LowerBack")
        self._target = {name: k for k, name in enumerate(KEYPOINT_JOINTS)}

    def _turn(self, positions, rotations, joint: int, turn: np.ndarray, pivot) -> None:
        rows = self._subtree[joint]
        positions[rows] = (positions[rows] - pivot) @ turn.T + pivot
        rotations[rows] = turn @ rotations[rows]

    def fit_frame(self, positions: np.ndarray, rotations: np.ndarray, targets: np.ndarray) -> None:
        """Fit one posture in place.

        Parameters
        ----------
        positions : (J, 3) float64
            Joint positions, world metres (changed in place).
        rotations : (J, 3, 3) float64
            World rotations relative to rest (changed in place).
        targets : (K, 3) float64
            :data:`~eigmotion.tracking.triangulation.KEYPOINT_JOINTS`, NaN where not
            trusted.
        """
        joint, target = self._joint, self._target
        trusted = np.isfinite(targets).all(axis=1)

        def ok(name: str) -> bool:
            return bool(trusted[target[name]])

        def aim(name: str) -> np.ndarray:
            return targets[target[name]]

        hips = ("LeftUpLeg", "RightUpLeg")
        if all(ok(h) for h in hips):
            centre = 0.5 * (aim(hips[0]) + aim(hips[1]))
            positions += centre - 0.5 * (positions[joint[hips[0]]] + positions[joint[hips[1]]])
            torso = [n for n in TORSO if ok(n)]
            if len(torso) >= 3:
                source = np.stack([positions[joint[n]] for n in torso]) - centre
                turn = best_rotation(source, np.stack([aim(n) for n in torso]) - centre)
                if np.trace(turn) >= 1.0 + 2.0 * np.cos(np.radians(MAX_ROOT_TURN_DEG)):
                    self._turn(positions, rotations, 0, turn, centre)
        shoulders = ("LeftArm", "RightArm")
        if all(ok(s) for s in shoulders):
            back = positions[joint["LowerBack"]].copy()
            now = 0.5 * (positions[joint[shoulders[0]]] + positions[joint[shoulders[1]]])
            wanted = 0.5 * (aim(shoulders[0]) + aim(shoulders[1]))
            turn = rotation_between(now - back, wanted - back)
            self._turn(positions, rotations, joint["LowerBack"], turn, back)
        for parent, child in BONES:
            if not ok(child):
                continue
            pivot = positions[joint[parent]].copy()
            bone = positions[joint[child]] - pivot
            wanted = aim(child) - pivot
            if np.linalg.norm(bone) < 1e-9 or np.linalg.norm(wanted) < 1e-9:
                continue
            self._turn(positions, rotations, joint[parent], rotation_between(bone, wanted), pivot)

    def fit(
        self,
        entries: np.ndarray,
        joints_m: np.ndarray,
        targets: np.ndarray | None,
        weight: float = 1.0,
        smooth_estimates: float = 0.0,
    ) -> FittedPoses:
        """Fit every estimate of a clip.

        Parameters
        ----------
        entries : (E,) int
            The tracker's dictionary entry per estimate.
        joints_m : (E, J, 3) float
            The tracker's joint positions per estimate (its body scale and position),
            world metres.
        targets : (E, K, 3) float or None
            Triangulated :data:`~eigmotion.tracking.triangulation.KEYPOINT_JOINTS`,
            NaN where not trusted; smoothed here (:func:`smooth_targets`).  None: no
            first fit, the paths are only smoothed.
        weight : float
            In [0, 1]: each trusted joint's target is this far from the tracker's joint
            toward the triangulated one (1: the triangulated joint itself).
        smooth_estimates : float
            Then the fitted joints' paths are smoothed over time by a Gaussian of this
            sigma, in estimates (:func:`gaussian_over_time`), and every estimate is fitted
            once more to them (bone lengths kept); 0: not.
        """
        entries = np.asarray(entries, dtype=np.int64)
        positions = np.array(joints_m, dtype=np.float64)
        rotations = self.dictionary.world_rotations(entries).copy()
        names = list(self.dictionary.joint_names)
        keypoints = [names.index(n) for n in KEYPOINT_JOINTS]
        trusted = None
        if targets is not None:
            own = positions[:, keypoints]
            smoothed = smooth_targets(own + float(weight) * (np.asarray(targets) - own))
            trusted = np.isfinite(smoothed).all(axis=-1)
            for e in range(len(entries)):
                if np.isfinite(positions[e]).all():
                    self.fit_frame(positions[e], rotations[e], smoothed[e])
        if smooth_estimates > 0:
            paths = gaussian_over_time(positions[:, keypoints], smooth_estimates)
            for e in range(len(entries)):
                if np.isfinite(positions[e]).all():
                    self.fit_frame(positions[e], rotations[e], paths[e])
        parents = self.dictionary.parents
        local = rotations.copy()
        local[:, 1:] = np.einsum("ejba,ejbc->ejac", rotations[:, parents[1:]], rotations[:, 1:])
        return FittedPoses(positions, local, trusted)
