"""Cuts between shots: where an edited clip jumps from one view to another.

A camera's clip shows one scene; an edited one (phone clips joined, a video cut
between two angles) shows one per shot, and what is learned of the empty scene from
one shot does not hold in the next.  A cut is found as PySceneDetect's adaptive
detector finds one (``AdaptiveDetector``, BSD-3-Clause): each frame's *content change*
from the frame before is compared with its neighbours'; a cut is a change of at least
:data:`CUT_MIN_CHANGE` that is also :data:`CUT_RATIO` times the mean change of the
:data:`CUT_NEIGHBOURS` frames on each side.  A person moving, a camera panning or the
light drifting change every frame a little; a cut changes one frame a lot.

The change is the mean absolute difference of L*, a* and b* (OpenCV's 8-bit scaling)
over every pixel, where PySceneDetect takes hue, saturation and value: the hue of a
grey pixel jumps with the least change of colour, and a low-resolution real clip of a
person before a grey wall measured hue changes up to 46 levels at frames with no cut
(saturation and value 3, L*a*b* 1.7).  The package itself is not a dependency: it
requires ``opencv-python``, which would be installed beside ``opencv-python-headless``
and overwrite its ``cv2``.
"""

from __future__ import annotations

import numpy as np

from eigmotion.segmentation.evidence import check_frames, lab_frames

#: Least content change of a cut, mean L*a*b* levels (PySceneDetect's ``min_content_val``).
CUT_MIN_CHANGE = 8.0

#: A cut's change over the mean of its neighbours' (PySceneDetect's ``adaptive_threshold``).
CUT_RATIO = 3.0

#: Frames on each side whose changes a cut is compared with (PySceneDetect's ``window_width``).
CUT_NEIGHBOURS = 2


def content_changes(frames: np.ndarray) -> np.ndarray:
    """(F - 1,) float64: mean absolute difference of L*, a* and b* (8-bit levels: L*
    × 255 / 100, a* + 128, b* + 128) between each frame and the one before, over every
    pixel and the three channels.

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB frames.
    """
    frames = check_frames(frames)
    lab = lab_frames(frames).reshape(len(frames), -1).astype(np.int16)
    return np.abs(np.diff(lab, axis=0)).mean(axis=1)


def shot_starts(frames: np.ndarray) -> np.ndarray:
    """(S,) int64: the first frame of each shot, 0 first (``[0]`` for a clip of one shot).

    Parameters
    ----------
    frames : (F, H, W, 3) uint8
        RGB frames, in order (sampled at any rate: the rule compares each change with
        its neighbours').

    Returns
    -------
    (S,) int64
        Increasing; frame ``i`` starts a shot where the change from frame ``i - 1`` is
        a cut (the module's description).  Without neighbours to compare with (fewer
        than 3 frames) the clip is one shot.
    """
    changes = content_changes(frames)
    starts = [0]
    n = len(changes)
    for i in range(n if n >= 2 else 0):
        lo, hi = max(0, i - CUT_NEIGHBOURS), min(n, i + CUT_NEIGHBOURS + 1)
        around = np.concatenate([changes[lo:i], changes[i + 1 : hi]])
        if changes[i] >= CUT_MIN_CHANGE and changes[i] >= CUT_RATIO * around.mean():
            starts.append(i + 1)
    return np.asarray(starts, dtype=np.int64)


def shot_spans(starts: np.ndarray | None, n_frames: int) -> list[tuple[int, int]]:
    """[(first, stop)] frame ranges of the shots whose first frames are ``starts``
    (None: the ``n_frames`` are one shot)."""
    if starts is None:
        return [(0, n_frames)]
    stops = [*(int(s) for s in starts[1:]), n_frames]
    return [(int(a), b) for a, b in zip(starts, stops, strict=True)]
