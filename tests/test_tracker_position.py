"""The person's 3D position from the views: rays onto the plane y = H_b, camera pairs."""

from __future__ import annotations

import numpy as np
import pytest

from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.imaging.cameras import intrinsics, look_at
from eigmotion.tracking.calibration import CameraPair
from eigmotion.tracking.position import (
    intersect_plane_lines,
    locate,
    mask_centroid,
    ray_plane_points,
    select_pair,
)

K = intrinsics(320, 240, 45.0)


def ring(n, radius=4.0, height=1.6):
    """``n`` cameras around the origin, looking at (0, 0.9, 0); two are 90° apart."""
    out = []
    azimuths = [0.3, 0.3 + np.pi / 2] if n == 2 else np.linspace(0, 2 * np.pi, n, False) + 0.3
    for i, az in enumerate(azimuths):
        eye = [radius * np.sin(az), height, radius * np.cos(az)]
        out.append(look_at(eye, [0, 0.9, 0], K, 320, 240, name=f"c{i}"))
    return out


@pytest.mark.parametrize("n_cameras", [1, 2, 3, 5])
@pytest.mark.parametrize("point", [(0.0, 0.9, 0.0), (0.7, 0.95, -0.4), (-1.1, 0.85, 0.6)])
def test_known_point_is_recovered(n_cameras, point):
    cams = ring(n_cameras)
    point = np.array(point)
    pixels = np.stack([cam.project(point[None])[0][0] for cam in cams])
    got = intersect_plane_lines(cams, pixels, height_m=point[1])
    np.testing.assert_allclose(got, point, atol=1e-4)


def test_lines_ignore_the_vertical_image_position():
    """The lines are the rays projected onto the plane: a centroid higher or lower in the
    image (a crouch, a raised arm) does not move the answer, unlike ray/plane hits."""
    cams = ring(2)
    point = np.array([0.4, 0.9, 0.3])
    above = point + [0, 0.3, 0]  # a point on the same vertical, 30 cm higher
    pixels_up = np.stack([cam.project(above[None])[0][0] for cam in cams])
    got = intersect_plane_lines(cams, pixels_up, height_m=point[1], prior_weight=0.0)
    np.testing.assert_allclose(got, point, atol=1e-6)
    hits = ray_plane_points(cams, pixels_up, point[1])
    assert np.linalg.norm(hits - point, axis=1).min() > 0.1


def test_least_squares_with_noise_beats_each_pair():
    rng = np.random.default_rng(1)
    cams = ring(6)
    point = np.array([0.3, 0.9, -0.2])
    errs_all, errs_pair = [], []
    for _ in range(50):
        pixels = np.stack([c.project(point[None])[0][0] for c in cams]) + rng.normal(0, 2, (6, 2))
        errs_all.append(np.linalg.norm(intersect_plane_lines(cams, pixels, 0.9) - point))
        errs_pair.append(np.linalg.norm(intersect_plane_lines(cams[:2], pixels[:2], 0.9) - point))
    assert np.mean(errs_all) < np.mean(errs_pair)


def test_single_camera_meets_the_plane():
    cam = ring(1)[0]
    point = np.array([0.2, 1.0, -0.3])
    px = cam.project(point[None])[0]
    np.testing.assert_allclose(ray_plane_points([cam], px, 1.0)[0], point, atol=1e-9)


def test_facing_cameras_stay_defined():
    """Two cameras facing each other across the person give parallel lines: the weak
    prior keeps the answer finite and on the line."""
    cams = [
        look_at([0, 1.5, -4], [0, 0.9, 0], K, 320, 240),
        look_at([0, 1.5, 4], [0, 0.9, 0], K, 320, 240),
    ]
    point = np.array([0.0, 0.9, 0.5])
    pixels = np.stack([c.project(point[None])[0][0] for c in cams])
    got = intersect_plane_lines(cams, pixels, 0.9, prior_m=point)
    np.testing.assert_allclose(got, point, atol=1e-6)


def test_ray_errors():
    cam = look_at([0, 1.0, -4], [0, 1.0, 0], K, 320, 240)
    centre = np.array([[cam.cx, cam.cy]])
    with pytest.raises(InvalidParameterError, match="parallel"):
        ray_plane_points([cam], centre, 0.9)
    with pytest.raises(InvalidParameterError, match="behind"):
        ray_plane_points([cam], centre + [0, -50], 0.9)
    with pytest.raises(InvalidParameterError, match="at least one camera"):
        intersect_plane_lines([], np.zeros((0, 2)), 0.9)


def test_mask_centroid():
    mask = np.zeros((10, 12), bool)
    mask[2:5, 3:9] = True  # rows 2..4, columns 3..8
    np.testing.assert_allclose(mask_centroid(mask), [5.5, 3.0])
    with pytest.raises(VideoError, match="empty"):
        mask_centroid(np.zeros((4, 4), bool))


def test_locate_from_rendered_masks():
    """Silhouettes of a box standing at a known place give that place."""
    from eigmotion.imaging.silhouettes import render_masks

    cams = ring(2)
    box = np.array([[x, y, z] for x in (-0.15, 0.15) for y in (0.0, 1.8) for z in (-0.1, 0.1)])
    faces = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ]
    )
    where = np.array([0.5, 0.0, -0.3])
    masks = [render_masks((box + where)[None], faces, c)[0] for c in cams]
    got = locate(cams, masks, 0.9)
    assert np.hypot(got[0] - where[0], got[2] - where[2]) < 0.05


def test_pair_selection_by_region_and_by_view():
    cams = [
        look_at([-2, 1.6, -3], [-2, 0.9, 0], K, 320, 240),
        look_at([-2, 1.6, 3], [-2, 0.9, 0], K, 320, 240),
        look_at([2, 1.6, -3], [2, 0.9, 0], K, 320, 240),
        look_at([2, 1.6, 3], [2, 0.9, 0], K, 320, 240),
    ]
    regions = [CameraPair((0, 1), (-4, -2, 0, 2)), CameraPair((2, 3), (0, -2, 4, 2))]
    automatic = [CameraPair((0, 1)), CameraPair((2, 3))]
    for pairs in (regions, automatic):
        assert select_pair(pairs, cams, [-1.8, 0.9, 0.2]).cameras == (0, 1)
        assert select_pair(pairs, cams, [2.5, 0.9, -0.3]).cameras == (2, 3)
    # Outside every region: the nearest region's pair.
    assert select_pair(regions, cams, [9.0, 0.9, 0.0]).cameras == (2, 3)
    with pytest.raises(InvalidParameterError):
        select_pair([], cams, [0, 0, 0])
