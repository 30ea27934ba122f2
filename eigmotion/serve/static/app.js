// The page: upload a clip, follow the job, show its answer.
import { MotionViewer } from './viewer.js';

const $ = (id) => document.getElementById(id);
const COLOURS = ['#0b5394', '#38761d', '#b45f06', '#741b47', '#134f5c', '#990000', '#7f6000'];
let viewer = null;

function show(id, visible) { $(id).hidden = !visible; }

function fail(message) {
  $('error').textContent = message;
  show('error', true);
  show('progress', false);
  $('submit').disabled = false;
}

async function submit(event) {
  event.preventDefault();
  show('error', false);
  show('result', false);
  const form = new FormData();
  form.append('clip', $('clip').files[0]);
  if ($('background').files.length) form.append('background', $('background').files[0]);
  $('submit').disabled = true;
  show('progress', true);
  $('progress-bar').value = 0;
  $('progress-text').textContent = 'uploading';
  let reply;
  try {
    const response = await fetch('/api/query', { method: 'POST', body: form });
    reply = await response.json();
    if (!response.ok) return fail(reply.error);
  } catch (err) {
    return fail(`the upload failed: ${err}`);
  }
  follow(reply.id);
}

async function follow(id) {
  document.body.dataset.job = id;
  for (;;) {
    const status = await (await fetch(`/api/jobs/${id}`)).json();
    if (status.state === 'failed') return fail(status.error);
    if (status.state === 'done') return showAnswer(id, status.answer);
    $('progress-bar').value = status.progress || 0;
    const elapsed = status.elapsed_s ? ` (${Math.round(status.elapsed_s)} s)` : '';
    $('progress-text').textContent = status.stage + elapsed;
    await new Promise((resolve) => setTimeout(resolve, 500));
  }
}

function viewText(view) {
  return `Seen from azimuth ${Math.round(view.azimuth_deg)}°, elevation ` +
    `${Math.round(view.elevation_deg)}° (0° azimuth: the person faces the camera).`;
}

function showAnswer(id, answer) {
  const base = `/api/jobs/${id}`;
  show('progress', false);
  $('submit').disabled = false;
  show('result', true);
  $('warnings').replaceChildren(...answer.warnings.map((text) => {
    const item = document.createElement('li');
    item.textContent = `Warning: ${text}`;
    return item;
  }));
  show('warnings', answer.warnings.length > 0);
  $('known').textContent = answer.p_known_words;
  $('dl-json').href = `${base}/answer.json`;
  $('clip-video').src = `${base}/clip.webm`;
  // a person who stands still: no motion, so nothing ranked, aligned or replayed
  for (const part of ['ranking', 'dl-motion', 'dl-replay-item', 'motion-view', 'replay-view']) {
    show(part, !answer.still);
  }
  if (answer.still) {
    $('label').textContent = 'no motion (the person stands still)';
    timeline(answer);
    document.body.dataset.state = 'done';
    return;
  }
  $('label').textContent = answer.accepted ? answer.label : `unknown (nearest: ${answer.label})`;
  $('view').textContent = viewText(answer.view);
  $('actions').replaceChildren(...answer.labels.map((match) => {
    const item = document.createElement('li');
    item.append(match.label + ' ');
    const detail = document.createElement('span');
    detail.textContent = `(${match.motion}, distance ${match.distance.toFixed(3)})`;
    item.append(detail);
    return item;
  }));
  $('dl-bvh').href = `${base}/motion.bvh`;
  $('dl-joints').href = `${base}/joints.npz`;
  $('dl-replay').href = `${base}/replay.mp4`;
  $('replay-video').src = `${base}/replay.webm`;
  $('replay-video').play().catch(() => {});
  timeline(answer);
  if (!viewer) {
    viewer = new MotionViewer($('viewer'), {
      play: $('play'), scrub: $('scrub'), frameText: $('frame-text'),
    });
    window.eigmotionViewer = viewer;
  }
  viewer.load(`${base}/motion.bvh`, answer.fps).then(() => {
    document.body.dataset.viewer = 'loaded';
  });
  document.body.dataset.state = 'done';
}

function timeline(answer) {
  const n = answer.n_frames, bar = $('timeline');
  bar.querySelectorAll('.segment').forEach((el) => el.remove());
  const list = [];
  answer.segments.forEach((seg, i) => {
    const el = document.createElement('div');
    el.className = 'segment';
    el.style.left = `${(100 * seg.start_frame) / n}%`;
    el.style.width = `${(100 * (seg.end_frame - seg.start_frame)) / n}%`;
    el.style.background = COLOURS[i % COLOURS.length];
    el.textContent = seg.label;
    // frames are numbered from 0, both ends included, as the command line and the replay say
    const range = `frames ${seg.start_frame}–${seg.end_frame - 1}`;
    el.title = `${seg.label}: ${range}`;
    el.addEventListener('click', () => { $('clip-video').currentTime = seg.start_frame / answer.fps; });
    bar.append(el);
    const item = document.createElement('li');
    item.textContent = `${range}: ${seg.label}`;
    list.push(item);
  });
  $('segments').replaceChildren(...list);
  const video = $('clip-video');
  const move = () => {
    const share = video.duration ? video.currentTime / video.duration : 0;
    $('timeline-cursor').style.left = `${100 * share}%`;
  };
  video.ontimeupdate = move;
  move();
}

$('upload').addEventListener('submit', submit);
