// rigid studio: draws the running scene from /api/meshes (once per scene version) and
// /api/frame (7 little-endian f32 per actor: position, quaternion x y z w), and drives the
// JSON API (docs/studio.md). URL parameters: ?play=1 starts playing once loaded; ?log=1
// writes the frame rates to the console each second (tests/studio_fps.rs reads them);
// ?adapt=0 turns the adaptive render scale off, ?scale=S starts it at S, ?fps=N aims it at N;
// ?points=0 draws every box as triangles (points.js).

import * as THREE from './three.module.min.js';
import { OrbitControls } from './OrbitControls.js';
import { HEXAGON_TRIANGLES, POINT_MAX_PX, chooseDetail, pointBoxMaterial } from './points.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);

function showError(message) {
  $('error').textContent = message || '';
}

async function api(path, body, json = true) {
  const init = body === undefined ? {} : {
    method: 'POST',
    headers: { 'Content-Type': json ? 'application/json' : 'text/plain' },
    body: json ? JSON.stringify(body) : body,
  };
  const r = await fetch(path, init);
  const v = await r.json().catch(() => ({}));
  if (!r.ok) {
    const message = v.error || `${r.status} ${r.statusText}`;
    showError(message);
    throw new Error(message);
  }
  showError('');
  return v;
}

// ---- three.js scene ----------------------------------------------------------------------

function softwareRenderer() {
  const gl = document.createElement('canvas').getContext('webgl2');
  const info = gl?.getExtension('WEBGL_debug_renderer_info');
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : '';
  gl?.getExtension('WEBGL_lose_context')?.loseContext();
  return /swiftshader|llvmpipe|softpipe|software/i.test(name);
}

const canvas = $('viewport');
let renderer = null;
try {
  // A software renderer (SwiftShader, llvmpipe) pays for multisampling on the processor: there it
  // halves the frame rate of a 4 000-body scene (BENCH.md), so edges stay sharp-stepped instead.
  renderer = new THREE.WebGLRenderer({ canvas, antialias: !softwareRenderer() });
} catch (e) {
  showError(`WebGL is not available: ${e.message}`);
}

// The adaptive render scale: while the scene plays and the page draws fewer frames a second than
// `target` although the server has newer states, the canvas is drawn at the next smaller share
// of its pixels (the browser stretches it to the viewport); with half as many frames again to
// spare it goes back up. A software renderer spends about a third of a frame filling pixels
// (BENCH.md, issue #21). Shown in the viewport's corner whenever below 1.
const SCALES = [1, 0.85, 0.7, 0.6, 0.5, 0.4];
const adapt = {
  on: params.get('adapt') !== '0',
  target: Number(params.get('fps')) > 0 ? Number(params.get('fps')) : 30,
  scale: 1,
  // Seconds to leave out after a change: the second it happened in mixes both scales.
  settle: 0,
  step: null,
};
{
  const s = Number(params.get('scale'));
  if (s > 0 && s <= 1) adapt.scale = s;
}

function setScale(scale) {
  adapt.scale = scale;
  adapt.settle = 1;
  if (!renderer) return;
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2) * scale);
  dirty = true;
  showScale();
}

function showScale() {
  const hud = $('hud');
  hud.dataset.scale = String(adapt.scale);
  $('hud-scale').textContent = adapt.scale < 1 ? `render scale ${adapt.scale}` : '';
}

// Once a second: `drawn` and `animation` frames in the second, the server's steps in it.
function adaptScale(drawn, animation, steps, running) {
  if (!adapt.on || !running || adapt.settle-- > 0) return;
  const lower = SCALES.find((s) => s < adapt.scale - 1e-9);
  const higher = SCALES.findLast((s) => s > adapt.scale + 1e-9);
  // The page skips states: drawing (not the server) holds the rate.
  const behind = steps > 1.2 * drawn;
  if (behind && drawn < adapt.target && lower) setScale(lower);
  else if (higher && (drawn >= 1.5 * adapt.target || (!behind && animation >= 1.5 * adapt.target))) setScale(higher);
}

const scene = new THREE.Scene();
scene.background = new THREE.Color(0x2b3038);
const camera = new THREE.PerspectiveCamera(45, 1, 0.05, 2000);
camera.position.set(6, 5, 8);
const controls = renderer ? new OrbitControls(camera, canvas) : null;
// The viewport is drawn only when something in it changed (a new state, the camera, the size,
// what is shown): with a software renderer, drawing is what a frame costs, and an idle page
// then leaves the processor to the simulation.
let dirty = true;
controls?.addEventListener('change', () => {
  dirty = true;
  // The joints' crosses keep their size on screen as the camera moves.
  if (lastFrame) placeJoints(lastFrame);
});
const hemi = new THREE.HemisphereLight(0xffffff, 0x445566, 1.6);
scene.add(hemi);
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
sun.position.set(5, 10, 7);
scene.add(sun);
let grid = new THREE.GridHelper(20, 20, 0x8899aa, 0x4a5260);
scene.add(grid);
scene.add(new THREE.AxesHelper(1));
const marker = new THREE.Mesh(new THREE.RingGeometry(0.15, 0.25, 24), new THREE.MeshBasicMaterial({ color: 0xffcc33, side: THREE.DoubleSide }));
marker.rotation.x = -Math.PI / 2;
marker.visible = false;
scene.add(marker);

// The joints: per joint a line between its two anchors and a small cross at each, one
// LineSegments for all, placed each frame from the bodies' poses (/api/meshes gives the anchors
// in the bodies' frames). Drawn over the bodies, as an anchor is usually inside one.
const SEGMENTS_PER_JOINT = 7;
let jointDefs = [];
const jointLines = new THREE.LineSegments(
  new THREE.BufferGeometry(),
  new THREE.LineBasicMaterial({ color: 0x28dce6, depthTest: false, transparent: true }),
);
jointLines.renderOrder = 1;
jointLines.frustumCulled = false;
scene.add(jointLines);

// The last step's contacts, on demand: a short line along each normal (from B to A) and a
// cross at each point, from /api/contacts, fetched after each new state while shown.
const contactLines = new THREE.LineSegments(
  new THREE.BufferGeometry(),
  new THREE.LineBasicMaterial({ color: 0xffaa22, depthTest: false, transparent: true }),
);
contactLines.renderOrder = 1;
contactLines.frustumCulled = false;
contactLines.visible = false;
scene.add(contactLines);

// Per (mesh, fixed) group: one merged mesh that draws every member, each vertex carrying its
// member's index and the poses read from a float texture in the vertex shader; and an
// InstancedMesh, never drawn, that the pointer's ray is tested against. For actor i,
// groupOf[i] = [group, member]. (SwiftShader draws one call of many triangles several times
// faster than the same triangles as instances; BENCH.md, issue #21.)
let groups = [];
let groupOf = [];
let version = -1;
let lastFrame = null;
let fitted = '';
let sceneName = '';
let loadingMeshes = false;
const POSE_WIDTH = 2048;

function flatGeometry(mesh) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(mesh.vertices, 3));
  g.setIndex(mesh.triangles);
  const flat = g.toNonIndexed();
  flat.computeVertexNormals();
  g.dispose();
  return flat;
}

// A box centred on its body's origin and aligned with its body's axes shows the camera at most
// one face of each pair: drawn as the three faces on the + side of its axes, each turned half a
// turn onto its opposite in the vertex shader when the camera is on that side (`FACING`), it
// gives the same picture with half the triangles. Its half extents, or null for another mesh.
function boxHalfExtents(mesh) {
  const v = mesh.vertices;
  if (v.length !== 24 || mesh.triangles.length !== 36) return null;
  const h = [Math.abs(v[0]), Math.abs(v[1]), Math.abs(v[2])];
  const corners = new Set();
  for (let i = 0; i < 8; i++) {
    let key = 0;
    for (let k = 0; k < 3; k++) {
      const x = v[3 * i + k];
      if (!(h[k] > 0) || Math.abs(Math.abs(x) - h[k]) > 1e-6 * h[k]) return null;
      key |= (x > 0 ? 1 : 0) << k;
    }
    corners.add(key);
  }
  return corners.size === 8 ? h : null;
}

function facingBoxGeometry([hx, hy, hz]) {
  // Per axis the + face as two triangles wound outwards: corners in order a b c d.
  const faces = [
    [[hx, -hy, -hz], [hx, hy, -hz], [hx, hy, hz], [hx, -hy, hz]],
    [[-hx, hy, -hz], [-hx, hy, hz], [hx, hy, hz], [hx, hy, -hz]],
    [[-hx, -hy, hz], [hx, -hy, hz], [hx, hy, hz], [-hx, hy, hz]],
  ];
  const position = [];
  const normal = [];
  const axis = [];
  faces.forEach((f, k) => {
    for (const c of [f[0], f[1], f[2], f[0], f[2], f[3]]) {
      position.push(...c);
      normal.push(k === 0 ? 1 : 0, k === 1 ? 1 : 0, k === 2 ? 1 : 0);
      axis.push(k);
    }
  });
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(position, 3));
  g.setAttribute('normal', new THREE.Float32BufferAttribute(normal, 3));
  g.setAttribute('axis', new THREE.Float32BufferAttribute(axis, 1));
  return g;
}

// A box seen from outside shows at most three faces, around the corner nearest the eye: drawn
// as that hexagon, 7 shared corners and 6 triangles, for the eye in the + octant of the body's
// axes and mirrored into the eye's octant in the vertex shader (`HEXAGON`). Each triangle takes
// its face's light from its last corner (a flat varying): the ring of corners is ordered so
// that each outer corner is the last of exactly one triangle.
function hexagonBoxGeometry([hx, hy, hz]) {
  // The near corner, then the ring around it; each ring corner with the normal of the face
  // whose triangle it ends.
  const corners = [[1, 1, 1], [1, 1, -1], [-1, 1, -1], [-1, 1, 1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]];
  const normals = [[1, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0]];
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(corners.flatMap(([x, y, z]) => [x * hx, y * hy, z * hz]), 3));
  g.setAttribute('normal', new THREE.Float32BufferAttribute(normals.flat(), 3));
  g.setIndex(HEXAGON_TRIANGLES);
  return g;
}

// `count` copies of `geometry`, each vertex tagged with its copy's index, coloured per copy.
function mergedGeometry(geometry, members, coloured) {
  const v = geometry.getAttribute('position').count;
  const count = members.length;
  const g = new THREE.BufferGeometry();
  for (const [name, a] of Object.entries(geometry.attributes)) {
    const out = new Float32Array(a.array.length * count);
    for (let k = 0; k < count; k++) out.set(a.array, k * a.array.length);
    g.setAttribute(name, new THREE.BufferAttribute(out, a.itemSize));
  }
  const index = geometry.getIndex();
  if (index) {
    const n = index.array.length;
    const out = new (v * count > 65535 ? Uint32Array : Uint16Array)(n * count);
    for (let k = 0; k < count; k++) for (let j = 0; j < n; j++) out[k * n + j] = index.array[j] + k * v;
    g.setIndex(new THREE.BufferAttribute(out, 1));
  }
  const body = new Float32Array(v * count);
  members.forEach((_, k) => body.fill(k, k * v, (k + 1) * v));
  g.setAttribute('body', new THREE.BufferAttribute(body, 1));
  if (coloured) g.setAttribute('color', new THREE.BufferAttribute(memberColours(members, v), 3));
  return g;
}

// Each member's colour, `v` times over.
function memberColours(members, v) {
  const color = new Float32Array(v * 3 * members.length);
  const c = new THREE.Color();
  members.forEach((a, k) => {
    c.setRGB(a.colour[0] / 255, a.colour[1] / 255, a.colour[2] / 255, THREE.SRGBColorSpace);
    for (let j = 0; j < v; j++) color.set([c.r, c.g, c.b], (k * v + j) * 3);
  });
  return color;
}

// The members as points (points.js), each vertex one member; which are drawn, and in what order,
// is the index `chooseDetail` fills each frame.
function pointsOf(g, box) {
  const n = g.members.length;
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * n), 3));
  geometry.setAttribute('body', new THREE.BufferAttribute(Float32Array.from(g.members, (_, k) => k), 1));
  geometry.setAttribute('color', new THREE.BufferAttribute(memberColours(g.members, 1), 3));
  geometry.setIndex(new THREE.BufferAttribute(new (n > 65535 ? Uint32Array : Uint16Array)(n), 1).setUsage(THREE.DynamicDrawUsage));
  geometry.setDrawRange(0, 0);
  const uniforms = { ...lightUniforms(), projection: { value: camera.projectionMatrix }, viewport: { value: drawingViewport } };
  const points = new THREE.Points(geometry, pointBoxMaterial(g.poses, box, POSE_WIDTH, uniforms));
  points.frustumCulled = false;
  g.radius = Math.hypot(...box);
  g.hexIndex = g.draw.geometry.getIndex().array;
  g.draw.geometry.getIndex().setUsage(THREE.DynamicDrawUsage);
  g.pointIndex = geometry.getIndex().array;
  g.points = 0;
  g.hexes = n;
  return points;
}

// The drawing buffer's viewport [pixels], for the points' shader.
const drawingViewport = new THREE.Vector4();

// Points where the renderer can draw them as large as a point may be.
function pointsAllowed() {
  if (!renderer || params.get('points') === '0') return false;
  const range = renderer.getContext().getParameter(renderer.getContext().ALIASED_POINT_SIZE_RANGE);
  return range && range[1] >= POINT_MAX_PX;
}

// Before drawing: which boxes are points this frame, and the draw ranges that follow.
function placeDetail() {
  renderer.getDrawingBufferSize(bufferSize);
  drawingViewport.set(0, 0, bufferSize.x, bufferSize.y);
  camera.updateMatrixWorld();
  for (const g of groups) {
    if (!g.dots) continue;
    if (chooseDetail(g, camera, bufferSize.x, bufferSize.y)) {
      g.draw.geometry.getIndex().needsUpdate = true;
      g.dots.geometry.getIndex().needsUpdate = true;
    }
    g.draw.geometry.setDrawRange(0, 18 * g.hexes);
    g.dots.geometry.setDrawRange(0, g.points);
  }
}
const bufferSize = new THREE.Vector2();

// Boxes the last frame drew as points.
function pointsDrawn() {
  return groups.reduce((n, g) => n + (g.dots ? g.points : 0), 0);
}

// The page's hemisphere and sun as the posed shaders' uniforms (the points' shader lights as the
// hexagons' does).
function lightUniforms() {
  const scaled = (c, k) => c.clone().multiplyScalar(k);
  return {
    sky: { value: scaled(hemi.color, hemi.intensity) },
    ground: { value: scaled(hemi.groundColor, hemi.intensity) },
    up: { value: hemi.position.clone().normalize() },
    sunColor: { value: scaled(sun.color, sun.intensity) },
    sunDir: { value: sun.position.clone().sub(sun.target.position).normalize() },
  };
}

// Lambert light (three.js's formula for these two lights) worked out per vertex, each vertex
// placed by its member's pose (two texels: position, then the quaternion x y z w). The faces are
// flat (a vertex carries its face's normal) and a hemisphere and a sun light by the normal only,
// so this draws what MeshLambertMaterial draws, in a shader short enough to hold `FACING`.
function posedMaterial({ color, opacity = 1, vertexColors = false, facing = false, hexagon = false }, poses) {
  return new THREE.ShaderMaterial({
    uniforms: {
      poses: { value: poses },
      tint: { value: new THREE.Color(color) },
      opacity: { value: opacity },
      ...lightUniforms(),
    },
    defines: hexagon ? { HEXAGON: '' } : facing ? { FACING: '' } : {},
    // Mirrored into an octant with one or three axes flipped, a hexagon is wound the other way;
    // only the faces towards the eye are drawn, so there is nothing to cull.
    side: hexagon ? THREE.DoubleSide : THREE.FrontSide,
    vertexColors,
    transparent: opacity < 1,
    depthWrite: opacity >= 1,
    vertexShader: `attribute float body;
#ifdef FACING
attribute float axis;
#endif
uniform highp sampler2D poses;
uniform vec3 tint, sky, ground, up, sunColor, sunDir;
#ifdef HEXAGON
flat varying vec3 lit;
#else
varying vec3 lit;
#endif
vec3 turn(vec4 q, vec3 v) { return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v); }
vec4 poseTexel(int i) { return texelFetch(poses, ivec2(i % ${POSE_WIDTH}, i / ${POSE_WIDTH}), 0); }
void main() {
  vec4 at = poseTexel(int(body) * 2);
  vec4 q = poseTexel(int(body) * 2 + 1);
  vec3 local = position;
  vec3 nl = normal;
#ifdef FACING
  vec3 eye = turn(vec4(-q.xyz, q.w), cameraPosition - at.xyz);
  // Half a turn about the next axis takes the + face onto the - face, still wound outwards.
  if (axis < 0.5) { if (eye.x < 0.0) { local.xz = -local.xz; nl.xz = -nl.xz; } }
  else if (axis < 1.5) { if (eye.y < 0.0) { local.xy = -local.xy; nl.xy = -nl.xy; } }
  else if (eye.z < 0.0) { local.yz = -local.yz; nl.yz = -nl.yz; }
#endif
#ifdef HEXAGON
  vec3 eye = turn(vec4(-q.xyz, q.w), cameraPosition - at.xyz);
  vec3 side = vec3(eye.x < 0.0 ? -1.0 : 1.0, eye.y < 0.0 ? -1.0 : 1.0, eye.z < 0.0 ? -1.0 : 1.0);
  local *= side;
  nl *= side;
#endif
  vec3 n = normalize(turn(q, nl));
  vec3 base = tint;
#ifdef USE_COLOR
  base *= color;
#endif
  vec3 irradiance = mix(ground, sky, 0.5 * dot(n, up) + 0.5) + max(dot(n, sunDir), 0.0) * sunColor;
  lit = base * irradiance * 0.3183098861837907;
  gl_Position = projectionMatrix * modelViewMatrix * vec4(turn(q, local) + at.xyz, 1.0);
}`,
    fragmentShader: `uniform float opacity;
#ifdef HEXAGON
flat varying vec3 lit;
#else
varying vec3 lit;
#endif
void main() {
  gl_FragColor = vec4(lit, opacity);
#include <tonemapping_fragment>
#include <colorspace_fragment>
}`,
  });
}

async function loadMeshes() {
  loadingMeshes = true;
  try {
    const m = await api('/api/meshes');
    for (const g of groups) {
      scene.remove(g.draw);
      g.draw.geometry.dispose();
      g.draw.material.dispose();
      if (g.dots) {
        scene.remove(g.dots);
        g.dots.geometry.dispose();
        g.dots.material.dispose();
      }
      g.poses.dispose();
      g.object.dispose();
    }
    const geometries = m.meshes.map(flatGeometry);
    const byKey = new Map();
    groupOf = m.actors.map((a) => {
      const key = `${a.mesh}/${a.fixed}`;
      if (!byKey.has(key)) byKey.set(key, { mesh: a.mesh, fixed: a.fixed, members: [] });
      const g = byKey.get(key);
      g.members.push(a);
      return [g, g.members.length - 1];
    });
    groups = [...byKey.values()];
    for (const g of groups) {
      const rows = Math.ceil((g.members.length * 2) / POSE_WIDTH);
      g.poses = new THREE.DataTexture(new Float32Array(POSE_WIDTH * rows * 4), POSE_WIDTH, rows, THREE.RGBAFormat, THREE.FloatType);
      g.poses.needsUpdate = true;
      const box = boxHalfExtents(m.meshes[g.mesh]);
      const facing = box !== null;
      // Translucent (fixed) boxes keep the three faces drawn one-sided: with depth writes off, a
      // face drawn from behind would show through.
      const hexagon = facing && !g.fixed;
      const material = g.fixed
        ? posedMaterial({ color: 0xa0a0a8, opacity: 0.35, facing, hexagon }, g.poses)
        : posedMaterial({ color: 0xffffff, vertexColors: true, facing, hexagon }, g.poses);
      const drawn = hexagon ? hexagonBoxGeometry(box) : facing ? facingBoxGeometry(box) : geometries[g.mesh];
      g.draw = new THREE.Mesh(mergedGeometry(drawn, g.members, !g.fixed), material);
      g.draw.frustumCulled = false;
      scene.add(g.draw);
      if (hexagon && pointsAllowed()) {
        g.dots = pointsOf(g, box);
        scene.add(g.dots);
      }
      g.object = new THREE.InstancedMesh(geometries[g.mesh], material, g.members.length);
      g.object.frustumCulled = false;
    }
    setJoints(m.joints || []);
    version = m.version;
  } finally {
    loadingMeshes = false;
  }
}

const m4 = new THREE.Matrix4();
const pos = new THREE.Vector3();
const quat = new THREE.Quaternion();
const one = new THREE.Vector3(1, 1, 1);

function applyFrame(f) {
  const n = Math.min(groupOf.length, f.length / 7);
  for (let i = 0; i < n; i++) {
    const [g, k] = groupOf[i];
    const d = g.poses.image.data;
    d[8 * k] = f[7 * i];
    d[8 * k + 1] = f[7 * i + 1];
    d[8 * k + 2] = f[7 * i + 2];
    d[8 * k + 4] = f[7 * i + 3];
    d[8 * k + 5] = f[7 * i + 4];
    d[8 * k + 6] = f[7 * i + 5];
    d[8 * k + 7] = f[7 * i + 6];
  }
  for (const g of groups) g.poses.needsUpdate = true;
  placeJoints(f);
  dirty = true;
}

// The pick meshes' instances where the bodies are in `f` (done on a click, not every frame).
function placePickMeshes(f) {
  const n = Math.min(groupOf.length, f.length / 7);
  for (let i = 0; i < n; i++) {
    const [g, k] = groupOf[i];
    pos.set(f[7 * i], f[7 * i + 1], f[7 * i + 2]);
    quat.set(f[7 * i + 3], f[7 * i + 4], f[7 * i + 5], f[7 * i + 6]);
    m4.compose(pos, quat, one);
    g.object.setMatrixAt(k, m4);
  }
}

function setJoints(list) {
  jointDefs = list;
  const positions = new Float32Array(list.length * SEGMENTS_PER_JOINT * 6);
  jointLines.geometry.dispose();
  jointLines.geometry = new THREE.BufferGeometry();
  jointLines.geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3).setUsage(THREE.DynamicDrawUsage));
  $('joint-count').textContent = String(list.length);
  $('joint-count').dataset.drawn = '0';
  // Shown by default where there are joints; the checkbox keeps the user's choice after.
  const box = $('show-joints');
  // The attribute too, so a dumped page shows it.
  if (!box.dataset.touched) box.defaultChecked = box.checked = list.length > 0;
}

// A point given in actor i's body frame (`p`), in world coordinates from frame `f`; the world's
// own frame for the world (i null).
const bodyQuat = new THREE.Quaternion();
function toWorld(f, i, p, out) {
  out.set(p[0], p[1], p[2]);
  if (i === null || i === undefined || 7 * i + 6 >= f.length) return out;
  bodyQuat.set(f[7 * i + 3], f[7 * i + 4], f[7 * i + 5], f[7 * i + 6]);
  out.applyQuaternion(bodyQuat);
  out.x += f[7 * i]; out.y += f[7 * i + 1]; out.z += f[7 * i + 2];
  return out;
}

const onA = new THREE.Vector3();
const onB = new THREE.Vector3();
function placeJoints(f) {
  const show = $('show-joints').checked && jointDefs.length > 0;
  jointLines.visible = show;
  dirty = true;
  $('joint-count').dataset.drawn = show ? String(jointDefs.length) : '0';
  if (!show) return;
  // Crosses a fixed size on screen: a share of the camera's distance to what it looks at.
  const r = 0.012 * camera.position.distanceTo(controls ? controls.target : new THREE.Vector3());
  const attr = jointLines.geometry.getAttribute('position');
  const a = attr.array;
  let k = 0;
  const put = (p, dx, dy, dz) => { a[k++] = p.x + dx; a[k++] = p.y + dy; a[k++] = p.z + dz; };
  for (const j of jointDefs) {
    toWorld(f, j.a, j.anchor_a, onA);
    toWorld(f, j.b, j.anchor_b, onB);
    put(onA, 0, 0, 0);
    put(onB, 0, 0, 0);
    for (const p of [onA, onB]) {
      put(p, -r, 0, 0); put(p, r, 0, 0);
      put(p, 0, -r, 0); put(p, 0, r, 0);
      put(p, 0, 0, -r); put(p, 0, 0, r);
    }
  }
  attr.needsUpdate = true;
}

let contactsInFlight = false;
async function fetchContacts() {
  const box = $('show-contacts');
  if (!box.checked) {
    contactLines.visible = false;
    box.dataset.drawn = '0';
    dirty = true;
    return;
  }
  if (contactsInFlight) return;
  contactsInFlight = true;
  try {
    const f = new Float32Array(await (await fetch('/api/contacts')).arrayBuffer());
    const n = f.length / 6;
    const r = 0.008 * camera.position.distanceTo(controls ? controls.target : new THREE.Vector3());
    const a = new Float32Array(n * 4 * 6);
    let k = 0;
    const put = (x, y, z) => { a[k++] = x; a[k++] = y; a[k++] = z; };
    for (let i = 0; i < n; i++) {
      const [x, y, z, nx, ny, nz] = f.subarray(6 * i, 6 * i + 6);
      put(x, y, z); put(x + 6 * r * nx, y + 6 * r * ny, z + 6 * r * nz);
      put(x - r, y, z); put(x + r, y, z);
      put(x, y - r, z); put(x, y + r, z);
      put(x, y, z - r); put(x, y, z + r);
    }
    contactLines.geometry.dispose();
    contactLines.geometry = new THREE.BufferGeometry();
    contactLines.geometry.setAttribute('position', new THREE.BufferAttribute(a, 3));
    contactLines.visible = box.checked;
    box.dataset.drawn = box.checked ? String(n) : '0';
    dirty = true;
  } finally {
    contactsInFlight = false;
  }
}

// Frames the scene: the free bodies (all bodies when none is free) from a three-quarter view.
function fitCamera(f) {
  const box = new THREE.Box3();
  const anyFree = groupOf.some(([g]) => !g.fixed);
  for (let i = 0; i < groupOf.length && 7 * i < f.length; i++) {
    if (anyFree && groupOf[i][0].fixed) continue;
    box.expandByPoint(new THREE.Vector3(f[7 * i], f[7 * i + 1], f[7 * i + 2]));
  }
  if (box.isEmpty()) return;
  const centre = box.getCenter(new THREE.Vector3());
  const size = Math.max(box.getSize(new THREE.Vector3()).length(), 6);
  controls?.target.copy(centre);
  camera.position.copy(centre).add(new THREE.Vector3(0.6, 0.45, 0.8).normalize().multiplyScalar(size * 1.6));
  camera.near = size / 500;
  camera.far = size * 50;
  camera.updateProjectionMatrix();
  scene.remove(grid);
  const extent = Math.max(10, Math.ceil(size * 2));
  grid = new THREE.GridHelper(extent, Math.min(extent, 100), 0x8899aa, 0x4a5260);
  scene.add(grid);
  controls?.update();
}

// Per second: new server states drawn (`data-fps`) and frames drawn (`data-drawn-fps`: also
// for the camera moving), shown top left of the viewport; with ?log=1 also on the console, for
// a headless browser to report.
let fpsFrames = 0;
let drawnFrames = 0;
// Where the page's own second goes, for ?log=1: animation frames, `/api/frame` requests and their
// round trips, placing the poses, and the render call (what it hands the GPU process, not the
// drawing itself, which runs there) [ms].
const spent = { animation: 0, requests: 0, request: 0, place: 0, render: 0 };
let fpsSince = performance.now();
function countFrame() {
  fpsFrames++;
}
function countSecond() {
  const now = performance.now();
  if (now - fpsSince >= 1000) {
    const fps = (fpsFrames * 1000) / (now - fpsSince);
    const drawn = (drawnFrames * 1000) / (now - fpsSince);
    $('hud-rate').textContent = `${fps.toFixed(0)} frames/s (${drawn.toFixed(0)} drawn)`;
    $('hud').dataset.fps = fps.toFixed(1);
    $('hud').dataset.drawnFps = drawn.toFixed(1);
    $('hud').dataset.points = String(pointsDrawn());
    const step = Number($('time').dataset.step);
    const steps = adapt.step === null ? 0 : ((step - adapt.step) * 1000) / (now - fpsSince);
    adapt.step = step;
    if (params.get('log') === '1') {
      const per = (ms, n) => (ms / Math.max(n, 1)).toFixed(2);
      console.log(
        `studio-fps frames=${fps.toFixed(1)} drawn=${drawn.toFixed(1)} bodies=${groupOf.length} step=${$('time').dataset.step}` +
          ` animation=${spent.animation} request_ms=${per(spent.request, spent.requests)} place_ms=${per(spent.place, fpsFrames)}` +
          ` render_ms=${per(spent.render, drawnFrames)} scale=${adapt.scale} pixel_ratio=${renderer ? renderer.getPixelRatio() : 0}` +
          ` points=${pointsDrawn()}`,
      );
    }
    adaptScale(drawn, (spent.animation * 1000) / (now - fpsSince), steps, running);
    fpsFrames = 0;
    drawnFrames = 0;
    for (const k of Object.keys(spent)) spent[k] = 0;
    fpsSince = now;
  }
}

let frameInFlight = false;
let running = false;
let appliedKey = '';
async function fetchFrame() {
  if (frameInFlight || loadingMeshes) return;
  frameInFlight = true;
  let fresh = false;
  try {
    const asked = performance.now();
    const r = await fetch('/api/frame');
    const buf = await r.arrayBuffer();
    spent.request += performance.now() - asked;
    spent.requests++;
    const v = Number(r.headers.get('X-Version'));
    if (v !== version) {
      await loadMeshes();
      await pollState();
      if (selected) select(selected).catch(() => {});
    }
    const step = r.headers.get('X-Step');
    running = r.headers.get('X-Running') === 'true';
    // The same step of the same scene version: the same poses, nothing to draw again.
    const key = `${version}/${step}`;
    if (key === appliedKey && lastFrame) return;
    appliedKey = key;
    fresh = true;
    const f = new Float32Array(buf);
    lastFrame = f;
    const placing = performance.now();
    applyFrame(f);
    spent.place += performance.now() - placing;
    if ($('show-contacts').checked) fetchContacts().catch(() => {});
    if (fitted !== sceneName + '/' + version && (fitted === '' || !fitted.startsWith(sceneName + '/'))) {
      fitCamera(f);
    }
    fitted = sceneName + '/' + version;
    const t = Number(r.headers.get('X-Time'));
    $('time').textContent = `${t.toFixed(3)} s (step ${step})`;
    $('time').dataset.time = String(t);
    $('time').dataset.step = step;
    $('actor-count').textContent = String(groupOf.length);
    countFrame();
  } catch (e) {
    showError(`lost the studio: ${e.message}`);
  } finally {
    frameInFlight = false;
  }
  // While the scene plays, ask again at once rather than at the next animation frame.
  if (fresh && running) fetchFrame();
}

function resize() {
  const w = canvas.clientWidth || 640;
  const h = canvas.clientHeight || 480;
  if (renderer && (canvas.width !== Math.floor(w * renderer.getPixelRatio()) || canvas.height !== Math.floor(h * renderer.getPixelRatio()))) {
    renderer.setSize(w, h, false);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    dirty = true;
  }
}

function animate() {
  spent.animation++;
  fetchFrame();
  resize();
  controls?.update();
  if (renderer && dirty) {
    const rendering = performance.now();
    placeDetail();
    renderer.render(scene, camera);
    spent.render += performance.now() - rendering;
    dirty = false;
    drawnFrames++;
  }
  countSecond();
  requestAnimationFrame(animate);
}

// ---- state, schedule and timings ---------------------------------------------------------

let schedule = [];
let offered = [];

function renderSystems() {
  const box = $('systems');
  const key = offered.join(',') + '|' + schedule.join(',');
  if (box.dataset.key === key) return;
  box.dataset.key = key;
  box.replaceChildren();
  for (const name of offered) {
    const label = document.createElement('label');
    label.className = 'sys';
    const input = document.createElement('input');
    input.type = 'checkbox';
    // The attribute too, so a saved or dumped page shows the schedule.
    input.defaultChecked = input.checked = schedule.includes(name);
    input.dataset.testid = `system-${name}`;
    input.setAttribute('data-testid', `system-${name}`);
    input.addEventListener('change', () => postSchedule().catch(() => {}));
    label.append(input, ` ${name}`);
    box.append(label);
  }
}

function postSchedule() {
  const ticked = [...$('systems').querySelectorAll('input')]
    .filter((i) => i.checked)
    .map((i) => i.getAttribute('data-testid').slice('system-'.length));
  return api('/api/schedule', { systems: ticked }).then(pollState);
}

function renderTimings(s) {
  const rows = s.schedule.map((n) => [n, s.systems_ms[n] ?? 0]);
  const max = Math.max(1e-9, ...rows.map((r) => r[1]));
  const width = Math.max(...rows.map((r) => r[0].length), 4);
  const lines = rows.map(([n, ms]) => {
    const bar = '█'.repeat(Math.round((ms / max) * 16));
    return `${n.padEnd(width)} ${ms.toFixed(3).padStart(7)} ${bar}`;
  });
  lines.push(`${'step'.padEnd(width)} ${s.step_ms.toFixed(3).padStart(7)}`);
  if (s.running) lines.push(`${s.steps_per_second.toFixed(0)} steps/s`);
  $('timings').textContent = lines.join('\n');
}

// The last minute of step times, one stacked bar per poll (a colour per system).
const history = [];
function systemHue(name) {
  let h = 0;
  for (const ch of name) h = (h * 31 + ch.charCodeAt(0)) % 360;
  return h;
}
function renderChart(s) {
  if (s.running || history.length === 0) history.push({ order: s.schedule, ms: s.systems_ms });
  if (history.length > 120) history.shift();
  const c = $('chart');
  const g = c.getContext('2d');
  if (!g) return;
  g.clearRect(0, 0, c.width, c.height);
  const totals = history.map((h) => h.order.reduce((a, n) => a + (h.ms[n] ?? 0), 0));
  const max = Math.max(1e-6, ...totals);
  const w = c.width / 120;
  history.forEach((h, i) => {
    let y = c.height;
    for (const n of h.order) {
      const px = ((h.ms[n] ?? 0) / max) * (c.height - 12);
      g.fillStyle = `hsl(${systemHue(n)}, 60%, 60%)`;
      g.fillRect(i * w, y - px, Math.max(w - 0.5, 1), px);
      y -= px;
    }
  });
  g.fillStyle = '#aab';
  g.font = '10px sans-serif';
  g.fillText(`max ${max.toFixed(2)} ms/step`, 2, 10);
}

async function pollState() {
  const s = await fetch('/api/state?actors=0').then((r) => r.json());
  sceneName = s.scene;
  $('scene-name').textContent = s.scene;
  $('contacts').textContent = String(s.contacts);
  $('energy').textContent = s.energy.toPrecision(4);
  schedule = s.schedule;
  offered = s.systems;
  renderSystems();
  renderTimings(s);
  renderChart(s);
  const speed = $('speed');
  if (document.activeElement !== speed && [...speed.options].some((o) => Number(o.value) === s.speed)) {
    speed.value = [...speed.options].find((o) => Number(o.value) === s.speed).value;
  }
  $('play').disabled = s.running;
  $('pause').disabled = !s.running;
  if (s.error) showError(s.error);
  return s;
}

// ---- controls -----------------------------------------------------------------------------

const control = (body) => api('/api/control', body).then(pollState);
$('play').onclick = () => control({ action: 'play' }).catch(() => {});
$('pause').onclick = () => control({ action: 'pause' }).catch(() => {});
$('step').onclick = () => control({ action: 'step', steps: 1 }).catch(() => {});
$('reset').onclick = () => control({ action: 'reset' }).catch(() => {});
$('show-joints').onchange = () => {
  $('show-joints').dataset.touched = '1';
  if (lastFrame) placeJoints(lastFrame);
};
$('show-contacts').onchange = () => fetchContacts().catch(() => {});
// Unticked: every pixel drawn (scale 1) and left there.
$('adaptive-scale').onchange = (e) => {
  adapt.on = e.target.checked;
  if (!adapt.on) setScale(1);
};
$('speed').onchange = (e) => control({ action: 'speed', speed: Number(e.target.value) }).catch(() => {});

async function loadSceneFile(file) {
  fitted = '';
  await api('/api/scene', await file.text(), false).then(pollState).catch(() => {});
}

async function loadMeshFile(file) {
  const name = file.name.replace(/[^A-Za-z0-9._-]/g, '_').replace(/^\.+/, '') || 'mesh.obj';
  try {
    await api(`/api/mesh?name=${encodeURIComponent(name)}`, await file.text(), false);
    await addActor(`Obj(path: "${name}", hull: true)`);
  } catch (_) { /* shown in the error element */ }
}

$('scene-file').onchange = async (e) => {
  const file = e.target.files[0];
  if (file) await loadSceneFile(file);
  e.target.value = '';
};

$('mesh-file').onchange = async (e) => {
  const file = e.target.files[0];
  if (file) await loadMeshFile(file);
  e.target.value = '';
};

// A .ron scene or an .obj mesh dropped anywhere on the page loads as from the file inputs.
document.addEventListener('dragover', (e) => e.preventDefault());
document.addEventListener('drop', async (e) => {
  e.preventDefault();
  for (const file of e.dataTransfer.files) {
    if (/\.obj$/i.test(file.name)) await loadMeshFile(file);
    else await loadSceneFile(file);
  }
});

// Where new bodies drop: the clicked ground point, else above the centre of the bodies.
let placeAt = null;
function dropPoint() {
  const f = lastFrame;
  let top = 0;
  const c = new THREE.Vector3();
  let n = 0;
  for (let i = 0; f && i < groupOf.length && 7 * i < f.length; i++) {
    top = Math.max(top, f[7 * i + 1]);
    if (!groupOf[i][0].fixed) {
      c.x += f[7 * i];
      c.z += f[7 * i + 2];
      n++;
    }
  }
  if (n) c.divideScalar(n);
  if (placeAt) c.set(placeAt.x, 0, placeAt.z);
  return [c.x, top + 2.0, c.z];
}

let added = 0;
function addActor(shape) {
  const [x, y, z] = dropPoint();
  // Jitter a little so repeated adds do not stack exactly.
  const j = () => ((added * 0.37) % 0.3) - 0.15;
  added++;
  const text = `Actor(shape: ${shape}, density: 500.0, position: (${(x + j()).toFixed(3)}, ${y.toFixed(3)}, ${(z - j()).toFixed(3)}), friction: 0.5)`;
  return api('/api/actors', text, false).then(pollState);
}
const shapes = {
  'add-box': 'Box(size: (1.0, 1.0, 1.0))',
  'add-sphere': 'Icosphere(radius: 0.5, subdivisions: 2)',
  'add-cylinder': 'Cylinder(radius: 0.5, height: 1.0, segments: 24)',
};
for (const [id, shape] of Object.entries(shapes)) $(id).onclick = () => addActor(shape).catch(() => {});

// ---- selecting and editing an actor ------------------------------------------------------

let selected = null;
const fields = ['mass', 'restitution', 'friction', 'velocity'];

function setField(id, value, enabled) {
  const input = $(id);
  // The attribute too, so a dumped page shows the value.
  input.defaultValue = input.value = value;
  input.disabled = !enabled;
}

// Selects actor `name` (null: none) and fills the fields from /api/state. The name is shown
// with its fields, once they have arrived: never beside the last actor's.
async function select(name) {
  const a = name && (await fetch('/api/state').then((r) => r.json())).actors.find((x) => x.name === name);
  // Gone with a new scene: nothing is selected.
  if (name && !a) return select(null);
  selected = name;
  $('actor-name').textContent = name ?? 'none';
  $('actor-apply').disabled = !name;
  if (!name) {
    for (const f of fields) setField(`actor-${f}`, '', false);
    return null;
  }
  setField('actor-mass', String(a.mass), !a.fixed);
  setField('actor-restitution', String(a.restitution), true);
  setField('actor-friction', String(a.friction), true);
  setField('actor-velocity', a.velocity.map((v) => Number(v.toPrecision(6))).join(' '), !a.fixed);
  return a;
}

// The edit in field `f`'s input as the API wants it (undefined when empty).
function fieldValue(f) {
  const text = $(`actor-${f}`).value.trim();
  if (text === '') return undefined;
  if (f === 'velocity') return text.split(/[\s,;]+/).filter(Boolean).map(Number);
  return Number(text);
}

// Posts the fields named in `which` (default: every enabled one) for the selected actor.
async function applyEdit(which) {
  if (!selected) return;
  const body = { name: selected };
  for (const f of which || fields) {
    if (!which && $(`actor-${f}`).disabled) continue;
    const v = fieldValue(f);
    if (v !== undefined) body[f] = v;
  }
  await api('/api/actor', body);
  await select(selected);
  await pollState();
}
$('actor-apply').onclick = () => applyEdit().catch(() => {});

async function saveScene() {
  const r = await fetch('/api/scene');
  const text = await r.text();
  if (!r.ok) {
    let message = `${r.status} ${r.statusText}`;
    try { message = JSON.parse(text).error || message; } catch (_) { /* not JSON */ }
    showError(message);
    throw new Error(message);
  }
  showError('');
  return text;
}
$('save').onclick = async () => {
  try {
    const text = await saveScene();
    const a = document.createElement('a');
    a.href = URL.createObjectURL(new Blob([text], { type: 'application/octet-stream' }));
    a.download = 'scene.ron';
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  } catch (_) { /* shown in the error element */ }
};

// The actor under a viewport point (free bodies before fixed ones), or null.
function pickActor(ray) {
  if (lastFrame) placePickMeshes(lastFrame);
  const objects = groups.map((g) => g.object);
  // Instances move every frame: refresh the bounds the raycast first tests against.
  for (const o of objects) o.computeBoundingSphere();
  const hits = ray.intersectObjects(objects, false).filter((h) => h.instanceId !== undefined);
  const member = (h) => groups.find((g) => g.object === h.object)?.members[h.instanceId];
  const free = hits.find((h) => !groups.find((g) => g.object === h.object)?.fixed);
  const hit = free || hits[0];
  return hit ? member(hit) : null;
}

// A click (not a drag) selects the body under it; on a fixed body or the ground plane it also
// picks where new bodies drop.
let down = null;
canvas.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
canvas.addEventListener('pointerup', (e) => {
  if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4) return;
  const rect = canvas.getBoundingClientRect();
  clickAt((e.clientX - rect.left) / rect.width, (e.clientY - rect.top) / rect.height).catch(() => {});
});

// A click at (fx, fy), fractions of the viewport's width and height from its top left.
function clickAt(fx, fy) {
  const ray = new THREE.Raycaster();
  camera.updateMatrixWorld();
  ray.setFromCamera(new THREE.Vector2(fx * 2 - 1, -(fy * 2 - 1)), camera);
  const actor = pickActor(ray);
  const selecting = select(actor ? actor.name : null);
  if (!actor || actor.fixed) {
    const hit = ray.ray.intersectPlane(new THREE.Plane(new THREE.Vector3(0, 1, 0), 0), new THREE.Vector3());
    if (hit) {
      placeAt = hit;
      marker.position.set(hit.x, 0.01, hit.z);
      marker.visible = true;
      dirty = true;
    }
  }
  return selecting;
}

// ---- start ----------------------------------------------------------------------------------

async function start() {
  // The attribute too, so a dumped page shows it.
  $('adaptive-scale').defaultChecked = $('adaptive-scale').checked = adapt.on;
  setScale(adapt.scale);
  await pollState();
  await fetchFrame();
  requestAnimationFrame(animate);
  setInterval(() => pollState().catch(() => {}), 500);
  if (params.get('play') === '1') await control({ action: 'play' }).catch(() => {});
}

start().catch((e) => showError(`cannot start: ${e.message}`));
