"""CPU silhouettes: pixel convention, union of triangles, rigs, agreement with OpenGL."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from matplotlib.path import Path as PolygonPath
from scipy.spatial import ConvexHull

from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import intrinsics, look_at, virtual_rig
from eigmotion.imaging.render import default_renderer, depth_sample_offset_px, render_masks_gl
from eigmotion.imaging.silhouettes import iter_rig_masks, render_masks, render_rig_masks
from eigmotion.mocap.canonical import canonical_skeleton
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.motion import Motion


def _front_camera(width=64, height=48, yfov_deg=50.0):
    """A camera 5 m in front of the body (azimuth 0) at 1 m height, looking level."""
    return look_at((0, 1, 5), (0, 1, 0), intrinsics(width, height, yfov_deg), width, height)


@pytest.fixture(scope="module")
def avatar():
    from eigmotion.body.avatar import load_default_avatar

    return load_default_avatar()


@pytest.fixture(scope="module")
def low_poly(avatar):
    from eigmotion.body.avatar import DEFAULT_LOW_POLY_FACES

    return avatar.decimated(DEFAULT_LOW_POLY_FACES)


@pytest.fixture(scope="module")
def body(avatar):
    """(V, 3) rest vertices standing on y = 0 (metres) and (T, 3) faces."""
    return avatar.vertices, avatar.faces


def _random_joint_transforms(n_frames, rng, max_angle_deg=35.0):
    """World joint rotations (F, J, 3, 3) and positions (F, J, 3) of random poses:
    every Euler channel of the canonical skeleton uniform in ±max_angle_deg, the root
    shifted up to 0.3 m sideways."""
    skeleton = canonical_skeleton()
    values = rng.uniform(-max_angle_deg, max_angle_deg, (n_frames, skeleton.n_channels))
    values[:, :3] = rng.uniform(-0.3, 0.3, (n_frames, 3)) * [1, 0, 1]
    pose = forward_kinematics(Motion(skeleton, values, 1 / 30, 1.0, "random"), ground=False)
    return pose.rotations, pose.positions


# -- pixel convention ----------------------------------------------------------------------


@pytest.mark.parametrize("u0, v0, u1, v1", [(10.5, 20.5, 20.5, 30.5), (0.2, 3.7, 7.9, 44.1)])
def test_pixel_centres_at_integers(u0, v0, u1, v1):
    """A quad whose corners project to (u0, v0)-(u1, v1) covers exactly the pixels whose
    integer centres lie inside it."""
    cam = _front_camera()
    corners = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]])
    depth_m = 3.0
    rays = cam.pixel_rays(corners)
    # points on the plane z_cam = depth_m along each ray
    z = (rays @ cam.R.T)[:, 2]
    points = cam.center + rays * (depth_m / z)[:, None]
    np.testing.assert_allclose(cam.project(points)[0], corners, atol=1e-9)
    mask = render_masks(points[None], np.array([[0, 1, 2], [0, 2, 3]]), cam)[0]
    cols, rows = np.arange(cam.width), np.arange(cam.height)
    want = ((rows >= v0) & (rows <= v1))[:, None] & ((cols >= u0) & (cols <= u1))[None, :]
    np.testing.assert_array_equal(mask, want)


def test_overlapping_triangles_leave_no_hole():
    """Overlaps count once (no even-odd holes), whatever the winding."""
    cam = _front_camera()
    tri = np.array([[-1.0, 0.1, 0], [1.0, 0.1, 0], [0.0, 2.0, 0]])
    shifted = tri + [0.3, 0.2, 0.0]
    vertices = np.concatenate([tri, shifted])[None]
    one = render_masks(vertices, np.array([[0, 1, 2]]), cam)[0]
    two = render_masks(vertices, np.array([[3, 4, 5]]), cam)[0]
    both = render_masks(vertices, np.array([[0, 1, 2], [5, 4, 3]]), cam)[0]
    assert (one & two).sum() > 50
    np.testing.assert_array_equal(both, one | two)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_convex_body_matches_its_projected_hull(seed):
    """For a convex mesh the silhouette is the convex hull of the projected vertices."""
    import trimesh

    rng = np.random.default_rng(seed)
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=0.6)
    vertices = mesh.vertices @ np.diag(rng.uniform(0.5, 1.5, 3)) + [0, 1, 0]
    direction = rng.normal(size=3)
    cam = look_at(
        (0, 1, 0) + 3.0 * direction / np.linalg.norm(direction),
        (0, 1, 0),
        np.array([[90.0, 0, 40.3], [0, 90.0, 31.7], [0, 0, 1]]),
        80,
        64,
    )
    mask = render_masks(vertices[None], mesh.faces, cam)[0]
    px, _ = cam.project(vertices)
    hull = px[ConvexHull(px).vertices]
    rows, cols = np.mgrid[0 : cam.height, 0 : cam.width]
    centres = np.stack([cols.ravel(), rows.ravel()], axis=1)
    want = PolygonPath(hull).contains_points(centres).reshape(mask.shape)
    assert want.sum() > 200
    assert (mask != want).sum() <= 2  # only centres lying on the outline may differ


def test_winding_does_not_matter(body):
    vertices, faces = body
    cam = virtual_rig([30], [10], distance_m=4.0)[0]
    a = render_masks(vertices[None], faces, cam)
    b = render_masks(vertices[None], faces[:, ::-1], cam)
    assert a.sum() > 500
    np.testing.assert_array_equal(a, b)


def test_frames_are_independent(body):
    vertices, faces = body
    cam = virtual_rig([0], [0], distance_m=4.0)[0]
    frames = np.stack([vertices, vertices + [0.4, 0, 0], vertices + [0, 0, 100.0]])
    masks = render_masks(frames, faces, cam)
    assert masks.shape == (3, cam.height, cam.width) and masks.dtype == np.bool_
    cols = [np.nonzero(m.any(axis=0))[0] for m in masks[:2]]
    # seen from the front (+Z), the body's left (+X) is on the image's right
    assert cols[1].mean() > cols[0].mean() + 5
    assert not masks[2].any()  # behind the camera: nothing drawn


def test_float32_and_float64_give_the_same_masks(avatar):
    cam = virtual_rig([120], [20]).fitted(avatar.vertices)[0]
    single = render_masks(avatar.vertices[None].astype(np.float32), avatar.faces, cam)
    double = render_masks(avatar.vertices[None].astype(np.float64), avatar.faces, cam)
    assert single.sum() > 1000
    assert (single != double).sum() <= 2  # rounding of centres lying on an edge


@pytest.mark.parametrize("depth_m, drawn", [(0.02, True), (0.005, False), (-1.0, False)])
def test_triangles_crossing_the_near_plane(depth_m, drawn):
    """A vertex just beyond the near plane projects far off the image and its triangle
    still fills exactly the right pixels; a vertex in front of the near plane (or
    behind the camera) drops its triangle."""
    cam = _front_camera()
    near_corner = cam.center + [0.05, -0.02, -depth_m]
    vertices = np.array([[[-2.0, 1.0, 0.0], [2.0, 1.0, 0.0], near_corner]])
    mask = render_masks(vertices, np.array([[0, 1, 2]]), cam, near_m=0.01)[0]
    assert mask.any() == drawn
    if drawn:
        px, _ = cam.project(vertices[0])
        assert px[2, 0] > 2 * cam.width and px[2, 1] > cam.height
        rows, cols = np.mgrid[0 : cam.height, 0 : cam.width]
        centres = np.stack([cols.ravel(), rows.ravel()], axis=1)
        want = PolygonPath(px).contains_points(centres).reshape(mask.shape)
        assert want.sum() > 300
        assert (mask != want).sum() <= 2


# -- rigs ----------------------------------------------------------------------------------


def test_rig_masks_equal_per_camera_masks(body):
    vertices, faces = body
    frames = np.stack([vertices, vertices + [0.2, 0, 0.1]])
    rig = virtual_rig([0, 90, 225], [0, 30], distance_m=4.0)
    stacked = render_rig_masks(frames, faces, rig)
    assert stacked.shape == (len(rig), 2, 128, 128)
    for i, (cam, masks) in enumerate(iter_rig_masks(frames, faces, rig)):
        assert cam is rig[i]
        np.testing.assert_array_equal(stacked[i], masks)
        np.testing.assert_array_equal(masks, render_masks(frames, faces, cam))


def test_rig_of_mixed_sizes(body):
    vertices, faces = body
    rig = virtual_rig([0, 90], [0], distance_m=4.0)
    mixed = replace(rig, cameras=(rig[0], rig[1].with_image_size(64, 48)))
    with pytest.raises(InvalidParameterError, match="iter_rig_masks"):
        render_rig_masks(vertices[None], faces, mixed)
    shapes = [m.shape for _, m in iter_rig_masks(vertices[None], faces, mixed)]
    assert shapes == [(1, 128, 128), (1, 48, 64)]


# -- bad input -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "vertices, faces, match",
    [
        (np.zeros((4, 3)), np.array([[0, 1, 2]]), "vertices"),
        (np.zeros((1, 4, 2)), np.array([[0, 1, 2]]), "vertices"),
        (np.zeros((1, 4, 3)), np.array([0, 1, 2]), "faces"),
        (np.zeros((1, 4, 3)), np.array([[0.0, 1, 2]]), "integers"),
        (np.zeros((1, 4, 3)), np.array([[0, 1, 4]]), "0..3"),
        (np.zeros((1, 4, 3)), np.array([[-1, 1, 2]]), "0..3"),
        (np.full((1, 4, 3), np.nan), np.array([[0, 1, 2]]), "finite"),
    ],
)
def test_bad_input_raises(vertices, faces, match):
    cam = _front_camera()
    with pytest.raises(InvalidParameterError, match=match):
        render_masks(vertices, faces, cam)
    with pytest.raises(InvalidParameterError, match=match):
        iter_rig_masks(vertices, faces, virtual_rig([0], [0]))


def test_bad_camera_or_rig_raises():
    triangle, faces = np.zeros((1, 3, 3)), np.array([[0, 1, 2]])
    rig = virtual_rig([0, 90], [0])
    with pytest.raises(InvalidParameterError, match="Camera"):
        render_masks(triangle, faces, rig)
    with pytest.raises(InvalidParameterError, match="CameraRig"):
        render_rig_masks(triangle, faces, rig[0])
    with pytest.raises(InvalidParameterError, match="numbers"):
        render_masks(np.full((1, 3, 3), "a"), faces, rig[0])
    with pytest.raises(InvalidParameterError, match="no cameras"):
        iter_rig_masks(triangle, faces, replace(rig, cameras=()))


def test_bad_near_plane_raises():
    with pytest.raises(InvalidParameterError, match="near_m"):
        render_masks(np.zeros((1, 3, 3)), np.array([[0, 1, 2]]), _front_camera(), near_m=0.0)


# -- agreement with OpenGL -----------------------------------------------------------------


@pytest.fixture(scope="module")
def gl_render():
    """:func:`eigmotion.imaging.render.render_masks_gl`, its renderer started.  OpenGL
    (EGL, installed by ``.ci/system-deps``) is required: a machine without it fails
    here."""
    default_renderer()
    depth_sample_offset_px()
    return render_masks_gl


def _iou(a, b):
    """(F,) intersection over union of two (F, H, W) bool stacks."""
    return (a & b).sum(axis=(1, 2)) / np.maximum((a | b).sum(axis=(1, 2)), 1)


def _random_views(rng, n):
    """``n`` (azimuth, elevation) pairs: azimuth 0–360°, elevation −10..40°."""
    return zip(rng.uniform(0, 360, n), rng.uniform(-10, 40, n), strict=True)


@pytest.mark.parametrize("seed", range(3))
def test_agrees_with_opengl(avatar, low_poly, gl_render, seed):
    """Random poses, random views: the CPU masks of the full mesh match the GL render
    of the full mesh (IoU >= 0.98), those of the low-poly avatar match it with
    IoU >= 0.95."""
    rng = np.random.default_rng(seed)
    rotations, positions = _random_joint_transforms(3, rng)
    full = avatar.skin(rotations, positions)
    low = low_poly.skin(rotations, positions)
    for az, el in _random_views(rng, 2):
        cam = virtual_rig([az], [el]).fitted(full.reshape(-1, 3))[0]
        gl = gl_render(full, avatar.faces, cam)
        assert gl.sum(axis=(1, 2)).min() > 500
        iou_full = _iou(render_masks(full, avatar.faces, cam), gl)
        iou_low = _iou(render_masks(low, low_poly.faces, cam), gl)
        assert iou_full.min() >= 0.98, (cam.name, iou_full)
        assert iou_low.min() >= 0.95, (cam.name, iou_low)


@pytest.mark.parametrize(
    "clip, subject", [("16_15", "16"), ("135_04", "135"), ("14_27", "14"), ("09_01", "09")]
)
def test_agrees_with_opengl_on_cmu_frames(avatar, low_poly, gl_render, cmu_dir, clip, subject):
    """Random frames of real CMU clips (walk, kick, sit, run) from a random view."""
    from eigmotion.body.retarget import retarget
    from eigmotion.mocap.amc import read_amc

    motion = read_amc(cmu_dir / "amc" / f"{clip}.amc", cmu_dir / "asf" / f"{subject}.asf")
    rng = np.random.default_rng(int(clip.replace("_", "")))
    start = int(rng.integers(0, max(motion.n_frames - 240, 1)))
    animation = retarget(motion.trim(start, start + 240), avatar)
    frames = np.sort(rng.choice(animation.n_frames, 3, replace=False))
    rotations = animation.joint_rotations[frames]
    positions = animation.joint_positions[frames]
    full = avatar.skin(rotations, positions)
    low = low_poly.skin(rotations, positions)
    ((az, el),) = _random_views(rng, 1)
    cam = virtual_rig([az], [el]).fitted(full.reshape(-1, 3))[0]
    gl = gl_render(full, avatar.faces, cam)
    assert gl.sum(axis=(1, 2)).min() > 300
    iou_full = _iou(render_masks(full, avatar.faces, cam), gl)
    iou_low = _iou(render_masks(low, low_poly.faces, cam), gl)
    assert iou_full.min() >= 0.98, (cam.name, iou_full)
    assert iou_low.min() >= 0.95, (cam.name, iou_low)
