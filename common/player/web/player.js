// The 3D player of the HTML reports (docs/synthesis.md "3D player").
//
// An ES module, inlined into the page by mocap/player/player.hpp with three.js
// (its WebGLRenderer, BVHLoader and OrbitControls); the page's loader rewrites
// the three imports below to the inlined copies and calls start(root, data).
// data: {three_version, scenes: [{id, title, duration_s, marks: [{kind,
// label, start_s, end_s}], motions: [{id, tag, label, group, attach, colour,
// chosen, unit_m, ground_m, frame_time_s, frames, first_frame, start_s,
// box_m, hidden_joints, foot_joints, contacts, bvh}]}]} (metres, seconds;
// BVH in file units).
//
// State for tests and scripts: root's data-player-state ("loading", "ready",
// "error"), data-player-time (ms), data-player-scene, data-player-motions,
// data-player-view (the canvas's left, top, width, height on the page, CSS
// pixels), data-player-error; window.mocapPlayer (play, pause, setTime, showScene).
// The URL's hash may hold t=SECONDS (start paused there), paused,
// scene=ID, speed=X.
import * as THREE from 'three';
import { BVHLoader } from 'three/addons/loaders/BVHLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

// Metres.
const BONE_RADIUS = 0.028;
const JOINT_RADIUS = 0.036;
const FOOT_RADIUS = 0.055;
const CELL_MARGIN = 1.0; // around a motion's root path
const CELL_GAP = 0.3;
// Foot states (player.hpp kFootContact, kFootSkating).
const FOOT_COLOURS = { 1: new THREE.Color('#16a34a'), 2: new THREE.Color('#e0218a') };
const Y_AXIS = new THREE.Vector3(0, 1, 0);

function element(tag, attrs = {}, parent = null, text = null) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== null) e.textContent = text;
  if (parent) parent.appendChild(e);
  return e;
}

function hashOptions() {
  const out = {};
  for (const part of window.location.hash.replace(/^#/, '').split('&')) {
    if (!part) continue;
    const eq = part.indexOf('=');
    out[decodeURIComponent(eq < 0 ? part : part.slice(0, eq))] =
      eq < 0 ? '' : decodeURIComponent(part.slice(eq + 1));
  }
  return out;
}

// One motion: its bones (BVHLoader), keyframes, and instanced meshes for the
// bones (cylinders) and joints (spheres) in world space (metres).
class Figure {
  constructor(spec, scene) {
    this.spec = spec;
    const { skeleton, clip } = new BVHLoader().parse(spec.bvh);
    this.bones = skeleton.bones;
    this.group = new THREE.Group();
    this.group.scale.setScalar(spec.unit_m);
    this.group.add(this.bones[0]);
    scene.add(this.group);
    const byName = new Map();
    for (const b of this.bones) if (b.name !== 'ENDSITE' && !byName.has(b.name)) byName.set(b.name, b);
    this.tracks = [];
    for (const track of clip.tracks) {
      const dot = track.name.lastIndexOf('.');
      const bone = byName.get(track.name.slice(0, dot));
      if (bone) this.tracks.push({ bone, property: track.name.slice(dot + 1), values: track.values });
    }
    const hidden = new Set(spec.hidden_joints);
    const feet = new Map(spec.foot_joints.map((name, k) => [name, k]));
    const footOf = (bone) => (feet.has(bone.name) ? feet.get(bone.name) : -1);
    this.pelvis = this.bones.find((b) => b.name !== 'ENDSITE' && !hidden.has(b.name)) || this.bones[0];
    // Segments parent -> child (coloured by the parent's foot state: foot ->
    // toe, toe -> tip), joints (not End Sites).
    this.segments = [];
    for (const b of this.bones) {
      const p = b.parent;
      if (!p || !p.isBone || hidden.has(p.name) || hidden.has(b.name)) continue;
      this.segments.push({ from: p, to: b, foot: footOf(p) });
    }
    this.joints = this.bones
      .filter((b) => b.name !== 'ENDSITE' && !hidden.has(b.name))
      .map((b) => ({ bone: b, foot: footOf(b) }));
    const ghost = spec.attach !== '';
    const material = () =>
      new THREE.MeshLambertMaterial({
        color: 0xffffff,
        transparent: ghost,
        opacity: ghost ? 0.35 : 1.0,
        depthWrite: !ghost,
      });
    this.colour = new THREE.Color(spec.colour);
    this.boneMesh = new THREE.InstancedMesh(Figure.cylinder, material(), Math.max(1, this.segments.length));
    this.jointMesh = new THREE.InstancedMesh(Figure.sphere, material(), Math.max(1, this.joints.length));
    for (const mesh of [this.boneMesh, this.jointMesh]) {
      mesh.frustumCulled = false;
      mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
      scene.add(mesh);
    }
    this.boneMesh.count = this.segments.length;
    this.jointMesh.count = this.joints.length;
    this.frame = 0;
    this.visible = true;
  }

  // Places the motion: group offset in metres (its ground at y = 0).
  place(x, z) {
    this.group.position.set(x, -this.spec.ground_m, z);
  }

  frameAt(t) {
    const s = this.spec;
    const last = Math.max(0, s.frames - 1);
    return Math.min(last, Math.max(0, (t - s.start_s) / s.frame_time_s));
  }

  // The pose at global time t (seconds): keyframes interpolated (positions
  // linearly, rotations by slerp), then the instanced meshes.
  update(t) {
    const f = this.frameAt(t);
    const i0 = Math.floor(f);
    const i1 = Math.min(i0 + 1, Math.max(0, this.spec.frames - 1));
    const a = f - i0;
    this.frame = Math.round(f);
    const q = Figure.q;
    for (const tr of this.tracks) {
      const v = tr.values;
      if (tr.property === 'position') {
        tr.bone.position.set(
          v[3 * i0] + a * (v[3 * i1] - v[3 * i0]),
          v[3 * i0 + 1] + a * (v[3 * i1 + 1] - v[3 * i0 + 1]),
          v[3 * i0 + 2] + a * (v[3 * i1 + 2] - v[3 * i0 + 2]),
        );
      } else if (tr.property === 'quaternion') {
        THREE.Quaternion.slerpFlat(q, 0, v, 4 * i0, v, 4 * i1, a);
        tr.bone.quaternion.fromArray(q);
      }
    }
    this.group.updateMatrixWorld(true);
    const m = Figure.m, pa = Figure.pa, pb = Figure.pb, mid = Figure.mid, rot = Figure.rot, sc = Figure.sc;
    const contact = (k) => (k >= 0 ? this.spec.contacts[k][this.frame] : '0');
    this.segments.forEach((seg, i) => {
      seg.from.getWorldPosition(pa);
      seg.to.getWorldPosition(pb);
      mid.addVectors(pa, pb).multiplyScalar(0.5);
      pb.sub(pa);
      const len = pb.length();
      if (len > 1e-6) rot.setFromUnitVectors(Y_AXIS, pb.divideScalar(len));
      else rot.identity();
      sc.set(BONE_RADIUS, len, BONE_RADIUS);
      this.boneMesh.setMatrixAt(i, m.compose(mid, rot, sc));
      this.boneMesh.setColorAt(i, FOOT_COLOURS[contact(seg.foot)] || this.colour);
    });
    rot.identity();
    this.joints.forEach((j, i) => {
      j.bone.getWorldPosition(pa);
      const r = j.foot >= 0 ? FOOT_RADIUS : JOINT_RADIUS;
      sc.set(r, r, r);
      this.jointMesh.setMatrixAt(i, m.compose(pa, rot, sc));
      this.jointMesh.setColorAt(i, FOOT_COLOURS[contact(j.foot)] || this.colour);
    });
    for (const mesh of [this.boneMesh, this.jointMesh]) {
      mesh.instanceMatrix.needsUpdate = true;
      if (mesh.instanceColor) mesh.instanceColor.needsUpdate = true;
    }
  }

  setVisible(on) {
    this.visible = on;
    this.boneMesh.visible = on;
    this.jointMesh.visible = on;
  }

  // World position above the figure's pelvis, for its label.
  labelPosition(out) {
    this.pelvis.getWorldPosition(out);
    out.y += 0.95;
    return out;
  }

  dispose(scene) {
    scene.remove(this.group, this.boneMesh, this.jointMesh);
    this.boneMesh.material.dispose();
    this.jointMesh.material.dispose();
    this.boneMesh.dispose();
    this.jointMesh.dispose();
  }
}
Figure.cylinder = new THREE.CylinderGeometry(1, 1, 1, 10, 1);
Figure.sphere = new THREE.SphereGeometry(1, 14, 10);
Figure.q = [0, 0, 0, 1];
Figure.m = new THREE.Matrix4();
Figure.pa = new THREE.Vector3();
Figure.pb = new THREE.Vector3();
Figure.mid = new THREE.Vector3();
Figure.rot = new THREE.Quaternion();
Figure.sc = new THREE.Vector3();

class Player {
  constructor(root, data) {
    this.root = root;
    this.data = data;
    this.time = 0;
    this.playing = true;
    this.speed = 1;
    this.loop = true;
    this.figures = [];
    this.dirty = true;
    this.build();
  }

  build() {
    const root = this.root;
    root.querySelector('.mp-status').textContent = '';
    const bar = element('div', { class: 'mp-toolbar' }, root);
    if (this.data.scenes.length > 1) {
      element('label', { for: 'mp-scene' }, bar, 'query ');
      this.sceneSelect = element('select', { id: 'mp-scene' }, bar);
      for (const s of this.data.scenes) element('option', { value: s.id }, this.sceneSelect, s.id);
      this.sceneSelect.addEventListener('change', () => this.showScene(this.sceneSelect.value));
    }
    const button = (label, title, action) => {
      const b = element('button', { type: 'button', title }, bar, label);
      b.addEventListener('click', action);
      return b;
    };
    button('\u2759\u25c0', 'Back to the start (Home)', () => this.setTime(0));
    button('\u25c0', 'One frame back (left arrow)', () => this.step(-1));
    this.playButton = button('', 'Play or pause (space)', () => (this.playing ? this.pause() : this.play()));
    this.playButton.classList.add('mp-play');
    button('\u25b6\u2759', 'One frame on (right arrow)', () => this.step(1));
    element('label', { for: 'mp-speed' }, bar, ' speed ');
    this.speedSelect = element('select', { id: 'mp-speed' }, bar);
    for (const s of [0.1, 0.25, 0.5, 1, 2]) element('option', { value: String(s) }, this.speedSelect, `${s}\u00d7`);
    this.speedSelect.value = '1';
    this.speedSelect.addEventListener('change', () => (this.speed = Number(this.speedSelect.value)));
    const loopLabel = element('label', {}, bar, ' ');
    this.loopBox = element('input', { type: 'checkbox', checked: '' }, loopLabel);
    loopLabel.append(' loop');
    this.loopBox.addEventListener('change', () => (this.loop = this.loopBox.checked));
    button('reset view', 'Frame every motion again', () => this.frameAll());
    this.clock = element('span', { class: 'mp-clock' }, bar);

    const view = element('div', { class: 'mp-view' }, root);
    this.canvas = element('canvas', {}, view);
    this.labels = element('div', { class: 'mp-labels' }, view);
    element('div', { class: 'mp-hint' }, view, 'drag: orbit \u00b7 wheel: zoom \u00b7 right drag: pan');

    this.timeline = element('div', { class: 'mp-timeline' }, root);
    this.legend = element('div', { class: 'mp-legend' }, root);

    this.renderer = new THREE.WebGLRenderer({ canvas: this.canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(2, window.devicePixelRatio || 1));
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#f4f5f7');
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8d8d8d, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(3, 6, 4);
    this.scene.add(sun);
    this.camera = new THREE.PerspectiveCamera(40, 2, 0.05, 1000);
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.addEventListener('change', () => (this.dirty = true));

    new ResizeObserver(() => this.resize()).observe(view);
    this.root.tabIndex = 0;
    this.root.addEventListener('keydown', (e) => this.key(e));
  }

  key(e) {
    if (e.target.tagName === 'SELECT' || e.target.tagName === 'INPUT') return;
    if (e.key === ' ') this.playing ? this.pause() : this.play();
    else if (e.key === 'ArrowLeft') this.step(-1);
    else if (e.key === 'ArrowRight') this.step(1);
    else if (e.key === 'Home') this.setTime(0);
    else return;
    e.preventDefault();
  }

  resize() {
    const w = this.canvas.parentElement.clientWidth;
    const h = this.canvas.parentElement.clientHeight;
    if (w < 1 || h < 1) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.dirty = true;
    // Where the view is on the page (CSS pixels), for screenshots.
    const r = this.canvas.getBoundingClientRect();
    this.root.dataset.playerView = [r.left + window.scrollX, r.top + window.scrollY, r.width, r.height]
      .map((v) => v.toFixed(0))
      .join(',');
  }

  showScene(id) {
    const spec = this.data.scenes.find((s) => s.id === id) || this.data.scenes[0];
    for (const f of this.figures) f.dispose(this.scene);
    if (this.grid) this.scene.remove(this.grid);
    this.current = spec;
    if (this.sceneSelect) this.sceneSelect.value = spec.id;
    this.figures = spec.motions.map((m) => new Figure(m, this.scene));
    this.layOut();
    this.buildTimeline();
    this.buildLegend();
    this.duration = Math.max(spec.duration_s, 1e-3);
    this.root.dataset.playerScene = spec.id;
    this.root.dataset.playerMotions = String(this.figures.length);
    this.setTime(0);
    this.frameAll();
  }

  // Each motion is centred in a cell as wide and deep as its root path plus
  // a margin. Groups form rows (the first nearest the camera, the motions of
  // a group side by side), or, when the motions travel mostly in depth
  // (cells deeper than wide on average), one line across, group after group;
  // attached motions (query frames) take their motion's place.
  layOut() {
    const rows = [];
    const byId = new Map();
    for (const f of this.figures) {
      byId.set(f.spec.id, f);
      if (f.spec.attach) continue;
      let row = rows.find((r) => r.group === f.spec.group);
      if (!row) rows.push((row = { group: f.spec.group, figures: [] }));
      row.figures.push(f);
    }
    const width = (f) => f.spec.box_m[1] - f.spec.box_m[0] + CELL_MARGIN;
    const depth = (f) => f.spec.box_m[3] - f.spec.box_m[2] + CELL_MARGIN;
    const laid = rows.flatMap((r) => r.figures);
    const sum = (g) => laid.reduce((s, f) => s + g(f), 0);
    const lines = sum(depth) > 1.5 * sum(width) ? [{ figures: laid, gaps: true }] : rows.map((r) => ({ figures: r.figures }));
    const box = new THREE.Box3();
    const content = new THREE.Box3();
    let z = 0;
    for (const line of lines) {
      const d = Math.max(...line.figures.map(depth));
      const gapAfter = (i) =>
        i + 1 < line.figures.length && line.gaps && line.figures[i + 1].spec.group !== line.figures[i].spec.group
          ? 4 * CELL_GAP
          : CELL_GAP;
      const total = line.figures.reduce((s, f, i) => s + width(f) + (i + 1 < line.figures.length ? gapAfter(i) : 0), 0);
      let x = -total / 2;
      const cz = z - d / 2;
      line.figures.forEach((f, i) => {
        const b = f.spec.box_m;
        const cx = x + width(f) / 2;
        f.place(cx - (b[0] + b[1]) / 2, cz - (b[2] + b[3]) / 2);
        // What the camera frames: the root path and a body's reach around it.
        const p = f.group.position;
        content.expandByPoint(new THREE.Vector3(b[0] + p.x - 0.4, 0, b[2] + p.z - 0.4));
        content.expandByPoint(new THREE.Vector3(b[1] + p.x + 0.4, 1.9, b[3] + p.z + 0.4));
        box.expandByPoint(new THREE.Vector3(x, 0, z - d));
        box.expandByPoint(new THREE.Vector3(x + width(f), 2, z));
        x += width(f) + gapAfter(i);
      });
      z -= d + CELL_GAP;
    }
    for (const f of this.figures)
      if (f.spec.attach && byId.has(f.spec.attach)) f.group.position.copy(byId.get(f.spec.attach).group.position);
    this.box = box.isEmpty() ? new THREE.Box3(new THREE.Vector3(-1, 0, -1), new THREE.Vector3(1, 2, 1)) : box;
    this.content = content.isEmpty() ? this.box.clone() : content;
    const size = this.box.getSize(new THREE.Vector3());
    const centre = this.box.getCenter(new THREE.Vector3());
    const n = 2 * Math.ceil((Math.max(size.x, size.z) + 4) / 2);
    this.grid = new THREE.GridHelper(n, n, 0x9aa0a6, 0xd3d6da);
    this.grid.position.set(Math.round(centre.x), 0, Math.round(centre.z));
    this.scene.add(this.grid);
  }

  // The camera looks at the middle of the motions from the front and above,
  // as close as keeps their root paths and a body's reach around them in view.
  frameAll() {
    const b = this.content;
    const centre = b.getCenter(new THREE.Vector3());
    centre.y = 0.8;
    const dir = new THREE.Vector3(0.3, 0.45, 1).normalize();
    const corners = [];
    for (const x of [b.min.x, b.max.x])
      for (const y of [b.min.y, b.max.y])
        for (const z of [b.min.z, b.max.z]) corners.push(new THREE.Vector3(x, y, z));
    const fits = (d) => {
      this.camera.position.copy(centre).addScaledVector(dir, d);
      this.camera.lookAt(centre);
      this.camera.updateMatrixWorld(true);
      const p = new THREE.Vector3();
      return corners.every((c) => {
        p.copy(c).project(this.camera);
        return p.z < 1 && Math.abs(p.x) <= 0.96 && Math.abs(p.y) <= 0.92;
      });
    };
    let lo = 1.5;
    let hi = 3;
    while (!fits(hi) && hi < 1e4) hi *= 2;
    for (let i = 0; i < 30; i++) {
      const mid = 0.5 * (lo + hi);
      if (fits(mid)) hi = mid;
      else lo = mid;
    }
    this.camera.position.copy(centre).addScaledVector(dir, hi);
    this.controls.target.copy(centre);
    this.controls.update();
    this.dirty = true;
  }

  buildTimeline() {
    const tl = this.timeline;
    tl.replaceChildren();
    const spec = this.current;
    const pct = (t) => `${(100 * t) / Math.max(spec.duration_s, 1e-3)}%`;
    const tracks = element('div', { class: 'mp-tracks' }, tl);
    const row = (label) => {
      const r = element('div', { class: 'mp-row' }, tracks);
      element('span', { class: 'mp-row-label' }, r, label);
      return element('div', { class: 'mp-track' }, r);
    };
    if (spec.marks.length) {
      const track = row('output');
      for (const k of spec.marks) {
        if (k.kind === 'query') {
          const q = element('div', { class: 'mp-query', title: `${k.label}: ${k.start_s.toFixed(2)} s` }, track);
          q.style.left = pct(k.start_s);
          const label = element('span', {}, q, k.label);
          if (k.start_s > 0.9 * spec.duration_s) label.classList.add('mp-left');
        } else {
          const span = element('div', { class: `mp-span mp-${k.kind}`, title: `${k.kind} ${k.label}` }, track);
          span.style.left = pct(k.start_s);
          span.style.width = pct(Math.max(k.end_s - k.start_s, 0));
        }
      }
    }
    const groups = [];
    for (const f of this.figures) {
      if (f.spec.attach) continue;
      if (!groups.includes(f.spec.group) && f.spec.group !== 'synthesised') groups.push(f.spec.group);
    }
    for (const g of groups) {
      const track = row(g);
      const members = this.figures.filter((f) => f.spec.group === g);
      members.forEach((f, i) => {
        const s = f.spec;
        const bar = element('div', { class: 'mp-bar', title: s.label }, track);
        bar.style.left = pct(s.start_s);
        bar.style.width = pct((s.frames - 1) * s.frame_time_s);
        bar.style.top = `${2 + (i * 18) / members.length}px`;
        bar.style.height = `${Math.max(2, 18 / members.length - 1)}px`;
        bar.style.background = s.colour;
      });
    }
    this.playhead = element('div', { class: 'mp-playhead' }, tracks);
    // The tracks start 90 px into the timeline's padding box (a row's label,
    // 89 px, and the track's left border), as the playhead does.
    const scrub = (e) => {
      const r = tracks.getBoundingClientRect();
      const left = r.left + tracks.clientLeft + 90;
      const right = r.left + tracks.clientLeft + tracks.clientWidth;
      const x = Math.min(1, Math.max(0, (e.clientX - left) / Math.max(1, right - left)));
      this.setTime(x * spec.duration_s);
    };
    tracks.addEventListener('pointerdown', (e) => {
      this.pause();
      try {
        tracks.setPointerCapture(e.pointerId);
      } catch {
        // a synthetic event has no active pointer to capture
      }
      scrub(e);
      const move = (ev) => scrub(ev);
      const up = () => {
        tracks.removeEventListener('pointermove', move);
        tracks.removeEventListener('pointerup', up);
      };
      tracks.addEventListener('pointermove', move);
      tracks.addEventListener('pointerup', up);
    });
    const legend = element('div', { class: 'mp-timeline-legend' }, tl);
    if (spec.marks.length)
      legend.innerHTML =
        '<span class="mp-key mp-query-key"></span> query frame ' +
        '<span class="mp-key mp-transition"></span> transition ' +
        '<span class="mp-key mp-partial"></span> partial motion in the output; ';
    legend.append('bars: when each partial motion plays; click or drag to scrub');
  }

  buildLegend() {
    const lg = this.legend;
    lg.replaceChildren();
    const list = element('ul', {}, lg);
    this.labelNodes = [];
    for (const f of this.figures) {
      const s = f.spec;
      const li = element('li', {}, list);
      const box = element('input', { type: 'checkbox', checked: '', title: 'show or hide' }, li);
      box.addEventListener('change', () => {
        f.setVisible(box.checked);
        this.dirty = true;
      });
      const sw = element('span', { class: 'mp-swatch' }, li);
      sw.style.background = s.colour;
      if (s.attach) sw.style.opacity = '0.45';
      const name = element('a', { href: '#', title: 'look at this motion' }, li, s.label);
      name.addEventListener('click', (e) => {
        e.preventDefault();
        f.pelvis.getWorldPosition(this.controls.target);
        this.controls.update();
        this.dirty = true;
      });
      const tag = element('div', { class: 'mp-label' }, this.labels, s.tag || s.label);
      tag.style.borderColor = s.colour;
      this.labelNodes.push(s.attach ? null : tag);
      if (s.attach) tag.remove();
    }
    element('p', {}, lg).innerHTML =
      '<span class="mp-key" style="background:#16a34a"></span> foot or toe joint in contact ' +
      '(below 5 cm, slower than 0.5 m/s) <span class="mp-key" style="background:#e0218a"></span> ' +
      'skating (below 5 cm, faster) &middot; ' +
      (this.figures.some((f) => f.spec.attach) ? 'translucent: the query frames on the synthesised motion &middot; ' : '') +
      (this.figures.some((f) => f.spec.chosen) ? 'gold: the chosen partial motion &middot; ' : 'gold: rank 1 &middot; ') +
      'grid: 1 m';
  }

  play() {
    if (this.time >= this.duration - 1e-9) this.time = 0;
    this.playing = true;
    this.dirty = true;
  }

  pause() {
    this.playing = false;
    this.dirty = true;
  }

  step(frames) {
    this.pause();
    const dt = this.figures.length ? this.figures[0].spec.frame_time_s : 1 / 30;
    this.setTime(this.time + frames * dt);
  }

  setTime(t) {
    this.time = Math.min(this.duration || 0, Math.max(0, t));
    this.dirty = true;
  }

  tick(now) {
    if (this.last !== undefined && this.playing) {
      this.time += ((now - this.last) / 1000) * this.speed;
      if (this.time > this.duration) {
        if (this.loop) this.time %= this.duration;
        else {
          this.time = this.duration;
          this.playing = false;
        }
      }
      this.dirty = true;
    }
    this.last = now;
    if (this.dirty) this.render();
    requestAnimationFrame((t) => this.tick(t));
  }

  render() {
    this.dirty = false;
    for (const f of this.figures) f.update(this.time);
    this.renderer.render(this.scene, this.camera);
    const w = this.canvas.clientWidth;
    const h = this.canvas.clientHeight;
    const p = new THREE.Vector3();
    this.figures.forEach((f, i) => {
      const node = this.labelNodes[i];
      if (!node) return;
      f.labelPosition(p).project(this.camera);
      const on = f.visible && p.z < 1 && Math.abs(p.x) < 1.05 && Math.abs(p.y) < 1.05;
      node.style.display = on ? '' : 'none';
      if (on) node.style.transform = `translate(${((p.x + 1) / 2) * w}px, ${((1 - p.y) / 2) * h}px) translate(-50%, -100%)`;
    });
    if (this.playhead) this.playhead.style.left = `calc(90px + (100% - 90px) * ${this.time / this.duration})`;
    const base = this.figures[0];
    this.playButton.textContent = this.playing ? '\u275a\u275a pause' : '\u25b6 play';
    this.clock.textContent = ` t ${this.time.toFixed(2)} / ${this.duration.toFixed(2)} s` +
      (base
        ? ` \u00b7 ${base.spec.tag} frame ${base.spec.first_frame + base.frame}` +
          ` (${base.spec.first_frame}\u2013${base.spec.first_frame + base.spec.frames - 1})`
        : '');
    this.root.dataset.playerTime = String(Math.round(this.time * 1000));
  }
}

export async function start(root, data) {
  window.addEventListener('error', (e) => {
    root.dataset.playerError = String(e.message || e);
  });
  window.addEventListener('unhandledrejection', (e) => {
    root.dataset.playerError = String(e.reason && e.reason.message ? e.reason.message : e.reason);
  });
  const player = new Player(root, data);
  const opts = hashOptions();
  player.showScene(opts.scene || data.scenes[0].id);
  if (opts.speed && Number(opts.speed) > 0) {
    player.speed = Number(opts.speed);
    player.speedSelect.value = opts.speed;
  }
  if (opts.t !== undefined) {
    player.setTime(Number(opts.t) || 0);
    player.pause();
  }
  if (opts.paused !== undefined) player.pause();
  window.mocapPlayer = player;
  player.resize();
  player.render();
  root.dataset.playerState = 'ready';
  requestAnimationFrame((t) => player.tick(t));
}
