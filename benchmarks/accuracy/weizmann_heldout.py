"""Real clips of people the development set's real clips do not show: the Weizmann
actions as MoCoGAN re-packaged them, the actors the development set leaves out.

The development set's real clips are four actions (wave with one arm, wave with
both, bend, jumping jack) by four of the nine actors of MoCoGAN's copy of the Weizmann
"Actions as Space-Time Shapes" videos (``data/actions/<action>/<n>.jpg``: each a strip
of 64 × 64 frames; the even files as recorded, the odd ones mirrored).  This script
writes the other actors' clips in the development set's layout (``real/<id>/``:
``video.mp4`` at 25 fps and ``meta.json`` with the label: ``wave``, ``pick_up`` for a
bend, ``unknown`` for a jumping jack), so that ``eigmotion eval recognition`` scores
real people it was never tuned on.  Files the development set's manifest lists are
left out.  The clips are for evaluation only: the data states no licence.

Run from the repository root, with a checkout of github.com/sergeytulyakov/mocogan::

    python benchmarks/accuracy/weizmann_heldout.py --mocogan ../mocogan --out /tmp/heldout
    python -m eigmotion eval recognition --dev /tmp/heldout --modes real --db DB
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np

from eigmotion.imaging.media import write_video
from eigmotion.imaging.still_images import read_image_rgb

#: MoCoGAN's action folder -> (the Weizmann action, the label it is scored against).
ACTIONS = {"0": ("wave1", "wave"), "1": ("wave2", "wave"), "3": ("jack", "unknown"),
           "4": ("bend", "pick_up")}  # fmt: skip

#: Weizmann's frame rate (MoCoGAN's strips do not store it), frames/s.
FPS = 25.0

#: The side of MoCoGAN's square frames, pixels.
SIDE_PX = 64


def listed_sources(manifest: Path) -> set[str]:
    """The ``data/actions/...jpg`` paths a development set's manifest names."""
    if not manifest.is_file():
        return set()
    with manifest.open(newline="") as stream:
        sources = [row["source"] for row in csv.DictReader(stream)]
    return {s.split(":", 1)[1] for s in sources if "mocogan" in s and ":" in s}


def strip_frames(path: Path) -> np.ndarray:
    """(F, 64, 64, 3) uint8 RGB frames of one strip."""
    strip = read_image_rgb(path)
    count = strip.shape[1] // SIDE_PX
    if strip.shape[0] != SIDE_PX or count == 0:
        raise SystemExit(f"{path}: not a strip of {SIDE_PX} × {SIDE_PX} frames")
    return np.stack([strip[:, k * SIDE_PX : (k + 1) * SIDE_PX] for k in range(count)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mocogan", type=Path, required=True, help="a checkout of mocogan")
    parser.add_argument("--out", type=Path, required=True, help="folder to write real/ into")
    parser.add_argument(
        "--manifest", type=Path, default=Path("../shared/eval/dev/manifest.csv"),
        help="files this manifest names are left out (default the development set's)",
    )  # fmt: skip
    args = parser.parse_args()
    skip = listed_sources(args.manifest)
    written = 0
    for folder, (action, label) in ACTIONS.items():
        strips = sorted((args.mocogan / "data" / "actions" / folder).glob("*.jpg"))
        if not strips:
            raise SystemExit(f"{args.mocogan}: no data/actions/{folder}/*.jpg (not a checkout?)")
        as_recorded = [p for p in strips if int(p.stem) % 2 == 0]
        for slot, path in enumerate(as_recorded):
            source = f"data/actions/{folder}/{path.name}"
            if source in skip:
                continue
            clip = args.out / "real" / f"weizmann-{action}-slot{slot}"
            frames = strip_frames(path)
            write_video(frames, clip / "video.mp4", FPS)
            meta = {"label": label, "source_label": action, "fps": FPS, "frames": len(frames),
                    "source": f"sergeytulyakov/mocogan:{source}", "slot": slot}  # fmt: skip
            (clip / "meta.json").write_text(json.dumps(meta, indent=1) + "\n")
            written += 1
    print(f"wrote {written} clips under {args.out / 'real'} ({len(skip)} left out: the manifest's)")


if __name__ == "__main__":
    main()
