"""The default avatar: loading, skinning, body shapes and the low-poly copy."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from mesh_helpers import winding_numbers
from scipy.spatial.transform import Rotation

from eigmotion.body.avatar import Avatar, load_avatar, load_default_avatar
from eigmotion.body.makehuman_files import read_obj
from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.canonical import makehuman_dir
from eigmotion.mocap.kinematics import forward_kinematics
from eigmotion.mocap.motion import Motion

# -- geometry helpers -------------------------------------------------------------------


def silhouette_area_m2(
    vertices: np.ndarray, faces: np.ndarray, drop_axis: int, pixel_m: float = 0.002
) -> float:
    """Area of the orthographic projection along ``drop_axis``, rasterised, m²."""
    keep = [i for i in range(3) if i != drop_axis]
    p = np.asarray(vertices, np.float64)[:, keep]
    sub = 16  # 4 fractional bits for cv2
    q = np.round((p - p.min(axis=0) + 0.01) / pixel_m * sub).astype(np.int32)
    width, height = q.max(axis=0) // sub + 2
    img = np.zeros((height, width), np.uint8)
    for tri in q[faces]:
        cv2.fillConvexPoly(img, tri.reshape(3, 1, 2), 1, lineType=cv2.LINE_8, shift=4)
    return float(img.sum()) * pixel_m**2


def edge_counts(faces: np.ndarray) -> np.ndarray:
    """How many faces share each undirected edge."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), 1)
    return np.unique(edges, axis=0, return_counts=True)[1]


def signed_volume_m3(vertices: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (np.asarray(vertices, np.float64)[faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)


def rest_transforms(avatar: Avatar, n_frames: int = 1):
    rot = np.broadcast_to(np.eye(3), (n_frames, avatar.n_joints, 3, 3))
    pos = np.broadcast_to(avatar.joint_positions, (n_frames, avatar.n_joints, 3))
    return rot, pos


@pytest.fixture(scope="module")
def avatar() -> Avatar:
    return load_default_avatar()


@pytest.fixture(scope="module")
def low(avatar) -> Avatar:
    return avatar.decimated(4000)


# -- the default avatar -----------------------------------------------------------------
def test_default_avatar_is_the_makehuman_body(avatar):
    assert avatar.n_vertices == 13380 and avatar.n_faces == 2 * 13378
    assert avatar.vertices.dtype == np.float32 and avatar.faces.dtype == np.int32
    assert avatar.weights.shape == (13380, 31)
    np.testing.assert_allclose(avatar.weights.sum(axis=1), 1.0, atol=1e-5)
    assert avatar.vertices[:, 1].min() == 0.0  # feet on the floor
    assert 1.55 < avatar.height_m < 1.8
    # Facing +Z, left side towards +X.
    j = avatar.joint_index
    assert avatar.bone_tails[j("LeftFoot"), 2] > avatar.joint_positions[j("LeftFoot"), 2] + 0.05
    assert avatar.joint_positions[j("LeftUpLeg"), 0] > 0.05
    assert avatar.joint_positions[j("RightUpLeg"), 0] < -0.05
    with pytest.raises(ValueError):
        avatar.vertices[0, 0] = 1.0  # shared and cached: read-only
    assert load_default_avatar() is avatar


def test_body_mesh_is_closed_and_outward(avatar):
    counts = edge_counts(avatar.faces)
    assert np.all(counts == 2)  # watertight, every edge in exactly two triangles
    volume = signed_volume_m3(avatar.vertices, avatar.faces)
    assert 0.04 < volume < 0.08  # m³ of a 50-70 kg body, positive: faces outward


def test_rig_sits_inside_the_body(avatar):
    # Every joint (hip inside the pelvis, ankles, knees, fingers …) and every bone
    # tail but the top of the head lies inside the closed body mesh.
    inside = winding_numbers(avatar.joint_positions, avatar.vertices, avatar.faces)
    assert np.all(inside > 0.5), [
        n for n, w in zip(avatar.joint_names, inside, strict=True) if w < 0.5
    ]
    tails = winding_numbers(avatar.bone_tails, avatar.vertices, avatar.faces)
    outside = {n for n, w in zip(avatar.joint_names, tails, strict=True) if w < 0.5}
    assert outside <= {"Head"}


# -- skinning -------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["full", "decimated"])
def test_rest_pose_skins_to_the_rest_mesh(avatar, low, which):
    mesh = avatar if which == "full" else low
    posed = mesh.skin(*rest_transforms(mesh, 3))
    assert posed.shape == (3, mesh.n_vertices, 3) and posed.dtype == np.float32
    np.testing.assert_allclose(posed, np.broadcast_to(mesh.vertices, posed.shape), atol=1e-5)


@pytest.mark.parametrize("shift", [(0.5, 0.0, 0.0), (0.0, 1.2, 0.0), (-3.0, 0.2, 7.5)])
def test_root_translation_moves_every_vertex(avatar, shift):
    rot, pos = rest_transforms(avatar)
    posed = avatar.skin(rot, pos + np.asarray(shift))[0]
    np.testing.assert_allclose(
        posed - avatar.vertices, np.broadcast_to(shift, posed.shape), atol=2e-5
    )


@pytest.mark.parametrize("seed", [0, 1])
def test_rigid_rotation_rotates_the_whole_mesh(avatar, seed):
    rot = Rotation.random(random_state=seed).as_matrix()
    root = avatar.joint_positions[0]
    positions = (avatar.joint_positions - root) @ rot.T + root
    rotations = np.broadcast_to(rot, (avatar.n_joints, 3, 3))
    posed = avatar.skin(rotations[None], positions[None])[0]
    expected = (avatar.vertices - root) @ rot.T + root
    np.testing.assert_allclose(posed, expected, atol=2e-5)


def test_one_bone_moves_only_its_vertices(avatar):
    j = avatar.joint_index("LeftForeArm")
    rot, pos = rest_transforms(avatar)
    rot = rot.copy()
    rot[0, j] = Rotation.from_euler("x", 60, degrees=True).as_matrix()
    moved = np.linalg.norm(avatar.skin(rot, pos)[0] - avatar.vertices, axis=1) > 1e-6
    np.testing.assert_array_equal(moved, avatar.weights[:, j] > 0)


def test_skin_subset_matches_full(avatar):
    rng = np.random.default_rng(3)
    rot = Rotation.random(4 * 31, random_state=3).as_matrix().reshape(4, 31, 3, 3)
    pos = rng.normal(size=(4, 31, 3))
    ids = np.array([0, 17, 4000, 13379])
    np.testing.assert_allclose(avatar.skin(rot, pos, ids), avatar.skin(rot, pos)[:, ids], atol=1e-6)


def test_skin_rejects_bad_shapes(avatar):
    with pytest.raises(InvalidParameterError, match=r"\(F, 31, 3, 3\)"):
        avatar.skin(np.zeros((2, 30, 3, 3)), np.zeros((2, 30, 3)))
    with pytest.raises(InvalidParameterError, match="vertex_ids"):
        avatar.skin(*rest_transforms(avatar), vertex_ids=[13380])


# -- body shapes ----------------------------------------------------------------------
def _torso_radius_m(avatar: Avatar) -> float:
    """Mean distance of the trunk vertices from the spine bones' segments."""
    trunk = [avatar.joint_index(n) for n in ("LowerBack", "Spine", "Spine1")]
    owner = np.argmax(avatar.weights, axis=1)
    dist = []
    for j in trunk:
        v = avatar.vertices[owner == j].astype(np.float64)
        head, tail = avatar.joint_positions[j], avatar.bone_tails[j]
        t = np.clip((v - head) @ (tail - head) / np.sum((tail - head) ** 2), 0, 1)
        dist.append(np.linalg.norm(v - head - t[:, None] * (tail - head), axis=1))
    return float(np.concatenate(dist).mean())


@pytest.mark.parametrize(
    "height_m, girth", [(1.5, 1.0), (1.9, 1.0), (None, 1.3), (1.75, 0.8), (1.6, 1.5)]
)
def test_with_shape_sets_height_and_girth(avatar, height_m, girth):
    shaped = avatar.with_shape(height_m=height_m, girth=girth)
    target = avatar.height_m if height_m is None else height_m
    assert shaped.height_m == pytest.approx(target, abs=0.01 if height_m is None else 1e-4)
    assert shaped.vertices[:, 1].min() == pytest.approx(0.0, abs=1e-6)
    scale = shaped.height_m / avatar.height_m
    ratio = _torso_radius_m(shaped) / (scale * _torso_radius_m(avatar))
    assert ratio == pytest.approx(girth, rel=0.1)
    # Bones keep their proportions: joints scale with the height, girth leaves them.
    bones = np.linalg.norm(np.diff(shaped.joint_positions[[0, 3]], axis=0))
    rest = np.linalg.norm(np.diff(avatar.joint_positions[[0, 3]], axis=0))
    assert bones == pytest.approx(scale * rest, rel=0.01)
    inside = winding_numbers(shaped.joint_positions, shaped.vertices, shaped.faces)
    assert np.all(inside > 0.5)
    assert np.all(edge_counts(shaped.faces) == 2)


@pytest.mark.parametrize("kwargs", [{"girth": 0.3}, {"girth": np.nan}, {"height_m": 4.0}])
def test_with_shape_rejects_out_of_range(avatar, kwargs):
    with pytest.raises(InvalidParameterError, match=next(iter(kwargs))):
        avatar.with_shape(**kwargs)


# -- the low-poly copy ----------------------------------------------------------------
def test_decimated_is_a_closed_low_poly_body(avatar, low):
    assert 1900 <= low.n_vertices <= 2100 and low.n_faces == 4000
    counts = edge_counts(low.faces)
    assert np.mean(counts == 2) > 0.995  # closed up to a few non-manifold edges
    assert signed_volume_m3(low.vertices, low.faces) == pytest.approx(
        signed_volume_m3(avatar.vertices, avatar.faces), rel=0.03
    )
    np.testing.assert_allclose(low.weights.sum(axis=1), 1.0, atol=1e-5)
    np.testing.assert_array_equal(low.joint_positions, avatar.joint_positions)


@pytest.mark.parametrize("drop_axis", [0, 1, 2])
def test_decimated_silhouette_area_close_to_full(avatar, low, drop_axis):
    full = silhouette_area_m2(avatar.vertices, avatar.faces, drop_axis)
    small = silhouette_area_m2(low.vertices, low.faces, drop_axis)
    assert small == pytest.approx(full, rel=0.03)


def posed_transforms(avatar: Avatar, local_deg: dict[str, tuple[str, float]]):
    """World rotations and positions (1, J, …) for local rotations of some joints."""
    skeleton = avatar.skeleton()
    local = np.broadcast_to(np.eye(3), (1, avatar.n_joints, 3, 3)).copy()
    for name, (axis, angle) in local_deg.items():
        local[0, avatar.joint_index(name)] = Rotation.from_euler(
            axis, angle, degrees=True
        ).as_matrix()
    motion = Motion.from_local_transforms(
        skeleton, local, avatar.joint_positions[:1], 1 / 30, length_unit_m=1.0
    )
    pose = forward_kinematics(motion, ground=False)
    return pose.rotations, pose.positions


def test_skeleton_forward_kinematics_reproduces_the_rest_joints(avatar):
    rot, pos = posed_transforms(avatar, {})
    np.testing.assert_allclose(pos[0], avatar.joint_positions, atol=1e-12)
    np.testing.assert_allclose(rot[0], np.broadcast_to(np.eye(3), rot[0].shape), atol=1e-12)


def test_decimated_silhouette_area_close_to_full_when_posed(avatar, low):
    # Arms raised and a knee bent: the transferred weights must follow the bones.
    rot, pos = posed_transforms(
        avatar, {"LeftArm": ("z", 110), "RightArm": ("z", -110), "LeftLeg": ("x", 80)}
    )
    full = avatar.skin(rot, pos)[0]
    small = low.skin(rot, pos)[0]
    assert full[:, 1].max() > avatar.height_m  # the hands are above the head
    for axis in (0, 2):
        assert silhouette_area_m2(small, low.faces, axis) == pytest.approx(
            silhouette_area_m2(full, avatar.faces, axis), rel=0.03
        )


@pytest.mark.parametrize("n_faces", [10, 26756, 30000, 2000.5])
def test_decimated_rejects_bad_face_counts(avatar, n_faces):
    with pytest.raises(InvalidParameterError, match="n_faces"):
        avatar.decimated(n_faces)


# -- loading errors -------------------------------------------------------------------
def test_obj_reader_names_file_and_line(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\ng body\nf 1 2 7\n")
    with pytest.raises(InvalidParameterError, match=r"bad\.obj:5"):
        read_obj(bad)
    bad.write_text("v 0 0 zero\n")
    with pytest.raises(InvalidParameterError, match=r"bad\.obj:1"):
        read_obj(bad)


def test_load_avatar_rejects_a_missing_body_group(tmp_path):
    obj = tmp_path / "tiny.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\ng helper\nf 1 2 3\n")
    root = makehuman_dir()
    with pytest.raises(InvalidParameterError, match="body"):
        load_avatar(obj, root / "rig.cmu_mb.json", root / "weights.cmu_mb.json")
