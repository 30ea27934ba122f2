"""Facts of the body the motion image blurs, each allowed to choose among the first
three labels a query ranked: how fast the person crosses the floor (walk or run),
whether their way across it bends (walk or turn), a foot raised high (a kick), and both
hands over the head (not a punch).

**Speed over the floor.** Seen from behind or in front, a walk and a run can cast
nearly the same silhouettes: the legs swing along the line of sight.  How fast the
person travels does not depend on the view.  A static camera sees it in the
silhouettes themselves: across the frame as the figure's sideways shift, along the line
of sight as the change of its height in pixels.  In body heights per second (so the
person's size and the camera's distance drop out), with h the figure's height in pixels,
x its centre's column from the frame's centre and f the focal length in pixels, a person
of height H at depth Z shows h = f H / Z, so ::

    sideways  dX/dt / H = d(x / h)/dt
    away      dZ/dt / H = f · d(1 / h)/dt

each slope fitted over the whole clip by least squares.  The focal length of an
uncalibrated camera is taken as a field of view of :data:`ASSUMED_FIELD_OF_VIEW_DEG`
across the frame's longer side; a wider lens makes the speed toward or away from the
camera read higher, a narrower one lower (sideways travel does not depend on it).  A
camera that pans or zooms moves and scales the whole picture: where the front end
measured that motion on the scene around the person
(:func:`~eigmotion.segmentation.camera_motion.camera_motion`), x and h are read in the
first frame's pixels.

People walk at up to about 2 m/s and change to a run near 2 m/s, about 1.1–1.2 body
heights per second (:data:`WALK_MAX_HEIGHTS_PER_S`, :data:`RUN_MIN_HEIGHTS_PER_S`
leave a margin on either side).  A query ranked ``run`` first whose person travels at a
walking speed answers the best-ranked ``walk`` instead, when that label is among the
first three (and the reverse), see :func:`answer_by_travel`.  A clip where the person
hardly travels (a treadmill, or a camera following the person whose motion the scene
does not show) says nothing and is left as ranked.

**A change of heading.** The same track gives the direction of travel: the person's
place on the floor in body heights is (x / h, f / h) sideways and away from the camera.
A walking turn changes that direction (the library's walking turns by 90° and 180°), a
walk keeps it.  A query answered ``walk`` whose direction in the clip's second half
differs from the first half's by :data:`TURN_MIN_DEG` or more answers the best-ranked
``turn`` instead, when that label is among the first three
(:func:`heading_change`, :func:`answer_by_turning`).  Each half must travel at
:data:`TURN_MIN_HEIGHTS_PER_S` or faster, or its direction is noise: a turn on the
spot, or a person hardly moving, says nothing.  Bending down also changes the figure's
height, which reads as a step away from the camera, so only a walk is judged.

**A foot raised high.** A kick lifts one foot to the height of the other leg's hip or
above; walking, running, jumping and punching keep the two feet within about a third of
the body's height of each other (the library's motions: kicks 0.49–0.92 of the
performer's height at the highest, every other motion 0.29 or less).  The pose
network's ankle landmarks give that rise in the image, in body heights
(:func:`foot_raise`); a clip whose feet come :data:`KICK_MIN_RAISE` apart answers the
best-ranked ``kick`` when that label is among the first three and the person does not
cross the floor at a run's pace, where the heel of the leg swung back rises high
(:func:`answer_by_raised_foot`).  The landmarks of small people often miss the kicking
foot, so a low rise says nothing: the cue only ever turns an answer into a kick.

**Both hands over the head.** A punch keeps at least one hand below the head: in the
library no punch raises its lower hand above the head joint (at the highest 0.13 m
below it), while overhead lifts, two-armed waves, a reaching jump and the cover-heads
do (up to 0.27 m above it).  The pose network's wrist landmarks give the lower wrist's
height over the nose, in body heights, in the frames where the person stands upright
(:func:`hands_raised`; a body bent double puts its landmarks anywhere).  An answer
``punch`` whose hands rise :data:`PUNCH_MAX_HANDS_RAISED` or more answers the
best-ranked of :data:`HANDS_RAISED_LABELS` among the first three labels instead
(:func:`answer_by_raised_hands`).  Only a punch is judged, and a low rise says nothing.
"""

from __future__ import annotations

import math

import numpy as np

from eigmotion.retrieval.results import Match
from eigmotion.segmentation.cut_bodies import ANKLES, HIPS

#: The field of view assumed across the frame's longer side, degrees: between a phone's
#: main camera (about 65–70°) and a standard lens (about 45–55°).
ASSUMED_FIELD_OF_VIEW_DEG = 60.0

#: Faster than this is not a walk, body heights per second.
WALK_MAX_HEIGHTS_PER_S = 1.0

#: Slower than this is not a run, body heights per second.
RUN_MIN_HEIGHTS_PER_S = 1.3

#: Below this the person does not visibly travel (a run on the spot, a treadmill, a
#: following camera), and the speed decides nothing, body heights per second.
TRAVEL_MIN_HEIGHTS_PER_S = 0.4

#: The speed is measured only when at least this share of the frames (and
#: :data:`MIN_MEASURED_FRAMES`) show the whole figure: touching none of the frame's
#: edges, where its height or its centre in pixels is not the person's; the other
#: frames are left out of the fit.
MIN_MEASURED_SHARE = 0.5
MIN_MEASURED_FRAMES = 5

#: The labels the rules choose between.
WALK, RUN, TURN = "walk", "run", "turn"

#: A walk whose direction of travel changes by this much between the clip's halves is
#: a walking turn, degrees: straight walks and runs read 15° or less (the library's,
#: rendered; 16 real ones filmed from the side), the library's walking turns by 90° and
#: 180°, rendered from four sides, 79–179°.
TURN_MIN_DEG = 45.0

#: Each half of the clip must travel at least this fast for its direction to count,
#: body heights per second (a slow walk, about 0.45 m/s).
TURN_MIN_HEIGHTS_PER_S = 0.25

#: The rise of one ankle over the other, in body heights, that only a kick reaches.
KICK_MIN_RAISE = 0.45

#: The label a raised foot chooses.
KICK = "kick"

#: MediaPipe's pose landmark of the nose (the ankles: :data:`~eigmotion.segmentation.
#: cut_bodies.ANKLES`).
NOSE = 0

#: The body's height is this many times the span from the nose to the lower ankle
#: (the head's top lies above the nose, the soles below the ankles).
STATURE_PER_NOSE_TO_ANKLE = 1.1

#: MediaPipe's pose landmarks of the wrists.
WRISTS = (15, 16)

#: The lower wrist this far above the nose, body heights, is not a punch: about the top
#: of the head.  The development set's punches read −0.03 or less, its lifts 0.15–0.19.
PUNCH_MAX_HANDS_RAISED = 0.10

#: A frame counts toward the hands' rise when the nose stands at least this far above
#: the middle of the hips, body heights (upright; about 0.4 standing straight).
UPRIGHT_MIN_NOSE_OVER_HIPS = 0.25

#: The label the raised hands rule out, and the labels of which some motions raise both
#: hands above the head (the library's lifts, waves, jumps and cover-heads).
PUNCH = "punch"
HANDS_RAISED_LABELS = ("lift", "wave", "jump", "cover_head")


def floor_track(
    masks: np.ndarray, fps: float, camera: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """Where the person stands on the floor in each frame that shows the whole figure.

    Parameters
    ----------
    masks : (F, H, W) bool
        The person's silhouette per frame.
    fps : float
        Frames per second of ``masks``.
    camera : (F, 2, 3) float, optional
        How the camera moved (:func:`~eigmotion.segmentation.camera_motion.
        camera_motion`): per frame, the similarity taking its pixels to the first
        frame's.  The figure's top and foot are carried into the first frame's pixels
        before its centre and height are read, so a camera that pans or zooms does not
        read as the person's travel.  None: a camera that stands still.

    Returns
    -------
    seconds : (F',) float
        The times of the frames measured: those where the figure touches none of the
        frame's edges (its height or centre in pixels is not the person's where it does).
    place : (F', 2) float
        Sideways (x / h) and away from the camera (f / h), body heights, with x the
        figure's centre column from the frame's centre, h its height and f the focal
        length (:data:`ASSUMED_FIELD_OF_VIEW_DEG`), pixels.
    None
        Where too few frames show the whole figure (:data:`MIN_MEASURED_SHARE`,
        :data:`MIN_MEASURED_FRAMES`).
    """
    masks = np.asarray(masks, dtype=bool)
    n_frames, height, width = masks.shape
    rows = masks.any(axis=2)  # (F, H)
    cols = masks.any(axis=1)  # (F, W)
    top = np.argmax(rows, axis=1)
    bottom = height - 1 - np.argmax(rows[:, ::-1], axis=1)
    inside = ~(cols[:, 0] | cols[:, -1])  # not cut by the frame's sides either
    whole = rows.any(axis=1) & (top > 0) & (bottom < height - 1) & inside
    if whole.sum() < max(MIN_MEASURED_FRAMES, MIN_MEASURED_SHARE * n_frames):
        return None
    cols = cols[whole]  # (F', W)
    count = cols.sum(axis=1)
    centre = (cols * np.arange(width)).sum(axis=1) / count - 0.5 * (width - 1)
    figure_px = (bottom - top + 1)[whole].astype(np.float64)
    if camera is not None:  # the figure's top and foot in the first frame's pixels
        x = centre + 0.5 * width  # continuous pixel coordinates
        ends = np.stack([np.stack([x, top[whole]], 1), np.stack([x, bottom[whole] + 1.0], 1)])
        moved = np.einsum("fij,efj->efi", camera[whole, :, :2], ends) + camera[whole, :, 2]
        figure_px = np.linalg.norm(moved[1] - moved[0], axis=1)
        centre = 0.5 * (moved[0, :, 0] + moved[1, :, 0]) - 0.5 * width
    focal_px = 0.5 * max(height, width) / math.tan(math.radians(ASSUMED_FIELD_OF_VIEW_DEG / 2))
    seconds = np.flatnonzero(whole) / float(fps)
    return seconds, np.stack([centre / figure_px, focal_px / figure_px], axis=1)


def _velocity(seconds: np.ndarray, place: np.ndarray) -> np.ndarray:
    """(2,) the least-squares slope of ``place`` (F', 2) over ``seconds`` (F',), body
    heights per second."""
    design = np.stack([seconds, np.ones_like(seconds)], axis=1)
    return np.linalg.lstsq(design, place, rcond=None)[0][0]


def _median_velocity(seconds: np.ndarray, place: np.ndarray) -> np.ndarray:
    """(2,) the median slope of ``place`` (F', 2) over ``seconds`` (F',) between every two
    frames (Theil–Sen), body heights per second: over a second or so of frames, a frame
    where the person was cut out short (a step away, read from its height) does not tilt
    it."""
    first, second = np.triu_indices(len(seconds), k=1)
    slopes = (place[second] - place[first]) / (seconds[second] - seconds[first])[:, None]
    return np.median(slopes, axis=0)


def travel_speed(masks: np.ndarray, fps: float) -> float | None:
    """How fast the person travels over the floor, body heights per second.

    Parameters
    ----------
    masks : (F, H, W) bool
        The person's silhouette per frame, from a static camera.
    fps : float
        Frames per second of ``masks``.

    Returns
    -------
    float or None
        The speed in body heights per second (>= 0), fitted over the whole clip
        (:func:`floor_track`); None where too few frames show the whole figure.
    """
    return _speed(floor_track(masks, fps))


def heading_change(masks: np.ndarray, fps: float) -> float | None:
    """How far the direction of travel turned between the clip's two halves, degrees.

    Parameters
    ----------
    masks : (F, H, W) bool
        The person's silhouette per frame, from a static camera.
    fps : float
        Frames per second of ``masks``.

    Returns
    -------
    float or None
        The angle in [0, 180] between the velocities over the first and the second half
        of the frames measured (:func:`floor_track`, each half's velocity the median
        slope between its frames); None where the track
        is not measured, a half has fewer than three frames, or either half travels
        slower than :data:`TURN_MIN_HEIGHTS_PER_S`.
    """
    return _turn(floor_track(masks, fps))


def floor_cues(
    masks: np.ndarray, fps: float, camera: np.ndarray | None = None
) -> tuple[float | None, float | None]:
    """:func:`travel_speed` and :func:`heading_change` of one clip, its track measured
    once (:func:`floor_track`, with the camera's motion ``camera`` where it moved)."""
    track = floor_track(masks, fps, camera)
    return _speed(track), _turn(track)


def _speed(track: tuple[np.ndarray, np.ndarray] | None) -> float | None:
    """:func:`travel_speed` of a :func:`floor_track`."""
    if track is None:
        return None
    return float(math.hypot(*_velocity(*track)))


def _turn(track: tuple[np.ndarray, np.ndarray] | None) -> float | None:
    """:func:`heading_change` of a :func:`floor_track`."""
    if track is None:
        return None
    seconds, place = track
    half = len(seconds) // 2
    if half < 3:
        return None
    first = _median_velocity(seconds[:half], place[:half])
    second = _median_velocity(seconds[half:], place[half:])
    speeds = math.hypot(*first), math.hypot(*second)
    if min(speeds) < TURN_MIN_HEIGHTS_PER_S:
        return None
    cosine = float(np.dot(first, second)) / (speeds[0] * speeds[1])
    return math.degrees(math.acos(min(1.0, max(-1.0, cosine))))


def answer_by_travel(ranking: list[Match], speed: float | None) -> list[Match]:
    """The ranking with walk or run first where the person's speed says which.

    Parameters
    ----------
    ranking : list of Match
        Distinct motions, the answer first.
    speed : float or None
        :func:`travel_speed` of the clip.

    Returns
    -------
    list of Match
        ``ranking`` itself, or with the best-ranked motion of the other gait moved to
        the front: when the answer is ``run`` and the person travels at a walking
        speed (from :data:`TRAVEL_MIN_HEIGHTS_PER_S` up to :data:`WALK_MAX_HEIGHTS_PER_S`)
        or the answer is ``walk`` and the person travels faster than
        :data:`RUN_MIN_HEIGHTS_PER_S`, and that gait is among the first three labels.
    """
    if speed is None or not ranking:
        return ranking
    first = ranking[0].label
    if first == RUN and TRAVEL_MIN_HEIGHTS_PER_S <= speed < WALK_MAX_HEIGHTS_PER_S:
        wanted = WALK
    elif first == WALK and speed > RUN_MIN_HEIGHTS_PER_S:
        wanted = RUN
    else:
        return ranking
    return _first_of(ranking, wanted)


def answer_by_turning(ranking: list[Match], change_deg: float | None) -> list[Match]:
    """The ranking with ``turn`` first where a walk's way across the floor bends.

    Parameters
    ----------
    ranking : list of Match
        Distinct motions, the answer first.
    change_deg : float or None
        :func:`heading_change` of the clip.

    Returns
    -------
    list of Match
        ``ranking`` itself, or with its best-ranked turn moved to the front when the
        answer is ``walk``, the direction of travel changed by :data:`TURN_MIN_DEG` or
        more and ``turn`` is among the first three labels.
    """
    if change_deg is None or change_deg < TURN_MIN_DEG or not ranking:
        return ranking
    if ranking[0].label != WALK:
        return ranking
    return _first_of(ranking, TURN)


def foot_raise(landmarks: np.ndarray | None) -> float | None:
    """How far one foot rose above the other at most, in body heights.

    Parameters
    ----------
    landmarks : (F, 33, 4) float or None
        The pose network's landmarks per frame (x, y in pixels, visibility, presence;
        NaN where the network found no one), as
        :attr:`~eigmotion.segmentation.video.ClipMasks.landmarks`.

    Returns
    -------
    float or None
        The largest vertical distance between the two ankles, over the body's height
        (:data:`STATURE_PER_NOSE_TO_ANKLE` × the 90th percentile over frames of the span
        from the nose down to the lower ankle), after a running median of three frames
        (one frame's slip of a landmark does not count); None without landmarks or with
        fewer than three frames that have them.
    """
    if landmarks is None:
        return None
    landmarks = np.asarray(landmarks, dtype=np.float64)
    ankles_y = landmarks[:, ANKLES, 1]  # (F, 2)
    nose_y = landmarks[:, NOSE, 1]
    seen = np.isfinite(ankles_y).all(axis=1) & np.isfinite(nose_y)
    if seen.sum() < 3:
        return None
    ankles_y, nose_y = ankles_y[seen], nose_y[seen]
    stature = _stature_px(ankles_y, nose_y)
    if not stature > 0:
        return None
    return _steady_peak(np.abs(ankles_y[:, 0] - ankles_y[:, 1]) / stature)


def answer_by_raised_foot(
    ranking: list[Match], raise_heights: float | None, speed: float | None = None
) -> list[Match]:
    """The ranking with ``kick`` first where a foot rose as only a kick's does.

    Parameters
    ----------
    ranking : list of Match
        Distinct motions, the answer first.
    raise_heights : float or None
        :func:`foot_raise` of the clip.
    speed : float or None
        :func:`travel_speed` of the clip: a person crossing the floor at a run's pace
        (:data:`RUN_MIN_HEIGHTS_PER_S` or faster) who lifts a heel high is running, and
        the rise decides nothing.

    Returns
    -------
    list of Match
        ``ranking`` itself, or with its best-ranked kick moved to the front when the
        rise is at least :data:`KICK_MIN_RAISE`, the person does not travel at a run's
        pace and ``kick`` is among the first three labels.
    """
    if raise_heights is None or raise_heights < KICK_MIN_RAISE or not ranking:
        return ranking
    if speed is not None and speed >= RUN_MIN_HEIGHTS_PER_S:
        return ranking
    return _first_of(ranking, KICK)


def hands_raised(landmarks: np.ndarray | None) -> float | None:
    """How far the lower of the two wrists rose above the nose at most, in body heights.

    Parameters
    ----------
    landmarks : (F, 33, 4) float or None
        The pose network's landmarks per frame, as for :func:`foot_raise`.

    Returns
    -------
    float or None
        The largest height of the lower wrist over the nose (negative: below it), over
        the body's height as in :func:`foot_raise`, over the frames where the person
        stands upright (the nose :data:`UPRIGHT_MIN_NOSE_OVER_HIPS` or more above the
        hips' middle), after a running median of three frames; None without landmarks,
        with fewer than three frames that have them or without an upright frame.
    """
    if landmarks is None:
        return None
    landmarks = np.asarray(landmarks, dtype=np.float64)
    wrists_y = landmarks[:, WRISTS, 1]  # (F, 2), image rows: down is larger
    ankles_y = landmarks[:, ANKLES, 1]
    nose_y = landmarks[:, NOSE, 1]
    hips_y = landmarks[:, HIPS, 1].mean(axis=1)
    seen = (
        np.isfinite(wrists_y).all(axis=1)
        & np.isfinite(ankles_y).all(axis=1)
        & np.isfinite(nose_y)
        & np.isfinite(hips_y)
    )
    if seen.sum() < 3:
        return None
    wrists_y, ankles_y, nose_y, hips_y = wrists_y[seen], ankles_y[seen], nose_y[seen], hips_y[seen]
    stature = _stature_px(ankles_y, nose_y)
    if not stature > 0:
        return None
    rise = (nose_y - wrists_y.max(axis=1)) / stature
    upright = (hips_y - nose_y) / stature >= UPRIGHT_MIN_NOSE_OVER_HIPS
    top = _steady_peak(np.where(upright, rise, -np.inf))
    return top if math.isfinite(top) else None


def answer_by_raised_hands(ranking: list[Match], raised: float | None) -> list[Match]:
    """The ranking without ``punch`` first where both hands rose over the head.

    Parameters
    ----------
    ranking : list of Match
        Distinct motions, the answer first.
    raised : float or None
        :func:`hands_raised` of the clip.

    Returns
    -------
    list of Match
        ``ranking`` itself, or, when the answer is ``punch`` and the hands rose
        :data:`PUNCH_MAX_HANDS_RAISED` or more, with the first motion of the
        best-ranked of :data:`HANDS_RAISED_LABELS` among the first three labels moved
        to the front (none there: ``ranking`` itself).
    """
    if raised is None or raised < PUNCH_MAX_HANDS_RAISED or not ranking:
        return ranking
    if ranking[0].label != PUNCH:
        return ranking
    for label in _first_labels(ranking):
        if label in HANDS_RAISED_LABELS:
            return _first_of(ranking, label)
    return ranking


def _first_labels(ranking: list[Match], count: int = 3) -> list[str]:
    """The first ``count`` distinct labels of ``ranking``, in order."""
    labels: list[str] = []
    for match in ranking:
        if match.label not in labels:
            labels.append(match.label)
            if len(labels) == count:
                break
    return labels


def _first_of(ranking: list[Match], wanted: str) -> list[Match]:
    """``ranking`` with its first motion labelled ``wanted`` moved to the front, when
    that label is among its first three; else ``ranking`` itself."""
    if wanted not in _first_labels(ranking):
        return ranking
    k = next(k for k, match in enumerate(ranking) if match.label == wanted)
    return [ranking[k], *ranking[:k], *ranking[k + 1 :]]


def _stature_px(ankles_y: np.ndarray, nose_y: np.ndarray) -> float:
    """The body's height, pixels: :data:`STATURE_PER_NOSE_TO_ANKLE` × the 90th
    percentile over frames of the span from the nose (F,) down to the lower of the
    ankles (F, 2), image rows."""
    return float(STATURE_PER_NOSE_TO_ANKLE * np.percentile(ankles_y.max(axis=1) - nose_y, 90))


def _steady_peak(values: np.ndarray) -> float:
    """The largest of ``values`` (F,) (F >= 3) after a running median of three frames:
    one frame's slip of a landmark does not count."""
    return float(np.median(np.stack([values[:-2], values[1:-1], values[2:]]), axis=0).max())
