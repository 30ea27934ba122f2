"""Clip I/O: video files, GIFs and image folders written and read back; bad input."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from eigmotion.errors import InvalidParameterError, VideoError
from eigmotion.imaging import media
from eigmotion.imaging.media import (
    FrameSampleStream,
    as_rgb_frames,
    mp4_fourcc,
    read_frame_sample,
    read_frames,
    sample_indices,
    write_video,
)
from eigmotion.imaging.still_images import image_files, read_image_rgb


def _smooth_clip(n_frames=8, height=48, width=64):
    """(F, H, W, 3) uint8: colour ramps that drift over time (easy on lossy codecs)."""
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float64)
    frames = []
    for f in range(n_frames):
        r = 40 + 160 * xx / width + 4 * f
        g = 30 + 180 * yy / height
        b = 60 + 100 * np.sin(0.1 * xx + 0.3 * f) ** 2
        frames.append(np.stack([r, g, b], axis=-1))
    return np.clip(np.round(frames), 0, 255).astype(np.uint8)


# -- sampled reading -------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
@pytest.mark.parametrize("clip_fps, sample_fps", [(30.0, 15.0), (25.0, 15.0), (10.0, 15.0)])
def test_frame_sample_holds_the_frames_sample_indices_picks(tmp_path, suffix, clip_fps, sample_fps):
    path = write_video(_smooth_clip(n_frames=23), tmp_path / f"clip{suffix}", fps=clip_fps)
    every, read_fps = read_frames(path)
    sample = read_frame_sample(path, sample_fps)
    expected = sample_indices(len(every), read_fps, sample_fps)
    assert sample.n_frames == len(every) and sample.clip_fps == read_fps
    np.testing.assert_array_equal(sample.frame_indices, expected)
    np.testing.assert_array_equal(sample.frames, every[expected])
    assert sample.fps == min(sample_fps, read_fps)
    whole = read_frame_sample(path)
    np.testing.assert_array_equal(whole.frames, every)
    assert whole.fps == read_fps


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
@pytest.mark.parametrize("size", [1, 4, 100])
def test_frame_sample_stream_hands_over_the_sample_in_chunks(tmp_path, suffix, size):
    path = write_video(_smooth_clip(n_frames=23), tmp_path / f"clip{suffix}", fps=25.0)
    whole = read_frame_sample(path, 15.0)
    stream = FrameSampleStream(path, 15.0)
    chunks = list(stream.chunks(size))
    assert all(1 <= len(chunk) <= size for chunk in chunks)
    np.testing.assert_array_equal(np.concatenate(chunks), whole.frames)
    np.testing.assert_array_equal(stream.frame_indices, whole.frame_indices)
    assert (stream.n_frames, stream.clip_fps, stream.fps) == (23, whole.clip_fps, whole.fps)


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
@pytest.mark.parametrize("clip_fps, n_frames", [(25.0, 74), (24.0, 71), (30.0, 23), (25.0, 23)])
def test_frame_sample_stream_transforms_exactly_the_frames_it_hands_over(
    tmp_path, suffix, clip_fps, n_frames
):
    """The last frame decoded is held back until the clip's length tells whether the
    sample takes it; a frame left out must not have been given to the transform, which
    may keep what it sees (the fused front end keeps each frame at its working size)."""
    path = write_video(_smooth_clip(n_frames=n_frames), tmp_path / f"c{suffix}", fps=clip_fps)
    seen = []

    def keep(frame):
        seen.append(frame.copy())
        return frame[::2, ::2]

    stream = FrameSampleStream(path, 15.0, transform=keep)
    handed = np.concatenate(list(stream.chunks(8)))
    whole = read_frame_sample(path, 15.0)
    assert len(seen) == len(handed) == len(stream.frame_indices)
    np.testing.assert_array_equal(np.stack(seen), whole.frames)
    np.testing.assert_array_equal(handed, whole.frames[:, ::2, ::2])


def test_a_folder_s_sample_reads_only_its_own_images(tmp_path, monkeypatch):
    frames = _smooth_clip(n_frames=23)
    for i, frame in enumerate(frames):
        Image.fromarray(frame).save(tmp_path / f"f{i}.png")
    reads = []
    original = media.read_image_rgb
    monkeypatch.setattr(media, "read_image_rgb", lambda p: reads.append(p) or original(p))
    stream = FrameSampleStream(tmp_path, 15.0, transform=lambda f: f[::2])
    handed = np.concatenate(list(stream.chunks(5)))
    expected = sample_indices(23, media.DEFAULT_FPS, 15.0)
    np.testing.assert_array_equal(stream.frame_indices, expected)
    assert [p.name for p in reads] == [f"f{i}.png" for i in expected]
    np.testing.assert_array_equal(handed, frames[expected][:, ::2])  # PNG is lossless
    assert (stream.n_frames, stream.clip_fps, stream.fps) == (23, media.DEFAULT_FPS, 15.0)
    with pytest.raises(InvalidParameterError, match="fps"):
        FrameSampleStream(tmp_path, 15.0, fps=-1.0)


def test_frame_sample_stream_counts_every_decoded_frame_on_its_bar(tmp_path, monkeypatch):
    """The bar (made after a second, at once here) counts the clip's frames, sampled or
    not, and the frames handed over are those of a stream without one."""
    import io

    from tqdm import tqdm

    from eigmotion.imaging import media

    shown = io.StringIO()
    monkeypatch.setattr(media, "FRAME_BAR_DELAY_S", 0.0)
    monkeypatch.setattr(
        media, "_frame_bar", lambda n: tqdm(total=n, desc="reading frames", file=shown)
    )
    path = write_video(_smooth_clip(n_frames=23), tmp_path / "clip.mp4", fps=25.0)
    with_bar = np.concatenate(list(FrameSampleStream(path, 15.0, progress=True).chunks(4)))
    np.testing.assert_array_equal(with_bar, read_frame_sample(path, 15.0).frames)
    assert "reading frames" in shown.getvalue() and "23/23" in shown.getvalue()


def test_a_clip_read_within_the_bar_delay_never_loads_tqdm(tmp_path):
    """A short clip is read before its bar would show: the process never imports tqdm
    (nor Pillow, which a video does not need)."""
    path = write_video(_smooth_clip(n_frames=23), tmp_path / "clip.mp4", fps=25.0)
    script = (
        "import sys; from eigmotion.imaging.media import FrameSampleStream as S; "
        f"list(S({str(path)!r}, 15.0, progress=True).chunks(4)); "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'tqdm', 'PIL'}))"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


@pytest.mark.parametrize("content", [b"", b"not a video at all"])
def test_frame_sample_stream_names_an_unreadable_video(tmp_path, content):
    path = tmp_path / "broken.mp4"
    path.write_bytes(content)
    stream = FrameSampleStream(path, 15.0)
    with pytest.raises(VideoError, match="broken.mp4: cannot be opened|broken.mp4: no frame"):
        list(stream.chunks(4))
    # The decoder is done before the error reaches the caller: a process exiting on it
    # while FFmpeg was still releasing the file could abort.
    assert not stream._decoder.is_alive()


def test_frame_sample_stream_stops_its_decoder_when_the_reader_gives_up(tmp_path):
    path = write_video(_smooth_clip(n_frames=60), tmp_path / "clip.mp4", fps=30.0)
    stream = FrameSampleStream(path, 15.0)
    chunks = stream.chunks(2)
    assert len(next(chunks)) == 2
    chunks.close()
    assert not stream._decoder.is_alive()


@pytest.mark.parametrize("sample_fps", [0.0, -5.0, float("nan")])
def test_frame_sample_rejects_bad_rates(tmp_path, sample_fps):
    path = write_video(_smooth_clip(), tmp_path / "clip.mp4", fps=30.0)
    with pytest.raises(InvalidParameterError, match="sample_fps"):
        read_frame_sample(path, sample_fps)


# -- round trips ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "suffix, max_mean_error",
    [(".mp4", 4.0), (".mov", 4.0), (".avi", 4.0), (".gif", 6.0)],
)
def test_video_round_trip(tmp_path, suffix, max_mean_error):
    clip = _smooth_clip()
    path = write_video(clip, tmp_path / f"clip{suffix}", fps=25.0)
    frames, fps = read_frames(path)
    assert frames.shape == clip.shape and frames.dtype == np.uint8
    error = np.abs(frames.astype(np.int16) - clip.astype(np.int16))
    assert error.mean() < max_mean_error
    # every frame must be closest to its own original (frames neither lost nor reordered)
    for f in range(len(clip)):
        errors = [np.abs(frames[f].astype(int) - c.astype(int)).mean() for c in clip]
        assert int(np.argmin(errors)) == f
    assert fps == pytest.approx(25.0, rel=1e-3)


@pytest.mark.parametrize("suffix", [".mp4", ".mov"])
def test_mp4_and_mov_files_hold_the_codec_mp4_fourcc_names(tmp_path, suffix):
    """The probed codec is the one :func:`write_video` writes: the file's sample entry
    names it, and not the other one."""
    codec = mp4_fourcc()
    assert codec in ("avc1", "mp4v")
    assert mp4_fourcc.cache_info().currsize == 1  # probed once per process
    data = write_video(_smooth_clip(3), tmp_path / f"clip{suffix}", fps=25.0).read_bytes()
    other = "mp4v" if codec == "avc1" else "avc1"
    assert codec.encode() in data and other.encode() not in data


@pytest.mark.parametrize("suffix", [".avi", ".gif", ".mp4"])
def test_masks_round_trip_as_white_on_black(tmp_path, suffix):
    masks = np.zeros((4, 40, 48), dtype=bool)
    for f in range(4):
        masks[f, 8 + 2 * f : 30, 10 : 20 + 4 * f] = True
    frames, _ = read_frames(write_video(masks, tmp_path / f"masks{suffix}", fps=10))
    assert frames.shape == (4, 40, 48, 3)
    recovered = frames.mean(axis=-1) > 127
    assert (recovered == masks).mean() > 0.99


@pytest.mark.parametrize("suffix", [".mp4", ".avi"])
@pytest.mark.parametrize("height, width", [(47, 64), (48, 65), (31, 33)])
def test_odd_sizes_are_padded_not_cropped(tmp_path, suffix, height, width):
    clip = _smooth_clip(3, height, width)
    frames, _ = read_frames(write_video(clip, tmp_path / f"odd{suffix}"))
    assert frames.shape == (3, height + height % 2, width + width % 2, 3)
    error = np.abs(frames[:, :height, :width].astype(int) - clip.astype(int)).mean()
    assert error < 5.0


def test_gif_frame_rate_is_whole_centiseconds(tmp_path):
    path = write_video(_smooth_clip(3), tmp_path / "rate.gif", fps=30.0)
    _, fps = read_frames(path)
    assert fps == pytest.approx(100.0 / 3.0)


def test_image_folder_in_natural_order(tmp_path):
    clip = _smooth_clip(12, 20, 24)
    for f in range(len(clip)):  # f1.png … f12.png: plain sorting would put f10 after f1
        Image.fromarray(clip[f]).save(tmp_path / f"f{f + 1}.png")
    (tmp_path / "notes.txt").write_text("not a frame")
    assert [p.name for p in image_files(tmp_path)][:3] == ["f1.png", "f2.png", "f3.png"]
    frames, fps = read_frames(tmp_path)
    np.testing.assert_array_equal(frames, clip)
    assert fps == 30.0
    assert read_frames(tmp_path, fps=12.5)[1] == 12.5


def test_image_folder_converts_grey_and_rgba(tmp_path):
    grey = np.full((10, 12), 77, np.uint8)
    Image.fromarray(grey).save(tmp_path / "a.png")
    rgba = np.zeros((10, 12, 4), np.uint8)
    rgba[..., 0] = 200
    rgba[..., 3] = 255
    Image.fromarray(rgba).save(tmp_path / "b.png")
    frames, _ = read_frames(tmp_path)
    assert frames.shape == (2, 10, 12, 3)
    assert np.all(frames[0] == 77) and np.all(frames[1] == [200, 0, 0])


@pytest.mark.parametrize("suffix", [".avi", ".gif"])
def test_max_frames(tmp_path, suffix):
    path = write_video(_smooth_clip(6), tmp_path / f"clip{suffix}")
    frames, _ = read_frames(path, max_frames=2)
    assert len(frames) == 2


def test_fps_override_for_files(tmp_path):
    path = write_video(_smooth_clip(2), tmp_path / "clip.avi", fps=24)
    assert read_frames(path, fps=50.0)[1] == 50.0


def test_as_rgb_frames_kinds():
    grey = np.arange(12, dtype=np.uint8).reshape(1, 3, 4)
    assert as_rgb_frames(grey).shape == (1, 3, 4, 3)
    assert as_rgb_frames(grey)[0, 2, 3].tolist() == [11, 11, 11]
    assert as_rgb_frames(np.ones((1, 2, 2), bool)).max() == 255


# -- errors --------------------------------------------------------------------------------


def test_missing_file(tmp_path):
    with pytest.raises(VideoError, match="no such file"):
        read_frames(tmp_path / "nothing.mp4")


def test_empty_folder(tmp_path):
    with pytest.raises(VideoError, match="holds no frames"):
        read_frames(tmp_path)


@pytest.mark.parametrize("suffix", [".mp4", ".avi", ".mov"])
@pytest.mark.parametrize("content", [b"", b"\x00\x01garbage" * 300])
def test_empty_or_corrupt_video(tmp_path, suffix, content):
    path = tmp_path / f"bad{suffix}"
    path.write_bytes(content)
    with pytest.raises(VideoError, match=str(path.name)):
        read_frames(path)


def test_a_cut_avi_keeps_the_frames_before_the_cut(tmp_path):
    """An ``.avi`` cut at three quarters (its index at the end lost) still reads: the
    first frames, in order, and none made up."""
    clip = _smooth_clip(10)
    path = write_video(clip, tmp_path / "cut.avi")
    data = path.read_bytes()
    path.write_bytes(data[: 3 * len(data) // 4])
    frames, _ = read_frames(path)
    assert 1 <= len(frames) < len(clip) and frames.shape[1:] == (48, 64, 3)
    for f in range(len(frames)):
        errors = [np.abs(frames[f].astype(int) - c.astype(int)).mean() for c in clip]
        assert int(np.argmin(errors)) == f and errors[f] < 4.0


def test_an_mp4_cut_in_half_is_refused_by_name(tmp_path):
    """Half an ``.mp4`` lacks the index written at its end: a VideoError naming it."""
    path = write_video(_smooth_clip(10), tmp_path / "cut.mp4")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(VideoError, match="cut.mp4: cannot be opened"):
        read_frames(path)


def test_corrupt_gif(tmp_path):
    path = tmp_path / "bad.gif"
    path.write_bytes(b"GIF89a" + b"\xff" * 50)
    with pytest.raises(VideoError, match="bad.gif"):
        read_frames(path)


def test_unknown_extension(tmp_path):
    path = tmp_path / "clip.txt"
    path.write_text("hello")
    with pytest.raises(VideoError, match="unknown clip type"):
        read_frames(path)
    with pytest.raises(VideoError, match="cannot write"):
        write_video(_smooth_clip(2), tmp_path / "out.webm")


def test_inconsistent_frame_sizes_name_the_file(tmp_path):
    Image.fromarray(np.zeros((10, 12, 3), np.uint8)).save(tmp_path / "0.png")
    Image.fromarray(np.zeros((11, 12, 3), np.uint8)).save(tmp_path / "1.png")
    with pytest.raises(VideoError, match=r"1\.png is 12×11"):
        read_frames(tmp_path)


def test_unreadable_image_in_folder(tmp_path):
    Image.fromarray(np.zeros((10, 12, 3), np.uint8)).save(tmp_path / "0.png")
    (tmp_path / "1.png").write_bytes(b"not a png")
    with pytest.raises(VideoError, match=r"1\.png"):
        read_frames(tmp_path)


@pytest.mark.parametrize(
    "frames",
    [
        np.zeros((2, 8, 8, 3), np.float32),
        np.zeros((2, 8, 8, 4), np.uint8),
        np.zeros((8, 8), np.uint8),
        np.zeros((0, 8, 8, 3), np.uint8),
    ],
)
def test_bad_frames_to_write(tmp_path, frames):
    with pytest.raises(InvalidParameterError):
        write_video(frames, tmp_path / "out.avi")


@pytest.mark.parametrize("fps", [0.0, -1.0, float("nan")])
def test_bad_fps(tmp_path, fps):
    with pytest.raises(InvalidParameterError, match="fps"):
        write_video(_smooth_clip(2), tmp_path / "out.avi", fps=fps)
    with pytest.raises(InvalidParameterError, match="fps"):
        read_frames(tmp_path, fps=fps)


def test_video_error_is_a_value_error(tmp_path):
    with pytest.raises(ValueError):
        read_frames(tmp_path / "missing.avi")


@pytest.mark.parametrize("kind", ["RGB", "RGBA", "L", "LA", "P", "P with alpha", "P 4-bit", "I;16"])
@pytest.mark.filterwarnings("ignore:Palette images with Transparency:UserWarning")
def test_a_png_reads_as_pillow_converts_it_to_rgb(tmp_path, kind):
    """8-bit PNGs are read by OpenCV, others by Pillow: either way the pixels are
    Pillow's ``convert("RGB")`` of the file."""
    rgba = np.random.default_rng(0).integers(0, 256, (37, 53, 4), dtype=np.uint8)
    image = {
        "RGB": lambda: Image.fromarray(rgba[..., :3]),
        "RGBA": lambda: Image.fromarray(rgba),
        "L": lambda: Image.fromarray(rgba[..., 0]),
        "LA": lambda: Image.fromarray(rgba[..., 0]).convert("LA"),
        "P": lambda: Image.fromarray(rgba[..., :3]).quantize(200),
        "P with alpha": lambda: Image.fromarray(rgba).quantize(200),
        "P 4-bit": lambda: Image.fromarray(rgba[..., :3]).quantize(16),
        "I;16": lambda: Image.fromarray(rgba[..., 0].astype(np.uint16) * 257),
    }[kind]()
    path = tmp_path / "image.png"
    image.save(path)
    with Image.open(path) as opened:
        expected = np.asarray(opened.convert("RGB"))
    np.testing.assert_array_equal(read_image_rgb(path), expected)


def test_a_truncated_png_is_one_error_naming_the_file(tmp_path):
    path = tmp_path / "half.png"
    Image.fromarray(np.full((40, 60, 3), 90, np.uint8)).save(path)
    path.write_bytes(path.read_bytes()[:-30])
    with pytest.raises(VideoError, match="half.png: not a readable image"):
        read_image_rgb(path)


def test_a_png_beyond_the_pixel_limit_is_refused_from_its_header(tmp_path):
    """Only the header is read: a PNG claiming 100,000 × 100,000 pixels is refused
    before anything is decoded."""
    path = tmp_path / "huge.png"
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(path)
    data = bytearray(path.read_bytes())
    data[16:24] = (100_000).to_bytes(4, "big") * 2
    path.write_bytes(bytes(data))
    with pytest.raises(InvalidParameterError, match="huge.png"):
        read_image_rgb(path)
