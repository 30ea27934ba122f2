"""The retrieval engine end to end: build → query → index, on real files.

A small real database (four library motions × the patent's six horizontal cameras)
is built once into a temporary ZODB file; clips are rendered from another body shape
at views between the rig's cameras.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from mask_helpers import edge_flicker

from eigmotion.body.retarget import animate_avatar
from eigmotion.cli.main import main
from eigmotion.errors import DatabaseError, InvalidParameterError, VideoError
from eigmotion.evaluation.query_variants import EntryTable
from eigmotion.evaluation.rejection_ceiling import ask_both_ways, rejection_ceiling_report
from eigmotion.imaging.cameras import virtual_rig
from eigmotion.mocap.bvh import read_bvh
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.library import load_library
from eigmotion.retrieval.brute_force import BruteForceIndex
from eigmotion.retrieval.build import build_database
from eigmotion.retrieval.calibration import (
    CALIBRATION_LEVELS,
    calibration_quantiles,
    leave_one_motion_out_distances,
    leave_one_motion_out_threshold,
    stored_quantiles,
)
from eigmotion.retrieval.database import MotionDatabase, brute_force_check, candidate_motions
from eigmotion.retrieval.library_views import BuildConfig, window_bounds
from eigmotion.retrieval.query_windows import (
    FILLER_CANDIDATES,
    WINDOW_CANDIDATES,
    clip_segments,
    search_windows,
    specific_window_entry,
    window_label_path,
    within_person,
)
from eigmotion.retrieval.results import Match, Segment
from eigmotion.retrieval.sequences import POSE_COMPONENTS, pose_speeds

REPO = Path(__file__).resolve().parents[1]

MOTIONS = ("walk_02_01", "kick_135_04", "wave_14_24", "pick_up_02_06_a")
CONFIG = BuildConfig(
    n_components=16, key_axes=3, key_sections=6, garments=((),), body_shapes=((None, 1.0),)
)


@pytest.fixture(scope="module")
def library():
    by_name = {m.name: m for m in load_library()}
    return [by_name[n] for n in MOTIONS]


@pytest.fixture(scope="module")
def db_path(ring6_database):
    return ring6_database(MOTIONS, CONFIG)


@pytest.fixture(scope="module")
def other_body():
    from eigmotion.body.avatar import load_default_avatar

    return load_default_avatar().with_shape(height_m=1.62, girth=1.15).decimated(4000)


def _masks(motion, body, azimuth_deg, elevation_deg, size=(160, 120)):
    from eigmotion.imaging.silhouettes import render_masks

    _, vertices = animate_avatar(body, motion.resample(30))
    cam = virtual_rig([azimuth_deg], [elevation_deg], *size).fitted(
        vertices[:, ::7].reshape(-1, 3)
    )[0]
    return render_masks(vertices, body.faces, cam)


def test_window_bounds_cover_the_clip():
    rows = window_bounds(100, 30.0, 1.5, 0.5)
    assert tuple(rows[0]) == (0, 100)
    assert rows[1:, 0].min() == 0 and rows[1:, 1].max() == 100
    assert np.all(rows[1:, 1] - rows[1:, 0] == 45)
    assert window_bounds(40, 30.0, 1.5, 0.5).shape == (1, 2)


def test_database_holds_what_was_built(db_path, library):
    with MotionDatabase.open(db_path) as db:
        assert db.store.n_motions == len(library)
        assert db.n_entries == db.store.n_entries > 6 * len(library)
        assert db.config == CONFIG
        assert len(db.rig) == 6
        assert 0 < db.threshold < np.inf
        db.store.check()
        for mid, item in enumerate(library):
            back = db.motion(mid)
            np.testing.assert_allclose(back.values, item.motion.values, atol=1e-5)
            # one silhouette sequence per (body, view) of the whole motion
            sequences = db.store.sequences(mid)
            assert len(sequences.lengths) == len(CONFIG.bodies) * len(db.rig)
            assert sorted(set(sequences.azimuth_deg)) == sorted({c.azimuth_deg for c in db.rig})
            assert sequences.frames.shape == (sequences.lengths.sum(), POSE_COMPONENTS + 1)


def test_threshold_is_the_quantile_of_each_whole_entry_nearest_other_performance(rng):
    points = rng.normal(size=(700, 5)).astype(np.float32)
    performance = rng.integers(0, 2, size=700)
    whole = rng.random(700) < 0.9  # each performance: more whole entries than one block
    found = [
        float(np.linalg.norm(points[performance != performance[i]] - points[i], axis=1).min())
        for i in np.flatnonzero(whole)
    ]
    # entry by entry, in the points' float32: the same to the last bit
    assert leave_one_motion_out_threshold(points, performance, whole) == np.quantile(found, 0.95)
    # rendered on three bodies: each entry against the other performances' entries on
    # the other bodies only, which lie farther
    body = rng.integers(0, 3, size=700)
    found_elsewhere = [
        float(
            np.linalg.norm(
                points[(performance != performance[i]) & (body != body[i])] - points[i], axis=1
            ).min()
        )
        for i in np.flatnonzero(whole)
    ]
    assert leave_one_motion_out_threshold(points, performance, whole, body) == np.quantile(
        found_elsewhere, 0.95
    )
    assert np.quantile(found_elsewhere, 0.95) > np.quantile(found, 0.95)
    # one body in all: as without bodies
    same = np.full(700, 2)
    assert leave_one_motion_out_threshold(points, performance, whole, same) == np.quantile(
        found, 0.95
    )
    # two builds in two outfits: each entry against the bodies of the other build in
    # the other outfit only (bodies shape by shape: (1.0, plain), (1.0, shorts),
    # (1.25, plain), (1.25, shorts))
    config = BuildConfig(body_shapes=((None, 1.0), (None, 1.25)), garments=((), ("wide_shorts",)))
    alike = config.alike_bodies()
    np.testing.assert_array_equal(alike, ~np.eye(4, dtype=bool)[::-1])
    body4 = rng.integers(0, 4, size=700)
    found_unlike = [
        float(
            np.linalg.norm(
                points[(performance != performance[i]) & (body4 == 3 - body4[i])] - points[i],
                axis=1,
            ).min()
        )
        for i in np.flatnonzero(whole)
    ]
    distances = leave_one_motion_out_distances(points, performance, whole, body4, alike)
    np.testing.assert_array_equal(np.sort(distances), np.sort(found_unlike))
    # one build in several outfits, or one outfit on several builds: the body alone
    one_build = BuildConfig(body_shapes=((None, 1.0),), garments=((), ("wide_shorts",)))
    np.testing.assert_array_equal(one_build.alike_bodies(), np.eye(2, dtype=bool))
    np.testing.assert_array_equal(
        BuildConfig(body_shapes=((None, 1.0), (None, 1.25)), garments=((),)).alike_bodies(),
        np.eye(2, dtype=bool),
    )
    one = np.zeros(700, dtype=int)
    radius = np.linalg.norm(points - points.mean(axis=0), axis=1).max()
    assert leave_one_motion_out_threshold(points, one, whole) == pytest.approx(2 * radius)
    # the distances behind it, and the quantiles a build stores of them
    distances = leave_one_motion_out_distances(points, performance, whole, body)
    np.testing.assert_array_equal(distances, found_elsewhere)  # in the entries' order
    quantiles = calibration_quantiles(distances)
    assert len(quantiles) == len(CALIBRATION_LEVELS) == 201
    assert quantiles[190] == np.quantile(found_elsewhere, 0.95)
    assert quantiles[0] == min(found_elsewhere) and quantiles[-1] == max(found_elsewhere)
    assert leave_one_motion_out_distances(points, one, whole) is None
    # bodies all alike: no entry has anyone else's to compare with
    all_alike = np.ones((3, 3), dtype=bool)
    assert leave_one_motion_out_distances(points, performance, whole, body, all_alike) is None
    assert calibration_quantiles(None) is None


def test_p_known_and_the_false_rejection_agree(db_path, library, other_body):
    """``p_known`` is the share of the calibration distances at least as far as the
    clip; the query accepts at a share r exactly when ``p_known >= r``; the default
    share is the database's own threshold."""
    masks = _masks(library[2].motion, other_body, azimuth_deg=75.0, elevation_deg=12.0)
    with MotionDatabase.open(db_path) as db:
        quantiles = db.calibration_quantiles
        assert quantiles.shape == (201,) and np.all(np.diff(quantiles) >= 0)
        assert db.threshold_at(0.05) == db.threshold
        for share in (0.01, 0.2, 0.5, 0.9):
            assert db.p_known(db.threshold_at(share)) == pytest.approx(share)
        assert db.p_known(0.0) == 1.0 and db.p_known(2 * quantiles[-1]) == 0.0
        answer = db.query_masks(masks, 30.0)
        assert answer.threshold == db.threshold and 0.0 <= answer.p_known <= 1.0
        assert answer.accepted == (answer.p_known >= 0.05)
        for share in (max(answer.p_known - 0.02, 0.001), min(answer.p_known + 0.02, 0.999)):
            judged = db.query_masks(masks, 30.0, false_rejection=share)
            assert judged.threshold == db.threshold_at(share)
            assert judged.accepted == (judged.p_known >= share)
            assert judged.best == answer.best and judged.p_known == answer.p_known
        for share in (0.0, 1.0, -0.1, float("nan")):
            with pytest.raises(InvalidParameterError, match="false rejection"):
                db.query_masks(masks, 30.0, false_rejection=share)
        db.calibration_quantiles = None  # as a database built before they were stored
        assert db.p_known(0.3) is None and db.query_masks(masks, 30.0).p_known is None
        with pytest.raises(DatabaseError, match="build it again"):
            db.threshold_at(0.2)


def test_damaged_calibration_quantiles_are_refused():
    good = np.linspace(0.1, 0.5, 201).tolist()
    assert stored_quantiles("db.fs", {}) is None
    np.testing.assert_array_equal(stored_quantiles("db.fs", {"calibration_quantiles": good}), good)
    for bad in (good[:-1], good[::-1], [*good[:-1], float("nan")], ["a"] * 201):
        with pytest.raises(DatabaseError, match="db.fs: the stored calibration quantiles"):
            stored_quantiles("db.fs", {"calibration_quantiles": bad})


def test_a_build_calibrates_each_entry_against_the_other_bodies(tmp_path):
    """Two motions on two bodies: every entry record keeps its body, and the stored
    threshold compares each whole-motion entry with the other motion on the other
    body only, which lies farther than on its own."""
    from dataclasses import replace as with_fields

    by_name = {m.name: m for m in load_library()}
    two = [with_fields(by_name[n], motion=by_name[n].motion.trim(0, 60)) for n in MOTIONS[1:3]]
    path = tmp_path / "bodies.fs"
    rig = virtual_rig([0.0, 90.0], [0.0], 64, 64)
    config = replace(CONFIG, n_components=4, key_axes=2, garments=((), ("wide_shorts",)))
    build_database(two, rig, path, config, workers=1, progress=False)
    with MotionDatabase.open(path) as db:
        arrays = db.store.arrays()
        records = [db.store.entry(i) for i in arrays.ids.tolist()]
        frames = {m: db.motion(m).n_frames for m in set(arrays.motions.tolist())}
        threshold = db.threshold
    body = np.array([r["body"] for r in records])
    whole = np.array([r["start_frame"] == 0 and r["end_frame"] == frames[r["motion"]]
                      for r in records])  # fmt: skip
    assert np.bincount(body).tolist() == [len(body) // 2] * 2
    assert whole.sum() == 2 * 2 * len(rig)  # motions × bodies × views
    elsewhere = leave_one_motion_out_threshold(arrays.points, arrays.motions, whole, body)
    assert threshold == elsewhere
    assert elsewhere > leave_one_motion_out_threshold(arrays.points, arrays.motions, whole)


def test_the_entry_table_reads_each_entry_as_the_build_made_it(db_path):
    """The entry table behind ``bench_rerank.py --unknown``: calibrating the threshold
    from it gives the one the build stored, and leaving a label out leaves its
    motions' entries out."""
    with MotionDatabase.open(db_path) as db:
        table = EntryTable(db)
        whole, body = table.calibration(db)
        n_views = len(CONFIG.bodies) * len(db.rig)
        assert whole.sum() == n_views * len(MOTIONS)
        assert np.bincount(body).tolist() == [len(body) // len(CONFIG.bodies)] * len(CONFIG.bodies)
        assert set(table.motion) == set(MOTIONS)
        assert len(set(table.performance)) == len(MOTIONS)  # no mirror images here
        threshold = leave_one_motion_out_threshold(table.points, table.performance, whole, body)
        assert threshold == db.threshold
        kept = table.label != "wave"
        table.search_only(db, kept)
        assert db.index.n_entries == kept.sum() < len(table.motion)


def test_rejection_ceiling_asks_each_whole_entry_both_ways(db_path):
    """``bench_rejection_ceiling.py``: each whole-motion entry, without its own
    performance, finds another entry no farther than without its whole label (a
    label of one performance here: both leave the same entries out)."""
    with MotionDatabase.open(db_path) as db:
        table = EntryTable(db)
        whole, body = table.calibration(db)
        alike = db.config.alike_bodies()
        label, known, unknown, known_answer, unknown_answer = ask_both_ways(
            table, whole, body, own_body=False, alike=alike
        )
        assert len(label) == whole.sum() and sorted(set(label)) == sorted(set(table.label))
        np.testing.assert_array_equal(known, unknown)  # one performance per label
        assert not np.any(unknown_answer == label)
        assert np.quantile(known, 0.95) == pytest.approx(db.threshold, rel=1e-6)
        _, own_known, *_ = ask_both_ways(table, whole, body, own_body=True, alike=alike)
        assert np.all(own_known <= known)
    out = rejection_ceiling_report(db_path)
    for name in set(label):
        assert f"| {name}" in out
    assert "one threshold: AUC 0.500" in out  # the same distances both ways
    assert "a threshold per answer label: AUC" in out


def test_stored_library_keeps_what_the_build_needs(tmp_path):
    from dataclasses import replace as with_fields

    by_name = {m.name: m for m in load_library()}
    kick, mirror = by_name["kick_135_04"], by_name["kick_135_04_mirror"]
    short = [with_fields(m, motion=m.motion.trim(0, 60)) for m in (kick, mirror)]
    path = tmp_path / "two.fs"
    rig = virtual_rig([0.0, 90.0], [0.0], 64, 64)
    config = replace(CONFIG, n_components=2, key_axes=2)
    build_database(short, rig, path, config, workers=1, progress=False)
    with MotionDatabase.open(path) as db:
        stored = db.stored_library()
    assert [(m.name, m.label, m.performer, m.mirror_of) for m in stored] == [
        (m.name, m.label, m.performer, m.mirror_of) for m in short
    ]
    assert stored[1].mirror_of == "kick_135_04"


def test_tree_search_is_exact_on_the_real_database(db_path):
    rng = np.random.default_rng(3)
    with MotionDatabase.open(db_path) as db:
        points = db.store.arrays().points
        picks = rng.integers(0, len(points), 10_000)
        scale = points.std(axis=0) * rng.uniform(0.05, 1.0, (10_000, 1))
        queries = points[picks] + rng.normal(size=(10_000, points.shape[1])) * scale
        assert brute_force_check(db, queries, top_k=1)
        assert brute_force_check(db, queries[:500], top_k=5)
        examined = db.index.walk(queries, 1).examined
        assert examined.mean() < db.n_entries


@pytest.mark.parametrize("name", MOTIONS)
def test_unseen_body_between_views_is_recognised(db_path, library, other_body, name):
    item = next(m for m in library if m.name == name)
    masks = _masks(item.motion, other_body, azimuth_deg=30.0, elevation_deg=8.0)
    with MotionDatabase.open(db_path) as db:
        result = db.query_masks(masks, 30.0, top_k=3)
    assert result.best.label == item.label
    assert result.best.azimuth_deg in (0.0, 60.0)  # a neighbour of the true 30°
    assert [m.label for m in result.top][0] == item.label
    assert len({m.motion for m in result.top}) == len(result.top)
    assert result.labels[0] == result.best
    assert result.segments[0].start_frame == 0
    assert result.segments[-1].end_frame == len(masks)


def test_segments_claim_only_the_frames_that_show_the_person(db_path, library, other_body):
    """A clip that shows the empty scene for a second before the person comes into view
    and half a second after they leave: its parts start and end with the person."""
    item = next(m for m in library if m.name == MOTIONS[0])
    masks = _masks(item.motion, other_body, azimuth_deg=30.0, elevation_deg=8.0)
    before, after = np.zeros((30, *masks.shape[1:]), bool), np.zeros((15, *masks.shape[1:]), bool)
    with MotionDatabase.open(db_path) as db:
        result = db.query_masks(np.concatenate([before, masks, after]), 30.0, top_k=3)
    assert result.best.label == item.label
    assert result.segments[0].start_frame == 30
    assert result.segments[-1].end_frame == 30 + len(masks)


def test_a_person_standing_still_is_no_motion_and_holding_a_pose_is_no_part(
    db_path, library, other_body
):
    """Two seconds of the motion's last pose, its edges flickering as a learned
    segmenter's do: alone it is "no motion"; after the motion it is no part of it."""
    item = next(m for m in library if m.name == MOTIONS[0])
    masks = _masks(item.motion, other_body, azimuth_deg=30.0, elevation_deg=8.0)
    held = edge_flicker(np.repeat(masks[-1:], 60, axis=0), 0.01)
    with MotionDatabase.open(db_path) as db:
        with pytest.raises(VideoError, match="the person stands still"):
            db.query_masks(held, 30.0)
        result = db.query_masks(np.concatenate([masks, held]), 30.0, top_k=3)
    assert result.best.label == item.label
    assert all(s.label == item.label for s in result.segments)


def test_query_cli_answers_a_person_standing_still_as_no_motion(
    db_path, library, other_body, tmp_path, capsys
):
    """A person who stands still is an answer, not an error: no motion of the library,
    not accepted, exit 0; the 3D outputs asked for are not written (exit 1). The
    development set's harness records the same answer."""
    from eigmotion.evaluation.devset import DevClip, answer_clip
    from eigmotion.evaluation.scoring import NO_ANSWER

    item = next(m for m in library if m.name == MOTIONS[0])
    masks = _masks(item.motion, other_body, azimuth_deg=30.0, elevation_deg=8.0)
    held = edge_flicker(np.repeat(masks[-1:], 60, axis=0), 0.01)
    clip = tmp_path / "still.npz"
    np.savez(clip, masks=held, fps=30.0)
    argv = ["query", str(clip), "--db", str(db_path)]
    assert main([*argv, "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)
    with MotionDatabase.open(db_path) as db:
        threshold, entries = db.threshold, db.n_entries
        assert set(answer) == set(db.query_masks(masks, 30.0).to_json())
    assert answer["still"] and not answer["accepted"] and answer["label"] is None
    assert answer["labels"] == answer["top"] == answer["segments"] == []
    assert answer["threshold"] == round(threshold, 6) and answer["db_entries"] == entries
    assert answer["warnings"][0].startswith("no motion: the silhouettes change by ")
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "no motion  (UNKNOWN: the person stands still)"
    assert lines[1].startswith("  the silhouettes change by ") and "stands still" in lines[1]
    bvh, joints = tmp_path / "still.bvh", tmp_path / "still_joints.npz"
    assert main([*argv, "--json", "--bvh-out", str(bvh), "--pose-out", str(joints)]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out) == answer
    assert captured.err.strip() == (
        f"eigmotion query: {bvh}, {joints} not written: the person stands still, "
        "there is no motion to align"
    )
    assert not bvh.exists() and not joints.exists()
    # eval recognition answers it as the command does: no answer, not accepted
    folder = tmp_path / "dev_still"
    folder.mkdir()
    np.savez(folder / "masks.npz", masks=held)
    dev_clip = DevClip("still", "retrieval", item.label, folder, 30.0)
    with MotionDatabase.open(db_path) as db:
        recorded = answer_clip(db, dev_clip, "masks", scratch=tmp_path)
    assert recorded.label == NO_ANSWER and not recorded.accepted and recorded.error is None


def test_the_decision_benchmark_counts_a_refused_clip_as_no_answer(db_path, library, other_body):
    """bench_rerank's queries (query_variants.answer_all): a clip the query refuses as
    "no motion" is answered NO_ANSWER and not accepted; the others as the query answers."""
    from eigmotion.evaluation.query_variants import HeldOutClip, answer_all
    from eigmotion.evaluation.scoring import NO_ANSWER

    item = next(m for m in library if m.name == MOTIONS[0])
    masks = _masks(item.motion, other_body, azimuth_deg=30.0, elevation_deg=8.0)
    held = edge_flicker(np.repeat(masks[-1:], 60, axis=0), 0.01)
    clips = [
        HeldOutClip("still", item.label, (), held, 30.0),
        HeldOutClip("moving", item.label, (), masks, 30.0),
    ]
    refused, answered = answer_all(db_path, clips)
    assert refused.ranked_labels == (NO_ANSWER,) and not refused.accepted
    assert answered.ranked_labels[0] == item.label


def test_within_person_cuts_the_outer_segments_and_drops_empty_ones():
    walk, kick = Segment(0, 40, "walk", 0.2), Segment(40, 90, "kick", 0.3)
    present = np.zeros(90, bool)
    present[10:60] = True
    assert within_person([walk, kick], present) == [
        Segment(10, 40, "walk", 0.2),
        Segment(40, 60, "kick", 0.3),
    ]
    present[:] = False
    present[50:70] = True
    assert within_person([walk, kick], present) == [Segment(50, 70, "kick", 0.3)]
    assert within_person([walk, kick], np.zeros(90, bool)) == [walk, kick]


def test_motions_beyond_the_ranked_candidates_follow_by_image_distance(
    db_path, library, other_body, monkeypatch
):
    import eigmotion.retrieval.database as database_module

    masks = _masks(library[2].motion, other_body, azimuth_deg=100.0, elevation_deg=5.0)
    with MotionDatabase.open(db_path) as db:
        ranked_all = db.query_masks(masks, 30.0, top_k=4)
        one = db.query_masks(masks, 30.0, top_k=1)
        monkeypatch.setattr(database_module, "candidate_motions", lambda nearest: nearest[:2])
        ranked_two = db.query_masks(masks, 30.0, top_k=4)
    # four motions of four labels: every one is a candidate
    assert all(m.sequence_distance is not None for m in ranked_all.top)
    assert len(ranked_two.top) == 4
    assert [m.sequence_distance is None for m in ranked_two.top] == [False, False, True, True]
    # every label once, at its first motion in the ranking, whatever top_k is
    assert [m.motion for m in one.labels] == [m.motion for m in ranked_all.top]
    assert len(one.top) == 1 and one.labels[0] == one.best
    # the two ranked are the motion image's two nearest; the rest follow nearest first
    by_image = sorted(ranked_all.top, key=lambda m: m.distance)
    assert {m.motion for m in ranked_two.top[:2]} == {m.motion for m in by_image[:2]}
    assert [m.motion for m in ranked_two.top[2:]] == [m.motion for m in by_image[2:]]


def test_a_candidate_is_warped_against_its_renderings_within_reach_of_its_view(db_path):
    from eigmotion.retrieval.sequences import (
        pace_factors,
        pose_speeds,
        sequence_distances,
        view_reach,
    )

    with MotionDatabase.open(db_path) as db:
        motion_id = min(db.store.motion_ids())
        stored = db.store.sequences(motion_id)
        starts = np.concatenate([[0], np.cumsum(stored.lengths)])
        # The query: the motion's own rendering seen from 300°, within reach of 0°.
        (seen,) = np.flatnonzero(stored.azimuth_deg == 300.0)[:1]
        query = stored.frames[starts[seen] : starts[seen + 1]]
        pace = pace_factors(
            pose_speeds(query, [len(query)])[0], pose_speeds(stored.frames, stored.lengths)
        )
        found = {}
        for azimuth in (0.0, 120.0):
            match = Match("any", "any", motion_id, 0, 0.1, azimuth, 0.0, (0, 30))
            (ranked,) = db._ranked_by_sequence(query, [match])
            # Each rendering in reach on its own, in the store's order.
            expected = min(
                sequence_distances(query, stored.frames[starts[r] : starts[r + 1]], [length])[0]
                * pace[r]
                for r, length in enumerate(stored.lengths)
                if view_reach(stored.azimuth_deg[r : r + 1], azimuth)[0]
            )
            # The frame distances are taken in float32 from one matrix product per
            # call (``sequence_distances``): the query's distance to its own
            # rendering, about 1e-4, is rounding, and it changes with the grouping of
            # the sums (the renderings in reach in one product here, one by one
            # there) by up to 1e-5 on some CPUs.  Any other distance: to 1e-6.
            rounding = 1e-4 if expected < 1e-3 else 0.0
            assert ranked.sequence_distance == pytest.approx(expected, rel=1e-6, abs=rounding)
            found[azimuth] = ranked.sequence_distance
    assert found[0.0] < 1e-3 < found[120.0]  # the reach across 0° holds the query's own


def test_candidates_are_the_nearest_motions_and_the_nearest_of_each_further_label(
    monkeypatch,
):
    import eigmotion.retrieval.database as database_module

    monkeypatch.setattr(database_module, "CANDIDATE_MOTIONS", 3)
    labels = ["walk", "walk", "turn", "walk", "turn", "wave", "jump", "wave", "jump"]
    nearest = [
        Match(label, f"m{i}", i, 10 * i, 0.1 * (i + 1), 0.0, 0.0, (0, 30))
        for i, label in enumerate(labels)
    ]
    assert [m.motion_id for m in candidate_motions(nearest)] == [0, 1, 2, 5, 6]
    assert [m.motion_id for m in candidate_motions(nearest[:2])] == [0, 1]
    assert candidate_motions([]) == []


#: Five windows' four nearest entries: walking, one window nearest a punch (a walk's
#: stride matched poorly), walking again.
WINDOW_LABELS = [
    ["walk", "turn", "walk", "walk"],
    ["walk", "walk", "jump", "turn"],
    ["punch", "jump", "walk", "punch"],
    ["walk", "jump", "walk", "turn"],
    ["walk", "walk", "walk", "jump"],
]
WINDOW_DISTANCES = np.array(
    [[0.20, 0.22, 0.23, 0.24], [0.21, 0.22, 0.25, 0.26], [0.30, 0.31, 0.33, 0.34],
     [0.22, 0.23, 0.24, 0.25], [0.20, 0.21, 0.22, 0.23]]
)  # fmt: skip


def test_a_lone_window_of_another_action_is_smoothed_into_its_neighbours():
    labels, costs = window_label_path(WINDOW_LABELS, WINDOW_DISTANCES, 0.05)
    assert labels == ["walk"] * 5
    # The punch window's distance from walk is its nearest walking entry's.
    np.testing.assert_allclose(costs, [0.20, 0.21, 0.33, 0.22, 0.20])
    # At no cost every window keeps its nearest entry's label ...
    labels, costs = window_label_path(WINDOW_LABELS, WINDOW_DISTANCES, 0.0)
    assert labels == ["walk", "walk", "punch", "walk", "walk"]
    np.testing.assert_allclose(costs, WINDOW_DISTANCES[:, 0])
    # ... and the punch stays while two switches cost less than its lead over walk there
    # (0.33 − 0.30).
    assert window_label_path(WINDOW_LABELS, WINDOW_DISTANCES, 0.014)[0][2] == "punch"
    assert window_label_path(WINDOW_LABELS, WINDOW_DISTANCES, 0.016)[0][2] == "walk"


def test_an_action_over_several_windows_stays_and_a_runner_up_everywhere_does_not_win():
    labels = [["walk", "jump"]] * 2 + [["wave", "jump"]] * 3
    distances = np.array([[0.20, 0.30]] * 5)
    walk_then_wave = ["walk", "walk", "wave", "wave", "wave"]
    assert window_label_path(labels, distances, 0.05)[0] == walk_then_wave
    # Two windows' lead of 0.1 each is worth one switch up to 0.2.
    assert window_label_path(labels, distances, 0.21)[0] == ["wave"] * 5
    # Jump, second in every window, is no window's nearest: it is not a choice, and
    # a label missing from a window's entries counts as far as its farthest entry.
    labels = [["walk", "jump"], ["punch", "jump"], ["kick", "jump"], ["walk", "jump"]]
    distances = np.array([[0.25, 0.26], [0.29, 0.29], [0.32, 0.32], [0.39, 0.39]])
    path, costs = window_label_path(labels, distances, 0.05)
    assert path == ["walk"] * 4
    np.testing.assert_allclose(costs, [0.25, 0.29, 0.32, 0.39])
    with pytest.raises(InvalidParameterError, match="distances must be"):
        window_label_path(labels, distances[:3], 0.05)


def test_a_walking_window_filled_by_one_specific_motion_does_not_override_walk():
    """Three walking windows whose WINDOW_CANDIDATES nearest entries are all one
    walked-up pick-up's (its bodies and views) do not make a walk a pick-up while a
    walking entry lies among the FILLER_CANDIDATES nearest, less than 1/0.7 as far;
    farther, or absent, they do."""
    from eigmotion.retrieval.neighbours import NearestEntries

    assert FILLER_CANDIDATES > WINDOW_CANDIDATES
    k = FILLER_CANDIDATES
    labels = {0: "pick_up", 1: "walk", 2: "sit_down"}
    ids = np.zeros((3, k), dtype=np.int64)  # every window: pick-up entries first ...
    ids[:, WINDOW_CANDIDATES] = 1  # ... and a walking entry just past the eighth
    ids[:, WINDOW_CANDIDATES + 1 :] = 2
    distances = np.tile(np.linspace(0.28, 0.36, k), (3, 1))

    def windowed(walk_distance: float) -> NearestEntries:
        found = distances.copy()
        found[:, WINDOW_CANDIDATES] = walk_distance
        order = np.argsort(found, axis=1, kind="stable")
        return NearestEntries(
            np.take_along_axis(ids, order, 1), np.take_along_axis(found, order, 1),
            np.full(3, 100),
        )  # fmt: skip

    assert specific_window_entry("walk", windowed(0.33), labels.get, 0.5) is None
    assert specific_window_entry("walk", windowed(0.45), labels.get, 0.5) == (0.28, 0)
    # Not for a specific answer, nor beyond the threshold.
    assert specific_window_entry("sit_down", windowed(0.45), labels.get, 0.5) is None
    assert specific_window_entry("walk", windowed(0.45), labels.get, 0.2) is None
    # Fewer than MIN_SPECIFIC_WINDOWS windows: one window is not enough.
    one = windowed(0.45)
    one = NearestEntries(one.ids[:1], one.distances[:1], one.examined[:1])
    assert specific_window_entry("walk", one, labels.get, 0.5) is None


def test_windows_of_one_action_throughout_carry_the_clips_answer(db_path, library, other_body):
    """One label along every window makes one segment, and its label is the clip's
    answer, whichever label the windows agreed on; several keep their own."""
    from eigmotion.retrieval.motion_image import ClipMotionImages

    by_name = {m.name: m for m in library}
    waving = _masks(by_name["wave_14_24"].motion, other_body, 30.0, 8.0)
    walk = by_name["walk_02_01"].motion
    walking = _masks(walk.trim(0, int(round(2.0 / walk.frame_time_s))), other_body, 30.0, 8.0)
    with MotionDatabase.open(db_path) as db:
        cfg = db.config
        for masks, n_labels in ((waving, 1), (np.concatenate([walking, waving, walking]), 2)):
            images = ClipMotionImages(masks, cfg.motion_image, clip_fps=30.0)
            windows = window_bounds(len(masks), 30.0, cfg.window_s, cfg.window_step_s)
            kept, windowed = search_windows(images, windows[1:], db.eigenspace, db.index)
            # Enough entries per window for the filler rule, the first eight for labels.
            assert windowed.ids.shape[1] == min(FILLER_CANDIDATES, db.n_entries)
            answer = dataclasses.replace(
                db.query_masks(masks, 30.0).best, label="elsewhere", distance=0.5
            )
            segments = clip_segments(kept, windowed, len(masks), answer, db._label_of, db.threshold)
            assert len({s.label for s in segments}) == n_labels
            if n_labels == 1:
                assert segments == [Segment(kept[0][0], kept[-1][1], "elsewhere", 0.5)]
            else:
                assert "elsewhere" not in {s.label for s in segments}


def test_pose_speeds_are_stored_as_a_query_measures_them(db_path, library, other_body, tmp_path):
    """Each rendering's stored pose speed is its own frames' :func:`pose_speeds` to the
    bit; a database whose records lack them (written before they were stored) has them
    measured by its first query, which answers the same to the bit, and kept."""
    import ZODB
    from ZODB.FileStorage import FileStorage

    by_name = {m.name: m for m in library}
    masks = _masks(by_name["wave_14_24"].motion, other_body, 30.0, 8.0)
    with MotionDatabase.open(db_path) as db:
        stored_answer = db.query_masks(masks, 30.0)
        for mid in db.store.motion_ids():
            stored = db.store.sequences(int(mid))
            assert stored.speeds is not None and stored.speeds.shape == stored.lengths.shape
            firsts = np.cumsum(stored.lengths) - stored.lengths
            for r, (first, length) in enumerate(zip(firsts, stored.lengths, strict=True)):
                own = stored.frames[first : first + length]
                assert pose_speeds(own, stored.lengths[r : r + 1])[0] == stored.speeds[r]
    old = tmp_path / "old.fs"
    old.write_bytes(Path(db_path).read_bytes())
    zodb = ZODB.DB(FileStorage(str(old)))
    with zodb.transaction() as conn:
        for record in conn.root()["sequences"].values():
            del record["speeds"]
    zodb.close()
    with MotionDatabase.open(old) as db:
        assert db.store.sequences(0).speeds is None
        first = db.query_masks(masks, 30.0)
        kept = {mid: found[3].copy() for mid, found in db._sequences.items()}
        assert sum(np.isfinite(speeds).sum() for speeds in kept.values()) > 0
        second = db.query_masks(masks, 30.0)
    for answer in (first, second):
        assert [(m.motion_id, m.distance, m.sequence_distance) for m in answer.top] == [
            (m.motion_id, m.distance, m.sequence_distance) for m in stored_answer.top
        ]


def test_walking_into_an_action_is_that_action(db_path, library, other_body):
    by_name = {m.name: m for m in library}
    walk = by_name["walk_02_01"].motion
    walk = walk.trim(0, int(round(2.0 / walk.frame_time_s)))
    walking = _masks(walk, other_body, azimuth_deg=30.0, elevation_deg=8.0)
    waving = _masks(by_name["wave_14_24"].motion, other_body, 30.0, 8.0)
    with MotionDatabase.open(db_path) as db:
        alone = db.query_masks(walking, 30.0)
        clip = db.query_masks(np.concatenate([walking, waving, walking]), 30.0)
    assert alone.best.label == "walk"
    assert clip.best.label == "wave" and clip.top[0] == clip.best
    # Walk, wave, walk in order; a window straddling two actions may match a third
    # motion, but only for a transition: no longer than one window step (0.5 s).
    segments = clip.segments
    wave_start, wave_end = len(walking), len(walking) + len(waving)
    assert segments[0].label == segments[-1].label == "walk"
    assert segments[0].end_frame >= wave_start - 15 and segments[-1].start_frame <= wave_end + 15
    (wave,) = [s for s in segments if s.label == "wave"]
    assert wave.start_frame <= wave_start + 15 and wave.end_frame >= wave_end - 15
    for seg in segments[1:-1]:
        assert seg is wave or seg.end_frame - seg.start_frame <= 15, seg


def test_a_3d_answer_asked_for_leaves_the_answer_as_it_is(db_path):
    """Every frame is cut out for a 3D answer, but the answer comes from the sampled
    frames alone: subtracted without a background image, the scene is estimated from
    the frames cut, so the two sets of silhouettes differ."""
    kick = REPO / "database" / "samples" / "kick.mp4"
    with MotionDatabase.open(db_path) as db:
        sampled, clip = db.query_clip(kick, segmenter="subtraction")
        every, whole = db.query_clip(kick, every_frame=True, segmenter="subtraction")
    assert clip.fps == db.config.motion_image.sample_fps and whole.fps == whole.clip_fps
    assert len(clip.masks) < len(whole.masks) == whole.n_frames == clip.n_frames
    assert (whole.masks[clip.frame_indices] != clip.masks).any()
    # The same silhouettes: the same image and distances, to the last bit.
    np.testing.assert_array_equal(sampled.motion_image, every.motion_image)
    assert [m.entry_id for m in sampled.top] == [m.entry_id for m in every.top]
    for a, b in zip(sampled.top, every.top, strict=True):
        assert (a.distance, a.sequence_distance) == (b.distance, b.sequence_distance)
    assert sampled.accepted == every.accepted
    assert [(s.start_frame, s.end_frame, s.label) for s in sampled.segments] == [
        (s.start_frame, s.end_frame, s.label) for s in every.segments
    ]
    assert "every_frame_silhouettes" in every.timing_ms
    assert "every_frame_silhouettes" not in sampled.timing_ms
    assert sampled.segments[0].start_frame == 0
    assert sampled.segments[-1].end_frame == clip.n_frames
    for before, after in zip(sampled.segments, sampled.segments[1:], strict=False):
        assert before.end_frame == after.start_frame


def test_query_cli_text_lists_the_likeliest_actions_and_motions(
    db_path, library, other_body, tmp_path, capsys
):
    item = library[1]  # kick
    masks = _masks(item.motion, other_body, azimuth_deg=90.0, elevation_deg=5.0)
    clip = tmp_path / "clip.npz"
    np.savez(clip, masks=masks, fps=30.0)
    assert main(["query", str(clip), "--db", str(db_path), "--top", "3", "--json"]) == 0
    answer = json.loads(capsys.readouterr().out)
    assert main(["query", str(clip), "--db", str(db_path), "--top", "3"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{answer['label']}  ({answer['motion']}, distance ")
    assert lines[1] == (
        f"  at least as close to the library as {answer['p_known']:.0%} of new performances "
        f"of known motions (p_known {answer['p_known']:.2f}; unknown beyond distance "
        f"{answer['threshold']:.3f})"
    )
    assert lines[2].startswith("  motions ranked by a combined score: the motion-image ")
    assert "× the silhouette-sequence distance" in lines[2]
    actions = [m["label"] for m in answer["labels"][:3]]
    assert lines[3] == "  actions, likeliest first: " + ", ".join(actions)
    # Segments with both ends included: the last ends on the clip's last frame.
    spans = [line for line in lines if line.startswith(("  frames ", "  frame "))]
    assert len(spans) == len(answer["segments"]) > 0
    last = answer["segments"][-1]
    assert spans[-1] == f"  frames {last['start_frame']}–{last['end_frame'] - 1}: {last['label']}"
    assert last["end_frame"] == len(masks)
    then = [line for line in lines if line.startswith("  then ")]
    assert [line.split()[1] for line in then] == [m["label"] for m in answer["top"][1:]]
    assert [line.split("(")[1].split(",")[0] for line in then] == [
        m["motion"] for m in answer["top"][1:]
    ]
    # a stricter share than a clip's p_known calls it unknown
    farther = tmp_path / "farther.npz"
    masks = _masks(item.motion, other_body, azimuth_deg=150.0, elevation_deg=5.0)
    np.savez(farther, masks=masks, fps=30.0)
    assert main(["query", str(farther), "--db", str(db_path), "--json"]) == 0
    usual = json.loads(capsys.readouterr().out)
    assert usual["accepted"] and usual["p_known"] < 0.97
    share = round(usual["p_known"] + 0.02, 4)
    argv = ["query", str(farther), "--db", str(db_path), "--false-rejection", str(share)]
    assert main([*argv, "--json"]) == 0
    stricter = json.loads(capsys.readouterr().out)
    assert not stricter["accepted"] and stricter["p_known"] == usual["p_known"]
    assert stricter["threshold"] < usual["threshold"] and stricter["label"] == usual["label"]
    assert main(argv) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.endswith("(UNKNOWN: farther than the threshold)")
    for bad in ("1.5", "0", "nan"):
        assert main(["query", str(clip), "--db", str(db_path), "--false-rejection", bad]) == 2
        captured = capsys.readouterr()
        assert "false rejection must be between 0 and 1" in captured.err
        assert "Traceback" not in captured.err and not captured.out


def test_query_cli_json_bvh_and_replay(db_path, library, other_body, tmp_path, capsys):
    item = library[1]  # kick
    masks = _masks(item.motion, other_body, azimuth_deg=90.0, elevation_deg=5.0)
    clip = tmp_path / "clip.npz"
    np.savez(clip, masks=masks, fps=30.0)
    bvh, video = tmp_path / "out.bvh", tmp_path / "out.mp4"
    code = main(
        [
            "query",
            str(clip),
            "--db",
            str(db_path),
            "--json",
            "--top",
            "2",
            "--bvh-out",
            str(bvh),
            "--replay-out",
            str(video),
        ]
    )
    assert code == 0
    answer = json.loads(capsys.readouterr().out)
    for key in (
        "label",
        "motion",
        "distance",
        "accepted",
        "view",
        "top",
        "labels",
        "threshold",
        "p_known",
        "segments",
        "examined",
        "db_entries",
        "timing_ms",
        "travel_speed",
        "heading_change_deg",
        "foot_raise",
        "hands_raised",
    ):
        assert key in answer
    assert answer["label"] == "kick" and len(answer["top"]) == 2
    assert answer["labels"][0] == {k: answer[k] for k in answer["labels"][0]}
    assert len({m["label"] for m in answer["labels"]}) == len(answer["labels"])
    assert answer["threshold"] > 0
    # the answer's own entry within the threshold: accepted (the clip's nearest is nearer)
    assert answer["accepted"] or answer["distance"] > answer["threshold"]
    assert answer["sequence_distance"] > 0 and "sequences" in answer["timing_ms"]
    assert set(answer["view"]) == {"azimuth_deg", "elevation_deg"}
    replayed = read_bvh(bvh)
    assert replayed.n_frames == len(masks)
    height = np.ptp(forward_kinematics(replayed).all_points()[0][:, 1])
    assert 1.4 < height < 2.0
    from eigmotion.imaging.media import read_frames

    frames, _ = read_frames(video)
    assert len(frames) == len(masks)


def test_index_makes_a_motion_queryable_at_once(db_path, tmp_path, other_body):
    work = tmp_path / "copy.fs"
    work.write_bytes(db_path.read_bytes())
    # A label the database does not hold.  (A run, projected into an eigenspace fitted
    # without runs, can lie as near the walk as its own entries: that is what --refit
    # and the report's badly_represented flag are for.)
    jump = next(m for m in load_library() if m.name == "jump_02_04")
    masks = _masks(jump.motion, other_body, azimuth_deg=150.0, elevation_deg=5.0)
    with MotionDatabase.open(work) as db:
        before = db.query_masks(masks, 30.0)
        n_before = db.n_entries
    assert before.best.label != "jump"
    with MotionDatabase.open(work, read_only=False) as db:
        report = db.index_motion(replace(jump, name="new_jump"), progress=False)
        assert db.n_entries == n_before + report.n_entries
        assert len(db.store.sequences(report.motion_id).lengths) == len(db.rig)
        after = db.query_masks(masks, 30.0)
    assert after.best.label == "jump"
    with MotionDatabase.open(work) as db:  # and it is on disk
        assert db.query_masks(masks, 30.0).best.motion == "new_jump"


def _eigmotion(*args, **kwargs):
    return subprocess.Popen(
        [sys.executable, "-m", "eigmotion", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYOPENGL_PLATFORM": "egl"},
        **kwargs,
    )


def _processes_mentioning(text: str) -> list[int]:
    """Pids whose command line holds ``text`` (forked workers inherit it)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/cmdline", "rb") as f:
                    if text.encode() in f.read():
                        found.append(int(entry))
            except OSError:
                continue
    return found


def _wait_until_no_process_mentions(text: str, timeout_s: float = 10.0) -> None:
    """The killed command's rendering workers must not outlive it."""
    deadline = time.monotonic() + timeout_s
    while _processes_mentioning(text) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not _processes_mentioning(text), "worker processes outlived a killed command"


def test_sigkill_during_index_keeps_the_database(db_path, tmp_path, other_body, library):
    work = tmp_path / "killed.fs"
    work.write_bytes(db_path.read_bytes())
    masks = _masks(library[2].motion, other_body, azimuth_deg=200.0, elevation_deg=5.0)
    with MotionDatabase.open(work) as db:
        expected = db.query_masks(masks, 30.0)
        n_entries = db.n_entries
    bvh = tmp_path / "jump.bvh"
    assert (
        main(
            [
                "convert",
                str(REPO / "database/motions/cmu/amc/16_01.amc"),
                "--asf",
                str(REPO / "database/motions/cmu/asf/16.asf"),
                str(bvh),
                "--stop",
                "200",
            ]
        )
        == 0
    )
    for delay_s in (1.0, 3.0, 6.0):
        proc = _eigmotion("index", str(bvh), "--label", "jump", "--db", str(work), "--quiet")
        time.sleep(delay_s)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        _wait_until_no_process_mentions(str(work))
        with MotionDatabase.open(work) as db:
            assert db.n_entries in (n_entries, db.store.n_entries)
            db.store.check()
            again = db.query_masks(masks, 30.0)
            if db.n_entries == n_entries:
                assert again.best == expected.best
            else:  # the index had committed before the kill: complete, never partial
                assert db.store.n_motions == len(library) + 1
                break


def test_queries_run_while_an_index_commits(db_path, tmp_path, other_body, library):
    work = tmp_path / "busy.fs"
    work.write_bytes(db_path.read_bytes())
    clip = tmp_path / "clip.npz"
    np.savez(clip, masks=_masks(library[0].motion, other_body, 10.0, 5.0), fps=30.0)
    bvh = tmp_path / "punch.bvh"
    assert (
        main(
            [
                "convert",
                str(REPO / "database/motions/cmu/amc/02_05.amc"),
                "--asf",
                str(REPO / "database/motions/cmu/asf/02.asf"),
                str(bvh),
                "--stop",
                "240",
            ]
        )
        == 0
    )
    indexer = _eigmotion("index", str(bvh), "--label", "punch", "--db", str(work), "--quiet")
    answers = []
    while indexer.poll() is None:
        readers = [_eigmotion("query", str(clip), "--db", str(work), "--json") for _ in range(2)]
        for r in readers:
            out, err = r.communicate(timeout=120)
            assert r.returncode == 0, err
            answers.append(json.loads(out)["label"])
    assert indexer.returncode == 0, indexer.stderr.read()
    assert answers and set(answers) == {"walk"}
    with MotionDatabase.open(work) as db:
        assert "punch" in {db.motion_record(m)["label"] for m in db.store.motion_ids()}


@pytest.mark.parametrize(
    "argv, message",
    [
        (["query", "missing.mp4", "--db", "{db}"], "missing.mp4"),
        # FFmpeg and OpenCV say nothing of their own about a video they cannot read.
        (["query", "{tmp}/empty.mp4", "--db", "{db}"], "empty.mp4"),
        (["query", "{tmp}/cut.mp4", "--db", "{db}"], "cut.mp4"),
        (["query", "{clip}", "--db", "{tmp}/nothing.fs"], "nothing.fs"),
        (["query", "{clip}", "--db", "{db}", "--top", "0"], "--top"),
        (["index", "{tmp}/none.bvh", "--label", "x", "--db", "{db}"], "none.bvh"),
        (["build", "--rig", "{tmp}/none.toml", "--db", "{tmp}/x.fs"], "none.toml"),
        (["build", "--girth", "1", "--girth", "2", "--db", "{tmp}/x.fs"], "girth"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(db_path, tmp_path, argv, message):
    clip = tmp_path / "clip.npz"
    np.savez(clip, masks=np.zeros((10, 32, 32), bool), fps=30.0)
    (tmp_path / "empty.mp4").write_bytes(b"")
    video = (REPO / "database" / "samples" / "kick.mp4").read_bytes()
    (tmp_path / "cut.mp4").write_bytes(video[: len(video) // 2])  # the index is at the end
    argv = [a.format(db=db_path, tmp=tmp_path, clip=clip) for a in argv]
    proc = _eigmotion(*argv)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and message.split("/")[-1] in lines[0], err
    assert "Traceback" not in err


@pytest.mark.slow
def test_build_with_girths_renders_every_girth_in_every_outfit(tmp_path):
    motions = REPO / "database" / "motions"
    manifest = tmp_path / "library.toml"
    manifest.write_text(
        "".join(
            f"""
[[motion]]
name = "{name}"
label = "{label}"
source = ["{motions}/cmu/amc/16_35.amc", "{motions}/cmu/asf/16.asf"]
frame_range = [{start}, {start + 80}]
performer = "cmu_16"
variation = "v"
licence = "l"
attribution = "a"
"""
            for name, label, start in (("x", "run", 0), ("y", "walk", 80))
        )
    )
    db = tmp_path / "girths.fs"
    rig = REPO / "virtual_cameras" / "ring6.toml"
    argv = ["build", "--motions", manifest, "--rig", rig, "--db", db, "--components", "8"]
    proc = _eigmotion(*map(str, argv), "--girth", "0.85", "--girth", "1.25")
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    # Each step after the rendering says so; the summary counts the renderings.
    stages = [line.split(" … ")[0] for line in err.splitlines() if line.startswith("build: ")]
    assert stages[-1].endswith("entries and 2 motions")
    assert [" ".join(line.split()[1:3]) for line in stages] == [
        "fitting the",
        "cutting the",
        "calibrating the",
        "storing " + stages[-1].split()[2],
    ]
    outfits = len(BuildConfig().garments)
    bodies = 2 * outfits
    assert f"2 motions × 6 views × {bodies} bodies = {12 * bodies} renderings → " in err
    with MotionDatabase.open(db) as built:
        assert built.config.body_shapes == ((None, 0.85), (None, 1.25))
        for motion_id in np.unique(built.store.arrays().motions):
            renderings = built.store.sequences(int(motion_id)).lengths
            assert len(renderings) == 6 * 2 * outfits  # views × girths × outfits


def test_a_person_who_never_moves_is_answered_by_the_command(db_path, tmp_path):
    """A new process, as a user runs it: the answer "no motion", exit 0, nothing on
    stderr."""
    clip = tmp_path / "still.npz"
    masks = np.zeros((20, 48, 48), bool)
    masks[:, 10:40, 20:30] = True  # a person who never moves
    np.savez(clip, masks=masks, fps=30.0)
    proc = _eigmotion("query", str(clip), "--db", str(db_path))
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0 and not err
    assert out.splitlines()[0] == "no motion  (UNKNOWN: the person stands still)"


def test_missing_database_is_not_created(tmp_path):
    with pytest.raises(DatabaseError, match="no such database"):
        MotionDatabase.open(tmp_path / "absent.fs")
    assert not (tmp_path / "absent.fs").exists()


def test_bruteforce_reference_agrees_with_itself(db_path):
    with MotionDatabase.open(db_path) as db:
        arrays = db.store.arrays()
        res = BruteForceIndex.from_arrays(arrays.points, arrays.ids).search(arrays.points[:5], 1)
        np.testing.assert_array_equal(res.ids[:, 0], arrays.ids[:5])


def test_a_build_is_the_same_to_the_last_bit_on_one_process_or_two(tmp_path, library):
    """The same motions, rig and configuration give the same database, whichever
    processes rendered it."""
    rig = virtual_rig([0.0, 120.0, 240.0], [0.0], 64, 64)
    config = replace(CONFIG, n_components=4, key_axes=2)
    for workers in (1, 2):
        build_database(
            library[:2], rig, tmp_path / f"{workers}.fs", config, workers=workers, progress=False
        )
    with (
        MotionDatabase.open(tmp_path / "1.fs") as one,
        MotionDatabase.open(tmp_path / "2.fs") as two,
    ):
        a, b = one.store.arrays(), two.store.arrays()
        for name in ("points", "ids", "motions"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert one.threshold == two.threshold


def test_a_build_from_given_images_equals_a_build_that_renders(tmp_path, library):
    """build_database(views=...) stores what a rendering build stores, from the images a
    render made once (how the benchmarks build many fold databases from one render)."""
    from eigmotion.retrieval.library_views import render_views

    rig = virtual_rig([0.0, 120.0, 240.0], [0.0], 64, 64)
    config = replace(CONFIG, n_components=4, key_axes=2)
    two = library[:2]
    build_database(two, rig, tmp_path / "rendered.fs", config, workers=1, progress=False)
    images = list(render_views(library, rig, config, workers=1, progress=False))
    first_two = [v for v in images if v.motion_index < 2]
    wave_only = [replace(v, motion_index=0) for v in images if v.motion_index == 2]
    build_database(two, rig, tmp_path / "given.fs", config, progress=False, views=first_two)
    build_database(library[2:3], rig, tmp_path / "one.fs", config, progress=False, views=wave_only)
    with (
        MotionDatabase.open(tmp_path / "rendered.fs") as rendered,
        MotionDatabase.open(tmp_path / "given.fs") as given,
        MotionDatabase.open(tmp_path / "one.fs") as one,
    ):
        a, b = rendered.store.arrays(), given.store.arrays()
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.motions, b.motions)
        assert rendered.threshold == given.threshold
        assert one.store.n_motions == 1
        assert one.motion_record(0)["label"] == "wave"
        assert one.n_entries == sum(len(v.vectors) for v in wave_only) > 3


def test_motion_records_are_read_when_first_needed(db_path):
    with MotionDatabase.open(db_path) as db:
        assert not db._motions  # the open reads none
        records = db.motion_records()
        assert list(records) == db.store.motion_ids().tolist()
        assert [r["metadata"]["name"] for r in records.values()] == list(MOTIONS)
        assert db.motion_record(1) is records[1]


def test_list_cli_names_the_stored_motions(db_path, library, tmp_path, capsys):
    assert main(["list", "--db", str(db_path), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    motions = listed["motions"]
    assert [m["name"] for m in motions] == list(MOTIONS)
    assert [m["label"] for m in motions] == [item.label for item in library]
    assert [m["performer"] for m in motions] == [item.performer for item in library]
    assert {m["role"] for m in motions} == {"basic"}
    with MotionDatabase.open(db_path) as db:
        assert sum(m["entries"] for m in motions) == listed["n_entries"] == db.n_entries
    assert all(m["entries"] > 0 for m in motions)
    assert main(["list", "--db", str(db_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"{db_path}: 4 motions, 4 labels, {listed['n_entries']:,} entries"
    assert lines[1].split() == ["name", "label", "performer", "role", "entries", "source"]
    assert lines[3].split()[:5] == ["kick_135_04", "kick", motions[1]["performer"], "basic",
                                    str(motions[1]["entries"])]  # fmt: skip
    # A missing database: one line, exit 2.
    assert main(["list", "--db", str(tmp_path / "none.fs")]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines() == [
        f"eigmotion list: error: {tmp_path / 'none.fs'}: no such database file"
    ]
    assert not captured.out
    # The library's motions, without a database.
    assert main(["list", "--library", "--json"]) == 0
    offered = json.loads(capsys.readouterr().out)["motions"]
    names = {m["name"] for m in offered}
    assert set(MOTIONS) <= names and {m["role"] for m in offered} == {"basic", "distractor"}


def test_the_command_ends_at_once_with_its_whole_answer_and_its_status(
    db_path, tmp_path, library, other_body
):
    from eigmotion.cli.main import QUICK_EXIT

    assert "query" in QUICK_EXIT
    masks = _masks(library[2].motion, other_body, azimuth_deg=200.0, elevation_deg=5.0)
    clip = tmp_path / "clip.npz"
    np.savez(clip, masks=masks, fps=30.0)
    environ = dict(os.environ, PYTHONPATH=str(REPO))
    command = [sys.executable, "-m", "eigmotion", "query", str(clip), "--db", str(db_path)]
    done = subprocess.run([*command, "--json"], capture_output=True, text=True, env=environ)
    assert done.returncode == 0, done.stderr
    answer = json.loads(done.stdout)  # the whole answer, flushed before the exit
    assert answer["label"] and answer["db_entries"] > 0
    # bad input: one line and status 2, as ever
    done = subprocess.run(
        [*command[:4], str(tmp_path / "none.npz"), *command[5:]],
        capture_output=True, text=True, env=environ,
    )  # fmt: skip
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    # a reader that goes away early: no traceback from the flush at the exit
    with subprocess.Popen(
        [*command, "--top", "3"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=environ
    ) as proc:
        proc.stdout.close()
        assert "Traceback" not in proc.stderr.read().decode()
