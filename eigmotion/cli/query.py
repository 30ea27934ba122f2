"""``eigmotion query``: which basic motion is in this clip, seen from where?

Examples::

    eigmotion query clip.mp4 --json
    eigmotion query clip.mp4 --background empty.png --top 5 --bvh-out clip.bvh \\
        --replay-out clip_replay.mp4
    eigmotion query clip.mp4 --pose-out clip_pose.npz
    eigmotion query clip.mp4 --false-rejection 0.2
    eigmotion query clip.mp4 --segmenter subtraction

Without ``--background`` the person is cut out by person networks shipped with
eigmotion (:mod:`eigmotion.segmentation.learned`); with it, by those networks with what
subtracting the empty scene finds beside their masks added
(:mod:`eigmotion.segmentation.fused`).  ``--segmenter`` picks one front end.  The
answer warns when more than one person is in view.  A person who stands still is
answered "no motion" (``"still": true``, not accepted; exit status 1 where 3D outputs
were asked for, which are not written).

``--false-rejection`` trades known motions turned away for unknown ones rejected: the
answer's ``p_known`` says how close the clip is to the library: at least as close as
that share of new performances of known motions (motions of the library performed
again).  The clip is unknown when that share is below the one asked for (0.05 by
default).  The text answer gives frame ranges with both ends included ("frames 0–76":
77 frames); the JSON's segments keep ``end_frame`` one past the last frame.

``--bvh-out``, ``--replay-out`` and ``--pose-out`` align the matched motion to the clip
frame by frame (:mod:`eigmotion.pose.continuous_pose`): the output has one pose per clip
frame and follows the clip's own timing; with ``--pose-cue world`` (the default for a
video when LiteRT is installed) each frame's trunk and limbs are then moved toward the
pose landmark network's own 3D posture, the heading kept, and with ``--pose-cue
keypoints`` the heading, trunk and limbs are first fitted to its 2D keypoints
(:mod:`eigmotion.pose.keypoint_fit`); the joint set and axes unchanged.
``--linear-replay`` stretches the matched window linearly over the clip instead (for
``--bvh-out`` and ``--replay-out``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from eigmotion.errors import InvalidParameterError, StillPersonError
from eigmotion.mocap.bvh import write_bvh
from eigmotion.pose.keypoints import CUES, resolve_cue
from eigmotion.retrieval.database import MotionDatabase
from eigmotion.retrieval.motion_cues import (
    KICK,
    PUNCH,
    PUNCH_MAX_HANDS_RAISED,
    RUN,
    TURN,
    WALK,
)
from eigmotion.retrieval.motion_image import motion_image_picture
from eigmotion.retrieval.results import frame_range, still_answer_json, still_reason
from eigmotion.retrieval.sequences import SEQUENCE_WEIGHT
from eigmotion.retrieval.storage import DEFAULT_DB_PATH
from eigmotion.segmentation.learned import SEGMENTERS


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "clip", type=Path, help="video (.mp4/.avi), folder of frames, or .npz of masks"
    )
    parser.add_argument("--db", default=None, help="database (default database/eigmotion.fs)")
    parser.add_argument(
        "--background",
        type=Path,
        help="image of the empty scene from the same camera, the size of the frames; "
        "without it the scene is estimated from the clip, which needs the person to move "
        "and finds them less well",
    )
    parser.add_argument(
        "--segmenter",
        choices=SEGMENTERS,
        default="auto",
        help="how the person is cut out of video: learned (person networks shipped with "
        "eigmotion), subtraction (against --background, or the empty scene estimated from "
        "the clip), fused (learned, plus what subtracting --background finds beside it); "
        "auto (default): fused with --background, learned without",
    )
    parser.add_argument(
        "--top", type=int, default=3, help="distinct actions (labels) and motions to list"
    )
    parser.add_argument(
        "--false-rejection",
        type=float,
        metavar="SHARE",
        help="call the motion unknown beyond the distance that turns away this share of "
        "new performances of library motions (0-1; default the database's threshold, "
        "0.05): a larger share turns away more unknown motions and more known ones",
    )
    parser.add_argument(
        "--no-floor-track",
        dest="floor_track",
        action="store_false",
        help="do not let the person's track over the floor choose among the likeliest "
        "three actions: its speed between walk and run, a bend in it between walk and "
        "turn (without an image of the empty scene a camera's pan or zoom is measured "
        "on the scene and taken out of it)",
    )
    parser.add_argument(
        "--no-raised-foot",
        dest="raised_foot",
        action="store_false",
        help="do not let a foot raised to hip height (the pose network's ankles) make a "
        "kick among the likeliest three actions the answer",
    )
    parser.add_argument(
        "--no-raised-hands",
        dest="raised_hands",
        action="store_false",
        help="do not let both hands over the head (the pose network's wrists) turn an "
        "answer punch into a lift, wave, jump or cover_head among the likeliest three",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--bvh-out", type=Path, help="write the matched 3D motion as BVH")
    parser.add_argument(
        "--replay-out", type=Path, help="write input | silhouettes | motion image | replay"
    )
    parser.add_argument(
        "--pose-out",
        type=Path,
        help="write the 3D joints per clip frame as .npz (names, positions in metres, "
        "reference_frames, fps)",
    )
    parser.add_argument(
        "--pose-cue",
        choices=CUES,
        default="auto",
        help="what the 3D answer is fitted to: silhouette (the matched motion aligned to "
        "the silhouettes), world (then its limbs moved toward the pose network's 3D "
        "posture, the heading kept), keypoints (then refined with the pose network's 2D "
        "keypoints, the heading included); auto (default): world for a video or images "
        "when LiteRT is installed, else silhouette",
    )
    parser.add_argument(
        "--linear-replay",
        action="store_true",
        help="for --bvh-out/--replay-out, stretch the matched window over the clip "
        "instead of aligning it frame by frame",
    )


def run(args: argparse.Namespace) -> int:
    if args.top < 1:
        raise InvalidParameterError(f"--top must be >= 1, got {args.top}")
    for out in (args.bvh_out, args.replay_out, args.pose_out):
        if out is not None and not out.parent.is_dir():
            raise InvalidParameterError(f"{out}: folder {out.parent} does not exist")
    if args.bvh_out or args.replay_out or args.pose_out:
        resolve_cue(args.pose_cue, args.clip)  # told before the clip is read
    with MotionDatabase.open(args.db or DEFAULT_DB_PATH) as db:
        answer_3d = bool(args.bvh_out or args.replay_out or args.pose_out)
        try:
            result, clip = db.query_clip(
                args.clip,
                args.background,
                args.top,
                every_frame=answer_3d,
                progress=True,
                false_rejection=args.false_rejection,
                segmenter=args.segmenter,
                floor_track=args.floor_track,
                raised_foot=args.raised_foot,
                raised_hands=args.raised_hands,
            )
        except StillPersonError as still:
            return _answer_still(db, args, still_reason(still))
        if answer_3d:
            _write_replay(db, result, clip, args)
    if args.json:
        print(json.dumps(result.to_json()))
    else:
        best = result.best
        verdict = "" if result.accepted else "  (UNKNOWN: farther than the threshold)"
        print(f"{best.label}  ({_described(best)}){verdict}")
        for warning in result.warnings:
            print(f"  warning: {warning}")
        if result.p_known is not None:
            print(f"  {_p_known_in_words(result.p_known, result.threshold)}")
        print(f"  {RANKING_IN_WORDS}")
        ranked = ", ".join(m.label for m in result.labels[: args.top])
        print(f"  actions, likeliest first: {ranked}")
        if result.travel_speed is not None and best.label in (WALK, RUN):
            print(f"  travels {result.travel_speed:.2f} body heights per second")
        if result.heading_change is not None and best.label in (WALK, TURN):
            print(f"  the direction of travel turned {result.heading_change:.0f}°")
        if result.foot_raise is not None and best.label == KICK:
            print(f"  one foot rose {result.foot_raise:.2f} body heights above the other")
        raised = result.hands_raised
        if raised is not None and raised >= PUNCH_MAX_HANDS_RAISED and best.label != PUNCH:
            print(f"  both hands rose {raised:.2f} body heights above the nose: not a punch")
        for match in result.top[1:]:
            print(f"  then {match.label}  ({_described(match)})")
        for seg in result.segments:
            print(f"  {frame_range(seg.start_frame, seg.end_frame)}: {seg.label}")
        print(
            f"  examined {result.examined} of {result.db_entries} entries, "
            f"{result.timing_ms['total']:.0f} ms"
        )
    return 0


#: Exit status of a query asked for 3D outputs whose person stands still: the answer is
#: printed, and no motion is written (there is none to align); 2 is an error.
EXIT_NOTHING_WRITTEN = 1


def _answer_still(db: MotionDatabase, args: argparse.Namespace, reason: str) -> int:
    """Print the answer to a clip whose person does not move: no motion of the library.

    Returns the exit status: 0, or :data:`EXIT_NOTHING_WRITTEN` where 3D outputs were
    asked for (none is written)."""
    threshold = db.threshold
    if args.false_rejection is not None:
        threshold = db.threshold_at(args.false_rejection)
    if args.json:
        print(json.dumps(still_answer_json(reason, threshold, db.n_entries)))
    else:
        print("no motion  (UNKNOWN: the person stands still)")
        print(f"  {reason.removeprefix('no motion: ')}")
    asked = [str(p) for p in (args.bvh_out, args.replay_out, args.pose_out) if p]
    if not asked:
        return 0
    print(
        f"eigmotion query: {', '.join(asked)} not written: the person stands still, "
        "there is no motion to align",
        file=sys.stderr,
    )
    return EXIT_NOTHING_WRITTEN


#: How ``top`` and the actions are ordered, in the words the text answer prints.
RANKING_IN_WORDS = (
    "motions ranked by a combined score: the motion-image distance plus "
    f"{SEQUENCE_WEIGHT:g} × the silhouette-sequence distance, each divided by the smallest "
    "among the candidates"
)


def _p_known_in_words(p_known: float, threshold: float) -> str:
    """``p_known`` as a sentence: how the clip's distance compares with known motions'."""
    return (
        f"at least as close to the library as {p_known:.0%} of new performances of known "
        f"motions (p_known {p_known:.2f}; unknown beyond distance {threshold:.3f})"
    )


def _described(match) -> str:
    """A match's motion, distances and view, as the text answer lists them."""
    sequence = (
        "" if match.sequence_distance is None else f", sequence {match.sequence_distance:.3f}"
    )
    return (
        f"{match.motion}, distance {match.distance:.3f}{sequence}, view azimuth "
        f"{match.azimuth_deg:.0f}°, elevation {match.elevation_deg:.0f}°"
    )


def _write_replay(db, result, clip, args) -> None:
    # Lazy: the 3D answer loads retargeting and scipy.spatial, which a query that asks
    # for no 3D output never needs (0.5 s of a 4.5 s cold query on a busy two-core machine).
    from eigmotion.pose.clip_pose import clip_pose
    from eigmotion.pose.continuous_pose import ContinuousPoseConfig
    from eigmotion.pose.replay import read_input_panel, replay, replay_video, segment_captions

    best = result.best
    masks, fps = clip.masks, clip.fps
    pose = None
    pose_cue = resolve_cue(args.pose_cue, args.clip)
    if args.pose_out or not args.linear_replay:
        # seconds of work with nothing else on screen: say what it is
        print(
            f"aligning {best.motion} to the clip frame by frame (--pose-cue {pose_cue}) …",
            file=sys.stderr, flush=True,
        )  # fmt: skip
        config = ContinuousPoseConfig(cue=pose_cue)
        pose = clip_pose(db, result, clip, args.clip, config, progress=True)
    if args.pose_out:
        pose.save_npz(args.pose_out)
    if not (args.bvh_out or args.replay_out):
        rep = None
    elif args.linear_replay:
        motion = db.motion(best.motion_id)
        rep = replay(motion, best.window, best.azimuth_deg, best.elevation_deg, len(masks), fps)
    else:
        rep = pose.as_replay()
    if args.bvh_out:
        write_bvh(rep.motion, args.bvh_out)
    if args.replay_out:
        frames = None
        if args.clip.suffix.lower() != ".npz":
            frames = read_input_panel(args.clip)
        picture = motion_image_picture(result.motion_image, db.config.motion_image)
        answer = best.label if result.accepted else f"unknown (nearest {best.label})"
        captions = segment_captions(result.segments, len(masks), answer)
        replay_video(
            rep, frames, masks, picture, args.replay_out, fps, progress=True, captions=captions
        )
    written = ", ".join(str(p) for p in (args.bvh_out, args.replay_out, args.pose_out) if p)
    aligned = "" if pose is None else f"aligned frame by frame, --pose-cue {pose_cue}"
    if not args.linear_replay:
        how = aligned
    elif args.pose_out:
        how = f"the BVH and replay stretched linearly, the joints {aligned}"
    else:
        how = "stretched linearly"
    print(f"wrote {written} ({how})", file=sys.stderr)
