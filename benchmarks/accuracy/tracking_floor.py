"""How close a posture dictionary can come to the development set's tracking sets.

For every third frame of each ``tracking/<id>/`` set, the dictionary entry nearest to
the true joints: both skeletons centred on the middle of their hips, the dictionary's
scaled uniformly by the ratio of the median head heights above the hips; the mean
error over the 13 tracking joints (hips, knees, ankles, shoulders, elbows, wrists,
head), mm.  This is the tracker's floor with that dictionary and body model: a perfect
position, scale and search would still be this far off, because the performer's
posture is not in the dictionary or the skeleton's proportions are not the model's.

Run from the repository root::

    python benchmarks/accuracy/tracking_floor.py --dev ../shared/eval/dev
    python benchmarks/accuracy/tracking_floor.py --dictionary walk_02_01 walk_16_15 ...
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from eigmotion.evaluation.devset import find_dev_set
from eigmotion.evaluation.devset_joints import load_tracking_sets, load_truth
from eigmotion.evaluation.joint_errors import JOINT_ALIASES, TRACKING_JOINTS, find_joint
from eigmotion.tracking.pipeline import dictionary_from_specs


def centred(joints: np.ndarray) -> np.ndarray:
    """(..., 13, 3) joints minus the middle of their hips (the first two joints)."""
    return joints - joints[..., :2, :].mean(axis=-2, keepdims=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dev", type=Path, help="the development set (default ../shared/eval/dev)")
    parser.add_argument("--dictionary", nargs="+", help="motions (default: eigmotion track's)")
    parser.add_argument("--step", type=int, default=3, help="every n-th frame (default 3)")
    args = parser.parse_args()

    started = time.perf_counter()
    dictionary = dictionary_from_specs(args.dictionary)
    names = list(dictionary.joint_names)
    index = [find_joint(names, JOINT_ALIASES[j]) for j in TRACKING_JOINTS]
    entries = centred(dictionary.joint_positions[:, index])
    print(
        f"dictionary: {dictionary.n_base} postures, {len(dictionary)} entries "
        f"({time.perf_counter() - started:.0f} s)"
    )
    floors = []
    for folder in load_tracking_sets(find_dev_set(args.dev)):
        true_names, truth = load_truth(folder)
        truth = centred(truth[:, [true_names.index(j) for j in TRACKING_JOINTS]])
        head = TRACKING_JOINTS.index("head")
        scale = np.median(truth[:, head, 1]) / np.median(entries[:, head, 1])
        best = [
            np.linalg.norm(scale * entries - frame, axis=-1).mean(axis=1).min()
            for frame in truth[:: args.step]
        ]
        floors.append(1000 * float(np.mean(best)))
        print(f"{folder.name:<32} scale {scale:.2f}  floor {floors[-1]:6.1f} mm")
    print(f"{'mean':<32}             {np.mean(floors):6.1f} mm")


if __name__ == "__main__":
    main()
