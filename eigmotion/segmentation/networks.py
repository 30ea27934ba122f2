"""The person networks the learned front end runs, loaded once per process.

Two of MediaPipe's networks (Apache-2.0) ship in ``eigmotion/data/segmenter/`` beside
their licence; nothing is downloaded:

* the selfie segmentation network (general model): a 256×256 RGB image in, the
  probability of "person" per pixel out.  It runs through the LiteRT interpreter
  (``ai-edge-litert``, installed with eigmotion on the platforms LiteRT has wheels
  for: Linux x86_64, Windows AMD64, macOS arm64), else through OpenCV's DNN module,
  which reads the same file and gives the same probabilities, several times slower;
* the pose landmark network (full model): a 256×256 RGB square centred on one person
  in, out the person's segmentation (logits per pixel), 33 body landmarks (plus 6
  auxiliary points) with their visibility and presence, and a flag that a person is in
  the square.  OpenCV's DNN module returns only one of its five outputs, so it runs
  through LiteRT only; without LiteRT, :func:`pose_network` is ``None`` and the
  learned front end uses the selfie network for its second look as well.

Both take float32 RGB in [0, 1].  The interpreters run on as many threads as the
process may use (:func:`os.sched_getaffinity`).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import cv2
import numpy as np

from eigmotion.errors import VideoError

#: The folder of the shipped networks and their licence.
NETWORK_DIR = Path(__file__).resolve().parents[1] / "data" / "segmenter"

#: MediaPipe's selfie segmentation network (general model).
SELFIE_PATH = NETWORK_DIR / "selfie_segmentation.tflite"

#: MediaPipe's pose landmark network (full model), from the ``mediapipe`` 0.10.21 wheel.
POSE_PATH = NETWORK_DIR / "pose_landmark_full.tflite"

#: Both networks' input side (and the selfie network's output side), pixels.
MODEL_SIDE_PX = 256

#: Body landmarks of the pose network (MediaPipe's BlazePose topology: 0 nose ... 11, 12
#: shoulders, 23, 24 hips, 27, 28 ankles ... 32 right foot index); it outputs 39, the
#: last 6 auxiliary.
N_POSE_LANDMARKS = 33


@dataclass(frozen=True)
class PoseOutput:
    """The pose network's answer for one 256×256 square.

    Attributes
    ----------
    probabilities : (256, 256) float32
        Probability of "person" per pixel of the square, in [0, 1].
    landmarks : (33, 4) float32
        x, y (pixels of the square), visibility and presence (both probabilities in
        [0, 1]) of each body landmark.
    person : float
        Probability that a person is in the square.
    world : (33, 3) float32
        The same landmarks in metres, centred between the hips, the camera's axes (x
        right, y down, z away from the camera): the network's "world landmarks".
    """

    probabilities: np.ndarray
    landmarks: np.ndarray
    person: float
    world: np.ndarray


def runtime() -> str:
    """``"litert"`` when the LiteRT interpreter is installed, else ``"opencv"``."""
    return selfie_network()[0]


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return (1.0 / (1.0 + np.exp(-np.clip(x, -60.0, 60.0)))).astype(np.float32)


#: Threads each network runs on; ``None``: as many as the cores this process may use.
_network_threads: int | None = None


def set_network_threads(threads: int) -> None:
    """Run the networks loaded from now on on ``threads`` threads (a process of a pool
    that answers one query at a time among others wants 1)."""
    global _network_threads
    if int(threads) < 1:
        raise ValueError(f"network threads must be at least 1, not {threads}")
    _network_threads = int(threads)


def _threads() -> int:
    if _network_threads is not None:
        return _network_threads
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


def litert_interpreter(path: Path):
    """A LiteRT interpreter of ``path`` with its tensors allocated, or ``None`` when
    LiteRT is not installed."""
    try:
        from ai_edge_litert.interpreter import Interpreter
    except ImportError:
        return None
    with _quiet_stderr():  # LiteRT announces its CPU delegate on stderr
        interpreter = Interpreter(model_path=str(path), num_threads=_threads())
        interpreter.allocate_tensors()
    return interpreter


def _check_file(path: Path) -> None:
    if not path.is_file():
        raise VideoError(f"{path}: the person segmenter's network is missing")


@cache
def selfie_network() -> tuple[str, Callable[[np.ndarray], np.ndarray]]:
    """(runtime name, function from one (256, 256, 3) float32 RGB input in [0, 1] to
    the (256, 256) float32 probabilities of "person")."""
    _check_file(SELFIE_PATH)
    interpreter = litert_interpreter(SELFIE_PATH)
    if interpreter is not None:
        source = interpreter.get_input_details()[0]["index"]
        target = interpreter.get_output_details()[0]["index"]

        def run_litert(x: np.ndarray) -> np.ndarray:
            interpreter.set_tensor(source, x[None])
            interpreter.invoke()
            return interpreter.get_tensor(target)[0, :, :, 0]

        return "litert", run_litert
    net = cv2.dnn.readNetFromTFLite(str(SELFIE_PATH))

    def run_opencv(x: np.ndarray) -> np.ndarray:
        net.setInput(np.ascontiguousarray(x.transpose(2, 0, 1)[None]))
        return net.forward()[0, 0]

    return "opencv", run_opencv


@cache
def pose_network() -> Callable[[np.ndarray], PoseOutput] | None:
    """Function from one (256, 256, 3) float32 RGB input in [0, 1] (a square centred
    on the person) to its :class:`PoseOutput`; ``None`` without LiteRT."""
    _check_file(POSE_PATH)
    interpreter = litert_interpreter(POSE_PATH)
    if interpreter is None:
        return None
    source = interpreter.get_input_details()[0]["index"]
    outputs = {tuple(d["shape"][1:]): d["index"] for d in interpreter.get_output_details()}
    landmarks_at = outputs[(5 * (N_POSE_LANDMARKS + 6),)]
    world_at = outputs[(3 * (N_POSE_LANDMARKS + 6),)]
    flag_at = outputs[(1,)]
    mask_at = outputs[(MODEL_SIDE_PX, MODEL_SIDE_PX, 1)]

    def run(x: np.ndarray) -> PoseOutput:
        interpreter.set_tensor(source, x[None])
        interpreter.invoke()
        raw = interpreter.get_tensor(landmarks_at).reshape(-1, 5)[:N_POSE_LANDMARKS]
        landmarks = np.empty((N_POSE_LANDMARKS, 4), np.float32)
        landmarks[:, :2] = raw[:, :2]
        landmarks[:, 2:] = _sigmoid(raw[:, 3:5])
        probabilities = _sigmoid(interpreter.get_tensor(mask_at)[0, :, :, 0])
        world = interpreter.get_tensor(world_at).reshape(-1, 3)[:N_POSE_LANDMARKS]
        person = float(interpreter.get_tensor(flag_at)[0, 0])
        return PoseOutput(probabilities, landmarks, person, world.astype(np.float32))

    return run


@contextmanager
def _quiet_stderr():
    """File descriptor 2 sent to ``/dev/null`` for the block (what a native library
    prints there), then restored."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
