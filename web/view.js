// `rhier view`'s page: draws the served solution with three.js (WebGL2) as `rhier play`
// draws it (linear vertex radiosity × exposure, then the sRGB curve; back faces culled;
// black background), orbits from play's start camera (OrbitControls) and flies with the
// keys (WASD/arrows, Q/E, shift: camera and orbit target move together, R: back to the
// start), scrubs and plays time, and asks the server for the probe answer where a
// surface is clicked. Dragging with the right button turns the camera where it
// stands (mouse-look). State for tests and benchmarks is on `window.rhierView`.
import * as THREE from 'three';
import { OrbitControls } from '/vendor/OrbitControls.js';
import { parseFrame, parseMesh } from '/wire.js';

const $ = (id) => document.getElementById(id);
const api = {
  stats: { ready: false, start: {}, firstFrameMs: null, framesShown: 0, playStarted: null, lastProbe: null, meshes: 0, times: {} },
  // stats.times: milliseconds spent, and answers received, by kind: `frame` and `mesh` from asking
  // to parsed (the server's time, the transfer and the parse), `install` (a new
  // span mesh to the GPU), `upload` (the live leaves' triangles, colours and transforms), `draw` (handing the draw
  // to WebGL) (benchmarks).
};
window.rhierView = api;

const VERTEX = `
precision highp float;
uniform mat4 modelViewMatrix;
uniform mat4 projectionMatrix;
uniform float scale;
in vec3 position;
in vec3 color;
out vec3 radiosity;
void main() {
  radiosity = color * scale;
  gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);
}`;

// rhier::playback::raster::srgb_oetf of the exposed radiosity (IEC 61966-2-1).
const FRAGMENT = `
precision highp float;
uniform float exposure;
in vec3 radiosity;
out vec4 outColor;
void main() {
  vec3 x = clamp(radiosity * exposure, 0.0, 1.0);
  vec3 srgb = mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, x));
  outColor = vec4(srgb, 1.0);
}`;

const material = new THREE.RawShaderMaterial({
  glslVersion: THREE.GLSL3,
  vertexShader: VERTEX,
  fragmentShader: FRAGMENT,
  uniforms: { exposure: { value: 1 }, scale: { value: 1 } },
  side: THREE.FrontSide,
});

const canvas = $('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setClearColor(0x000000, 1);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(45, 1, 0.1, 1000);
const controls = new OrbitControls(camera, canvas);
let info = null;
let bounds = new THREE.Sphere(); // the scene at the first frame: fly speed, clip planes
let mesh = { key: null, live: null, objects: new Map() }; // object index -> THREE.Mesh
let shownFrame = null;
const AHEAD = 8; // frames asked for ahead while playing
const frames = new Map(); // `${shading}|${fps}|${k}` -> Promise<frame>, oldest first
// Frames are kept up to KEPT_BYTES of messages, so that an animation played again or
// scrubbed back is drawn from memory (ACTOR's 76 frames: 7 MB; 100k's: 2.4 MB each).
const KEPT_BYTES = 64 * 1024 * 1024;
const frameBytes = new Map(); // key -> bytes of its message, once received
let keptBytes = 0;
const meshes = new Map(); // key -> Promise<parsed mesh>
const colorsById = new Map(); // colour id -> Uint16Array, the last few received
let latestColors = 0; // id of the colours received last
let uploadedColors = 0; // id of the colours on the GPU

// A frame's colours: its own, else those of its colour id received before, else
// (evicted) the frame asked for again with them.
async function colorsOf(frame) {
  if (frame.colors) return frame.colors;
  if (colorsById.has(frame.colorsId)) return colorsById.get(frame.colorsId);
  const again = parseFrame(await fetchBinary(`/api/frame?t=${frame.t}&shading=${shading()}`));
  return keep(again).colors;
}
function keep(frame) {
  if (frame.colors) {
    colorsById.set(frame.colorsId, frame.colors);
    if (colorsById.size > 4) colorsById.delete(colorsById.keys().next().value);
    latestColors = Math.max(latestColors, frame.colorsId);
  }
  return frame;
}

function render() {
  clip();
  renderer.render(scene, camera);
}

// Waits for the drawing to end (a one-pixel read), so that times measure it.
const onePixel = new Uint8Array(4);
function finish() {
  const gl = renderer.getContext();
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, onePixel);
}

function resize() {
  const w = canvas.clientWidth;
  const h = canvas.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / Math.max(1, h);
  camera.updateProjectionMatrix();
  render();
}

function spent(kind, t0) {
  const t = (api.stats.times[kind] ||= { ms: 0, n: 0 });
  t.ms += performance.now() - t0;
  t.n += 1;
}
async function timedFetch(kind, url, parse) {
  const t0 = performance.now();
  const out = parse(await fetchBinary(url));
  spent(kind, t0);
  return out;
}

async function fetchBinary(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: ${r.status} ${await r.text()}`);
  return r.arrayBuffer();
}

// Frame times as `rhier play --frames start..end --fps F`: start + k / F, the last clamped.
function frameCount() {
  const [a, b] = info.time;
  return Math.floor((b - a) * fps() + 1e-9) + 1;
}
function frameTime(k) {
  const [a, b] = info.time;
  return Math.min(a + k / fps(), b);
}
function fps() {
  const f = Number($('fps').value);
  return f > 0 && Number.isFinite(f) ? f : 25;
}
function shading() {
  return $('shading').value;
}

function frameAt(k) {
  const key = `${shading()}|${fps()}|${k}`;
  if (!frames.has(key)) {
    const t = frameTime(k);
    const have = colorsById.has(latestColors) ? `&have=${latestColors}` : '';
    // A frame whose live leaves differ from the mesh's has its mesh asked for too.
    const frame = timedFetch('frame', `/api/frame?t=${t}&shading=${shading()}${have}`, parseFrame).then(keep);
    // (The first frame's mesh is asked for with it, by `start`.)
    frame.then((f) => api.stats.ready && mesh.key !== f.key && meshFor(f.key, f.t)).catch(() => {});
    frames.set(key, frame);
    frame.then((f) => {
      if (frames.get(key) !== frame) return;
      frameBytes.set(key, f.transforms.buffer.byteLength);
      keptBytes += f.transforms.buffer.byteLength;
      while ((keptBytes > KEPT_BYTES || frames.size > 4096) && frames.size > 1) {
        const old = frames.keys().next().value;
        keptBytes -= frameBytes.get(old) || 0;
        frameBytes.delete(old);
        frames.delete(old);
      }
    }).catch(() => frames.get(key) === frame && frames.delete(key));
  }
  return frames.get(key);
}

function meshFor(key, t) {
  const k = key.toString();
  if (!meshes.has(k)) {
    meshes.set(k, timedFetch('mesh', `/api/mesh?t=${t}`, parseMesh));
    // As many as the frames asked ahead can need, each live-leaf change its own.
    if (meshes.size > AHEAD + 2) meshes.delete(meshes.keys().next().value);
  }
  return meshes.get(k);
}

// Each object's mesh is kept across span meshes (`pool`): a new mesh of the object is
// copied into its buffers and only the part in use is uploaded (`addUpdateRange`) and
// drawn (`setDrawRange`); the buffers are allocated anew, half again as large, only
// when a mesh outgrows them.
const pool = new Map(); // object index -> THREE.Mesh, in the scene or not

function pooled(object, vertices, indices) {
  let m = pool.get(object);
  if (m && m.geometry.getAttribute('position').count >= vertices && m.geometry.index.count >= indices) return m;
  if (m) m.geometry.dispose();
  // Exactly the first mesh's size (a still scene's one mesh), half again when outgrown.
  const room = (n) => (m ? Math.ceil(n * 1.5) : n);
  const geometry = new THREE.BufferGeometry();
  const attribute = (a, size) => new THREE.BufferAttribute(a, size).setUsage(THREE.DynamicDrawUsage);
  geometry.setAttribute('position', attribute(new Float32Array(3 * room(vertices)), 3));
  // Colours as 4 half floats a corner (the 4th unused): a 3-half vertex format is
  // not one Vulkan must have, and ANGLE on SwiftShader converted the whole buffer on
  // the CPU after each change (26 ms a frame, ACTOR, BENCHMARKS.md "Viewer").
  const colors = new THREE.Float16BufferAttribute(new Uint16Array(4 * room(vertices)), 4);
  geometry.setAttribute('color', colors.setUsage(THREE.DynamicDrawUsage));
  geometry.setIndex(attribute(new Uint32Array(room(indices)), 1));
  if (!m) {
    m = new THREE.Mesh(geometry, material);
    m.matrixAutoUpdate = false;
    m.frustumCulled = false;
    pool.set(object, m);
  } else {
    m.geometry = geometry;
  }
  return m;
}

// Copies `data` to the start of `attr` and uploads that part only.
function fill(attr, data) {
  attr.array.set(data);
  attr.clearUpdateRanges();
  attr.addUpdateRange(0, data.length);
  attr.needsUpdate = true;
}

// A new span mesh: its corner positions to the GPU, once for all the frames of the
// span; which leaves are drawn is chosen per live set (`select`).
function install(parsed) {
  for (const m of mesh.objects.values()) scene.remove(m);
  uploadedColors = 0;
  mesh = { key: parsed.key, live: null, objects: new Map() };
  for (const g of parsed.groups) {
    const vertices = g.positions.length / 3;
    const leaves = g.corners.length;
    // Each leaf's first corner, and room for all its triangles.
    const first = new Uint32Array(leaves);
    let triangles = 0;
    for (let k = 0, v = 0; k < leaves; k++) {
      first[k] = v;
      v += g.corners[k];
      triangles += g.corners[k] - 2;
    }
    const m = pooled(g.object, vertices, 3 * triangles);
    const geometry = m.geometry;
    fill(geometry.getAttribute('position'), g.positions);
    geometry.setDrawRange(0, 0);
    // Bounds of the part in use (what computeBoundingBox would give the mesh alone).
    geometry.boundingBox = new THREE.Box3().setFromArray(g.positions);
    geometry.boundingSphere = geometry.boundingBox.getBoundingSphere(new THREE.Sphere());
    m.userData = { object: g.object, times: g.times, corners: g.corners, first, live: new Uint32Array(leaves), lives: 0 };
    scene.add(m);
    mesh.objects.set(g.object, m);
  }
  api.stats.meshes += 1;
}

// The leaves of the mesh live at the frame's time, by the test of
// rhier::solution::Leaf::is_live (in f32: t0 <= t < t1, or t <= t1 when t1 is the
// domain's end): their triangles become the index buffer (so only they are drawn and
// hit by a click), and they are where the frame's colours go.
function select(frame) {
  if (mesh.live === frame.live) return;
  const t = Math.fround(frame.t);
  const end = Math.fround(info.time[1]);
  for (const m of mesh.objects.values()) {
    const { times, corners, first, live } = m.userData;
    const index = m.geometry.index;
    const out = index.array;
    let n = 0;
    let lives = 0;
    for (let k = 0; k < corners.length; k++) {
      const t0 = times[2 * k];
      const t1 = times[2 * k + 1];
      if (!(t0 <= t && (t < t1 || (t <= t1 && t1 >= end)))) continue;
      live[lives++] = k;
      const c = first[k];
      out[n++] = c;
      out[n++] = c + 1;
      out[n++] = c + 2;
      if (corners[k] === 4) {
        out[n++] = c;
        out[n++] = c + 2;
        out[n++] = c + 3;
      }
    }
    index.clearUpdateRanges();
    index.addUpdateRange(0, n);
    index.needsUpdate = true;
    m.geometry.setDrawRange(0, n);
    m.userData.lives = lives;
  }
  mesh.live = frame.live;
  uploadedColors = 0;
}

// The frame's colours (the live leaves' corners, in the mesh's order, 3 half floats
// each) to the corners of the live leaves (4 half floats each, the 4th unused).
function scatter(colors) {
  let at = 0;
  for (const m of mesh.objects.values()) {
    const { corners, first, live, lives } = m.userData;
    const attr = m.geometry.getAttribute('color');
    const out = attr.array;
    let lo = Infinity;
    let hi = 0;
    for (let j = 0; j < lives; j++) {
      const k = live[j];
      let d = 4 * first[k];
      const end = at + 3 * corners[k];
      lo = Math.min(lo, d);
      for (; at < end; at += 3, d += 4) {
        out[d] = colors[at];
        out[d + 1] = colors[at + 1];
        out[d + 2] = colors[at + 2];
      }
      hi = Math.max(hi, d);
    }
    if (lives === 0) continue;
    attr.clearUpdateRanges();
    attr.addUpdateRange(lo, hi - lo);
    attr.needsUpdate = true;
  }
  if (at !== colors.length) throw new Error(`frame: colours for ${colors.length / 3} corners, the live leaves have ${at / 3}`);
}

async function show(frame) {
  if (mesh.key !== frame.key) {
    const parsed = await meshFor(frame.key, frame.t);
    const t0 = performance.now();
    install(parsed);
    spent('install', t0);
  }
  const colors = uploadedColors === frame.colorsId && mesh.live === frame.live ? null : await colorsOf(frame);
  const t0 = performance.now();
  select(frame);
  material.uniforms.scale.value = frame.scale;
  for (const m of mesh.objects.values()) {
    const o = m.userData.object;
    const a = frame.transforms.subarray(12 * o, 12 * o + 12);
    m.matrix.set(a[0], a[3], a[6], a[9], a[1], a[4], a[7], a[10], a[2], a[5], a[8], a[11], 0, 0, 0, 1);
    m.matrixWorldNeedsUpdate = true;
  }
  if (colors) scatter(colors);
  uploadedColors = frame.colorsId;
  shownFrame = frame;
  $('clock').textContent = `t = ${frame.t.toFixed(3)} s`;
  spent('upload', t0);
  const t1 = performance.now();
  render();
  spent('draw', t1);
  api.stats.framesShown += 1;
}

// Shows frame k (the slider's), unless a later request overtook it.
let wanted = 0;
async function goTo(k) {
  wanted = k;
  const frame = await frameAt(k);
  if (wanted === k) await show(frame);
}

// Playing: one frame after another at the chosen fps, never faster than the data
// arrive; the next AHEAD frames (and their meshes) are asked for ahead of time.
let playing = false;
async function play() {
  if (playing) return;
  playing = true;
  $('play').textContent = 'pause';
  const n = frameCount();
  let k = Number($('time').value);
  if (k >= n - 1) k = 0;
  let due = performance.now();
  api.stats.playStarted = due;
  api.stats.playFrames = 0;
  api.stats.firstPassMs = null;
  api.stats.waitMs = 0; // waiting for frame data
  api.stats.drawMs = 0; // uploading and handing the draw to WebGL
  while (playing) {
    for (let j = 1; j <= AHEAD; j++) frameAt((k + j) % n);
    const asked = performance.now();
    const frame = await frameAt(k);
    api.stats.waitMs += performance.now() - asked;
    const wait = due - performance.now();
    if (wait > 0) await new Promise((r) => setTimeout(r, wait));
    if (!playing) break;
    $('time').value = k;
    wanted = k;
    const drawn = performance.now();
    await show(frame);
    api.stats.drawMs += performance.now() - drawn;
    api.stats.playFrames += 1;
    // The first pass over the frames, none of them kept yet (benchmarks).
    if (api.stats.playFrames === n) api.stats.firstPassMs = performance.now() - api.stats.playStarted;
    due = Math.max(due + 1000 / fps(), performance.now() - 1000 / fps());
    k = (k + 1) % n;
  }
  $('play').textContent = 'play';
}
function pause() {
  playing = false;
}

function setupTime() {
  const n = frameCount();
  $('time').max = String(n - 1);
  $('time').disabled = n < 2;
  $('play').disabled = n < 2;
}

// Click (not drag): the probe answer at the surface under the pointer.
const raycaster = new THREE.Raycaster();
let down = null;
canvas.addEventListener('pointerdown', (e) => {
  down = e.button === 0 ? [e.clientX, e.clientY] : null;
});
canvas.addEventListener('pointerup', async (e) => {
  if (e.button !== 0 || !down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4) return;
  const r = canvas.getBoundingClientRect();
  const ndc = new THREE.Vector2(((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
  await probeAt(ndc);
});

async function probeAt(ndc) {
  raycaster.setFromCamera(ndc, camera);
  const hit = raycaster.intersectObjects([...mesh.objects.values()], false)[0];
  if (!hit || !shownFrame) {
    $('probe').textContent = 'no surface there';
    return null;
  }
  const n = hit.face.normal.clone().transformDirection(hit.object.matrixWorld);
  const p = hit.point;
  const q = `t=${shownFrame.t}&p=${p.x},${p.y},${p.z}&n=${n.x},${n.y},${n.z}`;
  const r = await fetch(`/api/probe?${q}`);
  const body = await r.text();
  if (!r.ok) {
    $('probe').textContent = body;
    return null;
  }
  const a = JSON.parse(body);
  const fmt = (v) => v.map((x) => x.toPrecision(5)).join(', ');
  $('probe').textContent =
    `B = [${fmt(a.B)}] at t = ${a.t}\n` +
    `point (${fmt(a.p)}), normal (${fmt(a.n)})\n` +
    `patch ${a.patch} (object ${a.object}, material ${a.material}), (u, v) = (${fmt(a.uv)})\n` +
    (a.leaf ? `leaf ${a.leaf.index}: ${a.leaf.corners} corners, time [${a.leaf.time.join(', ')}]` : 'no leaf');
  api.stats.lastProbe = a;
  return a;
}
api.probeAt = (x, y) => probeAt(new THREE.Vector2(x, y));

function setExposure() {
  const stops = Number($('stops').value);
  material.uniforms.exposure.value = info.exposure * 2 ** stops;
  $('stopsOut').textContent = `${stops >= 0 ? '+' : ''}${stops} EV`;
  render();
}

function placeCamera(groups) {
  const c = info.camera;
  const box = new THREE.Box3();
  for (const m of mesh.objects.values()) {
    m.updateMatrixWorld();
    box.expandByObject(m);
  }
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  const eye = new THREE.Vector3(...c.eye);
  let target = new THREE.Vector3(...c.target);
  const dir = target.clone().sub(eye).normalize();
  // Orbit about the point of the view axis nearest the scene's centre, not about a
  // target a unit away (play's interior camera), so that the view does not change.
  const along = sphere.center.clone().sub(eye).dot(dir);
  if (along > target.distanceTo(eye)) target = eye.clone().addScaledVector(dir, along);
  const radius = Math.max(sphere.radius, 1e-9);
  bounds = new THREE.Sphere(sphere.center, radius);
  camera.fov = c.fov_y_degrees;
  camera.up.set(...c.up);
  camera.position.copy(eye);
  camera.near = radius * 1e-3;
  camera.lookAt(target);
  controls.target.copy(target);
  controls.update();
  controls.saveState();
  resize();
}

// Flying: while a key is held the camera and its orbit target move together, forward
// and back along the view direction (W/S, up/down arrows), sideways (A/D, left/right)
// and down/up (Q/E), at a quarter of the scene's bounding radius per second, four
// times that with shift; dragging still orbits about the (moved) target. R goes back
// to the start camera.
const MOVES = {
  KeyW: [0, 0, 1], ArrowUp: [0, 0, 1], KeyS: [0, 0, -1], ArrowDown: [0, 0, -1],
  KeyD: [1, 0, 0], ArrowRight: [1, 0, 0], KeyA: [-1, 0, 0], ArrowLeft: [-1, 0, 0],
  KeyE: [0, 1, 0], KeyQ: [0, -1, 0],
};
const held = new Set();
let fast = false;
let lastStep = null; // time of the last step; null when no step is coming
function typing(e) {
  return e.target instanceof HTMLElement && e.target.matches('input, select, textarea');
}
function onKeyDown(e) {
  if (typing(e) || e.ctrlKey || e.metaKey || e.altKey) return;
  fast = e.shiftKey;
  if (e.code === 'KeyR') {
    held.clear();
    controls.reset();
    return;
  }
  if (!MOVES[e.code]) return;
  e.preventDefault();
  held.add(e.code);
  if (lastStep === null) {
    lastStep = performance.now() - 1000 / 60;
    requestAnimationFrame(step);
  }
}
function onKeyUp(e) {
  fast = e.shiftKey;
  held.delete(e.code);
}
function step(now) {
  if (held.size === 0) {
    lastStep = null;
    return;
  }
  // A slow frame moves at most 0.1 s worth: a stall does not throw the camera away.
  const dt = Math.min(Math.max(now - lastStep, 0) / 1000, 0.1);
  lastStep = now;
  const forward = camera.getWorldDirection(new THREE.Vector3());
  const right = forward.clone().cross(camera.up).normalize();
  const up = camera.up.clone().normalize();
  const move = new THREE.Vector3();
  for (const code of held) {
    const [x, y, z] = MOVES[code];
    move.addScaledVector(right, x).addScaledVector(up, y).addScaledVector(forward, z);
  }
  if (move.lengthSq() > 0) {
    move.setLength(bounds.radius * 0.25 * (fast ? 4 : 1) * dt);
    camera.position.add(move);
    controls.target.add(move);
    controls.update();
  }
  requestAnimationFrame(step);
}

// Looking: dragging with the right button turns the camera where it stands, LOOK
// radians per pixel: right/left about the up direction, up/down about the right one
// (kept short of straight up or down); the orbit target turns with it at its
// distance, so that W then flies where the camera looks. (OrbitControls' right-button
// pan is left to shift/ctrl + left drag.)
const LOOK = Math.PI / 720; // 0.25° a pixel
const STEEPEST = Math.PI / 2 - 0.01;
controls.mouseButtons.RIGHT = null;
let looking = null; // the pointer's last position while the right button is down
canvas.addEventListener('pointerdown', (e) => {
  if (e.button !== 2) return;
  looking = [e.clientX, e.clientY];
  canvas.setPointerCapture(e.pointerId);
});
canvas.addEventListener('pointermove', (e) => {
  if (!looking) return;
  const [dx, dy] = [e.clientX - looking[0], e.clientY - looking[1]];
  looking = [e.clientX, e.clientY];
  turn(-dx * LOOK, -dy * LOOK);
});
canvas.addEventListener('pointerup', (e) => {
  if (e.button === 2) looking = null;
});
function turn(yaw, pitch) {
  const up = camera.up.clone().normalize();
  const offset = controls.target.clone().sub(camera.position);
  const distance = offset.length();
  const dir = offset.normalize().applyAxisAngle(up, yaw);
  const right = dir.clone().cross(up).normalize();
  const elevation = Math.asin(THREE.MathUtils.clamp(dir.dot(up), -1, 1));
  const to = THREE.MathUtils.clamp(elevation + pitch, -STEEPEST, STEEPEST);
  dir.applyAxisAngle(right, to - elevation);
  controls.target.copy(camera.position).addScaledVector(dir, distance);
  controls.update();
}

// Clip planes that keep the scene in view wherever the camera has gone.
function clip() {
  if (bounds.isEmpty()) return; // nothing placed yet
  const far = camera.position.distanceTo(bounds.center) + 4 * bounds.radius;
  if (far !== camera.far) {
    camera.far = far;
    camera.updateProjectionMatrix();
  }
}

// Milliseconds from navigation start to each step of the first frame (benchmarks).
function mark(step) {
  api.stats.start[step] = performance.now();
}

async function start() {
  mark('script');
  info = await (await fetch('/api/info')).json();
  mark('info');
  $('file').textContent = info.file;
  $('timeRow').hidden = !info.moving;
  setupTime();
  $('fps').addEventListener('change', () => {
    setupTime();
    goTo(0);
  });
  $('time').addEventListener('input', () => goTo(Number($('time').value)));
  $('play').addEventListener('click', () => (playing ? pause() : play()));
  $('shading').addEventListener('change', () => goTo(Number($('time').value)));
  $('stops').addEventListener('input', setExposure);
  setExposure();
  // The first frame and its mesh asked for together.
  const early = timedFetch('mesh', `/api/mesh?t=${frameTime(0)}`, parseMesh);
  const first = await frameAt(0);
  mark('frame');
  const m0 = await early;
  if (m0.key === first.key) meshes.set(m0.key.toString(), early);
  install(await meshFor(first.key, first.t));
  mark('mesh');
  placeCamera();
  await show(first);
  mark('show');
  finish();
  mark('drawn');
  api.stats.firstFrameMs = performance.now();
  api.stats.ready = true;
  controls.addEventListener('change', render);
  window.addEventListener('resize', resize);
  window.addEventListener('keydown', onKeyDown);
  window.addEventListener('keyup', onKeyUp);
  window.addEventListener('blur', () => held.clear());
  const inspect = await (await fetch('/api/inspect')).json();
  $('inspect').textContent = inspect.text;
  api.inspect = inspect.json;
}

// Milliseconds to draw the scene as it is, the mean of n draws (benchmarks).
api.timeDraw = (n) => {
  const t0 = performance.now();
  for (let i = 0; i < n; i++) {
    render();
    finish();
  }
  return (performance.now() - t0) / n;
};
// The camera shown now, in the form of /api/info's `camera` (tests).
api.view = () => ({
  eye: camera.position.toArray(),
  target: controls.target.toArray(),
  up: camera.up.toArray(),
  fov_y_degrees: camera.fov,
});
api.goTo = goTo;
api.play = play;
api.pause = pause;
start().catch((e) => {
  $('probe').textContent = String(e);
  console.error(e);
});
