"""OpenGL rendering: projection exactness, shading, buffer reuse, framing, ``show``."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import trimesh

from eigmotion.body.retarget import animate_avatar
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import Camera, look_at, virtual_rig
from eigmotion.imaging.framing import FOLLOW_TRAVEL_M, frame_cameras
from eigmotion.imaging.posed_mesh import vertex_normals
from eigmotion.imaging.render import (
    BACKGROUND_RGB,
    Renderer,
    checker_floor,
    depth_sample_offset_px,
    render_masks_gl,
)

SPHERE_RADIUS_M = 0.25


@pytest.fixture(scope="module")
def renderer():
    with Renderer() as r:
        yield r


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(subdivisions=4, radius=SPHERE_RADIUS_M)


def _background_u8():
    return np.round(np.asarray(BACKGROUND_RGB) * 255).astype(int)


def _off_centre_camera():
    """fx != fy and a principal point far from the image centre: catches cx/cy slips."""
    K = np.array([[150.0, 0, 40.3], [0, 170.0, 75.8], [0, 0, 1]])
    return look_at((1.0, 1.4, 4.0), (0.2, 0.8, 0.0), K, 130, 110, name="off-centre")


CASES = {
    "front": (virtual_rig([0], [0], 160, 120)[0], (0.0, 0.9, 0.0)),
    "three-quarter": (virtual_rig([35], [15], 160, 120)[0], (0.4, 1.2, -0.3)),
    "odd-size-below": (virtual_rig([200], [-10], 97, 131)[0], (-0.3, 0.6, 0.2)),
    "off-centre": (_off_centre_camera(), (0.1, 1.0, 0.1)),
}


def _expected_disc(camera: Camera, centre):
    """Projected centre (u, v) and radius (px) of the sphere's silhouette."""
    (u, v), depth = camera.project(np.asarray(centre, float))
    distance = np.linalg.norm(np.asarray(centre) - camera.center)
    half_angle = np.arcsin(SPHERE_RADIUS_M / distance)
    radius_px = np.sqrt(camera.fx * camera.fy) * np.tan(half_angle) * distance / depth
    return np.array([u, v]), radius_px


def _disc(mask):
    rows, cols = np.nonzero(mask)
    return np.array([cols.mean(), rows.mean()]), np.sqrt(mask.sum() / np.pi)


# -- projection ----------------------------------------------------------------------------


@pytest.mark.parametrize("case", sorted(CASES))
def test_sphere_mask_lands_where_camera_projects(renderer, sphere, case):
    camera, centre = CASES[case]
    mask = renderer.render_masks_gl((sphere.vertices + centre)[None], sphere.faces, camera)[0]
    expected_uv, expected_r = _expected_disc(camera, centre)
    uv, r = _disc(mask)
    assert np.abs(uv - expected_uv).max() < 0.3
    assert abs(r - expected_r) < 0.3


@pytest.mark.parametrize("case", sorted(CASES))
def test_shaded_sphere_lands_where_camera_projects(renderer, sphere, case):
    camera, centre = CASES[case]
    image = renderer.render_shaded(
        (sphere.vertices + centre)[None], sphere.faces, camera, floor=False
    )
    assert image.shape == (1, camera.height, camera.width, 3) and image.dtype == np.uint8
    body = np.abs(image[0].astype(int) - _background_u8()).max(axis=-1) > 2
    expected_uv, expected_r = _expected_disc(camera, centre)
    uv, r = _disc(body)
    assert np.abs(uv - expected_uv).max() < 1.0
    assert abs(r - expected_r) < 1.0


@pytest.mark.parametrize(
    "u0, u1, v0, v1",
    [
        (10.3, 30.3, 10.3, 20.3),
        (10.45, 30.55, 10.55, 20.45),
        (5.05, 40.95, 3.9, 36.1),
        (0.0, 8.0, 2.0, 9.0),
    ],
)
def test_gl_masks_follow_the_pixel_centre_rule(renderer, u0, u1, v0, v1):
    """A rectangle at depth 1 m covers exactly the pixel centres strictly inside it."""
    camera = Camera(
        np.array([[60.0, 0, 23.7], [0, 55.0, 19.2], [0, 0, 1]]), np.eye(3), np.zeros(3), 48, 40
    )
    corners_px = [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]
    points = np.array(
        [[(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0] for u, v in corners_px]
    )
    mask = renderer.render_masks_gl(points[None], np.array([[0, 1, 2], [0, 2, 3]]), camera)[0]
    cols, rows = np.arange(48), np.arange(40)
    inside = ((rows > v0) & (rows < v1))[:, None] & ((cols > u0) & (cols < u1))[None, :]
    # exact ties (a centre on an edge) are left to the rasteriser's fill rule
    ties = np.isin(rows, [v0, v1])[:, None] | np.isin(cols, [u0, u1])[None, :]
    np.testing.assert_array_equal(mask[~ties], inside[~ties])


def test_depth_sample_offset_is_inside_the_pixel():
    dx, dy = depth_sample_offset_px()
    assert -0.5 <= dx <= 0.5 and -0.5 <= dy <= 0.5


@pytest.fixture(scope="module")
def avatar():
    from eigmotion.body.avatar import load_default_avatar

    return load_default_avatar()


@pytest.fixture(scope="module")
def walk_vertices(avatar, cmu_dir):
    """(3, V, 3) avatar vertices of three frames of CMU walk 02_01, metres."""
    from eigmotion.mocap.amc import read_amc

    motion = read_amc(cmu_dir / "amc" / "02_01.amc", cmu_dir / "asf" / "02.asf").trim(0, 120)
    _, vertices = animate_avatar(avatar, motion.resample(10))
    return vertices[[0, 4, 9]]


@pytest.mark.parametrize("azimuth_deg, elevation_deg", [(0, 0), (35, 15), (160, 40), (270, -10)])
def test_gl_masks_agree_with_cpu_silhouettes(
    renderer, avatar, walk_vertices, azimuth_deg, elevation_deg
):
    from eigmotion.imaging.silhouettes import render_masks

    camera = virtual_rig([azimuth_deg], [elevation_deg], 128, 128).fitted(
        walk_vertices.reshape(-1, 3)
    )[0]
    gl = renderer.render_masks_gl(walk_vertices, avatar.faces, camera)
    cpu = render_masks(walk_vertices, avatar.faces, camera)
    for f in range(len(gl)):
        iou = (gl[f] & cpu[f]).sum() / (gl[f] | cpu[f]).sum()
        assert iou >= 0.99
        assert gl[f].sum() > 500


# -- shading -------------------------------------------------------------------------------


def test_shaded_frame_is_lit_and_stands_on_a_floor(renderer, sphere):
    camera = virtual_rig([0], [20], 160, 120, distance_m=3.0, target=(0, 0.5, 0))[0]
    centre = np.array([0.0, SPHERE_RADIUS_M, 0.0])  # resting on the floor
    vertices = (sphere.vertices + centre)[None]
    image = renderer.render_shaded(vertices, sphere.faces, camera)[0].astype(int)
    lum = image.mean(axis=-1)
    assert np.all(np.abs(image[0] - _background_u8()) <= 1)  # sky above the floor's far edge
    mask = renderer.render_masks_gl(vertices, sphere.faces, camera)[0]
    rows, cols = np.nonzero(mask)
    body = lum[mask]
    assert body.mean() > lum[0].mean() + 100  # the body is lit, brighter than the background
    centre_u = cols.mean()
    left = lum[rows[cols < centre_u - 3], cols[cols < centre_u - 3]].mean()
    right = lum[rows[cols > centre_u + 3], cols[cols > centre_u + 3]].mean()
    assert left > right + 5  # the key light comes from the camera's upper left
    floor = lum[-25:][~mask[-25:]]
    checker_spread = np.percentile(floor, 90) - np.percentile(floor, 10)
    plain = renderer.render_shaded(vertices, sphere.faces, camera, checker=False)[0].mean(axis=-1)
    plain_floor = plain[-25:][~mask[-25:]]
    assert checker_spread > 25
    assert np.percentile(plain_floor, 90) - np.percentile(plain_floor, 10) < checker_spread / 2


def test_buffer_reuse_matches_fresh_renders(renderer, sphere):
    camera = virtual_rig([20], [10], 96, 80)[0]
    path = np.array([[-0.4 + 0.2 * f, 0.8 + 0.05 * f, 0.1 * f] for f in range(5)])
    vertices = sphere.vertices[None] * (1 + 0.1 * np.arange(5))[:, None, None] + path[:, None]
    batch = renderer.render_shaded(vertices, sphere.faces, camera, floor=False)
    assert renderer.last_update_counts == {"in_place": 4, "rebuilds": 1}
    masks = renderer.render_masks_gl(vertices, sphere.faces, camera)
    for f in range(5):
        single = renderer.render_shaded(vertices[f : f + 1], sphere.faces, camera, floor=False)
        np.testing.assert_array_equal(batch[f], single[0])
        single_mask = renderer.render_masks_gl(vertices[f : f + 1], sphere.faces, camera)
        np.testing.assert_array_equal(masks[f], single_mask[0])
    assert len({m.sum() for m in masks}) == 5  # the sphere really changed between frames


def test_per_frame_cameras(renderer, sphere):
    rig = virtual_rig([0, 90, 180], [10], 64, 64)
    vertices = np.repeat((sphere.vertices + [0.3, 0.9, 0])[None], 3, axis=0)
    masks = renderer.render_masks_gl(vertices, sphere.faces, list(rig))
    for f, camera in enumerate(rig):
        uv, _ = _disc(masks[f])
        expected_uv, _ = _expected_disc(camera, (0.3, 0.9, 0))
        assert np.abs(uv - expected_uv).max() < 0.3


def test_module_functions_use_a_shared_renderer(sphere):
    camera = virtual_rig([0], [0], 32, 32)[0]
    mask = render_masks_gl((sphere.vertices + [0, 0.9, 0])[None], sphere.faces, camera)
    assert mask.shape == (1, 32, 32) and mask.dtype == bool and mask.any()


def test_two_image_sizes_keep_two_contexts(renderer, sphere):
    vertices = (sphere.vertices + [0, 0.9, 0])[None]
    for size in ((40, 30), (30, 40), (40, 30)):
        camera = virtual_rig([0], [0], *size)[0]
        assert renderer.render_shaded(vertices, sphere.faces, camera).shape == (
            1,
            size[1],
            size[0],
            3,
        )


def test_closing_one_renderer_leaves_the_others_working(renderer, sphere):
    import gc

    camera = virtual_rig([0], [0], 24, 24)[0]
    vertices = (sphere.vertices + [0, 0.9, 0])[None]
    before = renderer.render_masks_gl(vertices, sphere.faces, camera)
    with Renderer() as other:
        other.render_masks_gl(vertices, sphere.faces, camera)
    Renderer().render_masks_gl(vertices, sphere.faces, camera)  # dropped without close()
    gc.collect()
    np.testing.assert_array_equal(renderer.render_masks_gl(vertices, sphere.faces, camera), before)


# -- bad input -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "vertices, faces, match",
    [
        (np.zeros((10, 3)), np.array([[0, 1, 2]]), r"\(F, V, 3\)"),
        (np.zeros((1, 10, 3)), np.array([[0, 1, 10]]), "faces index"),
        (np.zeros((1, 10, 3)), np.array([[0.0, 1.0, 2.0]]), "integers"),
        (np.zeros((1, 10, 3)), np.array([0, 1, 2]), r"\(T, 3\)"),
        (np.full((1, 10, 3), np.nan), np.array([[0, 1, 2]]), "finite"),
    ],
)
def test_bad_meshes(renderer, vertices, faces, match):
    camera = virtual_rig([0], [0], 16, 16)[0]
    with pytest.raises(InvalidParameterError, match=match):
        renderer.render_masks_gl(vertices, faces, camera)
    with pytest.raises(InvalidParameterError, match=match):
        renderer.render_shaded(vertices, faces, camera)


def test_bad_cameras(renderer, sphere):
    vertices = np.repeat(sphere.vertices[None], 2, axis=0)
    rig = virtual_rig([0], [0], 16, 16)
    with pytest.raises(InvalidParameterError, match="one per frame"):
        renderer.render_masks_gl(vertices, sphere.faces, [rig[0]] * 3)
    other = virtual_rig([0], [0], 20, 16)[0]
    with pytest.raises(InvalidParameterError, match="one image size"):
        renderer.render_shaded(vertices, sphere.faces, [rig[0], other])


@pytest.mark.parametrize(
    "kwargs",
    [{"body_rgb": (1.5, 0, 0)}, {"tile_m": 0}, {"ambient": 2.0}, {"floor_rgb": ((0, 0, 0),)}],
)
def test_bad_renderer_parameters(kwargs):
    with pytest.raises(InvalidParameterError):
        Renderer(**kwargs)


def test_importing_does_not_load_pyrender():
    code = (
        "import eigmotion.imaging.render, eigmotion.imaging.framing, eigmotion.cli.show, sys; "
        "sys.exit('pyrender' in sys.modules)"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


# -- geometry helpers ----------------------------------------------------------------------


def test_vertex_normals_of_a_sphere_point_outwards(sphere):
    normals = vertex_normals(sphere.vertices, sphere.faces)
    outward = sphere.vertices / np.linalg.norm(sphere.vertices, axis=1, keepdims=True)
    assert normals.dtype == np.float32
    assert np.min(np.sum(normals * outward, axis=1)) > 0.99


@pytest.mark.parametrize("checker", [True, False])
def test_checker_floor(checker):
    vertices, faces, colors = checker_floor((-1.2, 0.9), (0.0, 1.0), tile_m=0.5, checker=checker)
    n_tiles = 5 * 2  # x: -1.5 … 1.0, z: 0 … 1.0
    assert vertices.shape == (4 * n_tiles, 3) and faces.shape == (2 * n_tiles, 3)
    assert colors.shape == (4 * n_tiles, 4)
    assert np.all(vertices[:, 1] == 0)
    assert vertices[:, 0].min() == -1.5 and vertices[:, 0].max() == 1.0
    tri = vertices[faces]
    up = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 1]
    assert np.all(up > 0)  # counter-clockwise seen from above
    assert len({tuple(c) for c in colors.round(3)}) == (2 if checker else 1)


# -- framing -------------------------------------------------------------------------------


def _walking_sphere(sphere, travel_m, n_frames=40):
    path = np.stack(
        [np.linspace(0, travel_m, n_frames), np.full(n_frames, 0.9), np.zeros(n_frames)], 1
    )
    return sphere.vertices[None] * [1, 3.5, 1] + path[:, None]  # a body-sized ellipsoid


@pytest.mark.parametrize(
    "framing, travel_m", [("fixed", 4.0), ("follow", 4.0), ("auto", 0.3), ("auto", 4.0)]
)
def test_frame_cameras_keep_the_body_in_view(sphere, framing, travel_m):
    vertices = _walking_sphere(sphere, travel_m)
    times_s = np.arange(len(vertices)) / 30.0
    cameras = frame_cameras(vertices, times_s, 35.0, 10.0, 120, 90, framing)
    assert len(cameras) == len(vertices)
    for camera, frame in zip(cameras, vertices, strict=True):
        px, depth = camera.project(frame)
        assert np.all(depth > 0)
        assert px[:, 0].min() >= 0 and px[:, 0].max() <= 119
        assert px[:, 1].min() >= 0 and px[:, 1].max() <= 89
        assert (camera.azimuth_deg, camera.elevation_deg) == (35.0, 10.0)
    follows = len({id(c) for c in cameras}) > 1
    assert follows == (framing == "follow" or (framing == "auto" and travel_m > FOLLOW_TRAVEL_M))
    if follows:  # one orientation and height, the camera only slides along the floor
        for camera in cameras:
            np.testing.assert_allclose(camera.R, cameras[0].R, atol=1e-12)
            assert camera.center[1] == pytest.approx(cameras[0].center[1])
        assert np.ptp([c.center[0] for c in cameras]) > 0.5 * travel_m


def test_follow_frames_the_body_larger_than_fixed(sphere):
    vertices = _walking_sphere(sphere, 6.0)
    times_s = np.arange(len(vertices)) / 30.0
    fixed = frame_cameras(vertices, times_s, 35.0, 10.0, 120, 90, "fixed")
    follow = frame_cameras(vertices, times_s, 35.0, 10.0, 120, 90, "follow")
    height_px = [
        np.ptp(c.project(v)[0][:, 1])
        for c, v in ((fixed[0], vertices[0]), (follow[0], vertices[0]))
    ]
    assert height_px[1] > 1.5 * height_px[0]


@pytest.mark.parametrize(
    "kwargs, match",
    [({"framing": "orbit"}, "framing"), ({"times_s": np.zeros(3)}, "times_s")],
)
def test_frame_cameras_errors(sphere, kwargs, match):
    args = {"vertices": _walking_sphere(sphere, 1.0, 5), "times_s": np.arange(5) / 30.0}
    args.update(kwargs)
    with pytest.raises(InvalidParameterError, match=match):
        frame_cameras(
            args["vertices"], args["times_s"], 0.0, 0.0, 64, 64, args.get("framing", "auto")
        )


# -- the show command ----------------------------------------------------------------------


def _run_cli(argv):
    from eigmotion.cli.main import main

    return main(argv)


def test_show_contact_sheet_of_a_cmu_clip(tmp_path, cmu_dir, capsys):
    from PIL import Image

    out = tmp_path / "sheet.png"
    argv = ["show", str(cmu_dir / "amc" / "02_05.amc"), "--asf", str(cmu_dir / "asf" / "02.asf")]
    argv += [
        "--out",
        str(out),
        "--frames",
        "3",
        "--cols",
        "3",
        "--size",
        "64",
        "80",
        "--view",
        "90",
        "0",
    ]
    assert _run_cli(argv) == 0
    assert "wrote" in capsys.readouterr().out
    sheet = np.asarray(Image.open(out)).astype(int)
    assert sheet.shape[1] == 3 * 64 + 4 * 4
    band = (sheet.shape[0] - 80 - 2 * 4) // 2  # title and label bands, one row of panels
    assert band > 0 and sheet.shape[0] == 2 * band + 80 + 2 * 4
    for c in range(3):
        panel = sheet[band + 4 : band + 4 + 80, 4 + c * 68 : 4 + c * 68 + 64]
        background = np.all(np.abs(panel - _background_u8()) <= 1, axis=-1)
        lit = panel.mean(axis=-1) > 120  # the body (the floor is seen edge-on at elevation 0)
        assert background.sum() > 0.4 * panel[..., 0].size
        assert lit.sum() > 100


@pytest.fixture(scope="module")
def tiny_bvh(tmp_path_factory):
    """A 1 s canonical-skeleton BVH at 30 fps: the body turns and raises an arm."""
    from eigmotion.mocap.bvh import write_bvh
    from eigmotion.mocap.canonical import canonical_skeleton
    from eigmotion.mocap.motion import Motion

    skeleton = canonical_skeleton()
    values = np.zeros((31, skeleton.n_channels))
    start = skeleton.channel_start()
    values[:, start[0] + 5] = np.linspace(0, 90, 31)  # root: X/Y/Z position, Z/X/Y rotation
    values[:, start[skeleton.index("LeftArm")]] = np.linspace(0, 80, 31)  # its Z rotation
    path = tmp_path_factory.mktemp("bvh") / "tiny.bvh"
    write_bvh(Motion(skeleton, values, 1 / 30, 1.0, "tiny"), path)
    return path


@pytest.mark.parametrize("suffix, fps, n_frames", [(".gif", 10, 11), (".mp4", 15, 16)])
def test_show_replay_of_a_bvh(tmp_path, tiny_bvh, suffix, fps, n_frames):
    from eigmotion.imaging.media import read_frames

    out = tmp_path / f"replay{suffix}"
    argv = ["show", str(tiny_bvh), "--out", str(out), "--fps", str(fps), "--size", "48", "64"]
    assert _run_cli(argv + ["--floor", "plain"]) == 0
    frames, read_fps = read_frames(out)
    assert frames.shape[1:] == (64, 48, 3)
    assert len(frames) <= n_frames and len(frames) >= n_frames - 1  # GIF may merge equal frames
    assert read_fps == pytest.approx(fps, rel=0.05)
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 1  # it moves


def test_show_library_motion(tmp_path, capsys):
    from eigmotion.mocap.library import motion_names

    name = motion_names()[0]
    out = tmp_path / "lib.png"
    assert _run_cli(["show", name, "--out", str(out), "--frames", "2", "--size", "48", "48"]) == 0
    assert name in capsys.readouterr().out
    assert out.stat().st_size > 0


def test_show_unknown_library_name(tmp_path, capsys):
    assert _run_cli(["show", "no_such_motion", "--out", str(tmp_path / "o.png")]) == 2
    assert "no_such_motion" in capsys.readouterr().err


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--out", "x.txt"], "unknown output type"),
        (["--out", "x.png", "--fps", "0"], "--fps"),
        (["--out", "x.png", "--view", "0", "95"], "elevation"),
        (["--out", "x.png", "--frames", "0"], "--frames"),
    ],
)
def test_show_bad_arguments(tmp_path, tiny_bvh, capsys, extra, message):
    extra = [str(tmp_path / e) if e.startswith("x.") else e for e in extra]
    assert _run_cli(["show", str(tiny_bvh), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_show_missing_motion(tmp_path, capsys):
    assert _run_cli(["show", str(tmp_path / "none.bvh"), "--out", str(tmp_path / "o.png")]) == 2
    assert "none.bvh" in capsys.readouterr().err
