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
    Dynamic time warping (:func:`eigmotion.retrieval.sequences.sequence_distances`) between the
    clip's silhouette sequence and each rendering's (every body and view) as
    :func:`eigmotion.retrieval.sequences.sequence_frames` makes them, in the coordinates the
    engine compares (:func:`eigmotion.retrieval.sequences.pose_coordinates`, the pose
    eigenspace fitted on the fold's frames); the motion's distance its nearest
    rendering's.
``fused``
    Each distance over the smallest of its kind for the clip, summed, the sequence's
    weighted by ``--weight`` (default the engine's ``SEQUENCE_WEIGHT``).

Every motion of the fold and every view is compared: the upper bound of what the
engine's cheaper form of the same ranking gets (the candidate motions the search
reached, views near the retrieved one; :mod:`eigmotion.retrieval.sequences`).

It prints top-1 and top-3 label accuracy of each (top-3: the true label among the
first three distinct labels) and each one's ratio to the motion image's, from the same
run.  The database images are rendered once, each (motion, body, view) giving both its
motion images and its silhouette sequence::

    python benchmarks/studies/bench_sequence_matching.py [--rig virtual_cameras/ring6.toml]
        [--clips-dir DIR] [--weight 2.0] [--clips-per-motion 2] [--seed 0]
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

import numpy as np  # noqa: E402

from eigmotion.body.garments import BENCHMARK_GARMENTS  # noqa: E402
from eigmotion.errors import EigmotionError, VideoError  # noqa: E402
from eigmotion.evaluation.label_ranking import per_motion_min, ranked_labels_of  # noqa: E402
from eigmotion.evaluation.query_clips import (  # noqa: E402
    ClipMaker,
    holdout_parser,
    parse_holdout_args,
    random_specs,
    run_with_clips,
    subject_folds,
    variation_folds,
)
from eigmotion.evaluation.statistics import markdown_table  # noqa: E402
from eigmotion.imaging.cameras import CameraRig, load_rig  # noqa: E402
from eigmotion.imaging.silhouettes import render_masks  # noqa: E402
from eigmotion.mocap.library import LibraryMotion, load_library  # noqa: E402
from eigmotion.retrieval.eigenspace import Eigenspace  # noqa: E402
from eigmotion.retrieval.library_views import BuildConfig, build_body, pose_for_views, view_images  # noqa: E402
from eigmotion.retrieval.motion_image import ClipMotionImages  # noqa: E402
from eigmotion.retrieval.sequences import (  # noqa: E402
    SEQUENCE_WEIGHT,
    fit_pose_space,
    pose_coordinates,
    sequence_distances,
    sequence_frames,
)

METHODS = ("motion image", "sequence", "fused")


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
    return images.vectors, images.sequence


def render_library(library, rig: CameraRig, config: BuildConfig, workers: int | None):
    """Every (motion, body, view) of the library: motion images and sequences.

    Returns
    -------
    vectors : (N, D) float32
        Every motion image (whole motions and windows).
    vector_motion : (N,) int64
        Library index of each image's motion.
    sequences : list of (F, SEQUENCE_SIZE**2 + 1) float32
        Each rendering's whole-motion silhouette sequence (none for a rendering
        without a person).
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
            if len(sequence):
                sequences.append(sequence)
                sequence_motion.append(m)
    return (np.concatenate(vectors), np.asarray(vector_motion), sequences,
            np.asarray(sequence_motion))  # fmt: skip


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

    from eigmotion.retrieval.database import QUERY_SILHOUETTE_SIDE_PX
    from eigmotion.segmentation.config import SilhouetteConfig
    from eigmotion.segmentation.video import load_clip_masks

    silhouettes = SilhouetteConfig(work_max_side_px=QUERY_SILHOUETTE_SIDE_PX)
    hits = {method: [] for method in METHODS}  # (top-1, top-3) per in-library clip
    for _, held in tqdm(folds, desc="folds", unit="fold"):
        held_names = {m.name for m in held}
        kept = np.array([i for i, m in enumerate(library) if m.name not in held_names])
        kept_labels = set(labels[kept])
        in_fold = np.isin(vector_motion, kept)
        space = Eigenspace(config.n_components, config.explained_variance)
        points = space.fit(vectors[in_fold]).transform(vectors[in_fold]).astype(np.float64)
        in_fold_sequences = np.flatnonzero(np.isin(sequence_motion, kept))
        fold_motion = sequence_motion[in_fold_sequences]
        fold_frames = np.concatenate([sequences[i] for i in in_fold_sequences])
        pose_space = fit_pose_space(fold_frames)
        fold_frames = pose_coordinates(pose_space, fold_frames)
        fold_lengths = np.array([len(sequences[i]) for i in in_fold_sequences])
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
                    sequence = pose_coordinates(pose_space, sequence_frames(whole))
                except VideoError:
                    for method in METHODS:
                        hits[method].append((False, False))
                    continue
                point = space.transform(query[None]).astype(np.float64)
                image_d = per_motion_min(
                    np.linalg.norm(points - point, axis=1), vector_motion[in_fold], len(library)
                )
                sequence_d = np.full(len(library), np.inf)
                np.minimum.at(
                    sequence_d,
                    fold_motion,
                    sequence_distances(sequence, fold_frames, fold_lengths),
                )
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
    p.add_argument(
        "--weight", type=float, default=SEQUENCE_WEIGHT,
        help="weight of the sequence distance (default: the engine's SEQUENCE_WEIGHT)",
    )  # fmt: skip
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
