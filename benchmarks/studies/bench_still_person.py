"""A person standing still against a person moving: how much their silhouettes change.

A learned segmenter answers each frame's sensor noise a little differently, so the mask
of a person who does not move flickers along its edges.  Aligned in the person frame
(each frame centred on its own body) that flicker moves the whole silhouette and passes
the motion image's own "no motion" test; the query therefore also holds the silhouettes
as given to :data:`~eigmotion.retrieval.motion_image.STILL_CHANGE_SHARE`
(:meth:`~eigmotion.retrieval.motion_image.ClipMotionImages.change`: pixels changed
between sampled frames over the body's area).

For every clip of a development set (``retrieval/*/video.mp4`` and ``real/*/video.mp4``,
read in place, without a background image) this cuts the person out as the query does
and prints the change of the clip as filmed and of a *still* copy of it: its first frame
held for ``--seconds`` with Gaussian sensor noise (``--noise``, grey levels) added to
every frame, written to a temporary video.  The summary gives the smallest change of a
filmed action beside the largest of a still person: the threshold must lie between
them.  ``--library`` also renders every library motion on the default avatar from 12
azimuths (every 30°, elevation 8°, clean masks 160×120) and lists the renderings that
change by less than the threshold: what a motion the camera barely sees costs (about
3 minutes more).  Run from the repository root with the venv active (about 4 minutes
for 140 clips)::

    python benchmarks/studies/bench_still_person.py --dev ../shared/eval/dev
        [--db database/eigmotion.fs] [--seconds 3] [--noise 2] [--limit N] [--library]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from eigmotion.errors import VideoError
from eigmotion.imaging.media import read_frames, write_video
from eigmotion.retrieval.database import QUERY_SILHOUETTE_CONFIG, MotionDatabase
from eigmotion.retrieval.motion_image import STILL_CHANGE_SHARE, ClipMotionImages, MotionImageConfig
from eigmotion.segmentation.camera_motion import stabilised
from eigmotion.segmentation.video import load_clip_masks


def still_copy(video: Path, out: Path, seconds: float, noise: float, seed: int) -> None:
    """Write ``out``: the first frame of ``video`` held ``seconds`` at its frame rate,
    with Gaussian noise of ``noise`` grey levels on every frame."""
    frames, fps = read_frames(video, max_frames=1)
    rng = np.random.default_rng(seed)
    held = frames[0] + rng.normal(0.0, noise, (int(round(seconds * fps)), *frames.shape[1:]))
    write_video(np.clip(np.rint(held), 0, 255).astype(np.uint8), out, fps)


def change_of(path: Path, db: MotionDatabase) -> float:
    """The whole clip's change (share of the body's area per sampled frame), its person
    cut out as a query without a background image cuts it."""
    config = db.config.motion_image
    clip = load_clip_masks(path, None, QUERY_SILHOUETTE_CONFIG, config.sample_fps, segmenter="auto")
    seen = clip.masks if clip.camera is None else stabilised(clip.masks, clip.camera)
    return ClipMotionImages(seen, config, clip.fps, clip.hidden_below_px).change(0, len(seen))


def library_changes() -> list[tuple[float, str, float]]:
    """(change, motion name, azimuth in degrees) of every library motion rendered on
    the default avatar from 12 azimuths, smallest change first."""
    from eigmotion.body.avatar import load_default_avatar
    from eigmotion.body.retarget import animate_avatar
    from eigmotion.imaging.cameras import virtual_rig
    from eigmotion.imaging.silhouettes import render_masks
    from eigmotion.mocap.library import load_library

    body, config, fps = load_default_avatar(), MotionImageConfig(), 15.0
    rows = []
    for item in load_library():
        _, vertices = animate_avatar(body, item.motion.resample(fps))
        for azimuth in range(0, 360, 30):
            camera = virtual_rig([float(azimuth)], [8.0], 160, 120).fitted(
                vertices[:, ::7].reshape(-1, 3)
            )[0]
            masks = render_masks(vertices, body.faces, camera)
            change = ClipMotionImages(masks, config, fps).change(0, len(masks))
            rows.append((change, item.name, float(azimuth)))
    return sorted(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dev", type=Path, required=True, help="development set folder")
    parser.add_argument("--db", default="database/eigmotion.fs", help="database (its config)")
    parser.add_argument("--seconds", type=float, default=3.0, help="length of a still copy, s")
    parser.add_argument("--noise", type=float, default=2.0, help="sensor noise, grey levels")
    parser.add_argument("--limit", type=int, default=None, help="at most this many clips")
    parser.add_argument(
        "--library", action="store_true", help="also the library's motions from 12 azimuths"
    )
    args = parser.parse_args()
    videos = sorted(args.dev.glob("retrieval/*/video.mp4")) + sorted(
        args.dev.glob("real/*/video.mp4")
    )
    videos = videos[: args.limit]
    filmed, still = {}, {}
    with MotionDatabase.open(args.db) as db, tempfile.TemporaryDirectory() as tmp:
        for i, video in enumerate(videos):
            name = video.parent.name
            copy = Path(tmp) / f"{name}.mp4"
            still_copy(video, copy, args.seconds, args.noise, seed=i)
            for store, path in ((filmed, video), (still, copy)):
                try:
                    store[name] = change_of(path, db)
                except VideoError as error:  # no person found: nothing to compare
                    print(f"{name}: {error}")
            print(
                f"{i + 1:4d}/{len(videos)} {name:44s} filmed {filmed.get(name, np.nan):7.2%}"
                f"  still {still.get(name, np.nan):7.2%}",
                flush=True,
            )
    if not filmed or not still:
        raise SystemExit("no clip gave a person to measure")
    low = min(filmed, key=filmed.get)
    high = max(still, key=still.get)
    print(
        f"\nchange as filmed: smallest {filmed[low]:.2%} ({low}), median "
        f"{np.median(list(filmed.values())):.2%}, over {len(filmed)} clips\n"
        f"change held still: largest {still[high]:.2%} ({high}), median "
        f"{np.median(list(still.values())):.2%}, over {len(still)} clips\n"
        f"threshold STILL_CHANGE_SHARE {STILL_CHANGE_SHARE:.2%}: "
        f"{filmed[low] / STILL_CHANGE_SHARE:.2f}× under the smallest action, "
        f"{STILL_CHANGE_SHARE / still[high]:.2f}× over the largest still person; "
        f"actions under it {sum(v < STILL_CHANGE_SHARE for v in filmed.values())}, "
        f"still people over it {sum(v >= STILL_CHANGE_SHARE for v in still.values())}"
    )
    if args.library:
        rows = library_changes()
        under = [row for row in rows if row[0] < STILL_CHANGE_SHARE]
        print(f"\nlibrary renderings under the threshold: {len(under)} of {len(rows)}")
        for change, name, azimuth in under:
            print(f"  {change:6.2%}  {name} from {azimuth:g}°")


if __name__ == "__main__":
    main()
