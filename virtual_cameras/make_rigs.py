"""Write the shipped virtual camera rigs (``*.toml`` next to this script).

Run ``python virtual_cameras/make_rigs.py`` after changing a layout; the TOML files are
what the rest of eigmotion reads (``eigmotion.imaging.cameras.load_rig``).  With ``--figures
DIR`` it also draws the pictures of ``docs/virtual-cameras.md`` (camera positions around
the avatar, and the avatar's silhouettes from every view of the default rig).  Every rig shares one
lens and one distance: 128×128 pixels, a 40° vertical field of view and cameras 4 m
from a target 0.9 m above the floor (about a standing adult's hip height), which keeps
a 2 m tall, 1 m wide box around the target in every view.  The build re-aims each rig
at each motion's bounding box with ``CameraRig.fitted``, so these distances only matter
for motions that stay in place.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from eigmotion.imaging.cameras import CameraRig, dome_rig, ring_rig, save_rig

HERE = Path(__file__).resolve().parent

#: Lens and placement shared by all shipped rigs.
COMMON = {
    "width": 128,
    "height": 128,
    "yfov_deg": 40.0,
    "distance_m": 4.0,
    "target": (0.0, 0.9, 0.0),
}


def _described(rig: CameraRig, name: str, description: str) -> CameraRig:
    meta = dict(rig.meta, target=list(COMMON["target"]), description=description)
    return replace(rig, name=name, meta=meta)


def shipped_rigs() -> dict[str, CameraRig]:
    """The rigs this folder ships, by file stem."""
    return {
        "ring6": _described(
            ring_rig(6, 0.0, **COMMON),
            "ring6",
            "6 horizontal cameras at equal angles (60° apart): the minimal rig",
        ),
        "default": _described(
            dome_rig(12, [0.0, 20.0], **COMMON),
            "default",
            "12 azimuths (30° apart) × elevations 0° and 20°: 24 views",
        ),
        "dome": _described(
            dome_rig(12, [-20.0, 0.0, 20.0, 40.0], **COMMON),
            "dome",
            "12 azimuths (30° apart) × elevations -20°, 0°, 20°, 40°: 48 views, "
            "below, level and above",
        ),
    }


#: CMU clip and frame (120 fps) posed for the silhouette sheet: a front kick with the
#: foot near its highest, whose asymmetry shows which side each camera sees.
SHEET_CLIP, SHEET_SUBJECT, SHEET_FRAME = "135_04", "135", 805


def plot_layout(rigs: dict[str, CameraRig], path: Path) -> None:
    """Top and side views of the camera positions around the avatar at rest."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from eigmotion.body.avatar import load_default_avatar

    body = load_default_avatar().vertices
    fig, (top, side) = plt.subplots(1, 2, figsize=(11, 5.8))
    for ax in (top, side):
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    # Top view looking down -Y: x to the right, z downwards on the page (the body's
    # front towards the bottom), so azimuth runs counter-clockwise.
    top.scatter(body[::7, 0], body[::7, 2], s=0.3, c="0.5")
    styles = {"dome": ("o", 30, "tab:orange"), "ring6": ("s", 90, "tab:blue")}
    for stem, (marker, size, colour) in styles.items():
        rig = rigs[stem]
        level = [c for c in rig if abs(c.elevation_deg) < 1e-9] if stem == "dome" else list(rig)
        centres = np.array([c.center for c in level])
        label = "default / dome azimuths" if stem == "dome" else stem
        top.scatter(centres[:, 0], centres[:, 2], marker=marker, s=size, c=colour, label=label)
        if stem == "ring6":
            for cam in level:
                x, z = cam.center[0], cam.center[2]
                top.annotate(
                    f"{cam.azimuth_deg:g}°",
                    (x, z),
                    xytext=(1.1 * x, 1.1 * z),
                    ha="center",
                    va="center",
                )
                top.plot([x, 0], [z, 0], c=colour, lw=0.6, alpha=0.5)
    top.set_ylim(-4.8, 4.8)
    top.invert_yaxis()
    top.set_xlabel("x (m) — the body's left")
    top.set_ylabel("z (m) — the body's front (down the page)")
    top.set_title("top view (from above)")
    top.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    # Side view in the plane of azimuth 0: horizontal distance along +Z, height Y.
    side.scatter(body[::7, 2], body[::7, 1], s=0.3, c="0.5")
    target = np.asarray(rigs["dome"].meta["target"])
    for stem, (marker, size, colour) in (
        ("dome", styles["dome"]),
        ("default", ("^", 60, "tab:green")),
    ):
        front = [c for c in rigs[stem] if abs(c.azimuth_deg) < 1e-9]
        for cam in front:
            side.scatter(cam.center[2], cam.center[1], marker=marker, s=size, c=colour)
            side.plot([cam.center[2], target[2]], [cam.center[1], target[1]], c=colour, lw=0.6)
            if stem == "dome":
                side.annotate(f"{cam.elevation_deg:+g}°", (cam.center[2] + 0.15, cam.center[1]))
        side.scatter([], [], marker=marker, c=colour, label=stem)
    side.axhline(0.0, c="k", lw=0.8)
    side.set_xlabel("z (m), azimuth 0 plane")
    side.set_ylabel("y (m)")
    side.set_title("side view: elevations (floor at y = 0)")
    side.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_masks(rig: CameraRig, path: Path) -> None:
    """Contact sheet of the avatar's silhouettes (one kick frame) from every view."""
    from eigmotion.body.avatar import load_default_avatar
    from eigmotion.body.retarget import pose_avatar, retarget
    from eigmotion.imaging.figures import contact_sheet, save_image
    from eigmotion.imaging.silhouettes import render_rig_masks
    from eigmotion.mocap.amc import read_amc

    cmu = HERE.parent / "database" / "motions" / "cmu"
    motion = read_amc(cmu / "amc" / f"{SHEET_CLIP}.amc", cmu / "asf" / f"{SHEET_SUBJECT}.asf")
    avatar = load_default_avatar()
    vertices = pose_avatar(avatar, retarget(motion, avatar))[SHEET_FRAME : SHEET_FRAME + 1]
    masks = render_rig_masks(vertices, avatar.faces, rig.fitted(vertices.reshape(-1, 3)))
    sheet = contact_sheet(
        list(masks[:, 0]),
        n_cols=12,
        labels=[cam.name for cam in rig],
        title=f"rig '{rig.name}' fitted to CMU {SHEET_CLIP} frame {SHEET_FRAME}",
    )
    save_image(sheet, path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE, help="folder to write into")
    parser.add_argument("--figures", type=Path, help="also draw the pictures into this folder")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rigs = shipped_rigs()
    for stem, rig in rigs.items():
        save_rig(rig, args.out / f"{stem}.toml")
    if args.figures is not None:
        plot_layout(rigs, args.figures / "virtual-cameras-layout.png")
        plot_masks(rigs["default"], args.figures / "virtual-cameras-default-masks.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
