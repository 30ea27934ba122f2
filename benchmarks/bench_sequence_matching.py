"""New performers: the motion image beside matching silhouette sequences frame by frame.

The ``holdout`` suite of ``bench_accuracy.py`` (new performers, bodies, garments, views;
``docs/accuracy.md``) is held back most by the new performance itself: with ideal
silhouettes of the database's own body a motion image still names about 70 % of new
performances right (``bench_accuracy_factors.py``).  This script asks whether the order
of the poses, kept frame by frame and aligned in time, carries what the after-image
loses.  For every holdout fold (the same folds, clips, views, bodies and garments as
``bench_accuracy.py holdout``) each in-library clip's video silhouettes are compared
with every motion left in the fold three ways:

``motion image``
    The whole clip's motion image in the fold's eigenspace (``BuildConfig()``), the
    motion's distance its nearest entry's (whole motion or window, any view and body):
    plain nearest motion, as the retrieval engine finds it before its decision rule.
``sequence``
    Dynamic time warping between the clip's silhouettes and each rendering of the
    motion (every body and view), each silhouette in the person frame of the motion
    image (``MotionImageConfig(size=SEQUENCE_SIZE)``), frame cost the Euclidean
    distance, path cost over the two lengths; the motion's distance its nearest
    rendering's.
``fused``
    Each distance over the smallest of its kind for the clip, summed, the sequence's
    weighted by ``--weight``.

It prints top-1 and top-3 label accuracy of each (top-3: the true label among the
first three distinct labels) and each one's ratio to the motion image's, from the same
run.  The database images are rendered once, each (motion, body, view) giving both its
motion images and its silhouette sequence::

    python benchmarks/bench_sequence_matching.py [--rig virtual_cameras/ring6.toml]
        [--clips-dir DIR] [--weight 1.0] [--clips-per-motion 2] [--seed 0]
"""

from __future__ import annotations

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from functools import lru_cache  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402
from bench_accuracy import (  # noqa: E402
    ClipMaker,
    random_specs,
    subject_folds,
    variation_folds,
)
from bench_accuracy_factors import (  # noqa: E402
    holdout_parser,
    parse_holdout_args,
    run_with_clips,
)

from eigmotion.build import BuildConfig, build_body, pose_for_views, view_images  # noqa: E402
from eigmotion.cameras import CameraRig, load_rig  # noqa: E402
from eigmotion.eigenspace import Eigenspace  # noqa: E402
from eigmotion.errors import EigmotionError, VideoError  # noqa: E402
from eigmotion.evaluation import markdown_table  # noqa: E402
from eigmotion.garments import BENCHMARK_GARMENTS  # noqa: E402
from eigmotion.library import LibraryMotion, load_library  # noqa: E402
from eigmotion.media import sample_indices  # noqa: E402
from eigmotion.motion_image import ClipMotionImages, MotionImageConfig, align_frames  # noqa: E402
from eigmotion.silhouettes import render_masks  # noqa: E402

#: Side of the person-frame silhouettes compared frame by frame, pixels.
SEQUENCE_SIZE = 16
METHODS = ("motion image", "sequence", "fused")


def silhouette_sequence(masks: np.ndarray, fps: float, config: BuildConfig) -> np.ndarray:
    """``(F', SEQUENCE_SIZE**2) float32``: the silhouettes sampled at the motion image's
    rate and aligned in its person frame at :data:`SEQUENCE_SIZE` pixels."""
    image_config = config.motion_image
    frames = sample_indices(len(masks), float(fps), image_config.sample_fps)
    small = MotionImageConfig(**{**image_config.to_dict(), "size": SEQUENCE_SIZE})
    aligned = align_frames(masks[frames], small)
    return np.ascontiguousarray(aligned.reshape(len(aligned), -1), dtype=np.float32)


@numba.njit(cache=True)
def dtw_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Dynamic time warping of ``a (n, d)`` against ``b (m, d)``: the cheapest monotone
    path's summed Euclidean frame distances over ``n + m``."""
    n, m = a.shape[0], b.shape[0]
    cost = np.full((n + 1, m + 1), np.inf)
    cost[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            sq = 0.0
            for k in range(a.shape[1]):
                diff = a[i - 1, k] - b[j - 1, k]
                sq += diff * diff
            step = min(cost[i - 1, j], cost[i, j - 1], cost[i - 1, j - 1])
            cost[i, j] = np.sqrt(sq) + step
    return cost[n, m] / (n + m)


_WORKER: dict = {}


def _init_worker(library, rig: CameraRig, config: BuildConfig) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _WORKER.update(library=library, rig=rig, config=config)


@lru_cache(maxsize=2)
def _posed(motion_index: int, shape_index: int):
    library, rig, config = _WORKER["library"], _WORKER["rig"], _WORKER["config"]
    shape, garments = config.bodies[shape_index]
    body = build_body(shape, config.low_poly_faces, garments)
    vertices, fitted = pose_for_views(library[motion_index].motion, body, rig, config.render_fps)
    return vertices, body.faces, fitted


def _render(task: tuple[int, int, int]):
    """One (motion, body, view): its motion images and its silhouette sequence."""
    motion_index, shape_index, view_index = task
    config = _WORKER["config"]
    vertices, faces, fitted = _posed(motion_index, shape_index)
    masks = render_masks(vertices, faces, fitted[view_index])
    images = view_images(_WORKER["library"][motion_index], masks, config, task)
    return images.vectors, silhouette_sequence(masks, config.render_fps, config)


def render_library(library, rig: CameraRig, config: BuildConfig, workers: int | None):
    """Every (motion, body, view) of the library: motion images and sequences.

    Returns
    -------
    vectors : (N, D) float32
        Every motion image (whole motions and windows).
    vector_motion : (N,) int64
        Library index of each image's motion.
    sequences : list of (F, SEQUENCE_SIZE**2) float32
    sequence_motion : (S,) int64
    """
    from tqdm import tqdm

    tasks = [(m, s, v) for m in range(len(library)) for s in range(len(config.bodies))
             for v in range(len(rig))]  # fmt: skip
    vectors, vector_motion, sequences, sequence_motion = [], [], [], []
    with ProcessPoolExecutor(
        workers or os.cpu_count() or 1, initializer=_init_worker, initargs=(library, rig, config)
    ) as pool:
        results = pool.map(_render, tasks, chunksize=len(rig))
        for (m, _, _), (images, sequence) in tqdm(
            zip(tasks, results, strict=True), total=len(tasks), desc="rendering views"
        ):
            vectors.append(images)
            vector_motion += [m] * len(images)
            sequences.append(sequence)
            sequence_motion.append(m)
    return (np.concatenate(vectors), np.asarray(vector_motion), sequences,
            np.asarray(sequence_motion))  # fmt: skip


def per_motion_min(distances: np.ndarray, motion_of: np.ndarray, n_motions: int) -> np.ndarray:
    """(n_motions,) float64: each motion's smallest distance (inf for motions absent)."""
    out = np.full(n_motions, np.inf)
    np.minimum.at(out, motion_of, distances)
    return out


def ranked_labels_of(distances: np.ndarray, labels: np.ndarray, n: int = 3) -> list[str]:
    """The first ``n`` distinct labels of the motions, nearest first."""
    out: list[str] = []
    for i in np.argsort(distances, kind="stable"):
        if not np.isfinite(distances[i]):
            break
        if labels[i] not in out:
            out.append(str(labels[i]))
        if len(out) == n:
            break
    return out


def run(args: argparse.Namespace) -> None:
    t0 = time.perf_counter()
    library: list[LibraryMotion] = [m for m in load_library() if m.role == "basic"]
    labels = np.array([m.label for m in library])
    rig = load_rig(args.rig)
    config = BuildConfig()
    folds = subject_folds(library, args) + variation_folds(library, args)
    maker = ClipMaker(args.clips_dir)
    outfits = ((), *((name,) for name in BENCHMARK_GARMENTS))
    items = {m.name: m for m in library}
    print(f"rendering the library: {len(library)} motions on {rig.name}", file=sys.stderr)
    vectors, vector_motion, sequences, sequence_motion = render_library(
        library, rig, config, args.workers
    )

    from tqdm import tqdm

    from eigmotion.database import QUERY_SILHOUETTE_SIDE_PX
    from eigmotion.video import SilhouetteConfig, load_clip_masks

    silhouettes = SilhouetteConfig(work_max_side_px=QUERY_SILHOUETTE_SIDE_PX)
    hits = {method: [] for method in METHODS}  # (top-1, top-3) per in-library clip
    for _, held in tqdm(folds, desc="folds", unit="fold"):
        held_names = {m.name for m in held}
        kept = np.array([i for i, m in enumerate(library) if m.name not in held_names])
        kept_labels = set(labels[kept])
        in_fold = np.isin(vector_motion, kept)
        space = Eigenspace(config.n_components, config.explained_variance)
        points = space.fit(vectors[in_fold]).transform(vectors[in_fold]).astype(np.float64)
        fold_sequences = [(int(m), s) for m, s in zip(sequence_motion, sequences, strict=True)
                          if m in kept]  # fmt: skip
        for item in held:
            for spec in random_specs(item, args, maker, outfits):
                if spec.label not in kept_labels:
                    continue  # out of the library for this fold
                clip = maker.make(spec, items[spec.motion])
                found = load_clip_masks(
                    clip.video, clip.background, silhouettes, config.motion_image.sample_fps
                )
                try:
                    whole = ClipMotionImages(found.masks, config.motion_image, found.fps)
                    query = whole.window(0, len(found.masks))
                    sequence = silhouette_sequence(found.masks, found.fps, config)
                except VideoError:
                    for method in METHODS:
                        hits[method].append((False, False))
                    continue
                point = space.transform(query[None]).astype(np.float64)
                image_d = per_motion_min(
                    np.linalg.norm(points - point, axis=1), vector_motion[in_fold], len(library)
                )
                sequence_d = np.full(len(library), np.inf)
                for m, candidate in fold_sequences:
                    sequence_d[m] = min(sequence_d[m], dtw_distance(sequence, candidate))
                fused = image_d / image_d.min() + args.weight * sequence_d / sequence_d.min()
                for method, d in zip(METHODS, (image_d, sequence_d, fused), strict=True):
                    ranked = ranked_labels_of(d, labels)
                    hits[method].append((ranked[:1] == [spec.label], spec.label in ranked))

    n = len(hits[METHODS[0]])
    base = [sum(h[k] for h in hits[METHODS[0]]) for k in (0, 1)]
    rows = []
    for method in METHODS:
        top1, top3 = (sum(h[k] for h in hits[method]) for k in (0, 1))
        rows.append([method, f"{top1}/{n} ({100.0 * top1 / n:.1f} %)",
                     f"{top1 / max(base[0], 1):.2f}", f"{top3}/{n} ({100.0 * top3 / n:.1f} %)",
                     f"{top3 / max(base[1], 1):.2f}"])  # fmt: skip
    print(f"\n## holdout, nearest motion: {len(folds)} folds, {n} in-library clips, "
          f"databases on {rig.name} ({len(rig)} views), fused weight {args.weight:g}, "
          f"seed {args.seed}\n")  # fmt: skip
    header = ["distance", "top-1", "÷ motion image", "top-3", "÷ motion image"]
    print("\n".join(markdown_table(header, rows)))
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    p = holdout_parser(__doc__.splitlines()[0])
    p.add_argument("--weight", type=float, default=1.0, help="weight of the sequence distance")
    args = parse_holdout_args(p, argv)
    if not (np.isfinite(args.weight) and args.weight >= 0):
        p.error(f"--weight must be a number >= 0, got {args.weight}")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    run_with_clips(run, parse_args(argv))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except EigmotionError as exc:
        print(f"bench_sequence_matching: error: {exc}", file=sys.stderr)
        sys.exit(2)
