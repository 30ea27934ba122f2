"""Garments for the avatar: skirts, coats and trousers that change the silhouette.

A garment is lofted around the body in its rest pose: rings of points around the
body's own cross-sections (the convex hull of the body's vertices near each ring,
plus some ease), joined into a thin double-walled tube that is a closed triangle
mesh with outward faces.  Two kinds of tube:

* *torso tubes* (skirt, coat, the seat of trousers) have horizontal rings from a
  top height (waist or neck) down to a hem.  Below the hip joints a ring is never
  narrower than the ring above it and flares out towards the hem, so a skirt hangs
  as one tube over both thighs instead of wrapping each leg;
* *limb tubes* (sleeves, trouser legs) have rings perpendicular to a bone chain
  (shoulder → elbow → wrist, hip → knee → ankle).

Skinning: every garment vertex takes the skin weights of its nearest body vertex
among the bones the tube covers (a coat's body: trunk, legs, neck and shoulder caps,
not the arms beside it; a sleeve or trouser leg: its limb and the trunk, so that its
top stretches over the joint as the skin does).  A hem below the crotch would tear
there, half of it taking the left thigh's weights and half the right one's; so from
the hip joints down to the crotch a torso tube blends into *hanging* weights: a
share :data:`LEG_FOLLOW` on the two thighs, mixed left to right across the front and
back (half each on the centre line), and the rest on the pelvis.  The skirt then
swings with the thighs and its centre line hangs between them.  Weights are finally
averaged over the garment's neighbouring vertices a few times so that they change
smoothly.

A :class:`DressedAvatar` is an :class:`~eigmotion.body.avatar.Avatar` whose mesh is the
body followed by its garments (vertices, faces and weights merged), so skinning,
retargeting, both silhouette rasterisers and the shaded renderer take it unchanged.
Its :meth:`~DressedAvatar.decimated` simplifies the body only and keeps the garments
(the named ones have 480 to 1,424 faces); :meth:`~DressedAvatar.with_shape`
reshapes the body and dresses it again, so the clothes fit the new body.  Ring
spacings are fractions of the body's height, so a garment has about as many faces
on a short body as on a tall one.

Garments :data:`BENCHMARK_GARMENTS` are held out of databases, to test recognition
of people in clothes never seen; :data:`DATABASE_GARMENTS` are other shapes, to
vary the database.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Real
from typing import ClassVar

import numpy as np

from eigmotion.body.avatar import DEFAULT_LOW_POLY_FACES, Avatar
from eigmotion.errors import InvalidParameterError
from eigmotion.validation import Interval, Options, validate_params

#: Wall thickness of every garment, metres.
THICKNESS_M = 0.006
#: Least ease over the skin of every ring per garment kind, metres (a tenth of the
#: garment's looseness is added): a coat is worn over other clothes.
EASE_M = {"skirt": 0.015, "coat": 0.03, "trousers": 0.015}
#: Points around a torso ring and around a limb ring.
TORSO_SEGMENTS = 20
LIMB_SEGMENTS = 8
#: Largest ring spacing above the hip joints (where the body's cross-section changes
#: fast), below them (a hanging skirt is a smooth cone) and along limbs, as fractions
#: of the body's height (7.5, 14 and 10 cm on the 1.67 m default body).
UPPER_RING_SPACING = 0.045
HANGING_RING_SPACING = 0.084
LIMB_RING_SPACING = 0.06
#: Body vertices within this distance along the limb of a limb ring shape it, as a
#: fraction of the body's height (5 cm).
LIMB_SLAB = 0.03
#: A torso ring is shaped by the body between its neighbour rings; the first ring by
#: the body within this height of it (the last one: down to this below it), metres.
EDGE_SLAB_M = 0.01
#: Share of the thighs in the weights of a hanging hem (the rest is on the pelvis).
LEG_FOLLOW = 0.8
#: Neighbour-averaging passes over a garment's weights; weights below
#: :data:`MIN_WEIGHT` are then dropped.
WEIGHT_SMOOTHING_ITERATIONS = 6
MIN_WEIGHT = 0.02

#: Bones of the body's trunk (pelvis to neck), of each arm and of each leg.
TRUNK_JOINTS = ("Hips", "LHipJoint", "RHipJoint", "LowerBack", "Spine", "Spine1", "Neck")
NECK_JOINTS = ("Neck1", "LeftShoulder", "RightShoulder")
ARM_CHAINS = {
    "Left": ("LeftArm", "LeftForeArm", "LeftHand"),
    "Right": ("RightArm", "RightForeArm", "RightHand"),
}
LEG_CHAINS = {
    "Left": ("LeftUpLeg", "LeftLeg", "LeftFoot"),
    "Right": ("RightUpLeg", "RightLeg", "RightFoot"),
}
THIGH_JOINTS = ("LeftUpLeg", "RightUpLeg")
#: The legs, around which a skirt or coat hangs.
LEG_JOINTS = THIGH_JOINTS + ("LeftLeg", "RightLeg")

#: Garment kinds: a tube hanging from the waist, a tube hanging from the neck with
#: optional sleeves, a seat and two leg tubes.
KINDS = ("skirt", "coat", "trousers")

#: Where the waistband sits on the lower back bone (0 = its head, 1 = its tail).
WAIST_ALONG_LOWER_BACK = 0.6
#: How far the seat of trousers reaches below the crotch, metres.
SEAT_BELOW_CROTCH_M = 0.03
#: How far a sleeve starts before the shoulder joint (over the shoulder), metres.
SLEEVE_START_M = 0.05
#: Upper-arm flesh this far past the shoulder joint is part of a coat's body, metres.
SHOULDER_CAP_M = 0.05


@dataclass(frozen=True)
class Garment:
    """A garment pattern: its kind and its measures, fitted to any body.

    Parameters
    ----------
    name : str
    kind : {"skirt", "coat", "trousers"}
        ``skirt``: a tube from the waist to the hem; ``coat``: a tube from the middle
        of the neck to the hem, with sleeves; ``trousers``: a seat from the waist to
        the crotch and one tube per leg.
    length : float
        Where the hem is, along the legs: 0 at the hip joints, 1 at the ankles (the
        knees are at about 0.53), in [0.05, 1].
    looseness_m : float
        Ease, metres, in [0, 0.25]: how far a skirt or coat flares out at its hem
        beyond the hips (its waist and chest get a tenth of it), how much wider than
        the leg a trouser leg is at its hem.
    sleeves : float
        Sleeve length as a fraction of the arm from shoulder to wrist, in [0, 1]
        (coats only; 0 = none).
    rgb : (3,) float
        Colour in the shaded renderings, linear RGB in [0, 1].
    held_out : bool
        A benchmark garment, never used to build a database.
    """

    name: str
    kind: str
    length: float
    looseness_m: float
    sleeves: float = 0.0
    rgb: tuple[float, float, float] = (0.3, 0.35, 0.5)
    held_out: bool = False

    #: The valid values of the measures (see :mod:`eigmotion.validation`); that only a
    #: coat has sleeves, and the colour, are checked after.
    _parameter_constraints: ClassVar[dict] = {
        "kind": Options(str, list(KINDS)),
        "length": Interval(Real, 0.05, 1.0, noun=""),
        "looseness_m": Interval(Real, 0.0, 0.25, noun=""),
        "sleeves": Interval(Real, 0.0, 1.0, noun=""),
    }

    def __post_init__(self):
        validate_params(self, self._parameter_constraints, context=f"garment {self.name!r}: ")
        if self.sleeves and self.kind != "coat":
            raise InvalidParameterError(
                f"garment {self.name!r}: only a coat has sleeves, got sleeves={self.sleeves}"
            )
        rgb = np.asarray(self.rgb, dtype=np.float64)
        if rgb.shape != (3,) or not np.all((rgb >= 0) & (rgb <= 1)):
            raise InvalidParameterError(
                f"garment {self.name!r}: rgb must be three numbers in [0, 1], got {self.rgb!r}"
            )
        object.__setattr__(self, "rgb", tuple(float(c) for c in rgb))


#: The named garments.  Benchmark (held-out) ones first.
GARMENTS: dict[str, Garment] = {
    g.name: g
    for g in (
        Garment("skirt", "skirt", 0.55, 0.07, rgb=(0.55, 0.16, 0.2), held_out=True),
        Garment("long_coat", "coat", 0.68, 0.1, 0.97, (0.28, 0.24, 0.2), held_out=True),
        Garment("loose_trousers", "trousers", 0.95, 0.06, rgb=(0.2, 0.3, 0.42), held_out=True),
        Garment("short_skirt", "skirt", 0.28, 0.1, rgb=(0.2, 0.45, 0.3)),
        Garment("jacket", "coat", 0.05, 0.02, 0.9, (0.35, 0.38, 0.2)),
        Garment("wide_shorts", "trousers", 0.4, 0.05, rgb=(0.45, 0.38, 0.25)),
        Garment("cropped_trousers", "trousers", 0.75, 0.04, rgb=(0.25, 0.25, 0.3)),
    )
}
#: Garments held out of databases, for the benchmark.
BENCHMARK_GARMENTS = tuple(name for name, g in GARMENTS.items() if g.held_out)
#: Garments used to vary a database.
DATABASE_GARMENTS = tuple(name for name, g in GARMENTS.items() if not g.held_out)


def garment(name: str | Garment) -> Garment:
    """The named garment (a :class:`Garment` is returned as it is).

    Raises
    ------
    InvalidParameterError
        An unknown name; the message lists the known ones.
    """
    if isinstance(name, Garment):
        return name
    try:
        return GARMENTS[name]
    except (KeyError, TypeError):
        raise InvalidParameterError(
            f"unknown garment {name!r}; known garments: {', '.join(GARMENTS)}"
        ) from None


@dataclass(frozen=True, eq=False)
class GarmentMesh:
    """One garment fitted to a body, skinned to the body's skeleton.

    Attributes
    ----------
    garment : Garment
    vertices : (V, 3) float32
        Rest-pose vertices, metres (the body's frame).
    faces : (T, 3) int32
        Triangles, counter-clockwise seen from outside; closed (every edge in two).
    weights : (V, J) float32
        Skin weights on the body's joints, rows summing to 1.
    """

    garment: Garment
    vertices: np.ndarray
    faces: np.ndarray
    weights: np.ndarray

    @property
    def n_faces(self) -> int:
        return self.faces.shape[0]


def garment_mesh(body: Avatar, item: str | Garment) -> GarmentMesh:
    """Fit a garment to a body in its rest pose and skin it.

    Parameters
    ----------
    body : Avatar
        A body on the canonical skeleton (any shape, any resolution).
    item : str or Garment
        A name from :data:`GARMENTS` or a pattern.

    Returns
    -------
    GarmentMesh
    """
    item = garment(item)
    fit = _BodyFit(body)
    ease = EASE_M[item.kind] + 0.1 * item.looseness_m
    tubes = []
    if item.kind == "coat":
        joints = TRUNK_JOINTS + LEG_JOINTS + NECK_JOINTS
        hem_y = fit.hem_y(item.length)
        tubes.append(fit.torso_tube(fit.neck_y, hem_y, ease, item.looseness_m, joints, True))
        if item.sleeves:
            for chain in ARM_CHAINS.values():
                tubes.append(fit.limb_tube(chain, -SLEEVE_START_M, item.sleeves, ease, 0.0))
    elif item.kind == "skirt":
        joints = TRUNK_JOINTS + LEG_JOINTS
        hem_y = fit.hem_y(item.length)
        tubes.append(fit.torso_tube(fit.waist_y, hem_y, ease, item.looseness_m, joints))
    else:
        seat_hem = fit.crotch_y - SEAT_BELOW_CROTCH_M
        tubes.append(fit.torso_tube(fit.waist_y, seat_hem, ease, 0.0, TRUNK_JOINTS + THIGH_JOINTS))
        for chain in LEG_CHAINS.values():
            tubes.append(fit.limb_tube(chain, 0.0, item.length, ease, item.looseness_m))
    vertices, faces, weights = [], [], []
    offset = 0
    for rings, centres, ring_weights in tubes:
        v, f = _shell(rings, centres, THICKNESS_M)
        vertices.append(v)
        faces.append(f + offset)
        w = ring_weights.reshape(-1, body.n_joints)
        weights.append(np.concatenate([w, w]))  # the inner wall moves with the outer
        offset += len(v)
    return GarmentMesh(
        item,
        np.concatenate(vertices).astype(np.float32),
        np.concatenate(faces).astype(np.int32),
        np.concatenate(weights).astype(np.float32),
    )


class _BodyFit:
    """Measures of one body in its rest pose, and the tubes fitted to it."""

    def __init__(self, body: Avatar):
        self.body = body
        self.owner = np.argmax(body.weights, axis=1)
        j = body.joint_index
        heads = body.joint_positions
        self.hip_y = float(heads[[j("LeftUpLeg"), j("RightUpLeg")], 1].mean())
        self.ankle_y = float(heads[[j("LeftFoot"), j("RightFoot")], 1].mean())
        self.hip_half_width = float(abs(heads[j("LeftUpLeg"), 0] - heads[j("RightUpLeg"), 0]) / 2)
        self.centre_x = float(heads[[j("LeftUpLeg"), j("RightUpLeg")], 0].mean())
        back = j("LowerBack")
        self.waist_y = float(
            heads[back, 1] + WAIST_ALONG_LOWER_BACK * (body.bone_tails[back, 1] - heads[back, 1])
        )
        neck = j("Neck")
        self.neck_y = float(0.5 * (heads[neck, 1] + body.bone_tails[neck, 1]))
        # The crotch: the highest point of the gap between the thighs, i.e. the lowest
        # body vertex on the centre line between the hip joints and the knees.
        v = body.vertices
        knee_y = float(heads[[j("LeftLeg"), j("RightLeg")], 1].mean())
        middle = (np.abs(v[:, 0] - self.centre_x) < 0.2 * self.hip_half_width) & (v[:, 1] > knee_y)
        self.crotch_y = float(v[middle, 1].min()) if middle.any() else self.hip_y

    def hem_y(self, length: float) -> float:
        return self.hip_y + length * (self.ankle_y - self.hip_y)

    def vertex_ids(self, joints: Sequence[str]) -> np.ndarray:
        """Body vertices whose largest weight is on one of ``joints``."""
        ids = [self.body.joint_index(n) for n in joints]
        return np.flatnonzero(np.isin(self.owner, ids))

    def shoulder_ids(self) -> np.ndarray:
        """Upper-arm vertices over the shoulder joints (less than
        :data:`SHOULDER_CAP_M` along the arm past them): the top of the shoulders."""
        out = []
        for chain in ARM_CHAINS.values():
            ids = self.vertex_ids(chain[:1])
            joints = self.body.joint_positions[[self.body.joint_index(n) for n in chain]]
            arcs = _arc_coordinates(self.body.vertices[ids].astype(np.float64), joints)
            out.append(ids[arcs < SHOULDER_CAP_M])
        return np.concatenate(out)

    def nearest_weights(self, points: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """(P, J) skin weights of the nearest body vertex among vertices ``ids``."""
        # Lazy: a query imports this module (a database's build config names garments), and
        # scipy.spatial would cost it ~0.14 s.
        from scipy.spatial import cKDTree

        _, nearest = cKDTree(self.body.vertices[ids]).query(points.reshape(-1, 3))
        return self.body.weights[ids[nearest]].astype(np.float64)

    def hanging_weights(self, points: np.ndarray) -> np.ndarray:
        """(P, J) weights of a hanging hem: pelvis and both thighs, mixed left to right."""
        j = self.body.joint_index
        left = np.clip(0.5 + (points[:, 0] - self.centre_x) / (2 * self.hip_half_width), 0, 1)
        out = np.zeros((len(points), self.body.n_joints))
        out[:, j("Hips")] = 1.0 - LEG_FOLLOW
        out[:, j("LeftUpLeg")] = LEG_FOLLOW * left
        out[:, j("RightUpLeg")] = LEG_FOLLOW * (1.0 - left)
        return out

    # -- tubes -------------------------------------------------------------------
    def torso_tube(
        self,
        top_y: float,
        hem_y: float,
        ease: float,
        flare: float,
        joints: Sequence[str],
        shoulders: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Horizontal rings from ``top_y`` down to ``hem_y`` around the body parts ``joints``.

        Parameters
        ----------
        top_y, hem_y : float
            Heights of the first and the last ring, metres.
        ease : float
            Added to the body's radius, metres.
        flare : float
            Further radius growing linearly from 0 at the hip joints to ``flare`` at
            the hem, metres.
        joints : sequence of str
            The tube goes around the body vertices of these bones, and the nearest
            of them gives a ring point its weights.
        shoulders : bool
            Go around the tops of the shoulders too (:meth:`shoulder_ids`), so that
            the garment's shoulders move with the arms as the skin under them does.

        Returns
        -------
        rings : (R, N, 3) float64
            Outer surface, top ring first, metres.
        centres : (R, 3) float64
        weights : (R, N, J) float64
        """
        heights = _ring_heights(top_y, hem_y, self.hip_y, self.body.height_m)
        ids = self.vertex_ids(joints)
        if shoulders:
            ids = np.union1d(ids, self.shoulder_ids())
        points = self.body.vertices[ids].astype(np.float64)
        angles = 2 * np.pi * np.arange(TORSO_SEGMENTS) / TORSO_SEGMENTS
        directions = np.stack([np.sin(angles), np.cos(angles)], axis=1)  # (x, z), 0 = front
        radii = np.empty((len(heights), TORSO_SEGMENTS))
        centres = np.empty((len(heights), 3))
        found = np.zeros(len(heights), bool)
        for k, y in enumerate(heights):
            lo = heights[k + 1] if 0 < k < len(heights) - 1 else y - EDGE_SLAB_M
            hi = heights[k - 1] if k > 0 else y + EDGE_SLAB_M
            slab = points[(points[:, 1] >= lo) & (points[:, 1] <= hi)][:, [0, 2]]
            found[k] = len(slab) > 0
            if found[k]:
                centre = np.array([self.centre_x, 0.5 * (slab[:, 1].min() + slab[:, 1].max())])
                radii[k] = _hull_distances(slab - centre, directions)
                centres[k] = (centre[0], y, centre[1])
        radii, centres = _fill_gaps(radii, found), _fill_gaps(centres, found)
        centres[:, 1] = heights
        radii += ease
        # Below the hip joints the garment hangs: never narrower than above, flaring
        # out linearly to ``flare`` at the hem.
        below = np.flatnonzero(heights < self.hip_y)
        if len(below):
            first = max(below[0] - 1, 0)
            radii[first:] = np.maximum.accumulate(radii[first:], axis=0)
            drop = (self.hip_y - heights[below]) / max(self.hip_y - heights[-1], 1e-6)
            radii[below] += flare * drop[:, None]
            centres[below, 2] = centres[first, 2]
        rings = np.empty((len(heights), TORSO_SEGMENTS, 3))
        rings[..., 0] = centres[:, None, 0] + radii * directions[:, 0]
        rings[..., 1] = heights[:, None]
        rings[..., 2] = centres[:, None, 2] + radii * directions[:, 1]
        flat = rings.reshape(-1, 3)
        near = self.nearest_weights(flat, ids)
        # From the hip joints to the crotch, blend into the hanging weights.
        t = np.clip((self.hip_y - flat[:, 1]) / max(self.hip_y - self.crotch_y, 1e-6), 0, 1)
        blend = (t * t * (3 - 2 * t))[:, None]
        weights = (1 - blend) * near + blend * self.hanging_weights(flat)
        weights = _smooth_weights(weights.reshape(len(heights), TORSO_SEGMENTS, -1))
        return rings, centres, weights

    def limb_tube(
        self, chain: Sequence[str], start_m: float, stop: float, ease: float, flare: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rings perpendicular to a bone chain, from its first joint outwards.

        Parameters
        ----------
        chain : three joint names
            The tube follows their heads (e.g. shoulder, elbow, wrist) around the
            flesh of the first two bones.
        start_m : float
            Where the tube starts, metres along the chain from its first joint
            (negative: before it, the first bone extended).
        stop : float
            Where the tube ends, as a fraction of the chain's length.
        ease : float
            Added to the body's radius, metres.
        flare : float
            Further radius growing linearly from 0 at the top to ``flare`` at the
            end, metres.

        Returns
        -------
        As :meth:`torso_tube`, rings from the chain's first joint outwards.
        """
        body = self.body
        joints = body.joint_positions[[body.joint_index(n) for n in chain]]
        seg = np.diff(joints, axis=0)
        seg_len = np.linalg.norm(seg, axis=1)
        arc_start = np.concatenate([[0.0], np.cumsum(seg_len)[:-1]])
        stop_m = stop * float(seg_len.sum())
        spacing, slab = LIMB_RING_SPACING * body.height_m, LIMB_SLAB * body.height_m
        n_rings = max(2, int(np.ceil((stop_m - start_m) / spacing)) + 1)
        arcs = np.linspace(start_m, stop_m, n_rings)

        def point_at(s):
            k = np.clip(np.searchsorted(arc_start, s, side="right") - 1, 0, len(seg) - 1)
            return joints[k] + ((s - arc_start[k]) / seg_len[k])[..., None] * seg[k]

        ids = self.vertex_ids(chain[:2])
        points = body.vertices[ids].astype(np.float64)
        point_arcs = _arc_coordinates(points, joints)
        front = np.array([0.0, 0.0, 1.0])
        angles = 2 * np.pi * np.arange(LIMB_SEGMENTS) / LIMB_SEGMENTS
        directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
        centres = point_at(arcs)
        step = arcs[1] - arcs[0]
        radii = np.empty((n_rings, LIMB_SEGMENTS))
        frames = np.empty((n_rings, 2, 3))
        found = np.zeros(n_rings, bool)
        for k, s in enumerate(arcs):
            tangent = point_at(np.asarray(s + step)) - point_at(np.asarray(s - step))
            tangent /= np.linalg.norm(tangent)
            e2 = front - (front @ tangent) * tangent  # towards the front of the body
            e2 /= np.linalg.norm(e2)
            frames[k] = np.cross(e2, tangent), e2
            # Before the first joint the limb's flesh ends: those rings are as wide
            # as the first one past the joint (a sleeve into the shoulder).
            near = np.abs(point_arcs - s) <= slab
            found[k] = s >= 0 and near.any()
            if found[k]:
                radii[k] = _hull_distances((points[near] - centres[k]) @ frames[k].T, directions)
        radii = _fill_gaps(radii, found)
        radii += ease + flare * ((arcs - start_m) / (stop_m - start_m))[:, None]
        rings = centres[:, None, :] + radii[..., None] * (directions @ frames)
        # Weights from the limb or the trunk, so that the top of the tube stretches
        # over the joint as the skin does.
        ids = np.union1d(ids, self.vertex_ids(TRUNK_JOINTS + NECK_JOINTS))
        weights = self.nearest_weights(rings.reshape(-1, 3), ids)
        return rings, centres, _smooth_weights(weights.reshape(n_rings, LIMB_SEGMENTS, -1))


def _ring_heights(top_y: float, hem_y: float, hip_y: float, height_m: float) -> np.ndarray:
    """Ring heights from ``top_y`` down to ``hem_y``: dense above ``hip_y``, sparse below
    (spacings scaled to a body ``height_m`` tall)."""
    if not top_y > hem_y:
        raise InvalidParameterError(f"a garment's top ({top_y:.3f} m) must be above its hem")
    parts = []
    for hi, lo, spacing in (
        (top_y, max(hip_y, hem_y), UPPER_RING_SPACING * height_m),
        (min(hip_y, top_y), hem_y, HANGING_RING_SPACING * height_m),
    ):
        if hi > lo + 1e-6:
            n = int(np.ceil((hi - lo) / spacing)) + 1
            parts.append(np.linspace(hi, lo, n)[1 if parts else 0 :])
    return np.concatenate(parts)


def _fill_gaps(values: np.ndarray, found: np.ndarray) -> np.ndarray:
    """Rows of ``values`` where ``found`` is False replaced by the nearest found row.

    Raises
    ------
    InvalidParameterError
        No row found: no body vertices near any ring of a tube.
    """
    rows = np.flatnonzero(found)
    if len(rows) == 0:
        raise InvalidParameterError(
            "no body vertices near a garment's rings: fit garments to a finer body "
            "(dress before decimating)"
        )
    nearest = rows[np.abs(np.arange(len(found))[:, None] - rows[None, :]).argmin(axis=1)]
    return values[nearest]


def _hull_distances(points: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(N,) distance from the origin to the convex hull of 2-D ``points`` along each direction.

    An origin outside the hull (or too few points for one) gives the distance to the
    farthest point instead, so that a ring of that radius still encloses them.
    """
    # Lazy: a query imports this module (a database's build config names garments), and
    # scipy.spatial would cost it ~0.14 s.
    from scipy.spatial import ConvexHull, QhullError

    fallback = np.full(len(directions), np.linalg.norm(points, axis=1).max())
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return fallback
    normals, offsets = hull.equations[:, :2], hull.equations[:, 2]
    if np.any(offsets >= 0):  # the origin is not inside (n·0 + offset < 0 inside)
        return fallback
    along = directions @ normals.T  # (N, hull edges)
    with np.errstate(divide="ignore"):
        t = np.where(along > 1e-12, -offsets / along, np.inf)
    return t.min(axis=1)


def _arc_coordinates(points: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """(P,) arc length along the polyline ``joints`` of each point's nearest point.

    The first segment extends backwards and the last forwards without limit.
    """
    seg = np.diff(joints, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    arc_start = np.concatenate([[0.0], np.cumsum(seg_len)[:-1]])
    t = np.einsum("psk,sk->ps", points[:, None, :] - joints[None, :-1], seg) / seg_len**2
    lo = np.where(np.arange(len(seg)) == 0, -np.inf, 0.0)
    hi = np.where(np.arange(len(seg)) == len(seg) - 1, np.inf, 1.0)
    t = np.clip(t, lo, hi)
    closest = joints[None, :-1] + t[..., None] * seg
    best = np.argmin(np.linalg.norm(points[:, None] - closest, axis=2), axis=1)
    rows = np.arange(len(points))
    return arc_start[best] + t[rows, best] * seg_len[best]


def _smooth_weights(weights: np.ndarray) -> np.ndarray:
    """Average (R, N, J) ring weights with their neighbours; drop tiny ones; normalise.

    Neighbours: the points either side on the ring (closed) and above and below it
    (the first and last rings count themselves in place of the missing one).
    """
    w = weights
    for _ in range(WEIGHT_SMOOTHING_ITERATIONS):
        up = np.concatenate([w[:1], w[:-1]])
        down = np.concatenate([w[1:], w[-1:]])
        w = 0.5 * w + 0.125 * (np.roll(w, 1, axis=1) + np.roll(w, -1, axis=1) + up + down)
    w = np.where(w >= MIN_WEIGHT, w, 0.0)
    return w / w.sum(axis=-1, keepdims=True)


def _shell(
    rings: np.ndarray, centres: np.ndarray, thickness: float
) -> tuple[np.ndarray, np.ndarray]:
    """A closed double-walled tube from its outer rings.

    Parameters
    ----------
    rings : (R, N, 3) float
        Outer rings, in order along the tube.
    centres : (R, 3) float
        Ring centres; the inner wall is ``thickness`` closer to them.
    thickness : float
        Metres.

    Returns
    -------
    vertices : (2 R N, 3) float64
        Outer rings, then inner rings.
    faces : (4 (R - 1) N + 4 N, 3) int64
        Counter-clockwise seen from outside (the tube's volume is positive).
    """
    n_rings, n = rings.shape[:2]
    inward = centres[:, None, :] - rings
    inward /= np.linalg.norm(inward, axis=2, keepdims=True)
    inner = rings + thickness * inward
    vertices = np.concatenate([rings.reshape(-1, 3), inner.reshape(-1, 3)])
    index = np.arange(2 * n_rings * n).reshape(2, n_rings, n)
    nxt = np.roll(index, -1, axis=2)

    def quads(a, b, c, d):  # a-b-c-d around a quad → two triangles
        return np.concatenate([np.stack([a, b, c], -1), np.stack([a, c, d], -1)]).reshape(-1, 3)

    out, inn = index
    out_next, inn_next = nxt
    faces = np.concatenate(
        [
            quads(out[:-1], out[1:], out_next[1:], out_next[:-1]),
            quads(inn[:-1], inn_next[:-1], inn_next[1:], inn[1:]),
            quads(out[0], out_next[0], inn_next[0], inn[0]),
            quads(out[-1], inn[-1], inn_next[-1], out_next[-1]),
        ]
    )
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    if np.einsum("ij,ij->i", a, np.cross(b, c)).sum() < 0:
        faces = faces[:, ::-1]
    return vertices, faces


# -- the dressed avatar --------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class DressedAvatar(Avatar):
    """An avatar wearing garments: the body's mesh followed by each garment's.

    Built by :func:`dress`.  Vertices, faces and skin
    weights are the body's, then each garment's in order, so it skins, poses and
    renders as any :class:`Avatar`.

    Attributes
    ----------
    body : Avatar
        The undressed body.
    parts : tuple of GarmentMesh
        The garments, fitted to ``body``.
    """

    body: Avatar | None = None
    parts: tuple[GarmentMesh, ...] = ()

    def __post_init__(self):
        super().__post_init__()
        if self.body is None or not self.parts:
            raise InvalidParameterError("a dressed avatar needs a body and garments: use dress()")
        expected = self.body.n_vertices + sum(len(p.vertices) for p in self.parts)
        if self.n_vertices != expected:
            raise InvalidParameterError(
                f"dressed avatar {self.name!r}: {self.n_vertices} vertices, the body and "
                f"garments have {expected}"
            )

    @property
    def garments(self) -> tuple[Garment, ...]:
        return tuple(p.garment for p in self.parts)

    def vertex_rgb(self, body_rgb: Sequence[float]) -> np.ndarray:
        """(V, 3) float32 colour per vertex: ``body_rgb`` on the body, each garment's own."""
        colours = [np.broadcast_to(np.asarray(body_rgb, np.float32), (self.body.n_vertices, 3))]
        for part in self.parts:
            colours.append(np.broadcast_to(np.float32(part.garment.rgb), part.vertices.shape))
        return np.concatenate(colours)

    def with_shape(self, height_m: float | None = None, girth: float = 1.0) -> DressedAvatar:
        """The body reshaped (see :meth:`Avatar.with_shape`) and dressed again.

        The garments are fitted anew to the new body, so they keep their ease.
        """
        return dress(self.body.with_shape(height_m, girth), self.garments)

    def decimated(self, n_faces: int = DEFAULT_LOW_POLY_FACES) -> DressedAvatar:
        """The body decimated to ``n_faces`` (see :meth:`Avatar.decimated`), the
        garments kept as they are (480 to 1,424 faces each for the named ones)."""
        return _merge(self.body.decimated(n_faces), self.parts)


def dress(body: Avatar, garments: Sequence[str | Garment]) -> Avatar:
    """The body wearing garments.

    Parameters
    ----------
    body : Avatar
        Any body on the canonical skeleton (a dressed one is dressed on top).
    garments : sequence of str or Garment
        Names from :data:`GARMENTS` or patterns; each at most once.  Empty: ``body``.

    Returns
    -------
    Avatar
        A :class:`DressedAvatar`, or ``body`` itself when ``garments`` is empty.

    Raises
    ------
    InvalidParameterError
        An unknown garment name (the message lists the known ones) or one given twice.
    """
    if isinstance(garments, str | Garment):
        garments = (garments,)
    items = [garment(g) for g in garments]
    if isinstance(body, DressedAvatar):
        items = list(body.garments) + items
        body = body.body
    names = [g.name for g in items]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InvalidParameterError(f"garments given more than once: {twice}")
    if not items:
        return body
    return _merge(body, tuple(garment_mesh(body, g) for g in items))


def _merge(body: Avatar, parts: tuple[GarmentMesh, ...]) -> DressedAvatar:
    offsets = np.cumsum([body.n_vertices] + [len(p.vertices) for p in parts[:-1]])
    return DressedAvatar(
        np.concatenate([body.vertices] + [p.vertices for p in parts]),
        np.concatenate([body.faces] + [p.faces + o for p, o in zip(parts, offsets, strict=True)]),
        body.joint_names,
        body.parents,
        body.joint_positions,
        body.bone_tails,
        np.concatenate([body.weights] + [p.weights for p in parts]),
        "+".join([body.name] + [p.garment.name for p in parts]),
        body=body,
        parts=parts,
    )
