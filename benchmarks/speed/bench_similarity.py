"""The tracker's silhouette similarity on one core, against OpenCV's template matching.

Scores the candidate silhouettes of one camera's layer against an observed silhouette
over every shift, as :class:`~eigmotion.tracking.frame_scoring.FrameScorer` does each
frame, two ways, and prints one table — candidates per second, the ratio to OpenCV,
and whether the scores and shifts are equal:

* ``score_masks``: :func:`eigmotion.tracking.similarity.score_masks`, one compiled loop
  over the candidates, their pixels listed once, every shift summed in float64;
* ``OpenCV``: per candidate, ``cv2.matchTemplate`` (``TM_CCORR``) of its bounding box
  over the padded observed silhouette for the overlap at every shift (and over a padded
  window of ones for the in-rectangle area near the border), the scores in NumPy.

The silhouettes are this script's own: bodies drawn as an ellipse (trunk) and four
limbs at random angles in a window of the tracker's size at half resolution, the
observed one a body of the same kind block-averaged from twice the size (weights in
quarters, as the tracker's).

    python benchmarks/speed/bench_similarity.py [--candidates 40] [--radius 3] [--layers 200]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"  # one core, set before numpy and OpenCV are imported

import argparse  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from eigmotion.evaluation.timing import best_time  # noqa: E402
from eigmotion.tracking.similarity import EMPTY_SCORE, score_masks  # noqa: E402

cv2.setNumThreads(1)


def body(shape: tuple[int, int], rng: np.random.Generator, scale: int = 1) -> np.ndarray:
    """(H, W) bool: a standing figure about two thirds of the window tall."""
    h, w = shape[0] * scale, shape[1] * scale
    img = np.zeros((h, w), np.uint8)
    cx, top = w // 2 + int(rng.integers(-2, 3)) * scale, h // 6
    tall = 2 * h // 3
    cv2.ellipse(img, (cx, top + tall // 3), (max(1, w // 10), tall // 4), 0, 0, 360, 1, -1)
    cv2.circle(img, (cx, top + tall // 12), max(1, tall // 14), 1, -1)
    for side in (-1, 1):
        for joint, length in ((top + tall // 6, tall // 3), (top + tall // 2, tall // 2)):
            angle = np.radians(90 + side * rng.uniform(5, 50))
            dx, dy = side * length * abs(np.cos(angle)), length * np.sin(angle)
            end = (int(cx + dx), int(joint + dy))
            cv2.line(img, (cx, joint), end, 1, max(1, scale * 2))
    return img.astype(bool)


def opencv_scores(observed: np.ndarray, candidates: np.ndarray, r: int):
    """The same scores and shifts, per candidate with ``cv2.matchTemplate``."""
    obs = observed.astype(np.float32)
    h, w = obs.shape
    total, area_r = float(obs.sum(dtype=np.float64)), float(h * w)
    padded, ones = np.pad(obs, r), np.pad(np.ones_like(obs), r)
    scores = np.full(len(candidates), EMPTY_SCORE)
    shifts = np.zeros((len(candidates), 2), np.int64)
    for i, cand in enumerate(candidates):
        rows, cols = np.flatnonzero(cand.any(1)), np.flatnonzero(cand.any(0))
        if rows.size == 0:
            continue
        y0, y1, x0, x1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        template = cand[y0:y1, x0:x1].astype(np.float32)
        area = float(template.sum())

        def sums(image, t=template, y0=y0, x0=x0):
            window = image[y0 : y0 + t.shape[0] + 2 * r, x0 : x0 + t.shape[1] + 2 * r]
            return cv2.matchTemplate(window, t, cv2.TM_CCORR).astype(np.float64)

        inside = sums(padded)
        in_r = area if y0 >= r and x0 >= r and y1 + r <= h and x1 + r <= w else sums(ones)
        outside_area = area_r - in_r
        with np.errstate(divide="ignore", invalid="ignore"):
            outside = np.where(outside_area > 0, (total - inside) / outside_area, 0.0)
        s = inside / area - outside
        best = int(np.argmax(s))
        dy, dx = divmod(best, 2 * r + 1)
        scores[i], shifts[i] = s.flat[best], (dx - r, dy - r)
    return scores, shifts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--candidates", type=int, default=40, help="candidates per layer")
    parser.add_argument("--radius", type=int, default=3, help="shift radius, window pixels")
    parser.add_argument("--layers", type=int, default=200, help="layers (observed silhouettes)")
    parser.add_argument("--height", type=int, default=64, help="window rows at half resolution")
    parser.add_argument("--width", type=int, default=44, help="window columns")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    shape = (args.height, args.width)
    layers = []
    for _ in range(args.layers):
        big = body(shape, rng, scale=2).astype(np.float32)
        observed = big.reshape(shape[0], 2, shape[1], 2).mean(axis=(1, 3))
        layers.append((observed, np.stack([body(shape, rng) for _ in range(args.candidates)])))
    score_masks(*layers[0], args.radius)  # compiled (or loaded from numba's cache) first

    def ours():
        return [score_masks(obs, cands, args.radius) for obs, cands in layers]

    def theirs():
        return [opencv_scores(obs, cands, args.radius) for obs, cands in layers]

    (t_ours, a), (t_cv, b) = best_time(ours), best_time(theirs)
    same = all(
        np.array_equal(x[0], y[0]) and np.array_equal(x[1], y[1]) for x, y in zip(a, b, strict=True)
    )
    n = args.layers * args.candidates
    print(
        f"{args.layers} layers × {args.candidates} candidates, {shape[0]} × {shape[1]} window, "
        f"shifts ±{args.radius}; best of 3, one core\n"
    )
    print("| method | candidates/s | vs OpenCV | equal scores and shifts |")
    print("| --- | ---: | ---: | --- |")
    print(f"| score_masks (compiled) | {n / t_ours:,.0f} | {t_cv / t_ours:.1f}× | {same} |")
    print(f"| OpenCV matchTemplate per candidate | {n / t_cv:,.0f} | 1.0× | — |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
