"""The basic-motion library: manifest, loader, and that each trimmed clip shows its label."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from eigmotion.errors import EigmotionError, InvalidParameterError
from eigmotion.evaluation import action_spans
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.library import (
    DEFAULT_MANIFEST,
    DISTRACTOR_LABELS,
    FILLER_LABELS,
    LABELS,
    MIRROR_SUFFIX,
    LibraryMotion,
    find_motion,
    load_library,
    mirror_image,
    motion_names,
    read_manifest,
)
from eigmotion.mocap.mirror import mirror_motion
from eigmotion.mocap.naming import canonical_joint_map
from eigmotion.retrieval.library_views import BuildConfig
from eigmotion.retrieval.motion_cues import HANDS_RAISED_LABELS

REPO = Path(__file__).resolve().parents[1]
MOTIONS_DIR = REPO / "database" / "motions"
PATIENT_LABELS = ("lift", "pick_up", "sit_down", "cover_head", "walk", "fall_down")
AUTHORED_LABELS = (
    "lift",
    "sit_down",
    "cover_head",
    "fall_down",
    "jump",
    "turn",
    "wave",
    "pick_up",
    "punch",
)


@pytest.fixture(scope="module")
def library() -> list[LibraryMotion]:
    return load_library(include_distractors=True)


@pytest.fixture(scope="module")
def poses(library):
    """Name → (canonical joint name → (F, 3) positions, metres, grounded)."""
    out = {}
    for lm in library:
        pose = forward_kinematics(lm.motion)
        joints = canonical_joint_map(lm.motion.skeleton)
        out[lm.name] = {name: pose.positions[:, j] for name, j in joints.items()}
    return out


# -- manifest and loader ----------------------------------------------------------------------


def test_default_manifest_is_the_bundled_one():
    assert DEFAULT_MANIFEST == MOTIONS_DIR / "library.toml"
    assert DEFAULT_MANIFEST.is_file()


def test_every_entry_loads_with_a_known_label(library):
    entries = read_manifest()
    assert [lm.name for lm in library if lm.mirror_of is None] == [e.name for e in entries]
    for lm in library:
        allowed = DISTRACTOR_LABELS if lm.role == "distractor" else LABELS
        assert lm.label in allowed, lm.name
        assert lm.motion.name == lm.name
        assert lm.motion.fps > 0 and lm.motion.n_frames >= 2
        assert lm.licence and lm.performer and lm.variation and lm.attribution
        assert all(p.is_file() for p in lm.source)


def test_durations(library):
    for lm in library:
        if lm.performer == "authored":
            assert 1.5 <= lm.motion.duration_s <= 4.0, lm.name
        else:
            assert 1.0 <= lm.motion.duration_s <= 6.0, lm.name


def test_frame_ranges_match_the_trimmed_motions(library):
    for lm in library:
        start, stop = lm.frame_range
        assert lm.motion.n_frames == stop - start, lm.name


def test_authored_entries_cover_their_whole_file(library):
    """The manifest follows generate.py: an authored entry spans its whole BVH."""
    for lm in library:
        if lm.performer == "authored":
            assert lm.frame_range == (0, read_bvh(lm.source[0]).n_frames), lm.name


@pytest.mark.parametrize("label", LABELS)
def test_every_label_has_a_motion(library, label):
    motions = [lm for lm in library if lm.label == label and lm.role == "basic"]
    assert motions
    authored = [lm for lm in motions if lm.performer == "authored" and lm.mirror_of is None]
    if label in AUTHORED_LABELS:  # a few ways each, none flooding the database
        assert 2 <= len(authored) <= 10


def test_the_patents_six_labels_are_there():
    assert set(PATIENT_LABELS) <= set(LABELS)
    assert len(LABELS) == 12


def test_distractors_are_left_out_by_default(library):
    default = load_library()
    assert all(lm.role == "basic" for lm in default)
    distractors = [lm for lm in library if lm.role == "distractor"]
    assert {lm.label for lm in distractors} == set(DISTRACTOR_LABELS)
    assert len(default) + len(distractors) == len(library)
    assert set(motion_names(include_distractors=False)) == {lm.name for lm in default}


def test_authored_motions_stand_on_the_floor(library, poses):
    """Every authored motion (mirror images too) starts on both feet, or on one in a
    run already under way, ends on its feet unless it ends lying down, and never sinks
    below the floor."""
    for lm in library:
        if lm.performer != "authored":
            continue
        p = poses[lm.name]
        # The ankle joints stand 4.7 cm above the floor on a flat foot.
        ankles = np.stack([p[n][:, 1] for n in ("LeftFoot", "RightFoot")], axis=1)
        on_the_floor = ankles[0].min() if lm.label == "run" else ankles[0].max()
        assert on_the_floor <= 0.07, lm.name
        assert p["Hips"][-1, 1] < 0.5 or ankles[-1].min() <= 0.07, lm.name
        assert min(v[:, 1].min() for v in p.values()) >= -0.01, lm.name


def test_sources_md_lists_every_motion():
    text = (MOTIONS_DIR / "SOURCES.md").read_text(encoding="utf-8")
    for entry in read_manifest():
        assert f"`{entry.name}`" in text, entry.name
    assert "mocap.cs.cmu.edu" in text and "NSF EIA-0196217" in text and "CC0" in text


# -- find_motion ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["pick_up_02_06_a", "cover_head_standing", "block_135_05"])
def test_find_motion_by_name(library, name):
    motion = find_motion(name)
    expected = next(lm.motion for lm in library if lm.name == name)
    np.testing.assert_array_equal(motion.values, expected.values)


def test_find_motion_by_path():
    bvh = MOTIONS_DIR / "authored" / "pick_up_heavy_box_to_chest.bvh"
    assert find_motion(bvh).n_frames == read_bvh(bvh).n_frames
    amc = find_motion(str(MOTIONS_DIR / "cmu/amc/16_35.amc"), asf=MOTIONS_DIR / "cmu/asf/16.asf")
    assert amc.n_frames == 162


def test_a_misspelt_name_gets_the_closest_basic_motions():
    with pytest.raises(InvalidParameterError) as caught:
        find_motion("kick_135_4")
    message = str(caught.value)
    assert message.startswith("no motion named 'kick_135_4' in the library; did you mean ")
    suggested = message.split("did you mean ")[1].rstrip("?").split(", ")
    assert suggested[0] == "kick_135_04" and 1 <= len(suggested) <= 5
    distractors = {e.name for e in read_manifest() if e.role == "distractor"}
    assert not distractors & set(suggested)
    assert len(message) < 200
    # A distractor's own misspelt name is suggested, as a distractor.
    distractor = sorted(distractors)[0]
    with pytest.raises(InvalidParameterError, match="did you mean the distractor ") as caught:
        find_motion(distractor[:-1] + "Q")
    assert distractor in str(caught.value) and "kick" not in str(caught.value)


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (("no_such_motion",), "no motion named 'no_such_motion'.*basic motions.*walk"),
        (("missing.bvh",), "not found"),
        (("missing.amc", "x.asf"), "not found"),
        ((str(MOTIONS_DIR / "cmu/amc/16_35.amc"),), r"needs its skeleton"),
        ((str(MOTIONS_DIR / "cmu/amc/16_35.amc"), "missing.asf"), "not found"),
        (("clip.mp4",), "unsupported motion file type"),
    ],
)
def test_find_motion_errors(args, match):
    with pytest.raises(InvalidParameterError, match=match):
        find_motion(*args)


# -- broken manifests ---------------------------------------------------------------------------

GOOD_ENTRY = """
[[motion]]
name = "x"
label = "run"
source = ["cmu/amc/16_35.amc", "cmu/asf/16.asf"]
frame_range = [0, 100]
performer = "cmu_16"
variation = "v"
licence = "l"
attribution = "a"
"""


def _manifest(tmp_path: Path, text: str) -> Path:
    cmu = tmp_path / "cmu"
    (cmu / "amc").mkdir(parents=True)
    (cmu / "asf").mkdir()
    shutil.copy(MOTIONS_DIR / "cmu/amc/16_35.amc", cmu / "amc")
    shutil.copy(MOTIONS_DIR / "cmu/asf/16.asf", cmu / "asf")
    path = tmp_path / "library.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_good_manifest_elsewhere_loads(tmp_path):
    (lm,) = load_library(_manifest(tmp_path, GOOD_ENTRY))
    assert lm.name == "x" and lm.motion.n_frames == 100 and lm.role == "basic"


def test_a_manifest_entry_with_mirror_loads_both(tmp_path):
    lm, mirror = load_library(_manifest(tmp_path, GOOD_ENTRY + "mirror = true\n"))
    assert (lm.name, mirror.name, mirror.mirror_of) == ("x", "x_mirror", "x")
    assert motion_names(tmp_path / "library.toml") == ["x", "x_mirror"]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "one or more"),
        ("[[motion]\n", "not a valid TOML"),
        (GOOD_ENTRY.replace('label = "run"\n', ""), "'label'"),
        (GOOD_ENTRY.replace('"run"', '"dance"'), "dance"),
        (GOOD_ENTRY.replace('"run"', '"duck"'), "not a known basic label"),
        (GOOD_ENTRY + GOOD_ENTRY, "duplicate name"),
        (GOOD_ENTRY.replace('name = "x"', 'name = "x y"'), "letters, digits"),
        (GOOD_ENTRY.replace("[0, 100]", "[100, 10]"), "frame_range"),
        (GOOD_ENTRY.replace("[0, 100]", "[0.5, 10]"), "frame_range"),
        (
            GOOD_ENTRY.replace(
                'source = ["cmu/amc/16_35.amc", "cmu/asf/16.asf"]', 'source = "cmu/amc/16_35.amc"'
            ),
            "with its .asf",
        ),
        (GOOD_ENTRY + 'role = "extra"\n', "role must be one of"),
        (GOOD_ENTRY + 'colour = "red"\n', "unknown field"),
        (GOOD_ENTRY.replace('performer = "cmu_16"', "performer = 16"), "'performer'"),
        (GOOD_ENTRY + 'mirror = "yes"\n', "mirror must be true or false"),
        (GOOD_ENTRY + "action = [0.5, 0.2]\n", "0 <= start_s < stop_s"),
        (GOOD_ENTRY + "action = [0.2, 0.2]\n", "0 <= start_s < stop_s"),
        (GOOD_ENTRY + "action = [-0.1, 0.2]\n", "0 <= start_s < stop_s"),
        (GOOD_ENTRY + "action = [0.1]\n", "action must be"),
        (GOOD_ENTRY + "action = [true, 0.5]\n", "action must be"),
        (GOOD_ENTRY + 'action = ["0.1", 0.5]\n', "action must be"),
        (GOOD_ENTRY + "action = [0.1, nan]\n", "action must be"),
        (
            GOOD_ENTRY + "action = [0.1, 0.5]\n" + 'filler = "stand"\n',
            "filler must be one of run, walk",
        ),
        (GOOD_ENTRY + "action = [0.1, 0.5]\n" + "filler = true\n", "filler must be one of"),
        (GOOD_ENTRY + 'filler = "walk"\n', "needs an action"),
        (GOOD_ENTRY + "action = [0.1, 0.5]\n" + 'filler = "run"\n', "the motion's own label"),
        (
            GOOD_ENTRY + "mirror = true\n" + GOOD_ENTRY.replace('"x"', '"x_mirror"'),
            "duplicate name 'x_mirror'",
        ),
    ],
)
def test_broken_manifests_raise(tmp_path, text, match):
    path = _manifest(tmp_path, text)
    with pytest.raises(InvalidParameterError, match=match):
        load_library(path)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (GOOD_ENTRY.replace("16_35.amc", "16_99.amc"), "file not found"),
        (GOOD_ENTRY.replace("[0, 100]", "[0, 1000]"), "runs past the end"),
        # 100 frames at 120 frames/s: the motion lasts 0.833 s.
        (GOOD_ENTRY + "action = [0.2, 0.9]\n", r"action \[0.2, 0.9\] s runs past the end"),
    ],
)
def test_entries_that_cannot_load_raise(tmp_path, text, match):
    path = _manifest(tmp_path, text)
    read_manifest(path)  # the manifest itself is fine
    with pytest.raises(InvalidParameterError, match=match):
        load_library(path)


def test_an_action_span_and_filler_load_and_mirror(tmp_path):
    text = GOOD_ENTRY.replace('"run"', '"jump"') + (
        'action = [0.25, 0.8]\nfiller = "run"\nmirror = true\n'
    )
    path = _manifest(tmp_path, text)
    (entry,) = read_manifest(path)
    assert (entry.action, entry.filler) == ((0.25, 0.8), "run")
    lm, mirror = load_library(path)
    assert (lm.action, lm.filler) == ((0.25, 0.8), "run")
    assert (mirror.action, mirror.filler, mirror.mirror_of) == ((0.25, 0.8), "run", "x")
    # Whole seconds and a span up to the motion's last frame are fine; no filler either.
    (whole,) = load_library(_manifest(tmp_path / "b", GOOD_ENTRY + "action = [0, 0.8]\n"))
    assert (whole.action, whole.filler) == ((0.0, 0.8), None)
    (plain,) = load_library(_manifest(tmp_path / "c", GOOD_ENTRY))
    assert (plain.action, plain.filler) == (None, None)


def test_missing_manifest_raises(tmp_path):
    with pytest.raises(EigmotionError, match="manifest not found"):
        load_library(tmp_path / "nope.toml")
    with pytest.raises(InvalidParameterError, match="no motion named 'x'"):
        find_motion("x", manifest=_manifest(tmp_path, GOOD_ENTRY.replace('"x"', '"y"')))


# -- each clip shows its label ----------------------------------------------------------------


def _travel(p):
    return float(np.linalg.norm(p["Hips"][-1, [0, 2]] - p["Hips"][0, [0, 2]]))


def _both_feet_height(p):
    """(F,) height of the lower ankle: > 0 only when both feet are off the floor."""
    return np.minimum(p["LeftFoot"][:, 1], p["RightFoot"][:, 1])


def _hands(p):
    return np.stack([p["LeftHand"], p["RightHand"]], axis=1)


def _lower_hand_over_head(p):
    """(F,) height of the lower hand over the head joint, metres."""
    return _hands(p)[..., 1].min(axis=1) - p["Head"][:, 1]


def test_only_the_labels_the_raised_hands_rule_allows_raise_both_hands(library, poses):
    """The query's rule (motion_cues.answer_by_raised_hands) turns an answer punch into
    a label whose motions raise both hands over the head: each such label has motions
    that do, and no motion of another label does."""
    raises = {name: _lower_hand_over_head(poses[name]).max() > 0.0 for name in poses}
    labels = {lm.label for lm in library if raises[lm.name]}
    assert labels == set(HANDS_RAISED_LABELS)


def _yaw_change_deg(p):
    d = p["LeftUpLeg"] - p["RightUpLeg"]
    yaw = np.degrees(np.unwrap(np.arctan2(-d[:, 2], d[:, 0])))
    n = max(1, len(yaw) // 10)
    return abs(yaw[-n:].mean() - yaw[:n].mean())


def _check_label(label: str, p, frame_time_s: float) -> None:
    hips_y = p["Hips"][:, 1]
    head_y = p["Head"][:, 1]
    hands = _hands(p)
    if label == "walk":
        assert _travel(p) >= 2.0 and _both_feet_height(p).max() < 0.18
    elif label == "run":
        assert _travel(p) >= 2.5 and _both_feet_height(p).max() >= 0.18
    elif label == "jump":
        # Off the floor, both feet (one foot held up in a hop), the hips well above
        # where they start (a run's flight is flat).
        assert _both_feet_height(p).max() >= 0.2 and hips_y.max() - hips_y[0] >= 0.15
    elif label == "pick_up":
        # Squatting or bending with straight legs: the head goes down, a hand to the floor
        # or to the top of a box standing on it.
        assert head_y[0] - head_y.min() >= 0.5 and hands[..., 1].min() <= 0.4
    elif label == "lift":
        # The hands end higher than their lowest point, loaded from below.
        assert hands[-1, :, 1].min() - hands[..., 1].min() >= 0.3 or (
            (hands[..., 1] > head_y[:, None]).all(axis=1).any()
        )
    elif label == "sit_down":
        # Onto a chair (the hips end well down) or a high stool (the feet end up on
        # its rung, off the floor).
        drop = hips_y.max() - hips_y[-1]
        assert drop >= 0.08 and (drop >= 0.2 or _both_feet_height(p)[-1] >= 0.15)
    elif label == "cover_head":
        late = slice(len(head_y) // 2, None)
        near = np.linalg.norm(hands[late] - p["Head"][late, None], axis=-1) < 0.3
        assert near.all()
    elif label == "fall_down":
        assert head_y[0] > 1.4 and head_y[-1] < 0.5
    elif label == "wave":
        assert (hands[..., 1] > head_y[:, None]).any(axis=1).mean() >= 0.5
    elif label == "kick":
        feet_y = np.stack([p["LeftFoot"][:, 1], p["RightFoot"][:, 1]], axis=1)
        assert (feet_y - feet_y.min()).max() >= 0.8
    elif label == "punch":
        speed = np.linalg.norm(np.diff(hands, axis=0), axis=-1) / frame_time_s
        assert speed.max() >= 2.5
        # one hand at least stays below the head (the query's raised-hands rule)
        assert _lower_hand_over_head(p).max() < -0.1
    elif label == "turn":
        assert _yaw_change_deg(p) >= 60
    elif label == "duck":
        assert _travel(p) >= 3.0 and hips_y.max() - hips_y.min() >= 0.15
    elif label == "block":
        assert (hands[..., 1] > p["Spine1"][:, None, 1] - 0.1).any()
    else:  # pragma: no cover - every label is listed above
        raise AssertionError(label)


def test_each_clip_shows_its_label(library, poses):
    """Crude body measures that tell the labels apart, so a wrong trim is caught."""
    for lm in library:
        try:
            _check_label(lm.label, poses[lm.name], lm.motion.frame_time_s)
        except AssertionError as exc:
            raise AssertionError(f"{lm.name} does not look like {lm.label!r}") from exc


def _seconds(p, frame_time_s: float, start_s: float, stop_s: float):
    """The poses of ``p`` in ``[start_s, stop_s)``."""
    part = slice(int(round(start_s / frame_time_s)), int(round(stop_s / frame_time_s)))
    return {name: xyz[part] for name, xyz in p.items()}


def test_turns_and_jumps_mark_their_action(library):
    """Every turn and jump says which seconds show it: what is around them (walking into
    a turn, the run-up of a jump, standing) is not labelled turn or jump."""
    for lm in library:
        if lm.label in ("turn", "jump"):
            assert lm.action is not None, lm.name
        if lm.action is not None:
            assert lm.filler in (None, *FILLER_LABELS), lm.name


def test_action_spans_show_the_action_and_the_rest_does_not(library, poses):
    """The span passes its label's check; each part outside it (long enough to judge)
    fails it, and the part before a filler's action moves like the filler: getting on
    at 0.5 m/s or more, both feet leaving the floor for a run only."""
    for lm in library:
        if lm.action is None:
            continue
        p, dt = poses[lm.name], lm.motion.frame_time_s
        try:
            _check_label(lm.label, _seconds(p, dt, *lm.action), dt)
        except AssertionError as exc:
            raise AssertionError(f"{lm.name}: its action span does not show {lm.label}") from exc
        for outside in ((0.0, lm.action[0]), (lm.action[1], lm.motion.duration_s)):
            part = _seconds(p, dt, *outside)
            if outside[1] - outside[0] < 0.25:
                continue
            with pytest.raises(AssertionError):
                _check_label(lm.label, part, dt)
            if lm.filler is not None and outside[0] == 0.0:
                floor = _both_feet_height(p).min()
                flight = _both_feet_height(part).max() - floor >= 0.04
                assert flight == (lm.filler == "run"), lm.name
                assert _travel(part) >= 0.5 * (outside[1] - outside[0]), lm.name  # >= 0.5 m/s


def test_action_spans_are_the_measured_ones(library):
    """Each turn's and jump's span and filler are what the measuring rules give (to the
    0.01 s the manifest writes); the mirror image measures the same."""
    for lm in library:
        if lm.label not in ("turn", "jump"):
            continue
        signals = action_spans.body_signals(lm)
        measured = action_spans.measured_span(lm, signals)
        np.testing.assert_allclose(lm.action, measured, atol=0.0051, err_msg=lm.name)
        assert lm.filler == action_spans.measured_filler(signals, measured), lm.name


def test_action_spans_plot(library, tmp_path):
    by_name = {lm.name: lm for lm in library}
    items = [by_name["turn_walking_180"], by_name["walk_02_01"]]
    windows_s, labels = action_spans.build_windows(items[0], BuildConfig())
    assert labels == ["walk", "turn", "turn", "turn", "walk", "walk"]
    assert windows_s[0, 0] == 0.0 and windows_s[-1, 1] == pytest.approx(items[0].motion.duration_s)
    out = tmp_path / "spans.png"
    action_spans.plot(items, BuildConfig(), out)
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("label", "other"),
    [("walk", "run"), ("jump", "walk"), ("jump", "run"), ("wave", "punch"), ("turn", "walk")],
)
def test_label_checks_can_fail(library, poses, label, other):
    lm = next(lm for lm in library if lm.label == other)
    with pytest.raises(AssertionError):
        _check_label(label, poses[lm.name], lm.motion.frame_time_s)


# -- mirror images --------------------------------------------------------------------------


def test_mirror_images_follow_their_originals(library):
    by_name = {lm.name: lm for lm in library}
    mirrored = [e.name for e in read_manifest() if e.mirror]
    assert mirrored
    for name in mirrored:
        mirror = by_name[name + MIRROR_SUFFIX]
        original = by_name[name]
        assert library.index(mirror) == library.index(original) + 1
        assert mirror.mirror_of == name and original.mirror_of is None
        assert (mirror.label, mirror.performer, mirror.role, mirror.source) == (
            original.label,
            original.performer,
            original.role,
            original.source,
        )
        assert "mirror" in mirror.variation and mirror.motion.name == mirror.name
        assert mirror.motion.n_frames == original.motion.n_frames
    assert set(motion_names()) == set(by_name)


def _hand_over_head(p, side):
    return p[f"{side}Hand"][:, 1] > p["Head"][:, 1]


@pytest.mark.parametrize("name", ["wave_14_24", "wave_right_hand"])
def test_a_mirrored_right_hand_wave_raises_the_left_hand(library, poses, name):
    original, mirror = poses[name], poses[name + MIRROR_SUFFIX]
    assert _hand_over_head(original, "Right").mean() >= 0.5
    assert not _hand_over_head(original, "Left").any()
    assert _hand_over_head(mirror, "Left").mean() >= 0.5
    assert not _hand_over_head(mirror, "Right").any()


def test_a_mirrored_walk_swaps_the_foot_heights(library):
    walk = next(lm for lm in library if lm.name == "walk_02_01")
    mirror = mirror_image(walk)
    assert mirror.name == "walk_02_01" + MIRROR_SUFFIX
    before = forward_kinematics(walk.motion)
    after = forward_kinematics(mirror.motion)
    for side, other in (("lfoot", "rfoot"), ("rfoot", "lfoot"), ("ltoes", "rtoes")):
        np.testing.assert_allclose(
            after.positions[:, after.names.index(side), 1],
            before.positions[:, before.names.index(other), 1],
            atol=1e-9,
        )
    # On the CMU skeleton too, mirroring twice gives the walk back.
    twice = forward_kinematics(mirror_motion(mirror.motion))
    np.testing.assert_allclose(twice.positions, before.positions, atol=1e-9)
    # The left foot is not simply the right one: the walk is not symmetric.
    left = before.positions[:, before.names.index("lfoot"), 1]
    right = before.positions[:, before.names.index("rfoot"), 1]
    assert np.abs(left - right).max() > 0.05


@pytest.mark.parametrize("name", ["wave_14_24_mirror", "turn_in_place_90_mirror"])
def test_find_motion_finds_mirror_images(library, name):
    expected = next(lm.motion for lm in library if lm.name == name)
    motion = find_motion(name)
    assert motion.name == name
    np.testing.assert_array_equal(motion.values, expected.values)
