"""Import BVH files with Blender's own importer and write their joint positions as JSON.

Run by an interpreter that has Blender's ``bpy`` module (not by pytest itself)::

    python blender_bvh_import.py OUT.json MOTION.bvh [MOTION.bvh ...]

Each file is imported into an empty scene by ``bpy.ops.import_anim.bvh`` with its
defaults (forward -Z, up Y, scale 1, first frame 1).  ``OUT.json`` maps each path given
to, in Blender's world frame (Z up) and the file's length units: ``names`` (the bones),
``heads`` (F, J, 3) the bone heads, which are the joints, ``leaves`` (the bones without
children) and ``leaf_tails`` (F, L, 3) their tails, which are the end sites.
"""

import json
import sys

import bpy


def _n_frames(path: str) -> int:
    with open(path, encoding="utf-8") as file:
        for line in file:
            if line.startswith("Frames:"):
                return int(line.split()[1])
    raise ValueError(f"{path}: no 'Frames:' line")


def import_positions(path: str) -> dict:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=path)
    armature = next(obj for obj in bpy.context.scene.objects if obj.type == "ARMATURE")
    bones = list(armature.pose.bones)
    leaves = [bone for bone in bones if not bone.children]
    scene = bpy.context.scene
    heads, tails = [], []
    for frame in range(_n_frames(path)):
        scene.frame_set(1 + frame)
        world = armature.matrix_world
        heads.append([list(world @ bone.head) for bone in bones])
        tails.append([list(world @ bone.tail) for bone in leaves])
    return {
        "names": [bone.name for bone in bones],
        "leaves": [bone.name for bone in leaves],
        "heads": heads,
        "leaf_tails": tails,
    }


def main(out: str, paths: list[str]) -> None:
    result = {"blender": bpy.app.version_string}
    result["files"] = {path: import_positions(path) for path in paths}
    with open(out, "w", encoding="utf-8") as file:
        json.dump(result, file)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
