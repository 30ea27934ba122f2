"""A proxy body for any skeleton: one tapered capsule around every bone.

Skeletons with no skinned mesh (animals, robots, a BVH of an unknown rig) still need
a body to be filmed by the virtual cameras.  :func:`proxy_body` wraps each bone
(joint → child joint, and joint → End Site) of a posed skeleton in a capsule whose
radius tapers from the bone's head to its tail, and returns one triangle mesh per
frame with a fixed topology (same faces every frame), ready for the silhouette
renderer.

Each capsule is built once in the rest frame of the joint that carries it and moved
rigidly with that joint's world rotation, so it follows the bone's twist too.
Radii default to a fraction of the bone length, clipped to a range, so long bones
are thick and short ones thin, whatever the creature.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.kinematics import Pose
from eigmotion.mocap.rotations import rotation_between

#: Head radius of a bone as a fraction of its length.
RADIUS_RATIO = 0.18

#: Tail radius ÷ head radius.
TAPER = 0.75

#: Default radii are clipped to these fractions of the skeleton's size (the largest
#: extent of its first frame): a 1.7 m person gets radii in [5.1, 13.6] cm, so the
#: short spine and neck segments still make a trunk.
MIN_RADIUS_FRACTION = 0.03
MAX_RADIUS_FRACTION = 0.08

#: Bones shorter than this (metres) get no capsule (e.g. a hip joint sitting on the
#: pelvis joint).
MIN_BONE_M = 1e-3


@dataclass(frozen=True, eq=False)
class ProxyBody:
    """A posed proxy body: capsule meshes over frames.

    Attributes
    ----------
    vertices : (F, V, 3) float32
        Mesh vertices per frame, metres, Y up.
    faces : (T, 3) int32
        Triangles (counter-clockwise seen from outside), the same every frame.
    bones : (B, 2) int64
        Per capsule, the joint it hangs from and the joint it reaches; a second
        index ``>= J`` is End Site ``k = index - J`` of the pose.
    radii_m : (B, 2) float64
        Head and tail radius of each capsule, metres.

    Capsule ``b`` owns the ``V / B`` consecutive vertex rows starting at
    ``b * V / B`` (see :meth:`vertex_bone`).
    """

    vertices: np.ndarray
    faces: np.ndarray
    bones: np.ndarray
    radii_m: np.ndarray

    @property
    def n_capsules(self) -> int:
        return self.bones.shape[0]

    @property
    def n_frames(self) -> int:
        return self.vertices.shape[0]

    def vertex_bone(self) -> np.ndarray:
        """(V,) int64: the capsule (row of :attr:`bones`) each vertex belongs to."""
        per = self.vertices.shape[1] // max(self.n_capsules, 1)
        return np.repeat(np.arange(self.n_capsules), per)


def capsule_mesh(
    length_m: float, head_radius_m: float, tail_radius_m: float, n_sides: int = 12, n_cap: int = 4
) -> tuple[np.ndarray, np.ndarray]:
    """A closed tapered capsule along +Y from the origin to ``(0, length_m, 0)``.

    Two hemispheres (radius ``head_radius_m`` at the origin, ``tail_radius_m`` at the
    tail) joined by a truncated cone.

    Parameters
    ----------
    length_m : float
        Distance between the two sphere centres, metres (> 0).
    head_radius_m, tail_radius_m : float
        Radii, metres (> 0).
    n_sides : int
        Vertices around the axis (>= 3).
    n_cap : int
        Rings per hemisphere, pole excluded (>= 1).

    Returns
    -------
    vertices : (2 + 2 * n_cap * n_sides, 3) float64
    faces : (4 * n_cap * n_sides - 2 * n_sides, 3) int32
        Closed, outward-facing.
    """
    if n_sides < 3 or n_cap < 1:
        raise InvalidParameterError(f"need n_sides >= 3 and n_cap >= 1, got {n_sides}, {n_cap}")
    if not (length_m > 0 and head_radius_m > 0 and tail_radius_m > 0):
        raise InvalidParameterError(
            f"capsule length and radii must be > 0, got {length_m}, {head_radius_m}, "
            f"{tail_radius_m}"
        )
    angle = 2 * np.pi * np.arange(n_sides) / n_sides
    # Clockwise about +Y, so that the faces below wind counter-clockwise outside.
    circle = np.stack([np.cos(angle), np.zeros(n_sides), np.sin(angle)], axis=1)
    # Latitudes from the head pole (-90°) to the equator, then equator to tail pole.
    lat = np.linspace(-np.pi / 2, 0.0, n_cap + 1)[1:]
    rings = []
    for centre_y, radius, lats in (
        (0.0, head_radius_m, lat),
        (length_m, tail_radius_m, -lat[::-1]),
    ):
        for phi in lats:
            ring = circle * radius * np.cos(phi)
            ring[:, 1] = centre_y + radius * np.sin(phi)
            rings.append(ring)
    head_pole = np.array([[0.0, -head_radius_m, 0.0]])
    tail_pole = np.array([[0.0, length_m + tail_radius_m, 0.0]])
    vertices = np.concatenate([head_pole, *rings, tail_pole])
    n_rings = len(rings)
    faces = []
    k = np.arange(n_sides)
    k1 = (k + 1) % n_sides
    first = 1
    faces.append(np.stack([np.zeros(n_sides, int), first + k, first + k1], axis=1))
    for r in range(n_rings - 1):
        a = first + r * n_sides
        b = a + n_sides
        faces.append(np.stack([a + k, b + k, b + k1], axis=1))
        faces.append(np.stack([a + k, b + k1, a + k1], axis=1))
    last = first + (n_rings - 1) * n_sides
    pole = len(vertices) - 1
    faces.append(np.stack([np.full(n_sides, pole), last + k1, last + k], axis=1))
    return vertices, np.concatenate(faces).astype(np.int32)


def proxy_body(
    pose: Pose,
    radii_m: np.ndarray | None = None,
    radius_ratio: float = RADIUS_RATIO,
    taper: float = TAPER,
    n_sides: int = 12,
    n_cap: int = 4,
) -> ProxyBody:
    """Tapered capsules around every bone of a posed skeleton.

    Parameters
    ----------
    pose : Pose
        From :func:`eigmotion.mocap.kinematics.forward_kinematics`; any skeleton.
    radii_m : (B, 2) float or (B,) float, optional
        Head and tail radius per capsule (one value: both), metres, for the bones
        in the order :attr:`ProxyBody.bones` lists them (call once without it to
        see that order).  Default: ``radius_ratio × bone length`` at the head,
        ``taper`` times that at the tail, clipped to
        [:data:`MIN_RADIUS_FRACTION`, :data:`MAX_RADIUS_FRACTION`] × the skeleton's
        size.
    radius_ratio : float
        Head radius ÷ bone length for the default radii (> 0).
    taper : float
        Tail radius ÷ head radius for the default radii, in (0, 2].
    n_sides, n_cap : int
        Capsule resolution (see :func:`capsule_mesh`).

    Returns
    -------
    ProxyBody
        Capsule ``b`` hangs from joint ``bones[b, 0]`` and reaches ``bones[b, 1]``.
    """
    if not (np.isfinite(radius_ratio) and radius_ratio > 0):
        raise InvalidParameterError(f"radius_ratio must be > 0, got {radius_ratio!r}")
    if not (np.isfinite(taper) and 0 < taper <= 2):
        raise InvalidParameterError(f"taper must lie in (0, 2], got {taper!r}")
    n_j = len(pose.names)
    if pose.n_frames == 0:
        raise InvalidParameterError("the pose has no frames")
    points = pose.all_points()  # (F, J + E, 3)
    carriers = np.concatenate([pose.parents[1:], pose.end_site_joints])
    reached = np.concatenate([np.arange(1, n_j), n_j + np.arange(len(pose.end_site_joints))])
    keep = carriers >= 0
    carriers, reached = carriers[keep], reached[keep]
    # Bones are rigid in their carrier's frame: the rest direction from frame 0.
    rot0 = pose.rotations[0, carriers]
    local = np.einsum("bki,bk->bi", rot0, points[0, reached] - points[0, carriers])
    lengths = np.linalg.norm(local, axis=1)
    long_enough = lengths > MIN_BONE_M
    carriers, reached = carriers[long_enough], reached[long_enough]
    local, lengths = local[long_enough], lengths[long_enough]
    n_b = len(carriers)
    if n_b == 0:
        raise InvalidParameterError(
            f"the skeleton has no bone longer than {MIN_BONE_M} m to wrap in a capsule"
        )
    if radii_m is None:
        size_m = float(np.ptp(points[0], axis=0).max())
        lo, hi = MIN_RADIUS_FRACTION * size_m, MAX_RADIUS_FRACTION * size_m
        head = np.clip(radius_ratio * lengths, lo, hi)
        radii = np.stack([head, np.clip(taper * head, lo, hi)], axis=1)
    else:
        radii = np.asarray(radii_m, dtype=np.float64)
        if radii.ndim == 1:
            radii = np.stack([radii, radii], axis=1) if radii.size == n_b else radii
        if radii.shape != (n_b, 2) or not np.all(np.isfinite(radii)) or np.any(radii <= 0):
            raise InvalidParameterError(
                f"radii_m must be {n_b} positive radii, shape ({n_b},) or ({n_b}, 2), "
                f"got shape {np.shape(radii_m)}"
            )
    meshes = []
    for b in range(n_b):
        verts, faces = capsule_mesh(lengths[b], radii[b, 0], radii[b, 1], n_sides, n_cap)
        # Turn +Y onto the bone's direction in its carrier's rest frame.
        meshes.append((verts @ _rotation_from_y(local[b] / lengths[b]).T, faces))
    per_v = len(meshes[0][0])
    template = np.stack([m[0] for m in meshes])  # (B, per_v, 3)
    faces = np.concatenate([m[1] + b * per_v for b, m in enumerate(meshes)])
    rot_t = np.swapaxes(pose.rotations[:, carriers], -1, -2).astype(np.float32)  # (F, B, 3, 3)
    origin = points[:, carriers].astype(np.float32)  # (F, B, 3)
    vertices = np.matmul(template.astype(np.float32)[None], rot_t) + origin[:, :, None, :]
    return ProxyBody(
        vertices.reshape(pose.n_frames, n_b * per_v, 3),
        faces.astype(np.int32),
        np.stack([carriers, reached], axis=1).astype(np.int64),
        radii,
    )


def _rotation_from_y(direction: np.ndarray) -> np.ndarray:
    """(3, 3) rotation taking +Y onto the unit vector ``direction``."""
    return rotation_between(np.array([0.0, 1.0, 0.0]), direction)
