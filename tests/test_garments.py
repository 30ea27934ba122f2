"""Garments: closed meshes that follow the body, a skirt that hangs as one tube,
wider silhouettes, dressed avatars everywhere an avatar goes, and the build config."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from mesh_helpers import winding_numbers
from scipy.spatial import cKDTree

from eigmotion.body.avatar import Avatar, load_default_avatar
from eigmotion.body.garments import (
    BENCHMARK_GARMENTS,
    DATABASE_GARMENTS,
    GARMENTS,
    DressedAvatar,
    Garment,
    dress,
    garment_mesh,
)
from eigmotion.body.retarget import animate_avatar
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import virtual_rig
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.library import find_motion
from eigmotion.retrieval.library_views import BuildConfig, build_body, hull_points, render_views


@pytest.fixture(scope="module")
def avatar() -> Avatar:
    return load_default_avatar()


@pytest.fixture(scope="module")
def low_poly(avatar) -> Avatar:
    return avatar.decimated(4000)


@pytest.fixture(scope="module")
def clips(avatar):
    """A walk and a kick from the library, retargeted onto the plain body."""
    out = {}
    for name in ("walk_02_01", "kick_135_04"):
        anim, vertices = animate_avatar(avatar, find_motion(name))
        out[name] = (anim, vertices)
    return out


def _edges(faces: np.ndarray) -> np.ndarray:
    return np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]]), 1), axis=0)


def _skinned(avatar: Avatar, vertices, faces, weights, anim) -> np.ndarray:
    """Vertices (F, V, 3) of a mesh with these skin weights on the avatar's skeleton."""
    mesh = Avatar(
        vertices,
        faces,
        avatar.joint_names,
        avatar.parents,
        avatar.joint_positions,
        avatar.bone_tails,
        weights,
        "probe",
    )
    return mesh.skin(anim.joint_rotations, anim.joint_positions)


def _stretch(rest: np.ndarray, posed: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(F,) largest ratio of posed to rest edge length per frame."""
    length = np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=-1)
    posed_length = np.linalg.norm(posed[:, edges[:, 0]] - posed[:, edges[:, 1]], axis=-1)
    return (posed_length / length).max(axis=1)


# -- the garments ------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(GARMENTS))
def test_garment_is_a_closed_outward_mesh_around_the_body(avatar, low_poly, name):
    mesh = garment_mesh(avatar, name)
    edges = np.sort(np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]]]), 1)
    edges = np.concatenate([edges, np.sort(mesh.faces[:, [2, 0]], 1)])
    counts = np.unique(edges, axis=0, return_counts=True)[1]
    assert np.all(counts == 2)  # watertight
    a, b, c = (mesh.vertices[mesh.faces[:, k]].astype(np.float64) for k in range(3))
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() > 0  # faces outward
    assert mesh.n_faces <= 1500  # kept whole in the low-poly avatar
    np.testing.assert_allclose(mesh.weights.sum(axis=1), 1.0, atol=1e-5)
    # Around the body: near the skin and outside it, but where two tubes of one
    # garment overlap inside a joint (a sleeve's top in the shoulder, a trouser
    # leg's top in the seat).
    distance, _ = cKDTree(avatar.vertices).query(mesh.vertices)
    assert 0.015 < np.median(distance) < 0.08 and distance.max() < 0.35
    inside = winding_numbers(mesh.vertices, low_poly.vertices, low_poly.faces) > 0.5
    assert inside.mean() < 0.05


def test_benchmark_and_database_garments_are_apart():
    assert set(BENCHMARK_GARMENTS) == {"skirt", "long_coat", "loose_trousers"}
    assert len(DATABASE_GARMENTS) >= 3 and not set(DATABASE_GARMENTS) & set(BENCHMARK_GARMENTS)
    assert all(GARMENTS[n].held_out for n in BENCHMARK_GARMENTS)


def test_length_and_looseness_shape_the_skirt(avatar):
    base = GARMENTS["skirt"]
    short = garment_mesh(avatar, Garment("s", "skirt", 0.2, base.looseness_m))
    long = garment_mesh(avatar, Garment("l", "skirt", 0.9, base.looseness_m))
    assert long.vertices[:, 1].min() < short.vertices[:, 1].min() - 0.4
    tight = garment_mesh(avatar, Garment("t", "skirt", base.length, 0.0))
    loose = garment_mesh(avatar, Garment("w", "skirt", base.length, 0.2))
    hem = [m.vertices[m.vertices[:, 1] < m.vertices[:, 1].min() + 1e-4] for m in (tight, loose)]
    widths = [np.ptp(h[:, 0]) for h in hem]
    assert widths[1] > widths[0] + 0.3  # 0.2 m more flare on each side


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"kind": "cape"}, "kind"),
        ({"length": 1.5}, "length"),
        ({"looseness_m": -0.1}, "looseness_m"),
        ({"sleeves": 0.5}, "only a coat"),
        ({"rgb": (1.0, 2.0, 0.0)}, "rgb"),
    ],
)
def test_bad_garment_patterns_raise(kwargs, match):
    spec = {"name": "x", "kind": "skirt", "length": 0.5, "looseness_m": 0.1} | kwargs
    with pytest.raises(InvalidParameterError, match=match):
        Garment(**spec)


def test_unknown_garment_names_list_the_known_ones(avatar):
    with pytest.raises(InvalidParameterError, match="unknown garment 'kilt'.*long_coat"):
        dress(avatar, ["kilt"])
    with pytest.raises(InvalidParameterError, match="more than once"):
        dress(avatar, ["skirt", "skirt"])


# -- following the body --------------------------------------------------------------------
@pytest.mark.parametrize("name", list(GARMENTS))
def test_garment_follows_the_body_over_a_walk_and_a_kick(avatar, clips, name):
    mesh = garment_mesh(avatar, name)
    rest_gap, nearest = cKDTree(avatar.vertices).query(mesh.vertices)
    above_hips = mesh.vertices[:, 1] > avatar.joint_positions[avatar.joint_index("LeftUpLeg"), 1]
    edges = _edges(mesh.faces)
    for anim, body in clips.values():
        posed = _skinned(avatar, mesh.vertices, mesh.faces, mesh.weights, anim)
        by_nearest = _skinned(avatar, mesh.vertices, mesh.faces, avatar.weights[nearest], anim)
        # Above the hips, where the garment lies on the body, it goes where the skin
        # under it goes.  Coats take no weights from the arms at their sides (their
        # nearest skin there is an arm's), so they move a few cm more on their own.
        deviation = np.linalg.norm(posed - by_nearest, axis=-1)[:, above_hips]
        limit = 0.07 if GARMENTS[name].kind == "coat" else 0.025
        assert np.percentile(deviation, 95) < limit
        # No vertex flies away: it stays as near the skin as at rest, give or take a
        # swing of 12 cm, on every frame; no edge is stretched threefold.
        for f in range(0, len(posed), 4):
            gap, _ = cKDTree(body[f]).query(posed[f])
            assert np.all(gap < rest_gap + 0.12), f
        assert _stretch(mesh.vertices, posed, edges).max() < 3.5


def test_skirt_hangs_as_one_tube_between_the_legs(avatar, clips):
    anim, _ = clips["walk_02_01"]
    knees = anim.joint_positions[:, [avatar.joint_index("LeftLeg"), avatar.joint_index("RightLeg")]]
    f = int(np.argmax(np.linalg.norm(knees[:, 0] - knees[:, 1], axis=1)))  # widest stride
    mesh = garment_mesh(avatar, "skirt")
    _, nearest = cKDTree(avatar.vertices).query(mesh.vertices)
    frame = replace(
        anim,
        joint_positions=anim.joint_positions[f : f + 1],
        joint_rotations=anim.joint_rotations[f : f + 1],
    )
    posed = _skinned(avatar, mesh.vertices, mesh.faces, mesh.weights, frame)
    torn = _skinned(avatar, mesh.vertices, mesh.faces, avatar.weights[nearest], frame)
    edges = _edges(mesh.faces)
    # Skinned with its nearest skin's weights the hem would split between the legs;
    # the skirt's own weights keep every edge within 1.6 × its rest length.
    assert _stretch(mesh.vertices, torn, edges)[0] > 4.0
    assert _stretch(mesh.vertices, posed, edges)[0] < 1.6
    # The middle of the hem, front and back, hangs between the thighs (sideways).
    hips = anim.joint_positions[f, [avatar.joint_index(n) for n in ("LeftUpLeg", "RightUpLeg")]]
    side = (hips[0] - hips[1]) * [1, 0, 1]
    hem = np.flatnonzero(mesh.vertices[:, 1] < mesh.vertices[:, 1].min() + 1e-4)
    for i in (hem[np.argmax(mesh.vertices[hem, 2])], hem[np.argmin(mesh.vertices[hem, 2])]):
        between = (posed[0, i] - knees[f, 1]) @ side / ((knees[f, 0] - knees[f, 1]) @ side)
        assert 0.3 < between < 0.7


# -- the dressed avatar ----------------------------------------------------------------------
def test_dressed_avatar_is_the_body_and_its_garments(avatar):
    dressed = dress(avatar, ["skirt", "jacket"])
    assert isinstance(dressed, DressedAvatar) and dressed.body is avatar
    assert [g.name for g in dressed.garments] == ["skirt", "jacket"]
    parts = [garment_mesh(avatar, n) for n in ("skirt", "jacket")]
    assert dressed.n_vertices == avatar.n_vertices + sum(len(p.vertices) for p in parts)
    assert dressed.n_faces == avatar.n_faces + sum(p.n_faces for p in parts)
    np.testing.assert_array_equal(dressed.vertices[: avatar.n_vertices], avatar.vertices)
    rot = np.broadcast_to(np.eye(3), (1, avatar.n_joints, 3, 3))
    posed = dressed.skin(rot, avatar.joint_positions[None])[0]
    np.testing.assert_allclose(posed, dressed.vertices, atol=1e-5)
    assert dress(avatar, []) is avatar
    more = dress(dressed, ["loose_trousers"])  # dressing again adds to the outfit
    assert [g.name for g in more.garments] == ["skirt", "jacket", "loose_trousers"]
    colours = dressed.vertex_rgb((0.8, 0.7, 0.6))
    assert colours.shape == (dressed.n_vertices, 3)
    np.testing.assert_allclose(colours[-1], GARMENTS["jacket"].rgb)


def test_decimated_dressed_avatar_keeps_its_garments(avatar):
    dressed = dress(avatar, ["long_coat"])
    low = dressed.decimated(4000)
    garment_faces = dressed.n_faces - avatar.n_faces
    assert isinstance(low, DressedAvatar) and low.body.n_faces == 4000
    assert low.n_faces == 4000 + garment_faces
    np.testing.assert_array_equal(
        low.vertices[low.body.n_vertices :], dressed.vertices[avatar.n_vertices :]
    )
    np.testing.assert_allclose(low.weights.sum(axis=1), 1.0, atol=1e-5)
    # Fitted to a coarse body (rings may find no vertex near them) it is still whole.
    coarse = dress(avatar.decimated(300), ["long_coat"])
    assert coarse.n_faces == 300 + garment_faces and np.isfinite(coarse.vertices).all()


def test_reshaped_dressed_avatar_is_dressed_anew(avatar):
    dressed = dress(avatar, ["skirt"])
    big = dressed.with_shape(height_m=1.85, girth=1.3)
    assert isinstance(big, DressedAvatar) and big.garments == dressed.garments
    assert big.body.height_m == pytest.approx(1.85, abs=1e-4)
    # The skirt is fitted to the new body: off its skin, wider than the old skirt.
    skirt = big.vertices[big.body.n_vertices :]
    gap, _ = cKDTree(big.body.vertices).query(skirt)
    assert gap.min() > 0.002
    assert np.ptp(skirt[:, 0]) > np.ptp(dressed.vertices[avatar.n_vertices :, 0]) + 0.05


@pytest.mark.parametrize("name", list(GARMENTS))
def test_dressed_silhouette_covers_the_body_and_is_wider_at_the_garment(
    avatar, low_poly, clips, name
):
    anim, _ = clips["walk_02_01"]
    frames = slice(0, None, 40)
    rotations, positions = anim.joint_rotations[frames], anim.joint_positions[frames]
    plain = low_poly
    dressed = dress(plain, [name])
    camera = virtual_rig([30], [10], 160, 200).fitted(
        hull_points(avatar.skin(rotations, positions))
    )[0]
    body_masks = render_masks(plain.skin(rotations, positions), plain.faces, camera)
    dressed_vertices = dressed.skin(rotations, positions)
    dressed_masks = render_masks(dressed_vertices, dressed.faces, camera)
    assert np.all(dressed_masks | ~body_masks)  # covers the body
    # Wider across the rows the garment spans.
    garment = dressed_vertices[:, plain.n_vertices :]
    for f in range(len(body_masks)):
        v = camera.project(garment[f])[0][:, 1]
        band = slice(max(int(v.min()), 0), min(int(v.max()) + 1, camera.height))
        gained = dressed_masks[f, band].sum() - body_masks[f, band].sum()
        assert gained > 0.15 * body_masks[f, band].sum(), f


def test_shaded_garments_have_their_own_colour(avatar, low_poly):
    from eigmotion.imaging.render import BODY_RGB, Renderer

    dressed = dress(low_poly, ["skirt"])
    vertices = np.stack([dressed.vertices, dressed.vertices + [0.02, 0.0, 0.0]])
    camera = virtual_rig([0], [0], 90, 120).fitted(dressed.vertices)[0]
    colours = dressed.vertex_rgb(BODY_RGB)
    with Renderer() as renderer:
        both = renderer.render_shaded(vertices, dressed.faces, camera, vertex_rgb=colours)
        assert renderer.last_update_counts == {"in_place": 1, "rebuilds": 1}
        second = renderer.render_shaded(
            vertices[1:], dressed.faces, camera, vertex_rgb=colours, floor=True
        )
        with pytest.raises(InvalidParameterError, match="vertex_rgb"):
            renderer.render_shaded(vertices, dressed.faces, camera, vertex_rgb=colours[:10])
    np.testing.assert_array_equal(both[1], second[0])  # the in-place update keeps colours
    skirt, _ = camera.project(dressed.vertices[dressed.body.n_vertices :])
    u, v = np.round(np.median(skirt, axis=0)).astype(int)
    r, g, b = both[0, v, u].astype(int)
    assert r > g + 40 and r > b + 40  # the skirt is red, the body is not
    chest, _ = camera.project(dressed.joint_positions[avatar.joint_index("Spine1")])
    r, g, b = both[0, int(round(chest[1])), int(round(chest[0]))].astype(int)
    assert r - b < 80 and g > 0.6 * r


# -- the build -------------------------------------------------------------------------------
def test_build_config_with_garments_round_trips():
    config = BuildConfig(
        body_shapes=((None, 1.0), (1.8, 1.2)),
        garments=((), ("short_skirt",), ["jacket", "wide_shorts"]),
    )
    assert config.garments == ((), ("short_skirt",), ("jacket", "wide_shorts"))
    assert len(config.bodies) == 6 and config.bodies[1] == ((None, 1.0), ("short_skirt",))
    stored = json.loads(json.dumps(config.to_dict()))  # plain values
    assert BuildConfig.from_dict(stored) == config
    old = {k: v for k, v in BuildConfig().to_dict().items() if k != "garments"}
    assert BuildConfig.from_dict(old).garments == ((),)  # a database made before garments
    # the default build: the avatar's own build first, then a slimmer and a stouter one
    assert BuildConfig().body_shapes == ((None, 1.0), (None, 0.85), (None, 1.25))
    assert len(BuildConfig().bodies) == 3 * len(BuildConfig().garments)


@pytest.mark.parametrize(
    "garments, match",
    [
        ((("kilt",),), "unknown garment 'kilt'.*wide_shorts"),
        (("skirt",), "write \\('skirt',\\)"),
        ((), "at least one outfit"),
        ((("jacket", "jacket"),), "twice"),
    ],
)
def test_build_config_refuses_bad_garments(garments, match):
    with pytest.raises(InvalidParameterError, match=match):
        BuildConfig(garments=garments)


@pytest.mark.parametrize(
    "shapes, match",
    [
        (((None, 0.5),), "girth .*0.5"),
        (((3.0, 1.0),), "height_m .*3.0"),
        (((None, np.nan),), "girth"),
    ],
)
def test_build_config_refuses_bad_body_shapes(shapes, match):
    with pytest.raises(InvalidParameterError, match=match):
        BuildConfig(body_shapes=shapes)


def test_build_renders_every_body_shape_in_every_outfit():
    from eigmotion.mocap.library import LibraryMotion

    motion = find_motion("walk_02_01").trim(0, 60)
    item = LibraryMotion(
        name="walk",
        label="walk",
        motion=motion,
        source=(),
        performer="",
        variation="",
        licence="",
        role="basic",
    )
    config = BuildConfig(
        body_shapes=((None, 1.0),),
        garments=((), ("wide_shorts",)),
        window_s=0.3,
        window_step_s=0.3,
    )
    rig = virtual_rig([0, 90], [0], 48, 64)
    views = list(render_views([item], rig, config, workers=1, progress=False))
    assert sorted((v.shape_index, v.view_index) for v in views) == [(0, 0), (0, 1), (1, 0), (1, 1)]
    low = build_body((None, 1.0), config.low_poly_faces, ("wide_shorts",))
    assert isinstance(low, DressedAvatar) and low.body.n_faces == config.low_poly_faces
    for view in (0, 1):  # the shorts change the motion images
        plain, dressed = (v.vectors[0] for v in views if v.view_index == view)
        assert np.linalg.norm(plain - dressed) > 0.05


def test_synthetic_clip_of_a_dressed_body(low_poly):
    from eigmotion.synth.clips import render_clip

    motion = find_motion("walk_02_01").trim(0, 40)

    def fill(garments):
        clip = render_clip(
            motion, low_poly, 30.0, 5.0, np.random.default_rng(1), 64, 96, garments=garments
        )
        rows = np.flatnonzero(clip.true_masks.any(axis=(0, 2)))
        return clip.true_masks.sum(axis=(1, 2)).mean() / np.ptp(rows) ** 2

    assert fill(("long_coat",)) > 1.3 * fill(())  # a wider figure for its height
