"""The body's facts that choose among a query's first three labels
(eigmotion.retrieval.motion_cues): the speed over the floor and the bend of the way
across it, measured on silhouettes of known motion, drawn and rendered; the rise of one
foot over the other and of both hands over the head from landmarks; and the rules that
reorder a ranking."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eigmotion.retrieval.motion_cues import (
    ASSUMED_FIELD_OF_VIEW_DEG,
    HANDS_RAISED_LABELS,
    KICK_MIN_RAISE,
    PUNCH_MAX_HANDS_RAISED,
    RUN_MIN_HEIGHTS_PER_S,
    TRAVEL_MIN_HEIGHTS_PER_S,
    TURN_MIN_DEG,
    TURN_MIN_HEIGHTS_PER_S,
    WALK_MAX_HEIGHTS_PER_S,
    answer_by_raised_foot,
    answer_by_raised_hands,
    answer_by_travel,
    answer_by_turning,
    floor_cues,
    foot_raise,
    hands_raised,
    heading_change,
    travel_speed,
)
from eigmotion.retrieval.results import Match

SIZE = (120, 160)  # rows, columns
FPS = 15.0


def _figure(height_px: np.ndarray, centre_px: np.ndarray, foot_row: int = 110) -> np.ndarray:
    """(F, 120, 160) masks of an upright box a quarter as wide as tall, standing on
    ``foot_row``."""
    masks = np.zeros((len(height_px), *SIZE), dtype=bool)
    for k, (h, x) in enumerate(zip(height_px, centre_px, strict=True)):
        h, half = int(round(h)), max(1, int(round(h / 8)))
        c = int(round(x))
        masks[k, foot_row - h + 1 : foot_row + 1, max(0, c - half) : c + half + 1] = True
    return masks


def test_sideways_travel_in_body_heights_per_second():
    frames = 45
    speed_px = 30.0  # px per second, a figure 80 px tall: 0.375 heights per second
    centre = 20.0 + speed_px * np.arange(frames) / FPS
    masks = _figure(np.full(frames, 80.0), centre)
    assert travel_speed(masks, FPS) == pytest.approx(speed_px / 80.0, rel=0.02)
    # the same figure standing still
    assert travel_speed(_figure(np.full(frames, 80.0), np.full(frames, 60.0)), FPS) < 1e-9


def test_travel_away_from_the_camera_from_the_figure_shrinking():
    """A person H tall at depth Z shows f H / Z pixels: walking away at u (heights per
    second) the figure shrinks so that f · d(1/h)/dt = u, with f the assumed focal
    length."""
    frames, fps = 60, 15.0
    focal = 0.5 * max(SIZE) / math.tan(math.radians(ASSUMED_FIELD_OF_VIEW_DEG / 2))
    u = 0.8  # body heights per second
    depth = 2.0 + u * np.arange(frames) / fps  # in body heights
    heights = focal / depth  # pixels
    masks = _figure(heights, np.full(frames, 80.0))
    assert travel_speed(masks, fps) == pytest.approx(u, rel=0.05)


def test_no_speed_where_the_figure_is_cut_by_the_frame_or_missing():
    frames = 30
    centre = np.linspace(30, 120, frames)
    tall = _figure(np.full(frames, 119.0), centre, foot_row=119)  # head at the top row
    assert travel_speed(tall, FPS) is None
    cut = _figure(np.full(frames, 60.0), centre, foot_row=119)  # feet on the bottom row
    assert travel_speed(cut, FPS) is None
    empty = np.zeros((frames, *SIZE), dtype=bool)
    assert travel_speed(empty, FPS) is None
    few = _figure(np.full(4, 60.0), centre[:4])  # fewer frames than the speed needs
    assert travel_speed(few, FPS) is None
    entering = _figure(np.full(frames, 60.0), np.linspace(0, 10, frames))  # cut by the side
    assert travel_speed(entering, FPS) is None


def test_frames_cut_by_the_side_are_left_out():
    """A person walking out of the picture: the frames where the box touches the side
    would shift its centre; the speed comes from the others."""
    frames = 45
    centre = 60.0 + 45.0 * np.arange(frames) / FPS  # leaves the 160-px frame at the end
    masks = _figure(np.full(frames, 80.0), centre)
    assert masks[:, :, -1].any() and not masks[0, :, -1].any()
    assert travel_speed(masks, FPS) == pytest.approx(45.0 / 80.0, rel=0.02)


def test_heading_change_between_the_halves():
    """Sideways for 2 s, then straight away from the camera for 2 s: a right angle; the
    same figure going on sideways: none; too slow to tell: not measured."""
    focal = 0.5 * max(SIZE) / math.tan(math.radians(ASSUMED_FIELD_OF_VIEW_DEG / 2))
    seconds = np.arange(60) / FPS
    u = 0.5  # body heights per second
    depth = 3.0 + u * np.clip(seconds - 2.0, 0.0, None)  # body heights
    sideways = u * np.minimum(seconds, 2.0) - 0.5  # body heights, from the frame's centre
    heights = focal / depth
    bend = _figure(heights, 79.5 + sideways * heights)
    assert heading_change(bend, FPS) == pytest.approx(90.0, abs=10.0)
    # the query measures the track once for both
    assert floor_cues(bend, FPS) == (travel_speed(bend, FPS), heading_change(bend, FPS))
    straight = _figure(np.full(60, 50.0), 79.5 + (u * seconds - 1.0) * 50.0)
    assert heading_change(straight, FPS) < 5.0
    slow = u * TURN_MIN_HEIGHTS_PER_S
    crawl = _figure(np.full(60, 50.0), 79.5 + (slow * seconds - 0.2) * 50.0)
    assert heading_change(crawl, FPS) is None
    assert heading_change(np.zeros((60, *SIZE), dtype=bool), FPS) is None


def _rendered(name: str, azimuth_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The library motion ``name`` on the avatar, rendered by the project's renderer from
    one fixed camera framing the whole motion: masks (F, 120, 160) and the body's
    vertices (F, V, 3), metres."""
    from eigmotion.body.avatar import load_default_avatar
    from eigmotion.body.retarget import animate_avatar
    from eigmotion.imaging.cameras import virtual_rig
    from eigmotion.imaging.silhouettes import render_masks
    from eigmotion.mocap.library import load_library

    motion = next(m for m in load_library() if m.name == name).motion.resample(FPS)
    body = load_default_avatar().decimated(4000)
    _, vertices = animate_avatar(body, motion)  # (F, V, 3) metres, Y up
    rig = virtual_rig([azimuth_deg], [0.0], SIZE[1], SIZE[0])
    cam = rig.fitted(vertices[:, ::7].reshape(-1, 3))[0]
    return render_masks(vertices, body.faces, cam), vertices


def test_rendered_walking_turn_bends_and_the_walk_does_not():
    """The library's walking turn by 90° (two steps, the turn, two steps) rendered from a
    fixed camera turns by more than :data:`TURN_MIN_DEG`; its walk from the same side
    keeps its heading."""
    turn, _ = _rendered("turn_walking_90", 45.0)
    assert heading_change(turn, FPS) > TURN_MIN_DEG
    walk, _ = _rendered("walk_02_01", 45.0)
    assert heading_change(walk, FPS) < 15.0


def test_rendered_walk_seen_from_the_side_travels_at_its_mocap_speed():
    """The library's walk rendered on the avatar by the project's renderer from a fixed
    camera at the person's side: the speed read from the silhouettes is the avatar's
    own speed over the floor in its own heights per second."""
    masks, vertices = _rendered("walk_02_01", 90.0)
    centroid = vertices.mean(axis=1)[:, [0, 2]]
    seconds = np.arange(len(vertices)) / FPS
    design = np.stack([seconds, np.ones_like(seconds)], axis=1)
    truth_m_per_s = np.linalg.norm(np.linalg.lstsq(design, centroid, rcond=None)[0][0])
    stature_m = np.ptp(vertices[0, :, 1])
    measured = travel_speed(masks, FPS)
    # the figure's height in a walk is a little under the standing stature
    assert measured == pytest.approx(truth_m_per_s / stature_m, rel=0.12)
    assert TRAVEL_MIN_HEIGHTS_PER_S < measured < WALK_MAX_HEIGHTS_PER_S


def _match(label: str, k: int) -> Match:
    return Match(label, f"{label}_{k}", k, 100 + k, 0.1 * (k + 1), 0.0, 0.0, (0, 30))


@pytest.mark.parametrize(
    ("labels", "speed", "first"),
    [
        (("run", "run", "walk", "turn"), 0.6, "walk_2"),  # walking speed: the walk
        (("run", "walk"), TRAVEL_MIN_HEIGHTS_PER_S / 2, "run_0"),  # hardly travels
        (("run", "walk"), (WALK_MAX_HEIGHTS_PER_S + RUN_MIN_HEIGHTS_PER_S) / 2, "run_0"),
        (("run", "walk"), None, "run_0"),  # not measured
        (("run", "kick", "jump", "walk"), 0.6, "run_0"),  # walk not among the first three
        (("walk", "turn", "run"), RUN_MIN_HEIGHTS_PER_S + 0.5, "run_2"),  # running speed
        (("walk", "run"), 0.9, "walk_0"),  # a walk at walking speed stays
        (("kick", "run", "walk"), 0.6, "kick_0"),  # neither gait first: left as ranked
    ],
)
def test_answer_by_travel(labels, speed, first):
    ranking = [_match(label, k) for k, label in enumerate(labels)]
    answered = answer_by_travel(ranking, speed)
    assert answered[0].motion == first
    # the same motions, the others in their order
    assert sorted(m.motion for m in answered) == sorted(m.motion for m in ranking)
    rest = [m.motion for m in ranking if m.motion != first]
    assert [m.motion for m in answered[1:]] == rest


@pytest.mark.parametrize(
    ("labels", "change", "first"),
    [
        (("walk", "run", "turn"), 80.0, "turn_2"),  # the way bends: the turn
        (("walk", "turn"), TURN_MIN_DEG / 2, "walk_0"),  # straight on
        (("walk", "turn"), None, "walk_0"),  # not measured (or hardly travels)
        (("walk", "run", "kick", "turn"), 80.0, "walk_0"),  # turn not among the first three
        (("run", "turn"), 80.0, "run_0"),  # only a walk is judged
        (("pick_up", "turn"), 150.0, "pick_up_0"),  # bending down reads as a step away
    ],
)
def test_answer_by_turning(labels, change, first):
    ranking = [_match(label, k) for k, label in enumerate(labels)]
    answered = answer_by_turning(ranking, change)
    assert answered[0].motion == first
    assert sorted(m.motion for m in answered) == sorted(m.motion for m in ranking)


def _landmarks(ankle_rise_px: np.ndarray) -> np.ndarray:
    """(F, 33, 4) landmarks of a person 100 px from nose to ankles, standing on row 200,
    the left ankle raised by ``ankle_rise_px`` in each frame; NaN elsewhere."""
    marks = np.full((len(ankle_rise_px), 33, 4), np.nan)
    marks[:, 0, :2] = (100.0, 100.0)  # nose
    marks[:, 27, :2] = np.stack([np.full(len(ankle_rise_px), 95.0), 200.0 - ankle_rise_px], 1)
    marks[:, 28, :2] = (105.0, 200.0)
    return marks


def test_foot_raise_in_body_heights():
    stature = 1.1 * 100.0
    kick = np.concatenate([np.zeros(10), [20, 50, 60, 55, 30], np.zeros(10)])
    assert foot_raise(_landmarks(kick)) == pytest.approx(55.0 / stature)
    # one frame's slip of a landmark does not count
    slip = np.zeros(20)
    slip[7] = 80.0
    assert foot_raise(_landmarks(slip)) == pytest.approx(0.0)
    # frames without the person (NaN) are left out; too few frames say nothing
    lost = _landmarks(kick)
    lost[:12] = np.nan
    assert foot_raise(lost) == pytest.approx(55.0 / stature)
    assert foot_raise(_landmarks(np.zeros(2))) is None
    assert foot_raise(None) is None


@pytest.mark.parametrize(
    ("labels", "rise", "speed", "first"),
    [
        (("punch", "kick", "walk"), KICK_MIN_RAISE + 0.1, None, "kick_1"),
        (("punch", "kick", "walk"), KICK_MIN_RAISE + 0.1, 0.3, "kick_1"),
        (("punch", "kick", "walk"), KICK_MIN_RAISE - 0.1, None, "punch_0"),
        (("punch", "kick", "walk"), None, None, "punch_0"),
        (("punch", "punch", "walk", "jump", "kick"), 0.8, None, "punch_0"),  # not in three
        (("kick", "punch"), 0.8, None, "kick_0"),
        # a runner's heel swung up high: running, not kicking
        (("run", "punch", "kick"), 0.8, RUN_MIN_HEIGHTS_PER_S + 0.2, "run_0"),
    ],
)
def test_answer_by_raised_foot(labels, rise, speed, first):
    ranking = [_match(label, k) for k, label in enumerate(labels)]
    answered = answer_by_raised_foot(ranking, rise, speed)
    assert answered[0].motion == first
    assert sorted(m.motion for m in answered) == sorted(m.motion for m in ranking)


def _arm_landmarks(wrist_rise_px: np.ndarray, bent: np.ndarray | None = None) -> np.ndarray:
    """(F, 33, 4) landmarks of a person 100 px from nose to ankles (nose on row 100,
    ankles on 200, hips on 150), the lower wrist ``wrist_rise_px`` above the nose (the
    other 10 px higher); ``bent`` frames have the nose down at the hips' height."""
    n = len(wrist_rise_px)
    marks = np.full((n, 33, 4), np.nan)
    marks[:, 0, :2] = (100.0, 100.0)  # nose
    marks[:, [23, 24], 1] = 150.0  # hips
    marks[:, [23, 24], 0] = (95.0, 105.0)
    marks[:, [27, 28], 1] = 200.0  # ankles
    marks[:, [27, 28], 0] = (95.0, 105.0)
    marks[:, 15, :2] = np.stack([np.full(n, 90.0), 100.0 - wrist_rise_px], 1)
    marks[:, 16, :2] = np.stack([np.full(n, 110.0), 90.0 - wrist_rise_px], 1)
    if bent is not None:
        marks[bent, 0, 1] = 150.0
    return marks


def test_hands_raised_in_body_heights():
    stature = 1.1 * 100.0
    lift = np.concatenate([np.full(8, -60.0), [-20, 10, 25, 30, 30, 28], np.full(6, -40.0)])
    assert hands_raised(_arm_landmarks(lift)) == pytest.approx(30.0 / stature)
    # a punch: the hands stay below the nose
    assert hands_raised(_arm_landmarks(np.full(20, -30.0))) == pytest.approx(-30.0 / stature)
    # one frame's slip of a landmark does not count
    slip = np.full(20, -50.0)
    slip[9] = 60.0
    assert hands_raised(_arm_landmarks(slip)) == pytest.approx(-50.0 / stature)
    # frames of a body bent double do not count (their landmarks lie anywhere)
    bent = np.zeros(20, bool)
    bent[8:14] = True
    assert hands_raised(_arm_landmarks(lift, bent)) == pytest.approx(-40.0 / stature)
    assert hands_raised(_arm_landmarks(lift, np.ones(20, bool))) is None
    assert hands_raised(_arm_landmarks(np.zeros(2))) is None
    assert hands_raised(None) is None


@pytest.mark.parametrize(
    ("labels", "raised", "first"),
    [
        (("punch", "lift", "walk"), PUNCH_MAX_HANDS_RAISED + 0.05, "lift_1"),
        (("punch", "kick", "wave"), PUNCH_MAX_HANDS_RAISED + 0.05, "wave_2"),
        (("punch", "lift", "walk"), PUNCH_MAX_HANDS_RAISED - 0.05, "punch_0"),
        (("punch", "lift", "walk"), None, "punch_0"),
        # none of the labels that raise the hands among the first three
        (("punch", "kick", "walk", "lift"), 0.3, "punch_0"),
        # only a punch is judged
        (("pick_up", "lift", "wave"), 0.3, "pick_up_0"),
        (("punch", "punch", "kick", "cover_head"), 0.3, "cover_head_3"),
    ],
)
def test_answer_by_raised_hands(labels, raised, first):
    ranking = [_match(label, k) for k, label in enumerate(labels)]
    answered = answer_by_raised_hands(ranking, raised)
    assert answered[0].motion == first
    assert sorted(m.motion for m in answered) == sorted(m.motion for m in ranking)
    assert set(HANDS_RAISED_LABELS) == {"lift", "wave", "jump", "cover_head"}
