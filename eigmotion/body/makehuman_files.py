"""Reading MakeHuman's files: the OBJ mesh, the rig's bone placement, the skin weights.

:func:`eigmotion.body.avatar.load_avatar` builds an avatar from these.  Lengths stay
in the files' units and axes (the OBJ's decimetres, :data:`OBJ_UNIT_M`) except where
a function says otherwise.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from eigmotion.errors import InvalidParameterError
from eigmotion.mocap.canonical import BLENDER_TO_WORLD

#: Scale of the MakeHuman OBJ: its lengths are decimetres.
OBJ_UNIT_M = 0.1


@dataclass(frozen=True, eq=False)
class ObjMesh:
    """The vertices and grouped polygons of a Wavefront OBJ file.

    Attributes
    ----------
    path : str
    vertices : (N, 3) float64
        Every ``v`` line, in the file's units and axes.
    groups : dict of str to list of list of int
        Per ``g`` group, its polygons as 0-based vertex indices.
    """

    path: str
    vertices: np.ndarray
    groups: dict[str, list[list[int]]]

    def group_vertex_ids(self, group: str) -> np.ndarray:
        """(K,) int64: sorted indices of the vertices used by ``group``."""
        if group not in self.groups:
            raise InvalidParameterError(f"{self.path}: no group {group!r}")
        return np.unique(np.concatenate([np.asarray(p) for p in self.groups[group]]))

    def triangles(self, group: str) -> np.ndarray:
        """(T, 3) int64: the group's polygons split into triangle fans (file indices)."""
        if group not in self.groups:
            raise InvalidParameterError(f"{self.path}: no faces in group {group!r}")
        tris = [
            [poly[0], poly[k], poly[k + 1]]
            for poly in self.groups[group]
            for k in range(1, len(poly) - 1)
        ]
        return np.asarray(tris, dtype=np.int64).reshape(-1, 3)


def read_obj(path: str | Path) -> ObjMesh:
    """Read the vertices and the grouped faces of a Wavefront OBJ file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    ObjMesh

    Raises
    ------
    InvalidParameterError
        A malformed ``v`` or ``f`` line, or a face index out of range (names the
        file and line).
    """
    path = Path(path)
    coords: list[list[float]] = []
    groups: dict[str, list[list[int]]] = {}
    current = groups.setdefault("default", [])
    with path.open() as fh:
        for lineno, line in enumerate(fh, 1):
            head, _, rest = line.partition(" ")
            if head == "v":
                try:
                    xyz = [float(x) for x in rest.split()[:3]]
                except ValueError:
                    xyz = []
                if len(xyz) != 3:
                    raise InvalidParameterError(
                        f"{path}:{lineno}: expected 'v x y z' with three numbers, "
                        f"got {line.strip()!r}"
                    )
                coords.append(xyz)
            elif head == "g":
                current = groups.setdefault(rest.strip(), [])
            elif head == "f":
                try:
                    idx = [int(tok.split("/")[0]) for tok in rest.split()]
                except ValueError:
                    idx = []
                # Negative indices count back from the vertices read so far.
                idx = [i - 1 if i > 0 else len(coords) + i for i in idx]
                if len(idx) < 3 or min(idx) < 0 or max(idx) >= len(coords):
                    raise InvalidParameterError(
                        f"{path}:{lineno}: expected a face of 3+ indices of vertices "
                        f"defined above (1..{len(coords)}), got {line.strip()!r}"
                    )
                current.append(idx)
    groups = {name: polys for name, polys in groups.items() if polys}
    return ObjMesh(str(path), np.asarray(coords, dtype=np.float64).reshape(-1, 3), groups)


def read_obj_group(path: str | Path, group: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices and triangles of one group of a Wavefront OBJ file.

    Polygons are split into triangle fans; vertices not used by the group are
    dropped and the faces re-indexed.

    Parameters
    ----------
    path : str or Path
    group : str
        The ``g`` group to keep.

    Returns
    -------
    vertices : (V, 3) float64
        In the file's units and axes.
    faces : (T, 3) int32
        Triangles into ``vertices``.
    kept : (V,) int64
        Index of each kept vertex in the file's full vertex list (0-based).
    """
    return group_mesh(read_obj(path), group)


def group_mesh(obj: ObjMesh, group: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices and triangles of one group of a read OBJ (see :func:`read_obj_group`).

    Returns
    -------
    vertices : (V, 3) float64
    faces : (T, 3) int32
    kept : (V,) int64
        Index of each kept vertex in ``obj.vertices``.
    """
    tris = obj.triangles(group)
    kept = np.unique(tris)
    remap = np.full(len(obj.vertices), -1, dtype=np.int64)
    remap[kept] = np.arange(len(kept))
    return obj.vertices[kept], remap[tris].astype(np.int32), kept


def rig_joint_positions(
    rig_path: str | Path, obj: ObjMesh, bones: tuple[str, ...], unit_m: float = OBJ_UNIT_M
) -> tuple[np.ndarray, np.ndarray]:
    """Bone heads and tails placed on the mesh the way MakeHuman places them.

    A MakeHuman rig locates each bone end on the mesh: ``CUBE`` is the centre of a
    helper cube (an OBJ group ``joint-*``), ``MEAN`` the mean of listed vertices,
    ``VERTEX`` one vertex.  The rig's ``default_position`` values belong to
    MakeHuman's default character, not to the bare base mesh (they miss its ankles
    by up to 4 cm), so they are used only for other strategies.

    Parameters
    ----------
    rig_path : str or Path
        A ``rig.*.json``.
    obj : ObjMesh
        The mesh with its helper groups.
    bones : tuple of str
        The bones wanted, in order.
    unit_m : float
        Metres per OBJ unit (to convert ``default_position``).

    Returns
    -------
    heads, tails : (J, 3) float64
        In the OBJ's units and axes.
    """
    try:
        rig = json.loads(Path(rig_path).read_text())
    except json.JSONDecodeError as exc:
        raise InvalidParameterError(f"{rig_path}: not a JSON rig file ({exc})") from None
    missing = [n for n in bones if n not in rig]
    if missing:
        raise InvalidParameterError(f"{rig_path}: no bones {missing}")
    out = np.empty((2, len(bones), 3))
    for j, name in enumerate(bones):
        for k, end in enumerate(("head", "tail")):
            spec = rig[name].get(end, {})
            strategy = spec.get("strategy")
            if strategy == "CUBE" and spec.get("cube_name") in obj.groups:
                out[k, j] = obj.vertices[obj.group_vertex_ids(spec["cube_name"])].mean(axis=0)
            elif strategy in ("MEAN", "VERTEX") and "vertex_indices" in spec:
                ids = np.atleast_1d(np.asarray(spec["vertex_indices"], dtype=np.int64))
                if ids.min() < 0 or ids.max() >= len(obj.vertices):
                    raise InvalidParameterError(
                        f"{rig_path}: bone {name!r} {end} uses vertex {ids.max()} of "
                        f"{len(obj.vertices)}"
                    )
                out[k, j] = obj.vertices[ids].mean(axis=0)
            elif "default_position" in spec:
                # Blender frame, metres → the OBJ's frame and units.
                pos = BLENDER_TO_WORLD @ np.asarray(spec["default_position"], dtype=np.float64)
                out[k, j] = pos / unit_m
            else:
                raise InvalidParameterError(
                    f"{rig_path}: bone {name!r} {end}: cannot place it (strategy "
                    f"{strategy!r}, no default_position)"
                )
    return out[0], out[1]


def read_weights(
    path: str | Path, joint_names: tuple[str, ...], kept: np.ndarray, n_file_vertices: int
) -> np.ndarray:
    """Skin weights of a MakeHuman ``weights.*.json`` as a dense normalised matrix.

    Parameters
    ----------
    path : str or Path
    joint_names : tuple of str
        The bones to keep, in column order; each must be in the file.
    kept : (V,) int
        Indices of the mesh's vertices in the OBJ's full vertex list.
    n_file_vertices : int
        Length of that full list.

    Returns
    -------
    (V, J) float32
        Rows normalised to sum 1.
    """
    path = Path(path)
    try:
        table = json.loads(path.read_text())["weights"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise InvalidParameterError(f"{path}: not a MakeHuman weights file ({exc})") from None
    missing = [n for n in joint_names if n not in table]
    if missing:
        raise InvalidParameterError(f"{path}: no weights for bones {missing}")
    full = np.zeros((n_file_vertices, len(joint_names)), dtype=np.float64)
    for j, name in enumerate(joint_names):
        pairs = np.asarray(table[name], dtype=np.float64).reshape(-1, 2)
        idx = pairs[:, 0].astype(np.int64)
        if len(idx) and (idx.min() < 0 or idx.max() >= n_file_vertices):
            raise InvalidParameterError(
                f"{path}: bone {name!r} weights vertex {idx.max()}, the mesh has {n_file_vertices}"
            )
        np.add.at(full[:, j], idx, pairs[:, 1])
    w = full[kept]
    sums = w.sum(axis=1)
    if np.any(sums <= 0):
        raise InvalidParameterError(
            f"{path}: {int(np.sum(sums <= 0))} body vertices carry no weight "
            f"(first: OBJ vertex {int(kept[np.argmax(sums <= 0)]) + 1})"
        )
    return (w / sums[:, None]).astype(np.float32)
