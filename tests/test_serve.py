"""``eigmotion serve`` end to end: the real server on 127.0.0.1 with a real database,
queried through its HTTP API (four clips at once) and through its page in a real
headless Chromium driven by selenium."""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
import uuid
from pathlib import Path

import cv2
import numpy as np
import pytest

from eigmotion.mocap.bvh import read_bvh

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "database" / "samples"


#: (clip, empty-scene image or None) of the four concurrent queries.
QUERIES = (
    ("kick.mp4", "kick_background.png"),
    ("walk.mp4", None),
    ("walk_3s.mp4", "walk_3s_background.png"),
    ("kick.mp4", None),
)

MAX_UPLOAD_MB = 1.0


@pytest.fixture(scope="module")
def db_path(four_motion_database):
    return four_motion_database


@pytest.fixture(scope="module")
def server(db_path, tmp_path_factory):
    """The URL of a real ``eigmotion serve`` on a free port, and its working folder."""
    work_dir = tmp_path_factory.mktemp("serve") / "work"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    process = subprocess.Popen(
        [sys.executable, "-m", "eigmotion", "serve", "--db", str(db_path), "--port", "0",
         "--workers", "2", "--work-dir", str(work_dir), "--max-upload-mb", str(MAX_UPLOAD_MB)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=REPO,
    )  # fmt: skip
    url = None
    for line in process.stdout:
        if match := re.search(r"serving on (http://\S+/)", line):
            url = match[1]
            break
    assert url, process.stderr.read()
    yield url, work_dir
    process.send_signal(signal.SIGTERM)  # SIGINT is ignored when pytest runs in the background
    assert process.wait(timeout=60) == 0, process.stderr.read()


def _multipart(fields: dict[str, tuple[str, bytes]]) -> tuple[bytes, str]:
    boundary = uuid.uuid4().hex
    body = io.BytesIO()
    for name, (filename, data) in fields.items():
        body.write(f"--{boundary}\r\n".encode())
        body.write(
            f'Content-Disposition: form-data; name="{name}"; filename="{filename}"\r\n'
            "Content-Type: application/octet-stream\r\n\r\n".encode()
        )
        body.write(data + b"\r\n")
    body.write(f"--{boundary}--\r\n".encode())
    return body.getvalue(), f"multipart/form-data; boundary={boundary}"


def _request(url: str, body: bytes | None = None, content_type: str | None = None):
    """(status, body bytes) of a GET (or a POST with ``body``)."""
    request = urllib.request.Request(url, data=body, method="POST" if body else "GET")
    if content_type:
        request.add_header("Content-Type", content_type)
    try:
        with urllib.request.urlopen(request, timeout=60) as response:
            return response.status, response.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


def _post_query(url: str, clip: str, background: str | None, clip_name: str | None = None):
    fields = {"clip": (clip_name or clip, (SAMPLES / clip).read_bytes())}
    if background:
        fields["background"] = (background, (SAMPLES / background).read_bytes())
    status, body = _request(url + "api/query", *_multipart(fields))
    return status, json.loads(body)


def _wait(url: str, job_id: str, timeout_s: float = 600) -> tuple[dict, list[dict]]:
    """The job's last status and every status seen while it ran."""
    seen = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        status, body = _request(f"{url}api/jobs/{job_id}")
        assert status == 200
        seen.append(json.loads(body))
        if seen[-1]["state"] in ("done", "failed"):
            return seen[-1], seen
        time.sleep(0.3)
    raise AssertionError(f"job {job_id} did not finish in {timeout_s} s: {seen[-1]}")


def _cli_answer(db_path: Path, clip: str, background: str | None) -> dict:
    command = [sys.executable, "-m", "eigmotion", "query", str(SAMPLES / clip), "--db",
               str(db_path), "--json"]  # fmt: skip
    if background:
        command += ["--background", str(SAMPLES / background)]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run(command, capture_output=True, text=True, env=env, check=True)
    return json.loads(done.stdout)


def test_four_concurrent_queries_answer_as_the_command_line(server, db_path, tmp_path):
    url, work_dir = server
    replies = [None] * len(QUERIES)

    def ask(i: int) -> None:
        clip, background = QUERIES[i]
        status, reply = _post_query(url, clip, background)
        assert status == 202, reply
        replies[i] = _wait(url, reply["id"])

    t0 = time.perf_counter()
    threads = [threading.Thread(target=ask, args=(i,)) for i in range(len(QUERIES))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    wall_s = time.perf_counter() - t0
    print(f"4 concurrent queries (2 workers): {wall_s:.1f} s")
    for (clip, background), (final, seen) in zip(QUERIES, replies, strict=True):
        assert final["state"] == "done", final
        expected = _cli_answer(db_path, clip, background)
        answer = final["answer"]
        assert answer["label"] == expected["label"], (clip, background)
        assert [m["label"] for m in answer["labels"]] == [m["label"] for m in expected["labels"]]
        assert answer["view"] == expected["view"] and answer["accepted"] == expected["accepted"]
        assert answer["p_known_words"]
        # progress was told while the job ran
        assert any(s["state"] in ("queued", "running") and s.get("stage") for s in seen)
        base = f"{url}api/jobs/{final['id']}/"
        status, bvh = _request(base + "motion.bvh")
        assert status == 200
        (tmp_path / "motion.bvh").write_bytes(bvh)
        motion = read_bvh(tmp_path / "motion.bvh")
        assert motion.n_frames == answer["n_frames"]
        status, joints = _request(base + "joints.npz")
        with np.load(io.BytesIO(joints)) as npz:
            assert npz["positions"].shape[:2] == (answer["n_frames"], len(npz["names"]))
        for name in ("replay.webm", "clip.webm"):
            status, video = _request(base + name)
            assert status == 200 and video[:4] == b"\x1a\x45\xdf\xa3"  # EBML: WebM
            (tmp_path / name).write_bytes(video)
            capture = cv2.VideoCapture(str(tmp_path / name))
            assert capture.read()[0]
            capture.release()
        status, body = _request(base + "answer.json")
        assert json.loads(body)["label"] == answer["label"]
    # uploads saved under generated names, inside the working folder only
    saved = sorted(p.name for p in (work_dir / "jobs").rglob("upload*"))
    assert saved and set(saved) <= {"upload.mp4"}


def _video_bytes(tmp_path: Path, frames: np.ndarray) -> bytes:
    path = tmp_path / "made.mp4"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25.0, (320, 240))
    for frame in frames:
        writer.write(frame)
    writer.release()
    return path.read_bytes()


def test_bad_uploads_are_refused_with_a_clear_message(server, tmp_path):
    url, work_dir = server
    query = url + "api/query"
    status, body = _request(query, *_multipart({"clip": ("notes.txt", b"hello")}))
    assert status == 400 and "is not a video" in json.loads(body)["error"]
    status, body = _request(query, *_multipart({"clip": ("fake.mp4", b"not a video at all")}))
    assert status == 400 and "not a video: no frame" in json.loads(body)["error"]
    big = os.urandom(int(MAX_UPLOAD_MB * 1e6) + 1000)
    status, body = _request(query, *_multipart({"clip": ("big.mp4", big)}))
    assert status == 413 and "too large" in json.loads(body)["error"]
    status, body = _request(query, *_multipart({"background": ("b.png", b"x")}))
    assert status == 400 and "no clip" in json.loads(body)["error"]
    kick = (SAMPLES / "kick.mp4").read_bytes()
    small = cv2.imencode(".png", np.zeros((10, 10, 3), np.uint8))[1].tobytes()
    fields = {"clip": ("k.mp4", kick), "background": ("s.png", small)}
    status, body = _request(query, *_multipart(fields))
    assert status == 400 and "must be the same size" in json.loads(body)["error"]
    fields = {"clip": ("k.mp4", kick), "background": ("s.png", b"zz")}
    status, body = _request(query, *_multipart(fields))
    assert status == 400 and "not an image" in json.loads(body)["error"]
    status, body = _request(query, b"clip=1", "application/x-www-form-urlencoded")
    assert status == 400 and "multipart/form-data" in json.loads(body)["error"]
    # an empty scene and no person in it: the job fails, saying so
    empty = np.full((40, 240, 320, 3), (90, 120, 150), np.uint8)
    scene = cv2.imencode(".png", empty[0])[1].tobytes()
    fields = {"clip": ("empty.mp4", _video_bytes(tmp_path, empty)), "background": ("e.png", scene)}
    status, reply = _request(query, *_multipart(fields))
    assert status == 202
    final, _ = _wait(url, json.loads(reply)["id"])
    assert final["state"] == "failed" and "no person" in final["error"]
    assert str(work_dir) not in final["error"]
    # a file name that climbs out of the folder is not used as a path
    escape = f"../../../escape-{uuid.uuid4().hex}.mp4"
    status, _ = _request(query, *_multipart({"clip": (escape, kick)}))
    assert status == 202
    assert not list(work_dir.parent.parent.rglob(Path(escape).name))
    for path in ("api/jobs/0123", "api/jobs/" + "0" * 32, "nothing", "static/../server.py"):
        assert _request(url + path)[0] == 404
    status, body = _request(url)
    assert status == 200 and b"importmap" in body and b"http" not in body.split(b"<body>")[0]


def _chromium() -> tuple[str, str] | None:
    found = shutil.which("chromium"), shutil.which("chromedriver")
    return found if all(found) else None


@pytest.fixture(scope="module")
def browser():
    in_ci = os.environ.get("CI", "").lower() == "true"
    if _chromium() is None:
        if in_ci:
            pytest.fail("chromium and chromium-driver are missing (.ci/system-deps installs them)")
        pytest.skip("chromium and chromium-driver are not installed")
    if in_ci:
        from selenium import webdriver
    else:
        webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    chromium, driver = _chromium()
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                "--window-size=1280,1400", "--enable-unsafe-swiftshader"):  # fmt: skip
        options.add_argument(arg)
    driver = webdriver.Chrome(options=options, service=Service(driver))
    yield driver
    driver.quit()


def _answered_on_the_page(browser, url: str, clip: Path, background: Path | None) -> None:
    """Upload ``clip`` (and ``background``) on the page and wait until the 3D viewer has
    loaded the answer; the page must have shown progress and no error."""
    from selenium.webdriver.common.by import By

    browser.get(url)
    browser.find_element(By.ID, "clip").send_keys(str(clip))
    if background is not None:
        browser.find_element(By.ID, "background").send_keys(str(background))
    browser.find_element(By.ID, "submit").click()
    deadline = time.monotonic() + 600
    progress_seen = False
    while time.monotonic() < deadline:
        state, viewer, error, progress = browser.execute_script(
            "const b = document.body.dataset; return [b.state, b.viewer, "
            "document.getElementById('error').textContent, "
            "document.getElementById('progress-text').textContent]"
        )
        progress_seen |= bool(progress)
        assert not error, error
        if viewer == "loaded":
            break
        time.sleep(0.5)
    assert viewer == "loaded" and progress_seen


def test_page_in_a_real_browser(server, db_path, browser, tmp_path):
    from selenium.webdriver.common.by import By

    url, _ = server
    _answered_on_the_page(browser, url, SAMPLES / "kick.mp4", SAMPLES / "kick_background.png")
    expected = _cli_answer(db_path, "kick.mp4", "kick_background.png")
    label = browser.find_element(By.ID, "label").text
    assert label == (expected["label"] if expected["accepted"] else
                     f"unknown (nearest: {expected['label']})")  # fmt: skip
    assert expected["warnings"] == [] and not browser.find_element(By.ID, "warnings").is_displayed()
    actions = [
        li.text.split(" ")[0] for li in browser.find_elements(By.CSS_SELECTOR, "#actions li")
    ]
    assert actions == [m["label"] for m in expected["labels"]]
    assert browser.find_elements(By.CSS_SELECTOR, "#timeline .segment")
    # the 3D viewer draws the motion, and it moves
    canvas = browser.find_element(By.CSS_SELECTOR, "#viewer canvas")
    first = cv2.imdecode(np.frombuffer(canvas.screenshot_as_png, np.uint8), cv2.IMREAD_GRAYSCALE)
    time.sleep(1.5)
    second = cv2.imdecode(np.frombuffer(canvas.screenshot_as_png, np.uint8), cv2.IMREAD_GRAYSCALE)
    background = np.median(first)
    assert (np.abs(first.astype(int) - background) > 40).mean() > 0.002  # skeleton drawn
    assert (np.abs(first.astype(int) - second) > 40).mean() > 0.0005  # and moving
    # both videos play in the browser
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        videos = browser.execute_script(
            "return ['replay-video', 'clip-video'].map((id) => { const v = "
            "document.getElementById(id); return [v.readyState, v.videoWidth, v.error]; })"
        )
        if all(ready >= 2 for ready, _, _ in videos):
            break
        time.sleep(0.5)
    assert all(ready >= 2 and width > 0 and err is None for ready, width, err in videos), videos
    # the pause button stops the motion
    browser.find_element(By.ID, "play").click()
    frame = browser.find_element(By.ID, "frame-text").text
    time.sleep(1)
    assert browser.find_element(By.ID, "frame-text").text == frame
    severe = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe


def test_page_shows_the_answers_warnings(server, browser, tmp_path):
    """An edited clip (the walk and the kick samples joined): the page shows the
    answer's warning that the clip cuts to another view, as the command line does."""
    from selenium.webdriver.common.by import By

    from eigmotion.imaging.media import read_frames, write_video

    walk, fps = read_frames(SAMPLES / "walk.mp4")
    kick, _ = read_frames(SAMPLES / "kick.mp4")
    clip = write_video(np.concatenate([walk, kick]), tmp_path / "edited.mp4", fps)
    assert clip.stat().st_size < MAX_UPLOAD_MB * 1e6
    url, _ = server
    _answered_on_the_page(browser, url, clip, None)
    shown = browser.find_element(By.ID, "warnings")
    assert shown.is_displayed()
    items = [li.text for li in shown.find_elements(By.TAG_NAME, "li")]
    assert len(items) == 1 and items[0].startswith("Warning: the clip cuts to another view once")


def test_page_answers_a_person_standing_still(server, db_path, browser, tmp_path):
    """The walk sample's first frame held 3 s with sensor noise: the page says "no
    motion", as the command line answers, with the answer and the clip but nothing
    ranked, aligned or replayed."""
    from selenium.webdriver.common.by import By

    from eigmotion.imaging.media import read_frames, write_video

    first, fps = read_frames(SAMPLES / "walk.mp4", max_frames=1)
    noise = np.random.default_rng(0).normal(0.0, 2.0, (int(3 * fps), *first.shape[1:]))
    held = np.clip(np.rint(first[0] + noise), 0, 255).astype(np.uint8)
    clip = write_video(held, tmp_path / "still.mp4", fps)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run(
        [sys.executable, "-m", "eigmotion", "query", str(clip), "--db", str(db_path), "--json"],
        capture_output=True, text=True, env=env, check=True,
    )  # fmt: skip
    expected = json.loads(done.stdout)
    assert expected["still"] and not expected["accepted"]
    url, _ = server
    browser.get(url)
    browser.find_element(By.ID, "clip").send_keys(str(clip))
    browser.find_element(By.ID, "submit").click()
    deadline = time.monotonic() + 300
    while browser.execute_script("return document.body.dataset.state") != "done":
        assert time.monotonic() < deadline, "the page shows no answer"
        assert not browser.find_element(By.ID, "error").text
        time.sleep(0.5)
    assert browser.find_element(By.ID, "label").text == "no motion (the person stands still)"
    shown = [li.text for li in browser.find_elements(By.CSS_SELECTOR, "#warnings li")]
    assert shown == [f"Warning: {expected['warnings'][0]}"]
    for part in ("ranking", "dl-bvh", "dl-replay", "motion-view", "replay-view"):
        assert not browser.find_element(By.ID, part).is_displayed(), part
    assert browser.find_element(By.ID, "dl-json").is_displayed()
    job = browser.execute_script("return document.body.dataset.job")
    status, body = _request(f"{url}api/jobs/{job}/answer.json")
    answer = json.loads(body)
    assert status == 200 and {k: answer[k] for k in expected} == expected
    for name, served in (("clip.webm", 200), ("motion.bvh", 404), ("replay.webm", 404)):
        assert _request(f"{url}api/jobs/{job}/{name}")[0] == served, name
    severe = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe
