"""Render the bundled sample query clips (run from the repository root).

Each sample is a library motion performed by a body shape the database was not built
with, filmed by a still camera halfway between two cameras of the default rig, over a
textured background with a cast shadow and sensor noise — an unseen clip of a known
motion.  Writes ``<name>.mp4`` and ``<name>_background.png`` next to this file.

    python database/samples/make_samples.py [NAME ...]     # all when none named
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import numpy as np  # noqa: E402

from eigmotion.body.avatar import load_default_avatar  # noqa: E402
from eigmotion.imaging.figures import save_image  # noqa: E402
from eigmotion.imaging.media import write_video  # noqa: E402
from eigmotion.mocap.library import find_motion  # noqa: E402
from eigmotion.synth.clips import render_clip  # noqa: E402

HERE = Path(__file__).resolve().parent

#: name → (library motion, azimuth°, elevation°, body height m, girth, seed, seconds)
#: (``None``: the whole motion).  ``walk_3s`` is the 3 s, 320×240 clip the query-time
#: benchmark (benchmarks/speed/bench_query.py) is measured on.
SAMPLES = {
    "kick": ("kick_135_04", 45.0, 10.0, 1.62, 1.2, 1, None),
    "walk": ("walk_16_22", 105.0, 10.0, 1.80, 0.9, 2, None),
    "walk_3s": ("walk_16_15", 165.0, 5.0, 1.70, 1.05, 3, 3.0),
}


def main(names: list[str]) -> None:
    unknown = sorted(set(names) - set(SAMPLES))
    if unknown:
        sys.exit(f"unknown sample(s) {unknown}; expected some of {sorted(SAMPLES)}")
    base = load_default_avatar()
    for name in names or SAMPLES:
        motion_name, az, el, height_m, girth, seed, seconds = SAMPLES[name]
        body = base.with_shape(height_m=height_m, girth=girth)
        motion = find_motion(motion_name)
        if seconds is not None:
            motion = motion.trim(0, round(seconds / motion.frame_time_s) + 1)
        clip = render_clip(motion, body, az, el, np.random.default_rng(seed))
        write_video(clip.frames, HERE / f"{name}.mp4", clip.fps)
        save_image(clip.background, HERE / f"{name}_background.png")


if __name__ == "__main__":
    main(sys.argv[1:])
