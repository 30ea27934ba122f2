"""The shipped virtual camera rigs (``virtual_cameras/*.toml``)."""

from __future__ import annotations

import importlib.util
import itertools
from pathlib import Path

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import (
    fit_distance,
    intrinsics,
    load_rig,
    look_at,
    view_direction,
)
from eigmotion.imaging.silhouettes import render_rig_masks
from eigmotion.mocap.canonical import canonical_skeleton
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.motion import Motion

RIG_DIR = Path(__file__).resolve().parents[1] / "virtual_cameras"
SHIPPED = ("ring6", "default", "dome")


def _load(stem):
    return load_rig(RIG_DIR / f"{stem}.toml")


@pytest.fixture(scope="module")
def avatar():
    from eigmotion.body.avatar import load_default_avatar

    return load_default_avatar()


def _unit(x):
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _border(masks):
    """(..., H, W) bool → (...,) bool: anything on the outermost rows or columns."""
    return (
        masks[..., 0, :].any(-1)
        | masks[..., -1, :].any(-1)
        | masks[..., :, 0].any(-1)
        | masks[..., :, -1].any(-1)
    )


@pytest.mark.parametrize("stem", SHIPPED)
def test_rig_loads(stem):
    rig = _load(stem)
    assert rig.name == stem
    assert len(rig) >= 6
    assert len({cam.name for cam in rig}) == len(rig)
    for cam in rig:
        assert (cam.width, cam.height) == (128, 128)
        assert cam.azimuth_deg is not None and cam.elevation_deg is not None


@pytest.mark.parametrize("stem", SHIPPED)
def test_cameras_look_at_the_target_upright_at_one_distance(stem):
    rig = _load(stem)
    target = np.asarray(rig.meta["target"], dtype=float)
    for cam in rig:
        offset = cam.center - target
        np.testing.assert_allclose(np.linalg.norm(offset), rig.meta["distance_m"], rtol=1e-9)
        np.testing.assert_allclose(
            _unit(offset), view_direction(cam.azimuth_deg, cam.elevation_deg), atol=1e-9
        )
        np.testing.assert_allclose(cam.R[2], -_unit(offset), atol=1e-9)  # optical axis
        assert cam.R[1] @ [0, 1, 0] < 0  # image down is world down: the body stands upright
        np.testing.assert_allclose(cam.project(target)[0], [cam.cx, cam.cy], atol=1e-9)
        np.testing.assert_allclose(np.rad2deg(cam.yfov_rad), rig.meta["yfov_deg"], rtol=1e-9)


def test_ring6_is_six_level_cameras_sixty_degrees_apart():
    rig = _load("ring6")
    assert len(rig) == 6
    target = np.asarray(rig.meta["target"], dtype=float)
    offsets = np.array([cam.center for cam in rig]) - target
    np.testing.assert_allclose(offsets[:, 1], 0.0, atol=1e-9)  # elevation 0
    distances = np.linalg.norm(offsets, axis=1)
    np.testing.assert_allclose(distances, distances[0], rtol=1e-12)
    azimuths = np.sort(np.rad2deg(np.arctan2(offsets[:, 0], offsets[:, 2])) % 360)
    np.testing.assert_allclose(np.diff(azimuths), 60.0, atol=1e-9)
    np.testing.assert_allclose(azimuths, [cam.azimuth_deg % 360 for cam in rig], atol=1e-9)


@pytest.mark.parametrize(
    "stem, n_azimuths, elevations",
    [("default", 12, [0.0, 20.0]), ("dome", 12, [-20.0, 0.0, 20.0, 40.0])],
)
def test_grid_layouts(stem, n_azimuths, elevations):
    rig = _load(stem)
    assert len(rig) == n_azimuths * len(elevations) >= 24
    views = {(round(c.azimuth_deg % 360, 6), round(c.elevation_deg, 6)) for c in rig}
    want = {
        (round(a, 6), e) for a, e in itertools.product(np.arange(n_azimuths) * 30.0, elevations)
    }
    assert views == want


def test_files_match_their_generator(tmp_path):
    spec = importlib.util.spec_from_file_location("make_rigs", RIG_DIR / "make_rigs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--out", str(tmp_path)]) == 0
    assert sorted(p.stem for p in tmp_path.glob("*.toml")) == sorted(SHIPPED)
    for stem in SHIPPED:
        fresh, shipped = load_rig(tmp_path / f"{stem}.toml"), _load(stem)
        assert fresh.meta == shipped.meta and len(fresh) == len(shipped)
        for a, b in zip(fresh, shipped, strict=True):
            assert a.name == b.name
            np.testing.assert_allclose(a.K, b.K, atol=1e-12)
            np.testing.assert_allclose(a.R, b.R, atol=1e-12)
            np.testing.assert_allclose(a.t, b.t, atol=1e-12)


@pytest.mark.parametrize("stem", SHIPPED)
def test_standing_person_in_frame_without_fitting(avatar, stem):
    """The avatar at rest, and any 2 m × 1 m × 1 m box on the floor around the target,
    lie inside every image with the rig as shipped."""
    rig = _load(stem)
    target = np.asarray(rig.meta["target"], dtype=float)
    box = np.array(list(itertools.product([-0.5, 0.5], [0.0, 2.0], [-0.5, 0.5])))
    box += [target[0], 0.0, target[2]]
    for cam in rig:
        px, depth = cam.project(box)
        assert np.all(depth > 0)
        assert np.all((px >= 0) & (px <= [cam.width - 1, cam.height - 1])), cam.name
    masks = render_rig_masks(avatar.vertices[None], avatar.faces, rig)
    assert masks.sum(axis=(2, 3)).min() > 300
    assert not _border(masks).any()


@pytest.mark.parametrize("stem", ["ring6", "default"])
def test_fitted_rig_keeps_a_travelling_body_in_frame(avatar, stem):
    """Random poses along a 3 m path: after ``fitted`` every frame lies inside every
    image, each view keeps its direction, and the body comes as close to the edge as
    the fitting margin allows."""
    low_poly = avatar.decimated(4000)
    rng = np.random.default_rng(7)
    skeleton = canonical_skeleton()
    n_frames = 6
    values = rng.uniform(-30, 30, (n_frames, skeleton.n_channels))
    values[:, :3] = 0.0
    values[:, 0] = np.linspace(-1.5, 1.5, n_frames)  # walk along X
    values[:, 2] = np.linspace(0.5, -0.5, n_frames)
    pose = forward_kinematics(Motion(skeleton, values, 1 / 30, 1.0, "travel"), ground=False)
    vertices = low_poly.skin(pose.rotations, pose.positions)
    margin = 0.05
    rig = _load(stem).fitted(vertices.reshape(-1, 3), margin=margin)
    masks = render_rig_masks(vertices, low_poly.faces, rig)
    assert masks.sum(axis=(2, 3)).min() > 100
    assert not _border(masks).any()
    centre = 0.5 * (vertices.reshape(-1, 3).min(0) + vertices.reshape(-1, 3).max(0))
    for cam, cam_masks in zip(rig, masks, strict=True):
        np.testing.assert_allclose(
            _unit(cam.center - centre),
            view_direction(cam.azimuth_deg, cam.elevation_deg),
            atol=1e-9,
        )
        seen = cam_masks.any(axis=0)
        rows, cols = np.nonzero(seen.any(axis=1))[0], np.nonzero(seen.any(axis=0))[0]
        gap = min(rows[0], cols[0], cam.height - 1 - rows[-1], cam.width - 1 - cols[-1])
        assert margin * cam.width - 1 <= gap <= margin * cam.width + 2, (cam.name, gap)


@pytest.mark.parametrize("elevation_deg", [-90.0, -35.0, 0.0, 20.0, 90.0])
@pytest.mark.parametrize(
    "width, height, yfov_deg", [(128, 128, 40.0), (320, 240, 60.0), (64, 160, 25.0)]
)
def test_fit_distance_is_the_nearest_distance_that_keeps_every_point_in_frame(
    elevation_deg, width, height, yfov_deg
):
    """At the fitted distance every point lies inside the image less its margin and one
    touches that border; a hair nearer, one is outside."""
    rng = np.random.default_rng(int(elevation_deg) + 100 + width)
    margin = 0.05
    K = intrinsics(width, height, yfov_deg)
    points = rng.normal(size=(50, 3)) * [0.4, 0.8, 0.3] + [0.0, 0.9, 0.0]
    target = 0.5 * (points.min(axis=0) + points.max(axis=0))
    azimuth_deg = float(rng.uniform(0, 360))
    direction = view_direction(azimuth_deg, elevation_deg)
    d = fit_distance(points, target, azimuth_deg, elevation_deg, K, width, height, margin)
    low = margin * np.array([width, height])
    high = (1 - margin) * np.array([width, height]) - 1

    def slack(distance):
        """Pixels from the points to the nearest border of the image less its margin."""
        camera = look_at(target + distance * direction, target, K, width, height)
        px, depth = camera.project(points)
        assert np.all(depth > 0.05)
        return min((px - low).min(), (high - px).min())

    assert abs(slack(d)) < 1e-6
    assert slack(d * 1.001) > 0
    assert slack(d * 0.999) < 0


def test_fit_distance_needs_the_principal_point_inside_the_image():
    K = intrinsics(128, 128, 40.0)
    K[0, 2] = 200.0
    with pytest.raises(InvalidParameterError, match="principal point"):
        fit_distance(np.zeros((1, 3)), np.array([0.0, 0.0, 0.1]), 0.0, 0.0, K, 128, 128)
