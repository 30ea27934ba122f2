"""The independent development set, answered in-process as ``eigmotion query`` answers it.

The development set (``../shared/eval/dev``, see its ``README.md``) holds clips made
apart from the product: ``retrieval/<id>/`` (``video.mp4``, ``background.png`` of the
empty scene, ``meta.json`` with the ``label``, ``masks.npz`` with the true ``masks``
(F, 240, 320) bool) and ``real/<id>/`` (``video.mp4``, ``meta.json``; label
``unknown`` for an action outside the label set).  Nothing here copies them anywhere:
the folder is read where it lies.

Each clip is asked in one of five :data:`MODES`, every time through
:meth:`~eigmotion.retrieval.database.MotionDatabase.query_clip`, with the arguments
``eigmotion query CLIP --json`` passes it (:func:`answer_clip`):

* ``bg``: the retrieval clip's video with its empty-scene image (``--background``);
* ``nobg``: the retrieval clip's video alone;
* ``masks``: the true masks as an ``.npz`` query (``masks`` and ``fps``, written as
  ``shared/eval/score.py`` writes them): the ceiling of the representation;
* ``masks_small``: the same masks shrunk to the size a video query cuts its
  silhouettes at (:data:`~eigmotion.retrieval.database.QUERY_SILHOUETTE_SIDE_PX` on the
  longer side, :func:`true_masks_at`): the ceiling of a video query, like with like;
* ``real``: the real clips, no background.

For ``bg`` and ``nobg`` the query's own silhouettes are compared with the true masks
(:func:`silhouette_iou`).  :mod:`eigmotion.evaluation.devset_report` scores the answers.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from eigmotion.errors import EigmotionError, InvalidParameterError, StillPersonError
from eigmotion.evaluation.measures import iou
from eigmotion.evaluation.query_clips import TOP_K
from eigmotion.evaluation.scoring import NO_ANSWER
from eigmotion.retrieval.database import QUERY_SILHOUETTE_CONFIG, MotionDatabase
from eigmotion.segmentation.learned import working_size

#: The ways a clip is asked, in the order they are run and printed.
MODES = ("bg", "nobg", "masks", "masks_small", "real")

#: What each mode asks, as the tables title it.
MODE_TITLES = {
    "bg": "retrieval clips, video with its empty-scene image",
    "nobg": "retrieval clips, video alone",
    "masks": "retrieval clips, true masks (.npz)",
    "masks_small": "retrieval clips, true masks at the video query's working size (.npz)",
    "real": "real clips, video alone",
}

#: The folder of the clips each mode asks.
MODE_KIND = {
    "bg": "retrieval", "nobg": "retrieval", "masks": "retrieval", "masks_small": "retrieval",
    "real": "real",
}  # fmt: skip

#: The real clips' label for an action outside the label set (jumping jacks).
UNKNOWN_LABEL = "unknown"

#: The answer recorded for a query that raised an error (it counts as wrong).
ERROR_LABEL = "(error)"

#: The frame rate of a clip whose ``meta.json`` has none (as ``score.py`` assumes).
DEFAULT_FPS = 30.0

#: Where the development set is looked for when none is given, from the current folder.
DEFAULT_DEV = Path("..") / "shared" / "eval" / "dev"


@dataclass(frozen=True)
class DevClip:
    """One clip of the development set.

    Attributes
    ----------
    clip_id : str
        Its folder's name (``walk_accadM1_B3_v0``, ``weizmann-jack-slot0``).
    kind : str
        ``"retrieval"`` or ``"real"``.
    label : str
        What it shows (``meta.json``'s ``label``).
    folder : Path
    fps : float
        Frames per second (``meta.json``'s ``fps``, else :data:`DEFAULT_FPS`).
    """

    clip_id: str
    kind: str
    label: str
    folder: Path
    fps: float

    @property
    def video(self) -> Path:
        return self.folder / "video.mp4"

    @property
    def background(self) -> Path:
        return self.folder / "background.png"

    @property
    def masks_file(self) -> Path:
        return self.folder / "masks.npz"

    def true_masks(self) -> np.ndarray:
        """(F, H, W) bool: the person's visible pixels in every frame of the video."""
        with np.load(self.masks_file) as stored:
            return stored["masks"].astype(bool)


def find_dev_set(dev: str | Path | None) -> Path:
    """The development set's folder: ``dev``, or :data:`DEFAULT_DEV` from the current
    folder when ``dev`` is ``None``.

    Raises
    ------
    InvalidParameterError
        The folder does not exist or holds neither ``retrieval/`` nor ``real/``.
    """
    if dev is None:
        if not DEFAULT_DEV.is_dir():
            raise InvalidParameterError(
                f"no development set at {DEFAULT_DEV} (from {Path.cwd()}); pass --dev DIR"
            )
        dev = DEFAULT_DEV
    dev = Path(dev)
    if not dev.is_dir():
        raise InvalidParameterError(f"{dev}: development set folder not found; pass --dev DIR")
    if not ((dev / "retrieval").is_dir() or (dev / "real").is_dir()):
        raise InvalidParameterError(
            f"{dev}: not a development set (holds neither retrieval/ nor real/)"
        )
    return dev


def load_dev_clips(dev: Path, kind: str, only: Sequence[str] | None = None) -> list[DevClip]:
    """The clips of ``dev/kind/`` (folders with a ``meta.json``), sorted by id.

    Parameters
    ----------
    dev : Path
        The development set (:func:`find_dev_set`).
    kind : str
        ``"retrieval"`` or ``"real"``.
    only : sequence of str, optional
        Keep the clips whose id contains any of these strings.

    Raises
    ------
    InvalidParameterError
        An unknown ``kind``, or a ``meta.json`` without a ``label``.
    """
    if kind not in ("retrieval", "real"):
        raise InvalidParameterError(f"kind must be 'retrieval' or 'real', got {kind!r}")
    root = Path(dev) / kind
    if not root.is_dir():
        return []
    clips = []
    for folder in sorted(root.iterdir()):
        meta_file = folder / "meta.json"
        if not meta_file.is_file() or (only and not any(o in folder.name for o in only)):
            continue
        meta = json.loads(meta_file.read_text())
        if "label" not in meta:
            raise InvalidParameterError(f"{meta_file}: no 'label'")
        fps = float(meta.get("fps") or DEFAULT_FPS)
        clips.append(DevClip(folder.name, kind, str(meta["label"]), folder, fps))
    return clips


@dataclass(frozen=True)
class ClipAnswer:
    """One clip's answer in one mode (a query's JSON, the part that is scored).

    Attributes
    ----------
    clip_id, mode, true_label : str
    label : str
        The answer's ``label``; :data:`ERROR_LABEL` when the query raised,
        :data:`~eigmotion.evaluation.scoring.NO_ANSWER` for a person standing still
        (answered as no motion, not accepted).
    labels : tuple of str
        The answer's ranked ``labels``, distinct, likeliest first (``(label,)`` for an
        error).
    accepted : bool
        The answer's ``accepted`` (True for an error: it is no rejection).
    p_known : float or None
    distance : float or None
        The best match's distance, eigenspace units (None for an error).
    query_s : float
        Wall time of :meth:`~eigmotion.retrieval.database.MotionDatabase.query_clip`,
        seconds: reading and cutting out the clip and answering it.
    error : str or None
        The one-line message of the :class:`~eigmotion.errors.EigmotionError` raised.
    iou : float or None
        ``bg`` and ``nobg``: :func:`silhouette_iou` of the query's silhouettes.
    iou_frames : int
        Frames the IoU is the mean of.
    travel_speed : float or None
        The answer's ``travel_speed``, body heights per second.
    heading_change : float or None
        The answer's ``heading_change``, degrees.
    foot_raise : float or None
        The answer's ``foot_raise``, body heights.
    hands_raised : float or None
        The answer's ``hands_raised``, body heights.
    """

    clip_id: str
    mode: str
    true_label: str
    label: str
    labels: tuple[str, ...]
    accepted: bool
    p_known: float | None
    distance: float | None
    query_s: float
    error: str | None = None
    iou: float | None = None
    iou_frames: int = 0
    travel_speed: float | None = None
    heading_change: float | None = None
    foot_raise: float | None = None
    hands_raised: float | None = None

    @property
    def in_library(self) -> bool:
        return self.true_label != UNKNOWN_LABEL

    @property
    def truth_rank(self) -> int | None:
        """Where the true label stands in ``labels``: 1 when it is the answer, None when
        the query did not rank it (or raised)."""
        if self.error is not None or self.true_label not in self.labels:
            return None
        return self.labels.index(self.true_label) + 1

    def to_json(self) -> dict:
        return {
            "id": self.clip_id,
            "mode": self.mode,
            "truth": self.true_label,
            "label": self.label,
            "labels": list(self.labels),
            "truth_rank": self.truth_rank,
            "accepted": self.accepted,
            "p_known": self.p_known,
            "distance": self.distance,
            "query_s": round(self.query_s, 4),
            "error": self.error,
            "iou": None if self.iou is None else round(self.iou, 6),
            "iou_frames": self.iou_frames,
            "travel_speed": self.travel_speed,
            "heading_change_deg": self.heading_change,
            "foot_raise": self.foot_raise,
            "hands_raised": self.hands_raised,
        }


def true_masks_at(true_masks: np.ndarray, frame_indices: np.ndarray, shape) -> np.ndarray:
    """The true masks of the frames ``frame_indices``, at the silhouettes' ``shape``.

    Parameters
    ----------
    true_masks : (F, H, W) bool
    frame_indices : (F',) int
    shape : (h, w)
        The query's working size: ``H, W`` shrunk by a whole factor (the last rows and
        columns that do not fill a block dropped, as the segmentation shrinks frames).

    Returns
    -------
    (F', h, w) bool
        Each pixel the person covers at least half of (area average ``>= 0.5``).
    """
    picked = true_masks[np.asarray(frame_indices)]
    h, w = shape
    height, width = picked.shape[1:]
    factor = height // h if h else 0
    if factor >= 1 and width // factor == w and height // factor == h:
        blocks = picked[:, : h * factor, : w * factor].reshape(len(picked), h, factor, w, factor)
        return blocks.mean(axis=(2, 4)) >= 0.5
    small = [cv2.resize(m.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA) for m in picked]
    return np.stack(small) >= 0.5 if small else np.zeros((0, h, w), bool)


def silhouette_iou(
    masks: np.ndarray, frame_indices: np.ndarray, true_masks: np.ndarray
) -> tuple[float, int]:
    """Mean intersection over union of a query's silhouettes with the true masks.

    Like with like: the query cuts out only the frames it samples, at its working size
    (160 px on the longer side: 160×120 for the 320×240 clips), so the true masks of
    those frames are brought to that size (:func:`true_masks_at`) and compared frame by
    frame (:func:`eigmotion.evaluation.measures.iou`, 0 for a frame empty in both).

    Returns
    -------
    iou : float
        The mean over the frames compared.
    n_frames : int
    """
    keep = np.asarray(frame_indices) < len(true_masks)
    if not keep.any():
        return float("nan"), 0
    truth = true_masks_at(true_masks, np.asarray(frame_indices)[keep], masks.shape[1:])
    return iou(masks[keep], truth), int(keep.sum())


def answer_clip(
    db: MotionDatabase,
    clip: DevClip,
    mode: str,
    scratch: Path | None = None,
    segmenter: str = "auto",
) -> ClipAnswer:
    """Ask ``db`` one clip in one mode, as ``eigmotion query CLIP --json`` asks it.

    Parameters
    ----------
    db : MotionDatabase
    clip : DevClip
    mode : str
        One of :data:`MODES` (see the module's description).
    scratch : Path, optional
        A folder for the ``masks`` mode's ``.npz`` query (needed in that mode).
    segmenter : {"auto", "learned", "subtraction", "fused"}
        The front end for video (``eigmotion query --segmenter``); in the ``bg`` mode
        ``learned`` ignores the background image (the clip is asked without it).

    Returns
    -------
    ClipAnswer
        An :class:`~eigmotion.errors.EigmotionError` the query raises is recorded in it.
    """
    if mode not in MODES:
        raise InvalidParameterError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    path, background = clip.video, None
    if mode == "bg" and segmenter != "learned":
        background = clip.background
    elif mode in ("masks", "masks_small"):
        if scratch is None:
            raise InvalidParameterError(f"the {mode} mode needs a scratch folder")
        path = Path(scratch) / f"{clip.clip_id}.npz"
        masks = clip.true_masks()
        if mode == "masks_small":
            small = working_size(*masks.shape[1:], QUERY_SILHOUETTE_CONFIG)
            masks = true_masks_at(masks, np.arange(len(masks)), small)
        np.savez_compressed(path, masks=masks, fps=np.float64(clip.fps))
    t0 = time.perf_counter()
    try:
        result, cut = db.query_clip(path, background, TOP_K, segmenter=segmenter)
    except StillPersonError:  # answered as the command answers it: no motion, not accepted
        return ClipAnswer(
            clip.clip_id, mode, clip.label, NO_ANSWER, (NO_ANSWER,), False, None, None,
            time.perf_counter() - t0,
        )  # fmt: skip
    except EigmotionError as exc:
        message = " ".join(str(exc).split())
        return ClipAnswer(
            clip.clip_id, mode, clip.label, ERROR_LABEL, (ERROR_LABEL,), True, None, None,
            time.perf_counter() - t0, error=message or type(exc).__name__,
        )  # fmt: skip
    query_s = time.perf_counter() - t0
    score, n_frames = None, 0
    if mode in ("bg", "nobg") and clip.masks_file.is_file():
        score, n_frames = silhouette_iou(cut.masks, cut.frame_indices, clip.true_masks())
        score = None if math.isnan(score) else score
    return ClipAnswer(
        clip.clip_id,
        mode,
        clip.label,
        result.best.label,
        tuple(m.label for m in result.labels),
        bool(result.accepted),
        None if result.p_known is None else round(float(result.p_known), 4),
        float(result.best.distance),
        query_s,
        iou=score,
        iou_frames=n_frames,
        travel_speed=None if result.travel_speed is None else round(result.travel_speed, 3),
        heading_change=None if result.heading_change is None else round(result.heading_change, 1),
        foot_raise=None if result.foot_raise is None else round(result.foot_raise, 3),
        hands_raised=None if result.hands_raised is None else round(result.hands_raised, 3),
    )


def answer_mode(
    db: MotionDatabase,
    clips: Sequence[DevClip],
    mode: str,
    scratch: Path | None = None,
    progress: bool = False,
    segmenter: str = "auto",
) -> list[ClipAnswer]:
    """Every clip's :func:`answer_clip` in ``mode``, in order; a bar on stderr if
    ``progress``."""
    bar = tqdm(clips, desc=mode, unit="clip", disable=not progress, leave=False)
    return [answer_clip(db, clip, mode, scratch, segmenter) for clip in bar]
