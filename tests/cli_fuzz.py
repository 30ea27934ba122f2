# ruff: noqa: E501
"""Fuzzed command lines: every file format and option the command line reads.

Each case is a command (``convert``, ``index``, ``query``, ``show``, ``render``,
``track``) on input files made by mutating small valid ones (lines, tokens and bytes
cut, swapped, duplicated and replaced; odd numbers; crafted ``.npz`` headers; huge
frames), with odd option values.  A case passes when the command exits 0 or 2 with
at most 3 lines on stderr and no traceback, within :data:`MAX_SECONDS` and
:data:`MAX_BYTES`, and a database it failed on is byte-identical afterwards.

Run as a script for a larger campaign (counts printed at the end)::

    python tests/cli_fuzz.py --count 1000 --seed 1
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import os
import random
import shutil
import sys
import time
import tracemalloc
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image
from test_format_fuzz import AMC, ASF, BVH, ODD_TOKENS  # noqa: E402

from eigmotion.cli.main import main  # noqa: E402

MAX_SECONDS = 60.0
MAX_BYTES = 2 * 2**30
MAX_STDERR_LINES = 3
COMMANDS = ("convert", "index", "query", "show", "render", "track")
ODD_NUMBERS = ["0", "-1", "1e6", "1e300", "1e-320", "nan", "inf", "-0", "abc", "3", "30", "0.5"]
RIG = Path(__file__).resolve().parents[1] / "virtual_cameras" / "ring6.toml"


def mutate_text(rng: random.Random, text: str) -> str:
    """``text`` with 1 to 4 random line, token or character edits."""
    for _ in range(rng.randint(1, 4)):
        lines = text.split("\n")
        i = rng.randrange(max(len(lines), 1))
        op = rng.choice(["cut", "del", "dup", "swap", "token", "insert", "char", "big"])
        if op == "cut":
            text = text[: rng.randint(0, len(text))]
        elif op == "del":
            text = "\n".join(lines[:i] + lines[i + 1 :])
        elif op == "dup":
            text = "\n".join(lines[: i + 1] + lines[i:] * rng.choice([1, 1, 50]))
        elif op == "swap":
            k = rng.randrange(max(len(lines), 1))
            lines[i], lines[k] = lines[k], lines[i]
            text = "\n".join(lines)
        elif op in ("token", "insert"):
            words = lines[i].split(" ")
            new = rng.choice(ODD_TOKENS + ODD_NUMBERS)
            words[rng.randrange(len(words))] = new if op == "token" else f"{new} {words[0]}"
            lines[i] = " ".join(words)
            text = "\n".join(lines)
        elif op == "char":
            at = rng.randint(0, len(text))
            text = text[:at] + chr(rng.choice([0, 9, 13, 0x7B, 0x7D, 0xE9, 0x221E])) + text[at:]
        else:  # one very long token
            at = rng.randint(0, len(text))
            text = (
                text[:at] + rng.choice(["a", "\x00", "9"]) * rng.choice([10**4, 10**6]) + text[at:]
            )
    return text


def mutate_bytes(rng: random.Random, data: bytes) -> bytes:
    """``data`` cut, or with a few bytes flipped, dropped or repeated."""
    data = bytearray(data)
    op = rng.choice(["cut", "flip", "flip", "drop", "repeat"])
    if op == "cut":
        return bytes(data[: int(len(data) * rng.choice([0.0, 0.1, 0.5, 0.9, 0.99]))])
    for _ in range(rng.randint(1, 8)):
        at = rng.randrange(len(data))
        if op == "flip":
            data[at] = rng.randrange(256)
        elif op == "drop":
            del data[at : at + rng.randint(1, 64)]
        else:
            data[at:at] = data[at : at + 64] * rng.randint(1, 4)
    return bytes(data)


def _masks(n_frames: int = 24) -> np.ndarray:
    masks = np.zeros((n_frames, 60, 80), bool)
    for f in range(n_frames):  # a person walking across, legs apart every other frame
        x = 10 + 2 * f
        masks[f, 10:50, x : x + 10] = True
        masks[f, 40:58, x - (f % 2) * 3 : x + 13 + (f % 2) * 3] = True
    return masks


def _npz(**arrays) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _huge_header_npz() -> bytes:
    """An .npz whose masks header declares a terabyte but holds a few bytes."""
    header = {"descr": "|b1", "fortran_order": False, "shape": (10**6, 10**3, 10**3)}
    text = repr(header).encode("latin1")
    text += b" " * (63 - (10 + len(text)) % 64) + b"\n"
    member = b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text + b"\x01" * 64
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("masks.npy", member)
    return buffer.getvalue()


def _image(array: np.ndarray, fmt: str) -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(array).save(buffer, format=fmt)
    return buffer.getvalue()


def _gif(masks: np.ndarray) -> bytes:
    frames = [Image.fromarray((~m * 200).astype(np.uint8) + 20).convert("RGB") for m in masks]
    buffer = io.BytesIO()
    frames[0].save(buffer, format="GIF", save_all=True, append_images=frames[1:], duration=40)
    return buffer.getvalue()


def _npz_variant(rng: random.Random, masks: np.ndarray) -> bytes:
    fps = rng.choice(
        [np.array([1.0, 2.0]), np.array(1 + 2j), np.array([]), np.array("x"), np.array(np.nan),
         np.array(0.0), np.array(1e300), np.array(30), np.array(True), np.array(25.0)]
    )  # fmt: skip
    odd_masks = rng.choice(
        [masks, masks.astype(complex), masks[0], masks[:0], masks.astype(np.float32) * np.nan,
         masks.astype(np.uint8), np.zeros_like(masks), masks.astype("U1")]
    )  # fmt: skip
    choice = rng.randrange(5)
    if choice == 0:
        return _npz(masks=masks, fps=fps)
    if choice == 1:
        return _npz(masks=odd_masks)
    if choice == 2:
        return _huge_header_npz()
    if choice == 3:
        buffer = io.BytesIO()
        np.save(buffer, masks)  # a .npy renamed .npz
        return buffer.getvalue()
    return mutate_bytes(rng, _npz(masks=masks, fps=np.array(25.0)))


@dataclass
class Case:
    """One command line and the files it reads (written under a fresh folder)."""

    command: str
    argv: list[str]
    files: dict[str, bytes] = field(default_factory=dict)
    db: bool = False  # the command is given a copy of the database as db.fs
    input_bytes: int = 0


def make_case(rng: random.Random, command: str) -> Case:
    """A random case of ``command``; file names are relative to the case folder."""
    masks = _masks()
    bvh = mutate_text(rng, BVH) if rng.random() < 0.9 else BVH
    if command == "convert":
        if rng.random() < 0.3:
            files = {
                "in.amc": mutate_text(rng, AMC).encode(),
                "in.asf": mutate_text(rng, ASF).encode(),
            }
            argv = ["in.amc", "out.bvh", "--asf", "in.asf"]
            if rng.random() < 0.3:
                argv += ["--amc-fps", rng.choice(ODD_NUMBERS)]
        else:
            files, argv = {"in.bvh": bvh.encode("utf-8", "surrogatepass")}, ["in.bvh", "out.bvh"]
        for option, values in (("--fps", ODD_NUMBERS), ("--start", ["0", "1", "-1", "99"]),
                               ("--stop", ["1", "-1", "0", "99"]), ("--precision", ["0", "17", "-1", "99"])):  # fmt: skip
            if rng.random() < 0.15:
                argv += [option, rng.choice(values)]
        if rng.random() < 0.1:
            argv.append("--canonical-names")
        if rng.random() < 0.05:
            argv[1] = "/dev/full/out.bvh" if rng.random() < 0.5 else "full.bvh"
        return Case("convert", argv, files)
    if command == "index":
        return Case("index", ["in.bvh", "--label", rng.choice(["x", "", "a/b", "é" * 300]),
                              "--db", "db.fs"], {"in.bvh": bvh.encode("utf-8", "surrogatepass")}, db=True)  # fmt: skip
    if command == "query":
        kind = rng.choice(["npz", "npz", "gif", "folder", "mp4"])
        files: dict[str, bytes] = {}
        if kind == "npz":
            files["clip.npz"] = _npz_variant(rng, masks)
            clip = "clip.npz"
        elif kind == "gif":
            files["clip.gif"] = (
                mutate_bytes(rng, _gif(masks)) if rng.random() < 0.8 else _gif(masks)
            )
            clip = "clip.gif"
        elif kind == "mp4":
            sample = Path(__file__).resolve().parents[1] / "database" / "samples" / "walk.mp4"
            files["clip.mp4"] = mutate_bytes(rng, sample.read_bytes())
            clip = "clip.mp4"
        else:
            for f in range(0, len(masks), 3):
                frame = np.repeat(((~masks[f]) * 200 + 20).astype(np.uint8)[..., None], 3, axis=2)
                data = _image(frame, "PNG")
                files[f"frames/f{f:03d}.png"] = (
                    mutate_bytes(rng, data) if rng.random() < 0.2 else data
                )
            if rng.random() < 0.1:
                files["frames/f999.png"] = _image(np.zeros((9000, 9000), np.uint8), "PNG")
            clip = "frames"
        argv = [clip, "--db", "db.fs"]
        if rng.random() < 0.2:
            files["bg.png"] = mutate_bytes(rng, _image(np.full((60, 80, 3), 220, np.uint8), "PNG"))
            argv += ["--background", "bg.png"]
        for option, values in (("--top", ["0", "-1", "1000000", "3"]),
                               ("--false-rejection", ["0", "1", "-1", "nan", "0.5"])):  # fmt: skip
            if rng.random() < 0.15:
                argv += [option, rng.choice(values)]
        if rng.random() < 0.1:
            argv += ["--bvh-out", "full.bvh"]
        return Case("query", argv, files, db=True)
    if command == "show":
        argv = ["in.bvh", "--out", rng.choice(["o.png", "o.gif", "o.txt"])]
        for option, values in (("--fps", ODD_NUMBERS), ("--frames", ["0", "1", "100000"]),
                               ("--cols", ["0", "1", "1000"])):  # fmt: skip
            if rng.random() < 0.2:
                argv += [option, rng.choice(values)]
        argv += ["--size"] + rng.choice(
            [["32", "32"], ["100000", "100000"], ["0", "5"], ["48", "40"]]
        )
        return Case("show", argv, {"in.bvh": bvh.encode("utf-8", "surrogatepass")})
    if command == "render":
        rig = RIG.read_text()
        if rng.random() < 0.3:
            rig = rig.replace('name = "az000', rng.choice(['name = "../../x', 'name = "/tmp/', 'name = "a\\u0000']), 1)  # fmt: skip
        rig = mutate_text(rng, rig) if rng.random() < 0.7 else rig
        bvh = bvh if rng.random() < 0.5 else BVH
        return Case("render", ["in.bvh", "--rig", "rig.toml", "--out", "out/r", "--no-masks"],
                    {"in.bvh": bvh.encode("utf-8", "surrogatepass"), "rig.toml": rig.encode("utf-8", "surrogatepass"), "out/.keep": b""})  # fmt: skip
    calib = (
        '{"cameras": [{"name": "a", "K": [[100,0,40],[0,100,30],[0,0,1]], "R": [[1,0,0],[0,1,0],[0,0,1]],'
        ' "t": [0,0,3], "width": 80, "height": 60}, {"name": "b", "K": [[100,0,40],[0,100,30],[0,0,1]],'
        ' "R": [[0,0,1],[0,1,0],[-1,0,0]], "t": [0,0,3], "width": 80, "height": 60}]}'
    )  # fmt: skip
    files = {"calib.json": mutate_text(rng, calib).encode("utf-8", "surrogatepass"),
             "a.npz": _npz_variant(rng, masks), "b.npz": _npz(masks=masks, fps=np.array(25.0)),
             "d.bvh": bvh.encode("utf-8", "surrogatepass")}  # fmt: skip
    argv = ["a.npz", "b.npz", "--calib", "calib.json", "--dictionary", "d.bvh"]
    if rng.random() < 0.2:
        argv += [rng.choice(["--estimate-fps", "--t", "--k", "--downsample", "--shift-px"]), rng.choice(ODD_NUMBERS)]  # fmt: skip
    return Case("track", argv, files)


@dataclass
class Outcome:
    case: Case
    code: int | None
    stderr: str
    seconds: float
    peak_bytes: int
    traceback: bool
    db_changed: bool

    def problems(self) -> list[str]:
        lines = stderr_lines(self.stderr)
        found = []
        if self.traceback:
            found.append("traceback")
        if self.code not in (0, 2):
            found.append(f"exit {self.code}")
        if len(lines) > MAX_STDERR_LINES:
            found.append(f"{len(lines)} stderr lines")
        if any(len(line) > 1000 for line in lines):
            found.append("a stderr line over 1000 characters")
        if self.input_small() and self.seconds > MAX_SECONDS:
            found.append(f"{self.seconds:.0f} s")
        if self.input_small() and self.peak_bytes > MAX_BYTES:
            found.append(f"{self.peak_bytes / 2**30:.1f} GiB")
        if self.db_changed and self.code != 0:
            found.append("the database changed on a failure")
        return found

    def input_small(self) -> bool:
        return self.case.input_bytes < 10 * 2**20


def stderr_lines(text: str) -> list[str]:
    """Lines written to stderr, progress-bar redraws (``\\r``) reduced to their last."""
    lines = [line.split("\r")[-1].strip() for line in text.split("\n")]
    return [line for line in lines if line]


def _hash(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def run_case(case: Case, folder: Path, database: Path | None) -> Outcome:
    """Run ``case`` in-process in ``folder`` (created), with peak memory by tracemalloc."""
    folder.mkdir(parents=True)
    for name, data in case.files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)
    case.input_bytes = sum(len(d) for d in case.files.values())
    os.symlink("/dev/full", folder / "full.bvh")
    before = None
    if case.db:
        shutil.copyfile(database, folder / "db.fs")
        before = _hash(folder / "db.fs")
    stderr = io.StringIO()
    code, traceback = None, False
    cwd = os.getcwd()
    os.chdir(folder)
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
            code = main([case.command, *case.argv])
    except SystemExit as exc:  # argparse: usage and one error line
        code = exc.code if isinstance(exc.code, int) else 2
    except BaseException as exc:  # noqa: BLE001 - what would reach the user as a traceback
        traceback = True
        stderr.write(f"{type(exc).__name__}: {str(exc)[:300]}\n")
    finally:
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        os.chdir(cwd)
    changed = before is not None and _hash(folder / "db.fs") != before
    return Outcome(case, code, stderr.getvalue(), seconds, peak, traceback, changed)


def campaign(count: int, seed: int, database: Path, work: Path, verbose: bool = False):
    """``count`` cases spread over :data:`COMMANDS`; returns their outcomes."""
    rng = random.Random(seed)
    outcomes = []
    for i in range(count):
        command = COMMANDS[i % len(COMMANDS)]
        outcome = run_case(make_case(rng, command), work / f"case{i:05d}", database)
        shutil.rmtree(work / f"case{i:05d}", ignore_errors=True)
        outcomes.append(outcome)
        if verbose and len(stderr_lines(outcome.stderr)) > 1:
            print(i, command, "multi-line:", stderr_lines(outcome.stderr), flush=True)
        if verbose and (outcome.problems() or i % 50 == 0):
            print(i, command, outcome.case.argv[:6], outcome.code, f"{outcome.seconds:.1f}s",
                  f"{outcome.peak_bytes / 2**20:.0f}MiB", outcome.problems(),
                  stderr_lines(outcome.stderr)[-1:], flush=True)  # fmt: skip
    return outcomes


def _report(outcomes) -> str:
    by_command = {}
    for o in outcomes:
        row = by_command.setdefault(o.case.command, [0, 0, 0, 0])
        row[0] += 1
        row[1] += o.code == 0
        row[2] += o.code == 2
        row[3] += bool(o.problems())
    lines = [f"{c}: {r[0]} cases, {r[1]} accepted, {r[2]} refused (exit 2), {r[3]} with problems"
             for c, r in by_command.items()]  # fmt: skip
    lines.append(
        f"all: {len(outcomes)} cases, {sum(o.traceback for o in outcomes)} tracebacks, "
        f"{sum(len(stderr_lines(o.stderr)) > 1 and o.code == 2 for o in outcomes)} multi-line "
        f"errors, {sum(len(stderr_lines(o.stderr)) > MAX_STDERR_LINES for o in outcomes)} over "
        f"{MAX_STDERR_LINES} lines, slowest {max(o.seconds for o in outcomes):.1f} s, largest "
        f"peak {max(o.peak_bytes for o in outcomes) / 2**20:.0f} MiB"
    )
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--db", type=Path, required=True, help="a database to copy per case")
    parser.add_argument("--work", type=Path, default=Path("/tmp/eigmotion-cli-fuzz"))
    args = parser.parse_args()
    shutil.rmtree(args.work, ignore_errors=True)
    results = campaign(args.count, args.seed, args.db, args.work, verbose=True)
    print(_report(results))
    sys.exit(1 if any(o.problems() for o in results) else 0)
