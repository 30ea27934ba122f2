"""The query clips of the accuracy benchmarks: which to render, how, and where.

A query clip is a library motion performed by a body shape no database is built with
(:data:`BODY_SHAPES`), filmed by one still camera over a textured scene
(:func:`eigmotion.synth.clips.render_clip`, :data:`WIDTH_PX` × :data:`HEIGHT_PX`,
:data:`CLIP_FPS`) and written to ``.mp4`` with an image of the empty scene
(:class:`ClipMaker`).  :func:`seen_specs` films a motion from views halfway between a
rig's cameras, :func:`random_specs` from random views with the person 50–200 px tall;
:func:`subject_folds` and :func:`variation_folds` are the holdout suite's folds.
:func:`holdout_parser`, :func:`parse_holdout_args` and :func:`run_with_clips` are the
command line of the scripts that answer the holdout clips offline.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from eigmotion.body.avatar import load_default_avatar
from eigmotion.body.garments import dress
from eigmotion.body.retarget import animate_avatar
from eigmotion.errors import InvalidParameterError
from eigmotion.imaging.cameras import CameraRig
from eigmotion.imaging.figures import save_image
from eigmotion.imaging.media import write_video
from eigmotion.mocap.library import LibraryMotion
from eigmotion.resources import default_rig
from eigmotion.synth.clips import clip_camera, render_clip

#: The rig of the default database, ``virtual_cameras/default.toml``.
DEFAULT_RIG = default_rig()

#: Body shapes of the query clips, (height_m, girth): none is the database's own.
BODY_SHAPES: tuple[tuple[float, float], ...] = ((1.62, 1.2), (1.85, 0.9))
WIDTH_PX, HEIGHT_PX = 320, 240
CLIP_FPS = 30.0
#: Frame margin of the ``seen`` and ``unknown`` clips (the motion fills the frame).
SEEN_MARGIN = 0.08
#: Elevation when the rig has a single row of cameras, degrees.
SINGLE_ROW_ELEVATION_DEG = 10.0
LOSO_ELEVATION_DEG = (-5.0, 30.0)
LOSO_PERSON_PX = (50.0, 200.0)
TOP_K = 3


@dataclass(frozen=True)
class ClipSpec:
    """One query clip to render.

    Attributes
    ----------
    motion, label : str
        Library motion and its label.
    height_m, girth : float
        Body shape.
    azimuth_deg, elevation_deg : float
        Camera direction.
    margin : float
        Fraction of the frame kept free around the whole motion.
    seed : int
        Seed of the scene (background, shadow, clothing, noise).
    outfit : tuple of str
        Garments the body wears (:data:`eigmotion.body.garments.GARMENTS`).
    """

    motion: str
    label: str
    height_m: float
    girth: float
    azimuth_deg: float
    elevation_deg: float
    margin: float
    seed: int
    outfit: tuple[str, ...] = ()

    @property
    def stem(self) -> str:
        dressed = "".join(f"_{name}" for name in self.outfit)
        return (
            f"{self.motion}__h{self.height_m:.2f}_g{self.girth:.2f}{dressed}"
            f"__az{self.azimuth_deg:05.1f}_el{self.elevation_deg:+05.1f}"
            f"__m{self.margin:.3f}__s{self.seed}"
        )


@dataclass(frozen=True)
class ClipFiles:
    """A rendered clip on disk."""

    video: Path
    background: Path
    person_px: float
    render_s: float


def clip_seed(seed: int, *parts: object) -> int:
    """A stable 31-bit seed from the run's seed and the clip's identity."""
    return zlib.crc32("/".join(map(str, (seed, *parts))).encode()) & 0x7FFFFFFF


def halfway_views(rig: CameraRig) -> tuple[np.ndarray, np.ndarray]:
    """Directions halfway between a rig's cameras.

    Returns
    -------
    azimuths_deg : (A,) float64
        Midpoints between neighbouring camera azimuths, around the circle.
    elevations_deg : (E,) float64
        Midpoints between neighbouring camera rows, or the single row's elevation +
        :data:`SINGLE_ROW_ELEVATION_DEG`.
    """
    az = np.unique(np.round([c.azimuth_deg % 360.0 for c in rig.cameras], 6))
    el = np.unique(np.round([c.elevation_deg for c in rig.cameras], 6))
    nxt = np.append(az[1:], az[0] + 360.0)
    azimuths = ((az + nxt) / 2.0) % 360.0
    if len(el) > 1:
        elevations = (el[:-1] + el[1:]) / 2.0
    else:
        elevations = el + SINGLE_ROW_ELEVATION_DEG
    return azimuths, elevations


def seen_specs(item: LibraryMotion, rig: CameraRig, n_clips: int, seed: int) -> list[ClipSpec]:
    """``n_clips`` clips of ``item`` from views halfway between ``rig``'s cameras.

    Clip ``j`` uses body shape ``j mod 2`` and a view drawn without repetition (while
    there are views left) from :func:`halfway_views`; clip 0 is the same whatever
    ``n_clips`` is, so suites share it.
    """
    azimuths, elevations = halfway_views(rig)
    rng = np.random.default_rng(clip_seed(seed, "views", item.name))
    order = rng.permutation(len(azimuths))
    specs = []
    for j in range(n_clips):
        height_m, girth = BODY_SHAPES[j % len(BODY_SHAPES)]
        specs.append(
            ClipSpec(
                item.name,
                item.label,
                height_m,
                girth,
                float(azimuths[order[j % len(order)]]),
                float(elevations[j % len(elevations)]),
                SEEN_MARGIN,
                clip_seed(seed, "scene", item.name, j),
            )
        )
    return specs


class ClipMaker:
    """Renders query clips into a folder (or finds them there), one body per shape.

    Parameters
    ----------
    clips_dir : Path
        Where ``<stem>.mp4``, ``<stem>_background.png`` and ``<stem>.json`` go.
    """

    def __init__(self, clips_dir: Path):
        self.clips_dir = Path(clips_dir)
        self.clips_dir.mkdir(parents=True, exist_ok=True)
        self._bodies: dict = {}

    def body(self, height_m: float, girth: float, outfit: tuple[str, ...] = ()):
        key = (height_m, girth, outfit)
        if key not in self._bodies:
            shaped = load_default_avatar().with_shape(height_m=height_m, girth=girth)
            self._bodies[key] = dress(shaped, outfit)
        return self._bodies[key]

    def margin_for_person_px(
        self,
        item: LibraryMotion,
        shape: tuple[float, float],
        azimuth_deg: float,
        elevation_deg: float,
        person_px: float,
        outfit: tuple[str, ...] = (),
    ) -> float:
        """The frame margin that makes the person about ``person_px`` tall.

        The camera fitted with margin :data:`SEEN_MARGIN` gives the largest view; the
        image scales with the fraction of the frame the motion may fill,
        ``1 - 2 margin``.  Clipped to ``[SEEN_MARGIN, 0.45]``: a motion that travels far
        cannot show its person bigger.
        """
        _, vertices = animate_avatar(self.body(*shape, outfit), item.motion.resample(CLIP_FPS))
        camera = clip_camera(vertices, azimuth_deg, elevation_deg, WIDTH_PX, HEIGHT_PX, SEEN_MARGIN)
        pixels, _ = camera.project(vertices)
        full_px = float(np.median(np.ptp(pixels[..., 1], axis=1)))
        fill = (1.0 - 2.0 * SEEN_MARGIN) * person_px / max(full_px, 1e-9)
        return float(np.clip(0.5 * (1.0 - fill), SEEN_MARGIN, 0.45))

    def make(self, spec: ClipSpec, item: LibraryMotion) -> ClipFiles:
        video = self.clips_dir / f"{spec.stem}.mp4"
        background = self.clips_dir / f"{spec.stem}_background.png"
        info = self.clips_dir / f"{spec.stem}.json"
        if video.is_file() and background.is_file() and info.is_file():
            return ClipFiles(video, background, json.loads(info.read_text())["person_px"], 0.0)
        t0 = time.perf_counter()
        clip = render_clip(
            item.motion,
            self.body(spec.height_m, spec.girth),
            spec.azimuth_deg,
            spec.elevation_deg,
            np.random.default_rng(spec.seed),
            width=WIDTH_PX,
            height=HEIGHT_PX,
            fps=CLIP_FPS,
            margin=spec.margin,
            garments=spec.outfit,
        )
        write_video(clip.frames, video, clip.fps)
        save_image(clip.background, background)
        person_px = person_height_px(clip.true_masks)
        info.write_text(json.dumps({"person_px": person_px, "n_frames": len(clip.frames)}))
        return ClipFiles(video, background, person_px, time.perf_counter() - t0)


def person_height_px(masks: np.ndarray) -> float:
    """Median over frames of the silhouette's bounding-box height.

    Parameters
    ----------
    masks : (F, H, W) bool

    Returns
    -------
    float
        Pixels; 0 when no frame shows the person.
    """
    heights = []
    for mask in masks:
        rows = np.flatnonzero(mask.any(axis=1))
        if len(rows):
            heights.append(rows[-1] - rows[0] + 1)
    return float(np.median(heights)) if heights else 0.0


# -- folds -------------------------------------------------------------------------------


def random_specs(
    item: LibraryMotion, args, maker: ClipMaker, outfits: Sequence[tuple[str, ...]] = ((),)
) -> list[ClipSpec]:
    """``--clips-per-motion`` clips from random views, the person 50–200 px tall.

    Clip ``j`` has body shape ``j mod 2`` and outfit ``(j + o) mod len(outfits)``, where
    the offset ``o`` is drawn per motion, so that every outfit shows up across motions.
    """
    rng = np.random.default_rng(clip_seed(args.seed, "random-views", item.name))
    offset = int(rng.integers(len(outfits))) if len(outfits) > 1 else 0
    specs = []
    for j in range(args.clips_per_motion):
        shape = BODY_SHAPES[j % len(BODY_SHAPES)]
        outfit = tuple(outfits[(j + offset) % len(outfits)])
        az = float(np.round(rng.uniform(0.0, 360.0), 1))
        el = float(np.round(rng.uniform(*LOSO_ELEVATION_DEG), 1))
        px = float(rng.uniform(*LOSO_PERSON_PX))
        margin = round(maker.margin_for_person_px(item, shape, az, el, px, outfit), 3)
        seed = clip_seed(args.seed, "random-scene", item.name, j)
        specs.append(ClipSpec(item.name, item.label, *shape, az, el, margin, seed, outfit))
    return specs


def subject_folds(basic: Sequence[LibraryMotion], args) -> list[tuple[str, list]]:
    """``(fold name, held-out motions)``: one fold per CMU performer (``--subjects``)."""
    subjects = sorted({m.performer for m in basic if m.performer.startswith("cmu_")})
    if args.subjects:
        unknown = sorted(set(args.subjects) - set(subjects))
        if unknown:
            raise InvalidParameterError(
                f"--subjects: {unknown} not among the library's CMU performers {subjects}"
            )
        subjects = list(args.subjects)
    elif args.quick:
        subjects = sorted(subjects, key=lambda s: sum(m.performer == s for m in basic))[:2]
    return [(s, [m for m in basic if m.performer == s]) for s in subjects]


def variation_folds(basic: Sequence[LibraryMotion], args) -> list[tuple[str, list]]:
    """``(fold name, held-out motions)``: fold ``k`` holds out the ``k``-th authored
    motion of every label (library order) and its mirror image."""
    by_label: dict[str, list[str]] = {}
    for m in basic:
        if m.performer == "authored" and m.mirror_of is None:
            by_label.setdefault(m.label, []).append(m.name)
    n_folds = max((len(names) for names in by_label.values()), default=0)
    if args.quick:
        n_folds = min(n_folds, 1)
    folds = []
    for k in range(n_folds):
        held_names = {names[k] for names in by_label.values() if k < len(names)}
        held = [m for m in basic if m.name in held_names or m.mirror_of in held_names]
        folds.append((f"authored_{k}", held))
    return folds


# -- the command line of the holdout scripts ---------------------------------------------


def holdout_parser(description: str) -> argparse.ArgumentParser:
    """The options of a script that answers the ``holdout`` clips offline: ``--rig``,
    ``--clips-dir``, ``--clips-per-motion``, ``--seed``, ``--workers``."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--rig", type=Path, default=DEFAULT_RIG, help="rig of the databases")
    p.add_argument("--clips-dir", type=Path, help="render the clips here and reuse them")
    p.add_argument("--clips-per-motion", type=int, default=2)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=None, help="rendering processes")
    return p


def parse_holdout_args(
    p: argparse.ArgumentParser, argv: Sequence[str] | None = None
) -> argparse.Namespace:
    """Parse ``argv`` with a :func:`holdout_parser`, check it, and set what the fold
    helpers (:func:`subject_folds`, :func:`random_specs`) read."""
    args = p.parse_args(argv)
    if args.clips_per_motion < 1:
        p.error(f"--clips-per-motion must be >= 1, got {args.clips_per_motion}")
    args.quick, args.subjects = False, None
    return args


def run_with_clips(run: Callable[[argparse.Namespace], None], args: argparse.Namespace) -> None:
    """``run(args)``, with the clips in a temporary folder when no ``--clips-dir`` is given."""
    if args.clips_dir is not None:
        run(args)
        return
    with tempfile.TemporaryDirectory(prefix="eigmotion-clips-") as clips:
        args.clips_dir = Path(clips)
        run(args)
