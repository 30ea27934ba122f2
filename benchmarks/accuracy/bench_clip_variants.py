"""The development set's clips as other cameras would have filmed them: does the answer hold?

The development set's clips are all 320 × 240 at 30 frames/s (the real ones 64 × 64 at
25), from a still camera in good light.  Users' videos are not: phones film in high
definition or at 60 frames/s, people stand far off or small in a wide frame, the camera
is held in the hand, rooms are dim.  This benchmark writes each clip again as such a
camera would give it (:data:`VARIANTS`), asks every copy exactly as
``eigmotion query CLIP --json`` asks it (:func:`eigmotion.evaluation.devset.answer_clip`),
and prints each variant's top-1 beside the unchanged clips' from the same run, as a
ratio, with how many answers stayed the same.

Modes: ``nobg`` (the retrieval clips without their empty-scene image: the learned front
end, what most users have), ``bg`` (with it, the image changed as the video is, where
that is possible: not under a shaking camera) and ``real`` (the real clips).  The
copies are written under ``--scratch`` (deleted afterwards unless ``--keep``): they are
for this evaluation only.

Run from the repository root::

    python benchmarks/accuracy/bench_clip_variants.py --db DB                # ~25 min
    python benchmarks/accuracy/bench_clip_variants.py --db DB --modes nobg \\
        --variants original shake dark --only kick_ wave_
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from eigmotion.evaluation.devset import (
    ERROR_LABEL,
    DevClip,
    answer_clip,
    find_dev_set,
    load_dev_clips,
)
from eigmotion.imaging.media import read_frames, sample_indices, write_video
from eigmotion.imaging.still_images import read_image_rgb
from eigmotion.retrieval.database import MotionDatabase

#: Seed of the shaking camera's path and the low-light noise.
SEED = 0

#: The handheld camera: the frame's centre wanders by a random walk of this many pixels
#: per frame (standard deviation, at 320 px wide), at most :data:`SHAKE_MAX` of the
#: frame's size away from the middle, and the picture is enlarged by :data:`SHAKE_ZOOM`
#: so that no border comes into view.
SHAKE_STEP_PX = 1.5
SHAKE_MAX = 0.04
SHAKE_ZOOM = 1.08

#: The panning camera: the view sweeps this share of the frame's width to one side and
#: back over the clip, while it zooms in from 1 to :data:`PAN_ZOOM`.
PAN_SWEEP = 0.2
PAN_ZOOM = 1.15

#: Low light: the pixel values times this gain, plus sensor noise of this standard
#: deviation (grey levels).
DARK_GAIN = 0.45
DARK_NOISE = 6.0

#: A room at night: the same, darker, with less noise (a camera at its limit).
NIGHT_GAIN = 0.2
NIGHT_NOISE = 4.0

#: JPEG quality of the heavily compressed copy (OpenCV's 0-100 scale).
JPEG_QUALITY = 25


@dataclass(frozen=True)
class Variant:
    """One way of filming a clip again.

    Attributes
    ----------
    name : str
    description : str
    frames : callable
        ``(frames (F, H, W, 3) uint8 RGB, fps, rng) -> (frames', fps')``.
    background : callable or None
        ``(image (H, W, 3) uint8, rng) -> image'``: the empty-scene image as the same
        camera would take it; ``None`` where no single image can stand for the scene
        (a moving camera): the ``bg`` mode is then skipped.
    """

    name: str
    description: str
    frames: Callable
    background: Callable | None


def _resize(images: np.ndarray, factor: float) -> np.ndarray:
    h, w = images.shape[1:3]
    size = (max(1, round(w * factor)), max(1, round(h * factor)))
    method = cv2.INTER_CUBIC if factor > 1 else cv2.INTER_AREA
    return np.stack([cv2.resize(image, size, interpolation=method) for image in images])


def _scaled(factor: float):
    return (
        lambda frames, fps, rng: (_resize(frames, factor), fps),
        lambda image, rng: _resize(image[None], factor)[0],
    )


def _widened(images: np.ndarray) -> np.ndarray:
    """The frames padded left and right to 16:9 with their own edge columns (a wider
    lens: the person fills less of the width), to an even width."""
    h, w = images.shape[1:3]
    pad = max(0, 2 * round((h * 16 / 9 - w) / 2))  # even: videos are written even-sized
    left, right = pad // 2, pad - pad // 2
    return np.stack(
        [cv2.copyMakeBorder(i, 0, 0, left, right, cv2.BORDER_REPLICATE) for i in images]
    )


def _tall(images: np.ndarray) -> np.ndarray:
    """The frames padded above and below to 9:16 with their own edge rows (a phone held
    upright: the person fills less of the height), to an even height."""
    h, w = images.shape[1:3]
    pad = max(0, 2 * round((w * 16 / 9 - h) / 2))
    top, bottom = pad // 2, pad - pad // 2
    return np.stack(
        [cv2.copyMakeBorder(i, top, bottom, 0, 0, cv2.BORDER_REPLICATE) for i in images]
    )


def _far(images: np.ndarray) -> np.ndarray:
    """The frames twice the size, padded on every side with their own edges to four
    times the size (a wide shot in high definition: the person fills a fifth of the
    height or less, drawn with as many pixels as in the twice-as-large copy)."""
    large = _resize(images, 2.0)
    h, w = large.shape[1:3]
    top, side = h // 2, w // 2
    return np.stack(
        [cv2.copyMakeBorder(i, top, top, side, side, cv2.BORDER_REPLICATE) for i in large]
    )


def _shaken(frames: np.ndarray, fps: float, rng: np.random.Generator):
    h, w = frames.shape[1:3]
    path = np.cumsum(rng.normal(0.0, SHAKE_STEP_PX * w / 320, (len(frames), 2)), axis=0)
    path = np.clip(path - path.mean(axis=0), -SHAKE_MAX * w, SHAKE_MAX * w)
    out = []
    for frame, (dx, dy) in zip(frames, path, strict=True):
        matrix = np.float32(
            [[SHAKE_ZOOM, 0, dx - (SHAKE_ZOOM - 1) * w / 2],
             [0, SHAKE_ZOOM, dy - (SHAKE_ZOOM - 1) * h / 2]]
        )  # fmt: skip
        out.append(cv2.warpAffine(frame, matrix, (w, h), borderMode=cv2.BORDER_REFLECT))
    return np.stack(out), fps


def _panned(frames: np.ndarray, fps: float, rng: np.random.Generator):
    h, w = frames.shape[1:3]
    out = []
    for i, frame in enumerate(frames):
        t = i / max(len(frames) - 1, 1)
        zoom = 1.0 + (PAN_ZOOM - 1.0) * t
        dx = PAN_SWEEP * w * (np.sin(np.pi * t) - 0.5)  # the view's centre, off the middle
        matrix = np.float32(
            [[zoom, 0, -dx * zoom - (zoom - 1) * w / 2], [0, zoom, -(zoom - 1) * h / 2]]
        )
        out.append(cv2.warpAffine(frame, matrix, (w, h), borderMode=cv2.BORDER_REFLECT))
    return np.stack(out), fps


def _dark(
    images: np.ndarray, rng: np.random.Generator, gain: float = DARK_GAIN, noise: float = DARK_NOISE
) -> np.ndarray:
    noisy = images.astype(np.float32) * gain + rng.normal(0.0, noise, images.shape)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def _night(images: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return _dark(images, rng, NIGHT_GAIN, NIGHT_NOISE)


def _jpeg(images: np.ndarray) -> np.ndarray:
    out = []
    for image in images:
        ok, data = cv2.imencode(".jpg", image[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        if not ok:
            raise RuntimeError("OpenCV could not encode a JPEG")
        out.append(cv2.imdecode(data, cv2.IMREAD_COLOR)[..., ::-1])
    return np.stack(out)


def _same(image, rng):
    return image


VARIANTS = {
    v.name: v
    for v in (
        Variant("original", "the clip as it is", lambda f, fps, rng: (f, fps), _same),
        Variant("hd", "4 × the size (1280 × 960; 256 × 256 for the real clips)",
                *_scaled(4.0)),
        Variant("x2", "2 × the size (640 × 480)", *_scaled(2.0)),
        Variant("far", "a wide shot in high definition: 2 × the size, padded on every side "
                "to 4 × (1280 × 960): the person a fifth of the height or less",
                lambda f, fps, rng: (_far(f), fps), lambda i, rng: _far(i[None])[0]),
        Variant("half", "half the size: a person 35–50 px tall (32 px for the real clips)",
                *_scaled(0.5)),
        Variant("wide", "padded to 16:9 with the frame's own edges",
                lambda f, fps, rng: (_widened(f), fps), lambda i, rng: _widened(i[None])[0]),
        Variant("tall", "padded to 9:16 (portrait) with the frame's own edges",
                lambda f, fps, rng: (_tall(f), fps), lambda i, rng: _tall(i[None])[0]),
        Variant("fps60", "60 frames/s (50 for the real clips): each frame twice",
                lambda f, fps, rng: (np.repeat(f, 2, axis=0), 2 * fps), _same),
        Variant("fps24", "24 frames/s (20 for the real clips): the nearest frames",
                lambda f, fps, rng: (f[sample_indices(len(f), fps, 0.8 * fps)], 0.8 * fps),
                _same),
        Variant("shake", "a handheld camera: the view wanders up to 4 % of the frame, "
                "zoomed 8 %", _shaken, None),
        Variant("pan", f"a camera that pans {PAN_SWEEP:.0%} of the frame's width and back "
                f"and zooms in to {PAN_ZOOM:g}×", _panned, None),
        Variant("dark", f"low light: × {DARK_GAIN} and sensor noise σ {DARK_NOISE:g}",
                lambda f, fps, rng: (_dark(f, rng), fps), lambda i, rng: _dark(i, rng)),
        Variant("night", f"a room at night: × {NIGHT_GAIN} and sensor noise σ {NIGHT_NOISE:g}",
                lambda f, fps, rng: (_night(f, rng), fps), _night),
        Variant("jpeg", f"every frame through JPEG at quality {JPEG_QUALITY}",
                lambda f, fps, rng: (_jpeg(f), fps), lambda i, rng: _jpeg(i[None])[0]),
    )
}  # fmt: skip


def write_copy(clip: DevClip, variant: Variant, folder: Path, with_background: bool) -> DevClip:
    """``clip`` filmed again as ``variant`` says, in the development set's layout
    under ``folder/<kind>/<id>/`` (video, ``meta.json``, the empty-scene image where
    the variant has one)."""
    rng = np.random.default_rng([SEED, sum(clip.clip_id.encode())])
    frames, _ = read_frames(clip.video)
    frames, fps = variant.frames(frames, clip.fps, rng)
    out = folder / clip.kind / clip.clip_id
    out.mkdir(parents=True, exist_ok=True)
    write_video(frames, out / "video.mp4", fps)
    meta = json.loads((clip.folder / "meta.json").read_text())
    meta.update(fps=fps, frames=len(frames), variant=variant.name)
    (out / "meta.json").write_text(json.dumps(meta, indent=1) + "\n")
    if with_background and variant.background is not None and clip.background.is_file():
        image = variant.background(read_image_rgb(clip.background), rng)
        cv2.imwrite(str(out / "background.png"), image[..., ::-1])
    return DevClip(clip.clip_id, clip.kind, clip.label, out, fps)


def is_right(label: str, answer) -> bool:
    """A library action answered with its label; an action outside the library
    (the real clips' jumping jacks) turned away."""
    if answer.label == ERROR_LABEL:
        return False
    if label == "unknown":
        return not answer.accepted
    return answer.label == label


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--db", required=True, help="the database to ask")
    parser.add_argument("--dev", help="the development set (default ../shared/eval/dev)")
    parser.add_argument(
        "--modes", nargs="+", choices=("nobg", "bg", "real"), default=["nobg", "bg", "real"]
    )
    parser.add_argument("--variants", nargs="+", choices=tuple(VARIANTS), default=list(VARIANTS))
    parser.add_argument("--only", nargs="+", help="clips whose id contains one of these")
    parser.add_argument("--scratch", type=Path, help="where the copies go (default a temp dir)")
    parser.add_argument("--keep", action="store_true", help="keep the copies")
    parser.add_argument("--json-out", type=Path, help="every answer, as JSON")
    args = parser.parse_args(argv)  # fmt: skip
    if "original" not in args.variants:
        args.variants.insert(0, "original")
    dev = find_dev_set(args.dev)
    kinds = {"nobg": "retrieval", "bg": "retrieval", "real": "real"}
    clips = {m: load_dev_clips(dev, kinds[m], args.only) for m in args.modes}
    scratch = Path(args.scratch or tempfile.mkdtemp(prefix="clip-variants-"))
    answers: dict[str, dict[str, dict[str, object]]] = {}
    t0 = time.perf_counter()
    try:
        with MotionDatabase.open(args.db) as db:
            for name in args.variants:
                variant = VARIANTS[name]
                for mode in args.modes:
                    if mode == "bg" and variant.background is None:
                        continue
                    done = answers.setdefault(name, {}).setdefault(mode, {})
                    for i, clip in enumerate(clips[mode]):
                        copy = write_copy(clip, variant, scratch / name, mode == "bg")
                        done[clip.clip_id] = answer_clip(db, copy, mode)
                        print(
                            f"\r{name:8s} {mode:4s} {i + 1}/{len(clips[mode])} "
                            f"({time.perf_counter() - t0:.0f} s)", end="", file=sys.stderr,
                        )  # fmt: skip
                print(file=sys.stderr)
    finally:
        if not args.keep:
            shutil.rmtree(scratch, ignore_errors=True)
    print_table(args, clips, answers)
    if args.json_out:
        rows = {v: {m: {c: a.to_json() for c, a in ans.items()} for m, ans in per.items()}
                for v, per in answers.items()}  # fmt: skip
        args.json_out.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


def print_table(args, clips, answers) -> None:
    """One row per variant: per mode, right / clips, the ratio to the original's, and
    the answers that stayed the same (label, and accepted or not)."""
    labels = {m: {c.clip_id: c.label for c in clips[m]} for m in args.modes}
    head = (
        "| variant | "
        + " | ".join(f"{m} right | vs original | same answer" for m in args.modes)
        + " | errors |"
    )
    print(head)
    print("|" + "---|" * (2 + 3 * len(args.modes)))
    base = answers["original"]
    for name in args.variants:
        cells, errors = [], 0
        for mode in args.modes:
            got = answers[name].get(mode)
            if not got:
                cells += ["—", "—", "—"]
                continue
            right = sum(is_right(labels[mode][c], a) for c, a in got.items())
            ref = sum(is_right(labels[mode][c], a) for c, a in base[mode].items())
            same = sum(
                (a.label, a.accepted) == (base[mode][c].label, base[mode][c].accepted)
                for c, a in got.items()
            )
            errors += sum(a.error is not None for a in got.values())
            ratio = right / ref if ref else float("nan")
            cells += [f"{right}/{len(got)}", f"{ratio:.2f}×", f"{same}/{len(got)}"]
        print(f"| {name} | " + " | ".join(cells) + f" | {errors} |")
    print()
    for name in args.variants:
        print(f"- {name}: {VARIANTS[name].description}")


if __name__ == "__main__":
    raise SystemExit(main())
