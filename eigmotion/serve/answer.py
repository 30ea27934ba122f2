"""One uploaded clip answered into a job folder: the JSON answer, the 3D motion (BVH and
joints), the side-by-side replay, and both videos in a format every browser plays.

The answer is the one ``eigmotion query CLIP --json --bvh-out --pose-out --replay-out``
gives: the same query, the same frame-by-frame alignment, the same replay.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from eigmotion.errors import StillPersonError, VideoError
from eigmotion.mocap.bvh import write_bvh
from eigmotion.pose.clip_pose import clip_pose
from eigmotion.pose.replay import read_input_panel, replay_video, segment_captions
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.motion_image import motion_image_picture
from eigmotion.retrieval.results import still_answer_json, still_reason

#: The files a finished job holds, by the name the API serves them under.
ARTEFACTS = {
    "answer.json": "application/json",
    "motion.bvh": "text/plain; charset=utf-8",
    "joints.npz": "application/octet-stream",
    "replay.mp4": "video/mp4",
    "replay.webm": "video/webm",
    "clip.webm": "video/webm",
}

#: A report of progress: (share done in [0, 1], what is being done).
Report = Callable[[float, str], None]


def p_known_in_words(p_known: float | None, accepted: bool) -> str:
    """What ``p_known`` says, in a sentence a person reads at once.

    Parameters
    ----------
    p_known : float or None
        The share (0-1) of new performances of library motions that lie at least as far
        from the database as the clip; None for a database built without it.
    accepted : bool
        Whether the clip lies within the unknown threshold.
    """
    if p_known is None:
        return "known motion" if accepted else "unknown motion: farther than the threshold"
    share = f"{p_known:.0%}"
    if not accepted:
        return (
            f"Probably not a motion of the library: only {share} of new performances of "
            "library motions lie this far from the database."
        )
    if p_known >= 0.5:
        closeness = "As close as most known motions come"
    elif p_known >= 0.2:
        closeness = "Close enough to be a known motion"
    else:
        closeness = "A known motion, but only just"
    return f"{closeness}: {share} of new performances of library motions lie this far or farther."


def browser_video(source: Path, target: Path) -> Path:
    """Copy a video as VP8 WebM, which browsers play (OpenCV's wheels write MPEG-4
    part 2 into ``.mp4``, which Chromium and Firefox do not).

    Parameters
    ----------
    source : Path
        Any video OpenCV reads.
    target : Path
        The ``.webm`` to write.
    """
    capture = cv2.VideoCapture(str(source))
    fps = capture.get(cv2.CAP_PROP_FPS) or 25.0
    writer = None
    try:
        while True:
            ok, frame = capture.read()
            if not ok:
                break
            if writer is None:
                height, width = frame.shape[:2]
                fourcc = cv2.VideoWriter_fourcc(*"VP80")
                writer = cv2.VideoWriter(str(target), fourcc, float(fps), (width, height))
                if not writer.isOpened():
                    raise VideoError(f"{target}: the VP8 encoder could not be opened")
            writer.write(frame)
    finally:
        capture.release()
        if writer is not None:
            writer.release()
    if writer is None:
        raise VideoError(f"{source}: no frame could be read")
    return target


def answer_clip(
    db: MotionDatabase,
    clip: Path,
    background: Path | None,
    job_dir: Path,
    report: Report,
    top_k: int = 3,
) -> dict:
    """Answer ``clip`` and write every artefact of :data:`ARTEFACTS` into ``job_dir``.

    Parameters
    ----------
    db : MotionDatabase
    clip : Path
        The uploaded video.
    background : Path or None
        The uploaded image of the empty scene.
    job_dir : Path
        Where the artefacts go (it exists).
    report : callable
        Called with (share done, stage) as the work goes on.
    top_k : int

    Returns
    -------
    dict
        The answer: :meth:`~eigmotion.retrieval.results.QueryResult.to_json` plus
        ``p_known_words``, ``fps`` and ``n_frames`` (of the clip).  For a person who
        stands still, :func:`~eigmotion.retrieval.results.still_answer_json` (``fps``
        None, ``n_frames`` 0), and of the artefacts only the answer and the clip.

    Raises
    ------
    EigmotionError
        The clip cannot be read, or no person is found in it.
    """
    report(0.02, "making the clip playable in the browser")
    browser_video(clip, job_dir / "clip.webm")
    report(0.08, "finding the person in the clip and querying the database")
    try:
        result, masks = db.query_clip(clip, background, top_k, every_frame=True)
    except StillPersonError as still:  # an answer, as the command line's: no motion
        answer = still_answer_json(still_reason(still), db.threshold, db.n_entries)
        answer["p_known_words"] = "No motion of the library: the person stands still."
        answer["fps"], answer["n_frames"] = None, 0
        write_json(job_dir / "answer.json", answer)
        return answer
    report(0.45, "aligning the matched motion to the clip frame by frame")
    pose = clip_pose(db, result, masks, clip)  # the query's default cue
    pose.save_npz(job_dir / "joints.npz")
    rep = pose.as_replay()
    write_bvh(rep.motion, job_dir / "motion.bvh")
    report(0.65, "drawing the side-by-side replay")
    best = result.best
    picture = motion_image_picture(result.motion_image, db.config.motion_image)
    answer_text = best.label if result.accepted else f"unknown (nearest {best.label})"
    captions = segment_captions(result.segments, len(masks.masks), answer_text)
    replay_video(
        rep, read_input_panel(clip), masks.masks, picture, job_dir / "replay.mp4", masks.fps,
        captions=captions,
    )  # fmt: skip
    report(0.9, "making the replay playable in the browser")
    browser_video(job_dir / "replay.mp4", job_dir / "replay.webm")
    answer = result.to_json()
    answer["p_known_words"] = p_known_in_words(result.p_known, result.accepted)
    answer["fps"] = float(masks.fps)
    answer["n_frames"] = len(masks.masks)
    write_json(job_dir / "answer.json", answer)
    return answer


def write_json(path: Path, value: dict) -> None:
    """Write ``value`` as JSON at ``path`` at once (a reader never sees half of it)."""
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(value), encoding="utf-8")
    os.replace(partial, path)


def first_frame_size(path: Path) -> tuple[int, int] | None:
    """(width, height) of a video's first frame, None when OpenCV reads no frame."""
    capture = cv2.VideoCapture(str(path))
    try:
        ok, frame = capture.read()
    finally:
        capture.release()
    return (frame.shape[1], frame.shape[0]) if ok and isinstance(frame, np.ndarray) else None
