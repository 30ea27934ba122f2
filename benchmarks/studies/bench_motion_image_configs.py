"""Which motion-image configuration retrieves best: nearest-neighbour retrieval over
the library, each configuration against the patent's plain image.

Database: every library motion (``--motions``) on the default avatar (4,000 faces),
seen by 8 fitted virtual cameras (azimuth 0, 45 … 315°, elevation 10°, 128×128) at
30 fps, cut into 1.5 s windows every 0.5 s.  Queries: the same motions on another
body (1.85 m, girth 1.15) seen from between the database views (azimuth 22.5 + 45 k,
elevation 5°) by a camera 1.6× further than needed and aimed 0.3 m off (the person
small and off-centre), 160×120, windows shifted by 0.25 s.  "clean" queries use the
rendered masks, "video" queries the masks :func:`eigmotion.segmentation.video.extract_silhouettes`
cuts out of :func:`eigmotion.synth.scene.compose_scene` videos of those renders
(background given).

Per configuration: "label" = the nearest database window (Euclidean distance on the
full vectors, no eigenspace) has the query's label; "motion" = it is the same
motion; "LOO" = leave-one-motion-out label accuracy (the query's own motion removed
from the database).  The ratio columns divide the label and LOO accuracy by those of
the patent's plain image (image frame, uniform weights, no filter, 64×64, no
silhouette term) in the same run.

The renders are cached per motion in ``--cache`` (default
``/tmp/eigmotion-bench-motion-image-configs``), so a second run only computes motion
images.  Run from the repository root with the venv active::

    python benchmarks/studies/bench_motion_image_configs.py [--motions all|N|NAME,...]
        [--configs 1,2,...] [--cache DIR]

The whole library takes about 6 min on two cores (most of it rendering, once);
``--motions 8 --configs 1,10,11,12`` (walks, runs and jumps; plain, default, uniform,
image frame) about 1.5 min.
"""

from __future__ import annotations

import argparse
import zlib
from pathlib import Path

import numpy as np

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.retarget import animate_avatar
from eigmotion.errors import VideoError
from eigmotion.evaluation.measures import PLAIN_CONFIG, ratio
from eigmotion.imaging.cameras import ring_rig
from eigmotion.imaging.silhouettes import render_masks
from eigmotion.mocap.library import load_library
from eigmotion.retrieval.library_views import window_bounds
from eigmotion.retrieval.motion_image import MotionImageConfig, motion_image
from eigmotion.segmentation.video import extract_silhouettes
from eigmotion.synth.scene import compose_scene
from eigmotion.synth.walk_scenes import offset_camera

FPS = 30.0
WINDOW_S, STEP_S, QUERY_OFFSET_S = 1.5, 0.5, 0.25
DEFAULT_CACHE = Path("/tmp/eigmotion-bench-motion-image-configs")

#: (row name, MotionImageConfig arguments); row 1 is the baseline (always run).
CONFIGS = (
    ("image   uniform  none  64 sil0   (plain)", PLAIN_CONFIG),
    ("image   recency  none  64 sil0", dict(PLAIN_CONFIG, weighting="recency")),
    ("person  uniform  none  64 sil0", dict(PLAIN_CONFIG, frame="person")),
    ("person  recency  none  64 sil0", dict(filter="none", size=64, silhouette_weight=0.0)),
    ("person  recency  log   64 sil0", dict(filter="log", size=64, silhouette_weight=0.0)),
    ("person  recency  sobel 64 sil0", dict(size=64, silhouette_weight=0.0)),
    ("person  recency  none  32 sil0", dict(filter="none", silhouette_weight=0.0)),
    ("person  recency  none  64 sil0.5", dict(filter="none", size=64)),
    ("person  recency  sobel 64 sil0.5", dict(size=64)),
    ("person  recency  sobel 32 sil0.5 (default)", {}),
    ("person  uniform  sobel 32 sil0.5", dict(weighting="uniform")),
    ("image   recency  sobel 32 sil0.5", dict(frame="image")),
    ("person  recency  sobel 32 sil0.5 step 2", dict(step=2)),
)


def int_list(text: str) -> list[int]:
    """``"0,1,2"`` → ``[0, 1, 2]`` (an argparse type)."""
    return [int(part) for part in text.split(",") if part.strip()]


def select_motions(text: str) -> list:
    """``all``, a count (the first N in manifest order) or comma-separated names."""
    library = load_library()
    if text == "all":
        return library
    if text.isdigit():
        return library[: int(text)]
    names = [n.strip() for n in text.split(",") if n.strip()]
    by_name = {item.name: item for item in library}
    unknown = [n for n in names if n not in by_name]
    if unknown:
        raise SystemExit(f"unknown motions {unknown}; known: {', '.join(by_name)}")
    return [by_name[n] for n in names]


def render_motion(item, out: Path) -> None:
    """Database masks (8, F, 128, 128), clean and video query masks (8, F, 120, 160)."""
    base = load_default_avatar()
    db_body = base.decimated(4000)
    q_body = base.with_shape(height_m=1.85, girth=1.15).decimated(4000)
    rng = np.random.default_rng([7, zlib.crc32(item.name.encode())])
    motion = item.motion.resample(FPS)
    _, v_db = animate_avatar(db_body, motion)
    _, v_q = animate_avatar(q_body, motion)
    db_rig = ring_rig(8, 10.0, width=128, height=128).fitted(v_db[:, ::7].reshape(-1, 3))
    db = np.stack([render_masks(v_db, db_body.faces, cam) for cam in db_rig])
    clean, video = [], []
    for k in range(8):
        camera = offset_camera(v_q, 22.5 + 45.0 * k, 5.0, 160, 120, 1.6, (0.3, 0.1, 0.0))
        masks = render_masks(v_q, q_body.faces, camera)
        frames, background = compose_scene(None, masks, rng)
        clean.append(masks)
        video.append(extract_silhouettes(frames, background))
    np.savez_compressed(out, db=db, clean=np.stack(clean), video=np.stack(video), label=item.label)


def vectors(clips_by_motion: dict, key: str, config: MotionImageConfig, offset_s: float):
    """Labels, motion names and motion images of every window of every view."""
    labels, names, rows = [], [], []
    shift = int(round(offset_s * FPS))
    for name, data in clips_by_motion.items():
        clips = data[key]
        n = clips.shape[1]
        windows = [(a + shift, b + shift) for a, b in window_bounds(n, FPS, WINDOW_S, STEP_S)]
        windows = [(a, b) for a, b in windows if b <= n] or [(0, n)]
        for clip in clips:
            for a, b in windows:
                try:
                    rows.append(motion_image(clip[a:b], config, clip_fps=FPS))
                except VideoError:  # no person or no motion in this window
                    continue
                labels.append(data["label"])
                names.append(name)
    return np.array(labels), np.array(names), np.stack(rows)


def accuracies(database, queries) -> tuple[float, float, float]:
    """(label, motion, leave-one-motion-out label) accuracy of the nearest window."""
    d_label, d_name, d_vec = database
    q_label, q_name, q_vec = queries
    sq = (q_vec**2).sum(1)[:, None] - 2 * q_vec @ d_vec.T + (d_vec**2).sum(1)[None]
    nearest = sq.argmin(axis=1)
    other = np.where(d_name[None, :] == q_name[:, None], np.inf, sq).argmin(axis=1)
    return (
        float((d_label[nearest] == q_label).mean()),
        float((d_name[nearest] == q_name).mean()),
        float((d_label[other] == q_label).mean()),
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--motions", default="all", help="all, a count, or names (all)")
    parser.add_argument(
        "--configs",
        type=int_list,
        default=list(range(1, len(CONFIGS) + 1)),
        help=f"rows to run, 1..{len(CONFIGS)}, comma-separated (all; row 1 always)",
    )
    parser.add_argument("--cache", type=Path, default=DEFAULT_CACHE, help="render cache folder")
    args = parser.parse_args(argv)
    rows = sorted({1, *args.configs})
    if not all(1 <= r <= len(CONFIGS) for r in rows):
        raise SystemExit(f"--configs: rows are 1..{len(CONFIGS)}")

    args.cache.mkdir(parents=True, exist_ok=True)
    clips_by_motion = {}
    for item in select_motions(args.motions):
        path = args.cache / f"{item.name}.npz"
        if not path.exists():
            print(f"rendering {item.name}", flush=True)
            render_motion(item, path)
        with np.load(path) as data:
            clips_by_motion[item.name] = {k: data[k] for k in ("db", "clean", "video")}
            clips_by_motion[item.name]["label"] = str(data["label"])
    n_labels = len({d["label"] for d in clips_by_motion.values()})
    print(f"{len(clips_by_motion)} motions, {n_labels} labels; ratio = accuracy / plain's")

    header = f"{'label':>6} {'motion':>6} {'LOO':>6} {'xlabel':>6} {'xLOO':>6}"
    print(f"{'':<59}{' clean masks ':-^34}   {' video masks ':-^34}")
    print(f"{'frame   weighting filter size silhouette':<48} {'queries':>7}   {header}   {header}")
    plain = None
    for r in rows:
        name, kwargs = CONFIGS[r - 1]
        config = MotionImageConfig(**kwargs)
        database = vectors(clips_by_motion, "db", config, 0.0)
        results = []
        for key in ("clean", "video"):
            queries = vectors(clips_by_motion, key, config, QUERY_OFFSET_S)
            results.append(accuracies(database, queries))
        plain = plain or results
        cells = [
            f"{acc[0]:>6.3f} {acc[1]:>6.3f} {acc[2]:>6.3f} "
            f"{ratio(acc[0], base[0]):>6.2f} {ratio(acc[2], base[2]):>6.2f}"
            for acc, base in zip(results, plain, strict=True)
        ]
        print(
            f"{f'{r:>2} {name}':<48} {len(queries[0]):>7}   {cells[0]}   {cells[1]}   "
            f"(database {len(database[0])})",
            flush=True,
        )


if __name__ == "__main__":
    main()
