// The 3D motion of an answer, drawn from its BVH: a skeleton on a floor grid that plays
// in a loop; drag to orbit, scroll to zoom, a button to play or pause, a slider to scrub.
import * as THREE from 'three';
import { BVHLoader } from 'three/addons/BVHLoader.js';
import { OrbitControls } from 'three/addons/OrbitControls.js';

export class MotionViewer {
  constructor(container, controls) {
    this.container = container;
    this.controls = controls; // {play, scrub, frameText}
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio);
    this.renderer.setClearColor(0xf7f7f7);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x666666, 3));
    this.camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1000);
    this.orbit = new OrbitControls(this.camera, this.renderer.domElement);
    this.clock = new THREE.Clock();
    this.playing = true;
    this.framesDrawn = 0;
    controls.play.addEventListener('click', () => this.setPlaying(!this.playing));
    controls.scrub.addEventListener('input', () => {
      this.setPlaying(false);
      this.seek(Number(controls.scrub.value) * this.duration);
    });
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
    this.renderer.setAnimationLoop(() => this.draw());
  }

  resize() {
    const w = this.container.clientWidth, h = this.container.clientHeight;
    if (!w || !h || (w === this.width && h === this.height)) return;
    this.width = w;
    this.height = h;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  setPlaying(playing) {
    this.playing = playing;
    this.controls.play.textContent = playing ? 'Pause' : 'Play';
  }

  async load(url, fps) {
    const text = await (await fetch(url)).text();
    const bvh = new BVHLoader().parse(text);
    if (this.root) this.scene.remove(this.root, this.helper, this.grid, ...this.joints);
    this.fps = fps;
    this.root = bvh.skeleton.bones[0];
    this.bones = bvh.skeleton.bones;
    this.helper = new THREE.SkeletonHelper(this.root);
    this.helper.material.linewidth = 3;
    this.mixer = new THREE.AnimationMixer(this.root);
    this.action = this.mixer.clipAction(bvh.clip);
    this.action.play();
    this.duration = bvh.clip.duration;
    this.scene.add(this.root, this.helper);
    // a ball on every joint, so the body reads as one at any distance
    const size = this.fitCamera();
    const ball = new THREE.SphereGeometry(size * 0.012, 10, 8);
    const material = new THREE.MeshStandardMaterial({ color: 0x0b5394 });
    this.joints = this.bones.map((bone) => {
      const mesh = new THREE.Mesh(ball, material);
      bone.add(mesh);
      return mesh;
    });
    this.grid = new THREE.GridHelper(size * 4, 20, 0x999999, 0xcccccc);
    this.scene.add(this.grid);
    this.seek(0);
    this.setPlaying(true);
  }

  fitCamera() {
    // the skeleton's box over the whole clip sets the view
    const box = new THREE.Box3(), point = new THREE.Vector3();
    const steps = 20;
    for (let i = 0; i <= steps; i++) {
      this.mixer.setTime((this.duration * i) / steps);
      this.root.updateMatrixWorld(true);
      for (const bone of this.bones) box.expandByPoint(bone.getWorldPosition(point));
    }
    const center = box.getCenter(new THREE.Vector3());
    const size = Math.max(...box.getSize(new THREE.Vector3()).toArray(), 1e-3);
    this.orbit.target.copy(center);
    this.camera.position.set(center.x + size * 0.9, center.y + size * 0.5, center.z + size * 1.8);
    this.camera.near = size / 100;
    this.camera.far = size * 100;
    this.camera.updateProjectionMatrix();
    this.orbit.update();
    return size;
  }

  seek(seconds) {
    this.mixer.setTime(Math.min(Math.max(seconds, 0), this.duration));
  }

  get time() {
    return this.mixer ? this.mixer.time % this.duration : 0;
  }

  draw() {
    const delta = this.clock.getDelta();
    if (this.mixer) {
      if (this.playing) this.mixer.update(delta);
      const t = this.time;
      if (this.playing) this.controls.scrub.value = String(t / this.duration);
      const frame = Math.min(Math.round(t * this.fps), Math.round(this.duration * this.fps));
      this.controls.frameText.textContent = `frame ${frame + 1} of ${Math.round(this.duration * this.fps) + 1}`;
    }
    this.orbit.update();
    this.renderer.render(this.scene, this.camera);
    this.framesDrawn += 1;
  }
}
