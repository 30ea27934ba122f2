"""What the motion database answers: a query's matches and segments, and what a build
or an index did; each answer with its JSON form (``eigmotion query --json``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Match:
    """One database entry returned for a query.

    Attributes
    ----------
    label : str
    motion : str
        The basic motion's name.
    motion_id : int
    entry_id : int
    distance : float
        Euclidean distance in the eigenspace.
    azimuth_deg, elevation_deg : float
        The matching virtual camera.
    window : (int, int)
        ``[start, stop)`` frames of the basic motion.
    sequence_distance : float or None
        Time-warped distance between the clip's silhouette sequence and the motion's
        nearest rendering, times what their difference of pace costs (pose-eigenspace
        units, :mod:`eigmotion.retrieval.sequences`); None when the motion was not compared
        that way.
    """

    label: str
    motion: str
    motion_id: int
    entry_id: int
    distance: float
    azimuth_deg: float
    elevation_deg: float
    window: tuple[int, int]
    sequence_distance: float | None = None

    def to_json(self) -> dict:
        out = {
            "label": self.label,
            "motion": self.motion,
            "distance": round(self.distance, 6),
            "view": {"azimuth_deg": self.azimuth_deg, "elevation_deg": self.elevation_deg},
        }
        if self.sequence_distance is not None:
            out["sequence_distance"] = round(self.sequence_distance, 6)
        return out


def frame_range(start_frame: int, end_frame: int, dash: str = "–") -> str:
    """Frames ``[start_frame, end_frame)`` as a person reads them, both ends included.

    Parameters
    ----------
    start_frame, end_frame : int
        The first frame and one past the last (as :class:`Segment` holds them).
    dash : str
        Between the two ends (``"-"`` where only ASCII can be drawn).

    Returns
    -------
    str
        ``"frames 0–76"`` for the 77 frames 0 … 76; ``"frame 5"`` for one frame.
    """
    last = end_frame - 1
    return f"frame {start_frame}" if last <= start_frame else f"frames {start_frame}{dash}{last}"


@dataclass(frozen=True)
class Segment:
    """A stretch of the query clip with one label.

    ``start_frame``/``end_frame`` are ``[start, end)`` frames of the clip."""

    start_frame: int
    end_frame: int
    label: str
    distance: float

    def to_json(self) -> dict:
        return {
            "start_frame": self.start_frame,
            "end_frame": self.end_frame,
            "label": self.label,
            "distance": round(self.distance, 6),
        }


@dataclass(frozen=True)
class QueryResult:
    """The answer to one clip (see
    :meth:`~eigmotion.retrieval.database.MotionDatabase.query_masks`).

    Attributes
    ----------
    best : Match
        The clip's answer: the whole clip's nearest motion by motion image and
        silhouette sequence together (:func:`~eigmotion.retrieval.sequences.fused_scores`) —
        its nearest entry — unless that is filler
        (:data:`~eigmotion.mocap.library.FILLER_LABELS`: walking into a turn) and a
        window of the clip shows a specific action — then that window's nearest entry.
    accepted : bool
        The whole clip's nearest entry (or the window that answers) lies within the
        threshold — as near as the database's own motions come to one another's
        performances, which is what the threshold is calibrated on; otherwise the
        motion is unknown.  The answer itself may be a motion whose nearest entry is
        farther: it was ranked first by both distances together.
    threshold : float
        The "unknown" threshold ``accepted`` was judged against, eigenspace units: the
        database's own, or the one for the false rejection the query asked for
        (:meth:`~eigmotion.retrieval.database.MotionDatabase.threshold_at`).
    p_known : float or None
        In [0, 1]: the share of new performances of the library's own motions that lie
        at least as far from the database as this clip (the distance ``accepted`` is
        judged by, against the quantiles the build stored,
        :func:`~eigmotion.retrieval.calibration.leave_one_motion_out_distances`).  Near
        1, as near as most known motions come; near 0, farther than nearly all.
        ``accepted`` at a false rejection r is ``p_known >= r``.  None for a database
        built without them.
    top : list of Match
        Distinct motions in that order, ``best`` first.
    labels : list of Match
        Every label the query ranked, once, in that order: the first motion of each in
        the ranking that ``top`` begins (``best`` first).  Its first three are the
        top-3 that ``docs/accuracy.md`` measures.
    segments : list of Segment
    examined : int
        Entries whose distance was computed by the whole-clip search.
    examined_windows : int
        The same, summed over the searches of the sliding windows (segments).
    db_entries : int
    timing_ms : dict of str to float
        Wall time of the query's steps, ms: ``motion_images`` (the whole clip's),
        ``search`` (the whole clip's; the windows' motion images and searches run
        beside it and the next step), ``sequences`` (the candidates ranked), ``total``.
    motion_image : (D,) float32
        The clip's motion image.
    warnings : tuple of str
        What the user should know about the answer (:func:`people_warning`: more than
        one person in view); empty when nothing.
    travel_speed : float or None
        How fast the person travels over the floor, body heights per second
        (:func:`~eigmotion.retrieval.motion_cues.travel_speed`); None where too few
        frames show the whole figure.
    heading_change : float or None
        How far the direction of travel turned between the clip's two halves, degrees
        (:func:`~eigmotion.retrieval.motion_cues.heading_change`); None where the track
        is not measured or the person hardly travels.
    foot_raise : float or None
        How far one foot rose above the other at most, body heights
        (:func:`~eigmotion.retrieval.motion_cues.foot_raise`); None where the query had
        no pose landmarks or did not measure it.
    hands_raised : float or None
        How far the lower wrist rose above the nose at most, body heights
        (:func:`~eigmotion.retrieval.motion_cues.hands_raised`); None as for
        ``foot_raise``, or where the person never stood upright.
    """

    best: Match
    accepted: bool
    threshold: float
    p_known: float | None
    top: list[Match]
    labels: list[Match]
    segments: list[Segment]
    examined: int
    examined_windows: int
    db_entries: int
    timing_ms: dict[str, float]
    motion_image: np.ndarray
    warnings: tuple[str, ...] = ()
    travel_speed: float | None = None
    heading_change: float | None = None
    foot_raise: float | None = None
    hands_raised: float | None = None

    def to_json(self) -> dict:
        out = self.best.to_json()
        out["still"] = False
        out["accepted"] = bool(self.accepted)
        out["threshold"] = round(self.threshold, 6)
        out["p_known"] = None if self.p_known is None else round(self.p_known, 4)
        out["top"] = [m.to_json() for m in self.top]
        out["labels"] = [m.to_json() for m in self.labels]
        out["segments"] = [s.to_json() for s in self.segments]
        out["examined"] = int(self.examined)
        out["examined_windows"] = int(self.examined_windows)
        out["db_entries"] = int(self.db_entries)
        out["timing_ms"] = {k: round(v, 3) for k, v in self.timing_ms.items()}
        out["warnings"] = list(self.warnings)
        out["travel_speed"] = None if self.travel_speed is None else round(self.travel_speed, 3)
        turned = self.heading_change
        out["heading_change_deg"] = None if turned is None else round(turned, 1)
        out["foot_raise"] = None if self.foot_raise is None else round(self.foot_raise, 3)
        raised = self.hands_raised
        out["hands_raised"] = None if raised is None else round(raised, 3)
        return out


def still_reason(error: Exception) -> str:
    """What the motion image measured of a person standing still, as the answer says it:
    the message of the :class:`~eigmotion.errors.StillPersonError` the query raised
    (``"no motion: the silhouettes change by 0.96% …"``), without the name of the
    masks it was measured on."""
    return str(error).removeprefix("masks: ")


def still_answer_json(reason: str, threshold: float, db_entries: int) -> dict:
    """The answer to a clip whose person does not move, in :meth:`QueryResult.to_json`'s
    keys: no motion of the library (``label`` None, ``"still": true``, not accepted),
    nothing ranked or searched, ``reason`` the only warning.

    Parameters
    ----------
    reason : str
        What the motion image measured (:func:`still_reason`).
    threshold : float
        The "unknown" threshold the query would have judged by, eigenspace units.
    db_entries : int
    """
    return {
        "label": None, "motion": None, "distance": None, "view": None,
        "sequence_distance": None, "still": True,
        "accepted": False, "threshold": round(float(threshold), 6), "p_known": None,
        "top": [], "labels": [], "segments": [], "examined": 0, "examined_windows": 0,
        "db_entries": int(db_entries), "timing_ms": {}, "warnings": [reason],
        "travel_speed": None, "heading_change_deg": None, "foot_raise": None,
        "hands_raised": None,
    }  # fmt: skip


def people_warning(people: int) -> str:
    """The answer's warning for a clip that shows ``people`` (> 1) people."""
    return (
        f"{people} people in view: the answer describes the largest figure, possibly "
        "mixed with the others; crop the clip to one person"
    )


def shots_warning(shot_starts: np.ndarray | None, frame_indices: np.ndarray) -> str | None:
    """The answer's warning for an edited clip, one that cuts between shots.

    Parameters
    ----------
    shot_starts : (S,) int or None
        The first frame taken of each shot, 0 first
        (:attr:`~eigmotion.segmentation.video.ClipMasks.shot_starts`).
    frame_indices : (F',) int
        The clip frame of each frame taken.

    Returns
    -------
    str or None
        E.g. ``"the clip cuts to another view 2 times (at clip frames 78, 122): one
        camera is assumed, and the answer runs across the cuts; query each shot on its
        own"``; None for one shot (or None).
    """
    if shot_starts is None or len(shot_starts) <= 1:
        return None
    cuts = [int(frame_indices[i]) for i in shot_starts[1:]]
    shown = ", ".join(str(c) for c in cuts[:3])
    more = f" and {len(cuts) - 3} more" if len(cuts) > 3 else ""
    times = "once" if len(cuts) == 1 else f"{len(cuts)} times"
    return (
        f"the clip cuts to another view {times} (at clip frames {shown}{more}): one "
        "camera is assumed, and the answer runs across the cuts; query each shot on its own"
    )


#: A clip whose silhouettes are empty in at least this share of its frames (and in
#: :data:`LOST_PERSON_MIN_FRAMES` or more) gets :func:`lost_person_warning`.
LOST_PERSON_SHARE = 0.1
LOST_PERSON_MIN_FRAMES = 2


def lost_person_warning(empty: np.ndarray, frame_indices: np.ndarray) -> str | None:
    """The answer's warning for a clip where no person was found in many frames.

    Parameters
    ----------
    empty : (F',) bool
        Frames taken whose silhouette is empty.
    frame_indices : (F',) int
        The clip frame of each.

    Returns
    -------
    str or None
        E.g. ``"no person found in 18 of 33 frames taken (clip frames 22-39): the
        answer rests on the others"``; None when fewer than :data:`LOST_PERSON_SHARE`
        of the frames (or :data:`LOST_PERSON_MIN_FRAMES`) are empty.
    """
    empty = np.asarray(empty, bool)
    count = int(empty.sum())
    if count < max(LOST_PERSON_MIN_FRAMES, LOST_PERSON_SHARE * len(empty)):
        return None
    frames = np.asarray(frame_indices)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], empty.view(np.int8), [0]])))
    starts, stops = edges[::2], edges[1::2]
    runs = [(int(frames[a]), int(frames[b - 1])) for a, b in zip(starts, stops, strict=True)]
    spans = ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in runs[:3])
    more = f" and {len(runs) - 3} more" if len(runs) > 3 else ""
    return (
        f"no person found in {count} of {len(empty)} frames taken (clip frames {spans}{more}): "
        "the answer rests on the others"
    )


@dataclass(frozen=True)
class BuildReport:
    """What a build made.

    Attributes
    ----------
    uri : str
    n_motions, n_entries, n_components : int
    explained_variance : float
        Fraction of the motion images' variance the eigenspace keeps.
    threshold : float
        Distance above which a query is "unknown", eigen-coordinate units.
    seconds : float
        Wall time of the build.
    """

    uri: str
    n_motions: int
    n_entries: int
    n_components: int
    explained_variance: float
    threshold: float
    seconds: float


@dataclass(frozen=True)
class IndexReport:
    """What indexing a motion did.

    Attributes
    ----------
    name : str
    motion_id : int
    n_entries : int
        Motion images inserted (views × windows × body shapes).
    reconstruction_error : float
        Median distance of its motion images from the eigenspace.
    reference_error : float
        The 95th percentile of that distance over the images the eigenspace was fitted
        on.
    badly_represented : bool
        ``reconstruction_error > reference_error``: the eigenspace was not made for
        this motion; rebuild with ``refit``.
    """

    name: str
    motion_id: int
    n_entries: int
    reconstruction_error: float
    reference_error: float
    badly_represented: bool
