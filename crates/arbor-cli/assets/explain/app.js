// The arbor explain page: reads the document of docs/explain-data.md from
// the #arbor-data element and draws the picture, the scene graph, the
// structures in 3D, one ray's traversal and the heatmaps from it.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const $ = (id) => document.getElementById(id);
const data = JSON.parse($('arbor-data').textContent);

// One colour per meaning, used by the 3D view, the lists and the legends.
const COLOR = {
  entered: '#1b9e77', skipped: '#d95f02', tested: '#7570b3', hit: '#e7298a', ray: '#ffffff',
  level: '#8ecae6', done: '#5c6b80', prim: '#c9ccd3', bvol: '#f2c14e', plane: '#8ecae6', cell: '#4f6d8f',
};
// Past this many boxes one level is drawn only in part (and the page says so).
const MAX_BOXES = 20000;
// Past this many nodes the scene graph is drawn only in part.
const MAX_GRAPH_NODES = 400;

const structures = data.structures || [];
const picks = (data.picks && data.picks.rays) || [];
const image = data.image || { width: 0, height: 0 };
const pageNotes = [];
const state = {
  accel: structures.length ? structures[0].accel : null,
  pick: null,
  step: 0,
  depth: 0,
  imageMode: 'picture',
};

window.addEventListener('error', (e) => showError(e.message));
function showError(message) {
  const el = $('page-error');
  el.hidden = false;
  el.textContent = 'The page met an error: ' + message;
}

const structureByAccel = (accel) => structures.find((s) => s.accel === accel);
const fmt = (x) => (Math.abs(x) >= 1000 ? String(Math.round(x * 1000) / 1000) : String(parseFloat(x.toPrecision(4))));
const fmtVec = (v) => '(' + v.map(fmt).join(', ') + ')';
function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') node.className = v;
    else if (k === 'text') node.textContent = v;
    else node.setAttribute(k, v);
  }
  for (const c of children) node.append(c);
  return node;
}
function swatch(color, text, line = false) {
  const s = el('span', { class: line ? 'swatch line' : 'swatch' });
  s.style.background = color;
  return el('span', {}, s, text);
}

// ---------------------------------------------------------------- header
$('input-name').textContent = data.input || '';
{
  const p = data.primitives || {};
  const parts = [];
  if (image.width) parts.push(`${image.width}×${image.height} pixels`);
  if (p.total !== undefined) parts.push(`${p.total} primitives`);
  if (structures.length) parts.push('structures: ' + structures.map((s) => s.accel).join(', '));
  $('summary').textContent = parts.length ? '— ' + parts.join(' · ') : '';
}

// ---------------------------------------------------------------- picture and heatmaps
const picture = $('picture');
picture.width = image.width;
picture.height = image.height;
const pictureCtx = picture.getContext('2d');
const pictureImage = new Image();
const heatmapCache = new Map();

// Counts per pixel, little-endian elements of the type the data names
// (u8, u16 or u32: the narrowest that holds the largest count).
function decodeCounts(b64, element) {
  const bin = atob(b64);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  if (element === 'u8') return bytes;
  if (element === 'u16') return new Uint16Array(bytes.buffer, 0, Math.floor(bytes.length / 2));
  return new Uint32Array(bytes.buffer, 0, Math.floor(bytes.length / 4));
}

// A perceptual ramp (dark violet to yellow), sampled at t in [0, 1].
const RAMP = [[13, 8, 135], [84, 2, 163], [139, 10, 165], [185, 50, 137], [219, 92, 104], [244, 136, 73], [254, 188, 43], [240, 249, 33]];
function ramp(t) {
  const x = Math.min(Math.max(t, 0), 1) * (RAMP.length - 1);
  const i = Math.min(Math.floor(x), RAMP.length - 2);
  const f = x - i;
  return RAMP[i].map((c, k) => Math.round(c + (RAMP[i + 1][k] - c) * f));
}

function heatmapImage(accel, measure) {
  const key = accel + '/' + measure;
  if (heatmapCache.has(key)) return heatmapCache.get(key);
  const s = structureByAccel(accel);
  const h = s && s.heatmap;
  if (!h) return null;
  const values = decodeCounts(measure === 'nodes' ? h.nodes_base64 : h.tests_base64, h.element);
  const max = (measure === 'nodes' ? h.max_nodes : h.max_tests) || 1;
  const img = new ImageData(image.width, image.height);
  for (let i = 0; i < values.length && i < image.width * image.height; i++) {
    const [r, g, b] = ramp(values[i] / max);
    img.data[4 * i] = r; img.data[4 * i + 1] = g; img.data[4 * i + 2] = b; img.data[4 * i + 3] = 255;
  }
  const result = { img, max };
  heatmapCache.set(key, result);
  return result;
}

function drawPicture() {
  const legend = $('heatmap-legend');
  if (state.imageMode === 'heatmap') {
    const accel = $('heatmap-accel').value;
    const measure = $('heatmap-measure').value;
    const heat = heatmapImage(accel, measure);
    if (heat) {
      pictureCtx.putImageData(heat.img, 0, 0);
      legend.hidden = false;
      $('heatmap-max').textContent = String(heat.max);
      $('heatmap-caption').textContent = `${measure === 'nodes' ? 'nodes visited' : 'primitives tested'} per pixel, ${accel}`;
      picture.dataset.shows = 'heatmap:' + accel + ':' + measure;
      return;
    }
  }
  legend.hidden = true;
  if (pictureImage.complete && pictureImage.naturalWidth) pictureCtx.drawImage(pictureImage, 0, 0);
  picture.dataset.shows = 'picture';
}

{
  const ctx = $('heatmap-ramp').getContext('2d');
  for (let x = 0; x < 256; x++) {
    const [r, g, b] = ramp(x / 255);
    ctx.fillStyle = `rgb(${r},${g},${b})`;
    ctx.fillRect(x, 0, 1, 12);
  }
  for (const s of structures) {
    if (s.heatmap) $('heatmap-accel').append(el('option', { value: s.accel, text: s.accel }));
  }
  if (!$('heatmap-accel').options.length) {
    $('mode-heatmap').disabled = true;
    pageNotes.push('no heatmap data: the heatmap view is off');
  }
  for (const input of document.querySelectorAll('input[name="image-mode"]')) {
    input.addEventListener('change', () => { state.imageMode = input.value; drawPicture(); });
  }
  for (const id of ['heatmap-accel', 'heatmap-measure']) {
    $(id).addEventListener('change', () => {
      state.imageMode = 'heatmap';
      $('mode-heatmap').checked = true;
      drawPicture();
    });
  }
  pictureImage.onload = drawPicture;
  if (data.image && data.image.png_base64) pictureImage.src = 'data:image/png;base64,' + data.image.png_base64;
}

// ---------------------------------------------------------------- pixel picker
function nearestPick(x, y) {
  let best = null;
  let bestD = Infinity;
  for (const r of picks) {
    const d = (r.pixel[0] - x) ** 2 + (r.pixel[1] - y) ** 2;
    if (d < bestD) { bestD = d; best = r; }
  }
  return best;
}

function pickPixel(x, y) {
  x = Math.min(Math.max(Math.round(x), 0), Math.max(image.width - 1, 0));
  y = Math.min(Math.max(Math.round(y), 0), Math.max(image.height - 1, 0));
  const ray = nearestPick(x, y);
  const status = $('picked-pixel');
  if (!ray) {
    status.textContent = 'This page holds no traced rays.';
    return;
  }
  state.pick = ray;
  // levels.js follows a pick through the nested levels.
  document.dispatchEvent(new CustomEvent('arbor-pick', { detail: ray }));
  const [sx, sy] = ray.pixel;
  status.dataset.x = sx;
  status.dataset.y = sy;
  status.dataset.askedX = x;
  status.dataset.askedY = y;
  const stride = (data.picks && data.picks.stride) || 1;
  const snapped = sx !== x || sy !== y
    ? `You chose (${x}, ${y}); it snapped to pixel (${sx}, ${sy}), the nearest one traced: the page keeps one ray every ${stride} pixels across and down.`
    : `Pixel (${sx}, ${sy}).` + (stride > 1 ? ` The page keeps one ray every ${stride} pixels across and down.` : '');
  status.textContent = snapped + ` Its camera ray starts at ${fmtVec(ray.ray.origin)} going ${fmtVec(ray.ray.direction)}.`;
  $('pick-x').value = x;
  $('pick-y').value = y;
  const marker = $('pick-marker');
  marker.hidden = false;
  marker.style.left = ((sx + 0.5) / image.width) * 100 + '%';
  marker.style.top = ((sy + 0.5) / image.height) * 100 + '%';
  selectTraversal(state.accel, 'end');
}

$('pick-x').max = Math.max(image.width - 1, 0);
$('pick-y').max = Math.max(image.height - 1, 0);
picture.addEventListener('click', (e) => {
  const rect = picture.getBoundingClientRect();
  pickPixel(Math.floor(((e.clientX - rect.left) / rect.width) * image.width),
    Math.floor(((e.clientY - rect.top) / rect.height) * image.height));
});
$('pick-form').addEventListener('submit', (e) => {
  e.preventDefault();
  pickPixel(Number($('pick-x').value), Number($('pick-y').value));
});

// ---------------------------------------------------------------- traversal steps
const rayOf = (accel) => state.pick && state.pick.structures.find((s) => s.accel === accel);

// The first top-level primitive number of a placement of shared geometry
// (world primitives come first, then one number per placement).
const placementBase = (() => {
  const p = data.primitives || {};
  const shared = (data.scene_graph && data.scene_graph.flattening && data.scene_graph.flattening.shared) || [];
  return (p.total || 0) - shared.reduce((sum, g) => sum + (g.placements || 0), 0);
})();

// The steps of one ray through one structure: its visits, and its primitive
// tests placed after the leaf visit that made them when that can be told
// (every entered leaf tests exactly its primitives, adding up to the tests
// recorded); otherwise all tests follow the visits, and the page says so.
// A placement's own traversal (instanced scenes) follows the top-level test
// that entered it.
function stepsOf(accel) {
  const r = rayOf(accel);
  if (!r) return { steps: [], interleaved: false };
  const top = topLevelSteps(r, structureByAccel(accel));
  const entries = r.placements || [];
  if (!entries.length) return top;
  const steps = [];
  let k = 0;
  for (const step of top.steps) {
    steps.push(step);
    if (step.kind === 'test' && k < entries.length && step.prim - placementBase === entries[k].placement) {
      steps.push(...placementSteps(entries[k], k));
      k++;
    }
  }
  const inOrder = k === entries.length;
  for (; k < entries.length; k++) steps.push(...placementSteps(entries[k], k));
  return { steps, interleaved: top.interleaved && inOrder, placements: true };
}

function placementSteps(entry, k) {
  const at = { placement: entry.placement, entry: k };
  return [{ kind: 'enter', ...at }].concat(entry.visits.map((v) => ({ kind: 'visit', node: v.node, entered: v.entered, ...at }))
    .concat(entry.tests.map((p) => ({ kind: 'test', prim: p, ...at }))));
}

function topLevelSteps(r, s) {
  const visits = r.visits.map((v, i) => ({ kind: 'visit', index: i, node: v.node, entered: v.entered }));
  const tests = r.tests.map((p, i) => ({ kind: 'test', index: i, prim: p }));
  if (!visits.length || !tests.length) return { steps: visits.concat(tests), interleaved: true };
  const nodes = s && s.nodes;
  if (nodes && nodes.length) {
    const steps = [];
    let next = 0;
    let ok = true;
    for (const v of visits) {
      steps.push(v);
      const n = nodes[v.node];
      if (!n) { ok = false; break; }
      if (v.entered && (!n.children || n.children.length === 0)) {
        const k = n.primitives || 0;
        if (next + k > tests.length) { ok = false; break; }
        for (let j = 0; j < k; j++) steps.push(tests[next++]);
      }
    }
    if (ok && next === tests.length) return { steps, interleaved: true };
  }
  return { steps: visits.concat(tests), interleaved: false };
}

function cellBox(s, cell) {
  const [nx, ny] = s.resolution;
  const ix = cell % nx;
  const iy = Math.floor(cell / nx) % ny;
  const iz = Math.floor(cell / (nx * ny));
  const lo = [s.origin[0] + ix * s.cell_size[0], s.origin[1] + iy * s.cell_size[1], s.origin[2] + iz * s.cell_size[2]];
  return [lo, [lo[0] + s.cell_size[0], lo[1] + s.cell_size[1], lo[2] + s.cell_size[2]]];
}
function visitBox(s, node, placement) {
  if (!s || placement !== undefined) return null;
  if (s.family === 'grid') return s.resolution ? cellBox(s, node) : null;
  const n = s.nodes && s.nodes[node];
  return n ? n.box : null;
}
function nodeName(s, node) {
  if (s && s.family === 'grid' && s.resolution) {
    const [nx, ny] = s.resolution;
    return `cell ${node} (${node % nx}, ${Math.floor(node / nx) % ny}, ${Math.floor(node / (nx * ny))})`;
  }
  return `node ${node}`;
}

let currentSteps = { steps: [], interleaved: false };

function selectTraversal(accel, where) {
  state.accel = accel;
  $('structure').value = accel;
  currentSteps = stepsOf(accel);
  const n = currentSteps.steps.length;
  $('step').max = n;
  state.step = where === 'end' ? n : Math.min(state.step, n);
  fillCounts();
  fillList();
  updateDepthControl();
  showStep(state.step);
}

function fillCounts() {
  const body = $('counts').querySelector('tbody');
  body.replaceChildren();
  if (!state.pick) return;
  const most = Math.max(1, ...state.pick.structures.map((r) => r.counts.nodes + r.counts.tests));
  for (const r of state.pick.structures) {
    const all = r.visits.concat(...(r.placements || []).map((e) => e.visits));
    const entered = all.filter((v) => v.entered).length;
    const work = el('td');
    const nodesBar = el('span', { class: 'bar', title: 'nodes visited' });
    nodesBar.style.width = (60 * r.counts.nodes) / most + 'px';
    const testsBar = el('span', { class: 'bar tests', title: 'primitives tested' });
    testsBar.style.width = (60 * r.counts.tests) / most + 'px';
    work.append(nodesBar, testsBar);
    const row = el('tr', { 'data-accel': r.accel },
      el('td', { text: r.accel }), el('td', { text: String(r.counts.nodes) }), el('td', { text: String(entered) }),
      el('td', { text: String(all.length - entered) }), el('td', { text: String(r.counts.tests) }),
      el('td', { text: r.hit ? `#${r.hit.primitive}, t = ${fmt(r.hit.t)}` : 'none' }), work);
    if (r.accel === state.accel) row.classList.add('current');
    row.addEventListener('click', () => selectTraversal(r.accel, 'end'));
    body.append(row);
  }
}

// The last traversal entry of placement `p` (the one a hit inside it was
// found in).
function lastEntryOf(r, p) {
  let k = -1;
  (r.placements || []).forEach((e, i) => { if (e.placement === p) k = i; });
  return k;
}

function fillList() {
  const body = $('traversal-list').querySelector('tbody');
  body.replaceChildren();
  const s = structureByAccel(state.accel);
  const r = rayOf(state.accel);
  currentSteps.steps.forEach((step, i) => {
    let row;
    const inner = step.placement !== undefined;
    const where = inner ? `placement ${step.placement} · ` : '';
    if (step.kind === 'enter') {
      row = el('tr', {},
        el('td', { text: String(i + 1) }),
        el('td', {}, el('span', { class: 'kind enter', text: 'inside' })),
        el('td', { text: `placement ${step.placement}` }),
        el('td', { text: 'the ray goes into this placement of shared geometry: its own structure, in the geometry\'s own space' }));
    } else if (step.kind === 'visit') {
      const box = visitBox(s, step.node, step.placement);
      row = el('tr', { 'data-node': String(step.node), 'data-entered': String(step.entered) },
        el('td', { text: String(i + 1) }),
        el('td', {}, el('span', { class: 'kind ' + (step.entered ? 'entered' : 'skipped'), text: step.entered ? 'entered' : 'skipped' })),
        el('td', { text: where + (inner ? `node ${step.node}` : nodeName(s, step.node)) }),
        el('td', { text: box ? `box ${fmtVec(box[0])} – ${fmtVec(box[1])}` : inner ? 'in the shared geometry\'s own space' : '' }));
    } else {
      const isHit = r && r.hit && (inner
        ? r.hit.placement === step.placement && r.hit.shared_primitive === step.prim && step.entry === lastEntryOf(r, step.placement)
        : r.hit.primitive === step.prim && r.hit.placement === undefined);
      const enters = !inner && r.placements && r.placements.some((e) => e.placement === step.prim - placementBase);
      row = el('tr', { 'data-prim': String(step.prim) },
        el('td', { text: String(i + 1) }),
        el('td', {}, el('span', { class: 'kind test' + (isHit ? ' hit' : ''), text: 'tested' })),
        el('td', { text: where + (inner ? `its primitive ${step.prim}` : `primitive ${step.prim}`) }),
        el('td', { text: isHit ? 'the closest hit of this ray' : enters ? `placement ${step.prim - placementBase} of shared geometry: the ray goes inside` : '' }));
    }
    if (inner) {
      row.dataset.placement = String(step.placement);
      row.dataset.entry = String(step.entry);
      row.classList.add('inner');
    }
    row.addEventListener('click', () => showStep(i + 1));
    body.append(row);
  });
  const hit = r && r.hit;
  $('hit-summary').textContent = !r ? '' : hit
    ? `Hit: primitive ${hit.primitive}` + (hit.placement !== undefined ? ` (placement ${hit.placement}, its primitive ${hit.shared_primitive})` : '') +
      ` at t = ${fmt(hit.t)} (${r.counts.nodes} nodes visited, ${r.counts.tests} primitives tested).`
    : `No hit (${r.counts.nodes} nodes visited, ${r.counts.tests} primitives tested).`;
  $('hit-summary').dataset.primitive = hit ? hit.primitive : '';
}

function showStep(k) {
  const steps = currentSteps.steps;
  state.step = Math.min(Math.max(k, 0), steps.length);
  $('step').value = state.step;
  $('step-value').textContent = `${state.step} / ${steps.length}`;
  const rows = $('traversal-list').querySelectorAll('tbody tr');
  rows.forEach((row, i) => {
    row.classList.toggle('future', i >= state.step);
    row.classList.toggle('now', i === state.step - 1);
  });
  const now = rows[state.step - 1];
  if (now) now.scrollIntoView({ block: 'nearest' });
  const s = structureByAccel(state.accel);
  const step = steps[state.step - 1];
  const order = (currentSteps.interleaved ? '' : ' (This list gives the visits first and then the tests: the data does not say which visit made each test.)') +
    (currentSteps.placements ? ' Inside a placement of shared geometry its own visits come first, then its tests; its boxes are in the geometry\'s own space and not drawn.' : '');
  let text;
  if (!state.pick) text = 'Pick a pixel to follow its ray.';
  else if (!step) text = `Step 0: the ray of pixel (${state.pick.pixel.join(', ')}) has not met ${state.accel} yet. Press Step to walk it.` + order;
  else if (step.kind === 'enter') {
    text = `Step ${state.step}: the ray goes into placement ${step.placement} of shared geometry, moved into the geometry's own space; its own structure's traversal follows.`;
  } else if (step.placement !== undefined) {
    text = step.kind === 'visit'
      ? `Step ${state.step}: inside placement ${step.placement}, the ray ${step.entered ? 'enters' : 'skips'} node ${step.node} of the shared geometry's own structure (not drawn: it is in the geometry's own space).`
      : `Step ${state.step}: inside placement ${step.placement}, the shared geometry's primitive ${step.prim} is tested.`;
  } else if (step.kind === 'visit') {
    text = step.entered
      ? `Step ${state.step}: the ray overlaps the box of ${nodeName(s, step.node)}, so the traversal goes inside.`
      : `Step ${state.step}: the ray misses the box of ${nodeName(s, step.node)} (or meets it beyond the nearest hit so far), so everything inside it is skipped.`;
  } else {
    const r = rayOf(state.accel);
    const hit = r && r.hit && r.hit.primitive === step.prim;
    text = `Step ${state.step}: primitive ${step.prim} is tested against the ray${hit ? ': it is the closest hit' : ''}.`;
  }
  $('step-explain').textContent = text;
  drawTraversal();
}

$('step').addEventListener('input', () => showStep(Number($('step').value)));
$('step-first').addEventListener('click', () => showStep(0));
$('step-prev').addEventListener('click', () => showStep(state.step - 1));
$('step-next').addEventListener('click', () => showStep(state.step + 1));
$('step-last').addEventListener('click', () => showStep(currentSteps.steps.length));
$('legend-list').append(
  swatch(COLOR.entered, 'box entered'), swatch(COLOR.skipped, 'box skipped'),
  swatch(COLOR.tested, 'primitive tested'), swatch(COLOR.hit, 'the hit'));

// ---------------------------------------------------------------- 3D view
const view = $('view3d');
let renderer = null;
try {
  renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
} catch (err) {
  view.append(el('p', { class: 'message', text: 'The 3D view needs WebGL, which this browser does not offer: ' + err.message }));
}
const scene3 = new THREE.Scene();
const groups = { primitives: new THREE.Group(), bvols: new THREE.Group() };
for (const g of Object.values(groups)) scene3.add(g);
scene3.add(new THREE.AmbientLight(0xffffff, 1.4));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
scene3.add(sun);

const bounds = new THREE.Box3();
const tmpBox = (b) => new THREE.Box3(new THREE.Vector3(...b[0]), new THREE.Vector3(...b[1]));
{
  const p = data.primitives || {};
  const t = p.triangles || [];
  for (let i = 0; i + 2 < t.length; i += 3) bounds.expandByPoint(new THREE.Vector3(t[i], t[i + 1], t[i + 2]));
  for (const s of p.spheres || []) bounds.union(tmpBox([[s[0] - s[3], s[1] - s[3], s[2] - s[3]], [s[0] + s[3], s[1] + s[3], s[2] + s[3]]]));
  for (const o of p.other || []) bounds.union(tmpBox(o.box));
  for (const s of structures) {
    if (s.nodes && s.nodes[0]) bounds.union(tmpBox(s.nodes[0].box));
    if (s.family === 'grid' && s.origin) {
      bounds.union(tmpBox([s.origin, s.origin.map((o, k) => o + s.cell_size[k] * s.resolution[k])]));
    }
  }
  if (bounds.isEmpty()) bounds.set(new THREE.Vector3(-1, -1, -1), new THREE.Vector3(1, 1, 1));
}
const sceneSize = bounds.getSize(new THREE.Vector3()).length() || 1;

const camera = new THREE.PerspectiveCamera((data.camera && data.camera.vfov_degrees) || 45, 1, sceneSize / 1000, sceneSize * 100);
let controls = null;
function resetView() {
  const c = data.camera;
  const center = bounds.getCenter(new THREE.Vector3());
  if (c && c.eye) {
    camera.position.set(...c.eye);
    camera.up.set(...(c.up || [0, 1, 0]));
    // The orbit turns about the point of the view line nearest the scene's
    // centre (a scene's own target may be only a unit in front of the eye).
    const look = new THREE.Vector3(...(c.target || center.toArray())).sub(camera.position).normalize();
    const along = Math.max(center.clone().sub(camera.position).dot(look), sceneSize / 100);
    const target = camera.position.clone().add(look.multiplyScalar(along));
    // Seen from the scene's own camera the boxes stand behind one another;
    // stepping back and aside a little shows their depth.
    const back = camera.position.clone().sub(target);
    const side = new THREE.Vector3().crossVectors(back, camera.up).normalize().multiplyScalar(back.length() * 0.35);
    camera.position.copy(target.clone().add(back.multiplyScalar(1.15)).add(side));
    camera.near = Math.max(camera.position.distanceTo(center) / 1000, sceneSize / 10000);
    camera.updateProjectionMatrix();
    if (controls) controls.target.copy(target);
    camera.lookAt(target);
  } else {
    camera.position.copy(center.clone().add(new THREE.Vector3(0.6, 0.5, 1).multiplyScalar(sceneSize)));
    if (controls) controls.target.copy(center);
    camera.lookAt(center);
  }
  if (controls) controls.update();
  render3d();
}

function boxEdges(b, out) {
  const [l, h] = b;
  const c = [[l[0], l[1], l[2]], [h[0], l[1], l[2]], [h[0], h[1], l[2]], [l[0], h[1], l[2]],
    [l[0], l[1], h[2]], [h[0], l[1], h[2]], [h[0], h[1], h[2]], [l[0], h[1], h[2]]];
  for (const [a, z] of [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]]) {
    out.push(...c[a], ...c[z]);
  }
}
function lines(positions, color, opacity = 1) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
  const m = new THREE.LineBasicMaterial({ color, transparent: opacity < 1, opacity });
  return new THREE.LineSegments(g, m);
}
function boxesLines(boxes, color, opacity = 1) {
  const pos = [];
  for (const b of boxes) boxEdges(b, pos);
  return lines(pos, color, opacity);
}
function dispose(group) {
  for (const child of [...group.children]) {
    group.remove(child);
    child.traverse((o) => { if (o.geometry) o.geometry.dispose(); if (o.material) o.material.dispose(); });
  }
}

// Primitives: triangles as one mesh, spheres as instances, others as boxes.
const triangleIndex = new Map(); // primitive number -> its drawn triangles
const sphereIndex = new Map(); // primitive number -> [cx, cy, cz, r]
const otherIndex = new Map(); // primitive number -> box
{
  const p = data.primitives || {};
  const t = p.triangles || [];
  (p.triangle_ids || []).forEach((id, i) => {
    if (!triangleIndex.has(id)) triangleIndex.set(id, []);
    triangleIndex.get(id).push(i);
  });
  if (t.length) {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(t, 3));
    g.computeVertexNormals();
    const m = new THREE.MeshLambertMaterial({ color: COLOR.prim, side: THREE.DoubleSide, transparent: true, opacity: 0.55, depthWrite: false });
    groups.primitives.add(new THREE.Mesh(g, m));
  }
  const spheres = p.spheres || [];
  if (spheres.length) {
    const m = new THREE.MeshLambertMaterial({ color: COLOR.prim, transparent: true, opacity: 0.55, depthWrite: false });
    const mesh = new THREE.InstancedMesh(new THREE.SphereGeometry(1, 24, 16), m, spheres.length);
    spheres.forEach((s, i) => {
      sphereIndex.set(s[4], s);
      mesh.setMatrixAt(i, new THREE.Matrix4().makeScale(s[3], s[3], s[3]).setPosition(s[0], s[1], s[2]));
    });
    groups.primitives.add(mesh);
  }
  const others = p.other || [];
  for (const o of others) otherIndex.set(o.primitive, o.box);
  if (others.length) groups.primitives.add(boxesLines(others.map((o) => o.box), COLOR.prim, 0.8));
  if (p.left_out) pageNotes.push(`${p.left_out} of ${p.total} primitives are not drawn in the 3D view`);
}

// Bounding volumes of the --bvol choices.
{
  const pos = [];
  const circle = (c, u, v, r) => {
    for (let i = 0; i < 48; i++) {
      for (const a of [i, i + 1].map((j) => (j / 48) * 2 * Math.PI)) {
        pos.push(...[0, 1, 2].map((k) => c[k] + r * (Math.cos(a) * u[k] + Math.sin(a) * v[k])));
      }
    }
  };
  for (const b of data.bounding_volumes || []) {
    if (b.kind === 'sphere') {
      circle(b.center, [1, 0, 0], [0, 1, 0], b.radius);
      circle(b.center, [0, 1, 0], [0, 0, 1], b.radius);
      circle(b.center, [1, 0, 0], [0, 0, 1], b.radius);
    } else if (b.kind === 'aabb') {
      boxEdges(b.box, pos);
    } else if (b.kind === 'obb') {
      const corner = (sx, sy, sz) => [0, 1, 2].map((k) => b.center[k] + sx * b.half[0] * b.axes[0][k] + sy * b.half[1] * b.axes[1][k] + sz * b.half[2] * b.axes[2][k]);
      const c = [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]].map((s) => corner(...s));
      for (const [a, z] of [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]]) pos.push(...c[a], ...c[z]);
    }
  }
  if (pos.length) groups.bvols.add(lines(pos, COLOR.bvol));
  else $('show-bvols').disabled = true;
}

// The deepest level the page holds whole (deeper nodes are given only
// where a picked ray visits them).
function maxDepthOf(s) {
  if (!s || !s.nodes || !s.nodes.length) return 0;
  if (typeof s.depth_drawn === 'number') return s.depth_drawn;
  let d = 0;
  for (const n of s.nodes) if (n) d = Math.max(d, n.depth);
  return d;
}

// Each structure has its own structure and traversal groups, so the view
// can show one of them or all side by side under the same camera.
const perAccel = new Map();
for (const s of structures) {
  const entry = { structure: new THREE.Group(), traversal: new THREE.Group(), drawn: {}, counts: {} };
  scene3.add(entry.structure, entry.traversal);
  perAccel.set(s.accel, entry);
}
const sideBySide = () => $('side-by-side').checked && structures.length > 1;
const shownAccels = () => (sideBySide() ? structures.map((s) => s.accel) : state.accel ? [state.accel] : []);

// What structure `s` looks like at `depth` (a tree's own depth is capped at
// its deepest node), with counts for the tests and the info line.
function drawStructure(s, group, depth) {
  dispose(group);
  const drawn = { boxes: 0, planes: 0, cells: 0, of: 0, depth: Math.min(depth, maxDepthOf(s)) };
  const d = drawn.depth;
  if (s.family === 'grid' && s.resolution) {
    const far = s.origin.map((o, k) => o + s.cell_size[k] * s.resolution[k]);
    group.add(boxesLines([[s.origin, far]], COLOR.level));
    const cells = (s.occupied || []).slice(0, MAX_BOXES).map((c) => cellBox(s, c));
    drawn.cells = cells.length;
    drawn.of = (s.occupied || []).length;
    group.add(boxesLines(cells, COLOR.cell, 0.55));
  } else if (s.nodes && s.nodes[0]) {
    const atLevel = [];
    const finished = [];
    const planes = [];
    for (const n of s.nodes) {
      if (!n) continue;
      if (n.depth === d) atLevel.push(n);
      else if (n.depth < d && (!n.children || !n.children.length)) finished.push(n);
      if (s.family === 'kdtree' && n.axis !== null && n.axis !== undefined && n.depth <= d) planes.push(n);
    }
    if (s.family === 'kdtree') {
      group.add(boxesLines([s.nodes[0].box], COLOR.level));
      const pos = [];
      const edge = [];
      for (const n of planes.slice(0, MAX_BOXES)) {
        const a = n.axis;
        const [u, v] = [0, 1, 2].filter((k) => k !== a);
        const corner = (cu, cv) => { const p = [0, 0, 0]; p[a] = n.split; p[u] = n.box[cu][u]; p[v] = n.box[cv][v]; return p; };
        const q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
        pos.push(...q[0], ...q[1], ...q[2], ...q[0], ...q[2], ...q[3]);
        for (let i = 0; i < 4; i++) edge.push(...q[i], ...q[(i + 1) % 4]);
      }
      drawn.planes = Math.min(planes.length, MAX_BOXES);
      drawn.of = planes.length;
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
      group.add(new THREE.Mesh(g, new THREE.MeshBasicMaterial({ color: COLOR.plane, side: THREE.DoubleSide, transparent: true, opacity: 0.22, depthWrite: false })));
      group.add(lines(edge, COLOR.plane));
    } else {
      const shown = atLevel.slice(0, MAX_BOXES);
      drawn.boxes = shown.length;
      drawn.of = atLevel.length;
      group.add(boxesLines(shown.map((n) => n.box), COLOR.level));
      group.add(boxesLines(finished.slice(0, MAX_BOXES).map((n) => n.box), COLOR.done, 0.6));
    }
  }
  return drawn;
}

function updateDepthControl() {
  const s = structureByAccel(state.accel);
  const depthInput = $('depth');
  const deepest = Math.max(0, ...shownAccels().map((a) => maxDepthOf(structureByAccel(a))));
  depthInput.disabled = !s || (s.family === 'grid' && !sideBySide());
  depthInput.max = deepest;
  if (state.depth > deepest) state.depth = deepest;
  depthInput.value = state.depth;
  drawAll();
}

function drawAll() {
  for (const s of structures) perAccel.get(s.accel).drawn = drawStructure(s, perAccel.get(s.accel).structure, state.depth);
  const s = structureByAccel(state.accel);
  const info = $('structure-info');
  if (!s) { info.textContent = ''; render3d(); return; }
  const drawn = perAccel.get(s.accel).drawn;
  const st = s.stats || {};
  const statText = `${s.accel}: ${st.nodes ?? '?'} nodes, ${st.leaves ?? '?'} leaves, depth ${st.max_depth ?? '?'}` +
    (st.memory_bytes ? `, ${(st.memory_bytes / 1024).toFixed(1)} KiB` : '') + '.';
  let shownText;
  if (s.family === 'grid') {
    shownText = ` Drawn: the grid's bounds and its ${drawn.cells} occupied cells` +
      (drawn.cells < drawn.of ? ` (of ${drawn.of})` : '') + (s.resolution ? `; resolution ${s.resolution.join(' × ')}.` : '.');
  } else if (s.family === 'kdtree') {
    shownText = ` Drawn: the split planes of nodes down to depth ${drawn.depth} (${drawn.planes} planes${drawn.planes < drawn.of ? ' of ' + drawn.of : ''}).`;
  } else {
    shownText = ` Drawn: the ${drawn.boxes} boxes at depth ${drawn.depth}` +
      (drawn.boxes < drawn.of ? ` (of ${drawn.of})` : '') + ', and in grey the leaves finished above it.';
  }
  $('depth-value').textContent = s.family === 'grid' && !sideBySide() ? 'a grid has one level' : `${state.depth} of ${$('depth').max}`;
  if (s.left_out) shownText += ` Nodes below depth ${maxDepthOf(s)} are not in this page (${s.left_out} left out).`;
  info.textContent = statText + shownText;
  view.dataset.depth = drawn.depth;
  view.dataset.structureBoxes = drawn.boxes;
  view.dataset.structurePlanes = drawn.planes;
  view.dataset.structureCells = drawn.cells;
  drawTraversal();
}

// Every structure's traversal of the chosen ray: the walked structure up
// to the current step, the others (side by side) to the end.
function drawTraversal() {
  for (const s of structures) {
    const entry = perAccel.get(s.accel);
    const walked = s.accel === state.accel;
    const steps = walked ? currentSteps : stepsOf(s.accel);
    entry.counts = drawTraversalOf(s, entry, steps, walked ? state.step : steps.steps.length);
  }
  const counts = perAccel.get(state.accel) ? perAccel.get(state.accel).counts : { entered: 0, skipped: 0, tested: 0, hit: 0 };
  view.dataset.step = state.step;
  view.dataset.entered = counts.entered;
  view.dataset.skipped = counts.skipped;
  view.dataset.tested = counts.tested;
  view.dataset.hit = counts.hit;
  render3d();
}

function drawTraversalOf(s, entry, walk, upto) {
  const group = entry.traversal;
  dispose(group);
  const counts = { entered: 0, skipped: 0, tested: 0, hit: 0 };
  const r = rayOf(s.accel);
  if (r) {
    const entered = [];
    const skipped = [];
    const testedTris = [];
    const testedOther = [];
    let current = null;
    walk.steps.slice(0, upto).forEach((step, i) => {
      if (step.kind === 'visit') {
        counts[step.entered ? 'entered' : 'skipped']++;
        const box = visitBox(s, step.node, step.placement);
        if (!box) return;
        (step.entered ? entered : skipped).push(box);
        if (i === upto - 1) current = { box, entered: step.entered };
      } else {
        counts.tested++;
        if (step.placement !== undefined) return; // drawn as its placement
        if (triangleIndex.has(step.prim)) testedTris.push(...triangleIndex.get(step.prim));
        else testedOther.push(step.prim);
      }
    });
    group.add(boxesLines(entered, COLOR.entered));
    group.add(boxesLines(skipped, COLOR.skipped));
    if (current) {
      const size = new THREE.Vector3(...current.box[1]).sub(new THREE.Vector3(...current.box[0]));
      const mesh = new THREE.Mesh(new THREE.BoxGeometry(size.x || 1e-6, size.y || 1e-6, size.z || 1e-6),
        new THREE.MeshBasicMaterial({ color: current.entered ? COLOR.entered : COLOR.skipped, transparent: true, opacity: 0.22, depthWrite: false }));
      mesh.position.set(...current.box[0]).add(size.clone().multiplyScalar(0.5));
      group.add(mesh);
    }
    const done = upto >= walk.steps.length;
    const hitPrim = done && r.hit ? r.hit.primitive : null;
    const hitTris = new Set(hitPrim !== null && triangleIndex.has(hitPrim) ? triangleIndex.get(hitPrim) : []);
    addPrimitives(group, testedTris.filter((t) => !hitTris.has(t)), testedOther.filter((p) => p !== hitPrim), COLOR.tested);
    if (hitPrim !== null) {
      counts.hit = 1;
      addPrimitives(group, [...hitTris], triangleIndex.has(hitPrim) ? [] : [hitPrim], COLOR.hit);
    }
    // The ray itself, to its hit (drawn once the walk has reached it) or
    // out of the scene.
    const o = new THREE.Vector3(...state.pick.ray.origin);
    const dir = new THREE.Vector3(...state.pick.ray.direction);
    const far = r.hit && done ? r.hit.t : o.distanceTo(bounds.getCenter(new THREE.Vector3())) + sceneSize;
    const end = o.clone().add(dir.clone().multiplyScalar(far));
    group.add(lines([...o.toArray(), ...end.toArray()], COLOR.ray));
    if (r.hit && done) {
      const dot = new THREE.Mesh(new THREE.SphereGeometry(sceneSize / 150, 12, 8), new THREE.MeshBasicMaterial({ color: COLOR.hit }));
      dot.position.copy(end);
      group.add(dot);
    }
  }
  // Under a walk in progress the structure's own boxes step back.
  const dim = r && upto > 0 && $('show-traversal').checked;
  for (const child of entry.structure.children) {
    if (child.material) {
      child.material.transparent = true;
      if (child.userData.opacity === undefined) child.userData.opacity = child.material.opacity;
      child.material.opacity = child.userData.opacity * (dim ? 0.3 : 1);
    }
  }
  return counts;
}

function addPrimitives(group, tris, prims, color) {
  const t = (data.primitives && data.primitives.triangles) || [];
  if (tris.length) {
    const pos = [];
    for (const i of tris) pos.push(...t.slice(9 * i, 9 * i + 9));
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
    g.computeVertexNormals();
    group.add(new THREE.Mesh(g, new THREE.MeshLambertMaterial({ color, side: THREE.DoubleSide, polygonOffset: true, polygonOffsetFactor: -1 })));
  }
  for (const p of prims) {
    const s = sphereIndex.get(p);
    if (s) {
      const m = new THREE.Mesh(new THREE.SphereGeometry(s[3] * 1.01, 24, 16), new THREE.MeshLambertMaterial({ color }));
      m.position.set(s[0], s[1], s[2]);
      group.add(m);
    } else if (otherIndex.has(p)) {
      group.add(boxesLines([otherIndex.get(p)], color));
    }
  }
}

// One viewport, or one per structure side by side, each labelled.
function render3d() {
  if (!renderer) return;
  groups.primitives.visible = $('show-primitives').checked;
  groups.bvols.visible = $('show-bvols').checked;
  const accels = shownAccels();
  const w = view.clientWidth || 600;
  const h = view.clientHeight || 400;
  // The grid of viewports whose cells are nearest to square.
  const n = Math.max(accels.length, 1);
  let cols = 1;
  const squareness = (c) => Math.abs(Math.log((w / c) / (h / Math.ceil(n / c))));
  for (let c = 2; c <= n; c++) if (squareness(c) < squareness(cols)) cols = c;
  const rows = Math.ceil(n / cols);
  const vw = w / cols;
  const vh = h / rows;
  sun.position.copy(camera.position);
  renderer.setScissorTest(true);
  renderer.setViewport(0, 0, w, h);
  renderer.setScissor(0, 0, w, h);
  renderer.clear();
  const labels = $('view-labels');
  labels.replaceChildren();
  camera.aspect = vw / vh;
  camera.updateProjectionMatrix();
  const draw = (accel) => {
    for (const [a, entry] of perAccel) {
      entry.structure.visible = a === accel && $('show-structure').checked;
      entry.traversal.visible = a === accel && $('show-traversal').checked;
    }
    renderer.render(scene3, camera);
  };
  if (!accels.length) draw(null);
  accels.forEach((accel, i) => {
    const x = (i % cols) * vw;
    const y = h - (Math.floor(i / cols) + 1) * vh;
    renderer.setViewport(x, y, vw, vh);
    renderer.setScissor(x, y, vw, vh);
    draw(accel);
    const r = rayOf(accel);
    const label = el('div', { class: 'view-label' + (accel === state.accel ? ' current' : ''),
      text: accel + (r ? ` · ${r.counts.nodes} nodes, ${r.counts.tests} tests` : '') });
    label.style.left = x + 'px';
    label.style.top = (h - y - vh) + 'px';
    labels.append(label);
  });
  renderer.setScissorTest(false);
}

function resize3d() {
  if (!renderer) return;
  const w = view.clientWidth || 600;
  const h = view.clientHeight || 400;
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(w, h);
  render3d();
}

if (renderer) {
  renderer.setClearColor(0x1d2230);
  view.append(renderer.domElement);
  renderer.domElement.id = 'view3d-canvas';
  renderer.autoClear = false;
  view.append(el('div', { id: 'view-labels' }));
  controls = new OrbitControls(camera, renderer.domElement);
  controls.addEventListener('change', render3d);
  window.addEventListener('resize', resize3d);
}
$('reset-view').addEventListener('click', resetView);
for (const id of ['show-primitives', 'show-structure', 'show-bvols']) $(id).addEventListener('change', render3d);
$('side-by-side').addEventListener('change', updateDepthControl);
if (structures.length < 2) $('side-by-side').disabled = true;
$('show-traversal').addEventListener('change', drawTraversal);
for (const s of structures) $('structure').append(el('option', { value: s.accel, text: `${s.accel} (${s.family})` }));
$('structure').addEventListener('change', () => selectTraversal($('structure').value, 'end'));
$('depth').addEventListener('input', () => { state.depth = Number($('depth').value); drawAll(); });
$('legend3d').append(
  swatch(COLOR.prim, 'primitives'), swatch(COLOR.level, 'boxes (k-d: split planes) at the chosen depth', true),
  swatch(COLOR.done, 'leaves above it', true), swatch(COLOR.cell, 'occupied grid cells', true),
  swatch(COLOR.entered, 'box entered', true), swatch(COLOR.skipped, 'box skipped', true), swatch(COLOR.tested, 'primitive tested'),
  swatch(COLOR.hit, 'the hit'), swatch(COLOR.ray, 'the ray', true), swatch(COLOR.bvol, 'bounding volumes', true));

// ---------------------------------------------------------------- scene graph
const KIND_COLOR = { group: '#e9ecef', transform: '#cfe2ff', instance: '#d1e7dd', definition: '#fff3cd', surface: '#f8d7da' };
function transformText(t) {
  if (!t) return '';
  t = t.slice(0, 3); // a 4×4 matrix's last row adds nothing to say
  const move = t.every((row) => row.length === 4) ? t.map((row) => row[3]) : null;
  const linear = t.map((row) => row.slice(0, 3));
  const identity = linear.every((row, i) => row.every((v, j) => Math.abs(v - (i === j ? 1 : 0)) < 1e-9));
  const parts = [];
  if (move && move.some((v) => Math.abs(v) > 1e-12)) parts.push('move ' + fmtVec(move));
  if (!identity) parts.push('rotate/scale');
  return parts.join(' · ') || 'identity';
}

function drawSceneGraph() {
  const g = data.scene_graph;
  const frame = $('graph');
  if (!g || !g.nodes || !g.nodes.length) {
    frame.append(el('p', { class: 'muted', text: 'This input has no scene graph to draw.' }));
    return;
  }
  const byId = new Map(g.nodes.map((n) => [n.id, n]));
  // Layers by breadth-first order from the root, a node drawn once however
  // many parents point at it (the DAG of shared definitions).
  const layerOf = new Map([[g.root, 0]]);
  const order = [g.root];
  for (let i = 0; i < order.length && order.length < MAX_GRAPH_NODES; i++) {
    const n = byId.get(order[i]);
    for (const c of (n && n.children) || []) {
      if (!layerOf.has(c) && byId.has(c) && order.length < MAX_GRAPH_NODES) { layerOf.set(c, layerOf.get(order[i]) + 1); order.push(c); }
    }
  }
  if (order.length < g.nodes.length) pageNotes.push(`the scene graph has ${g.nodes.length} nodes; the diagram shows the first ${order.length}`);
  const parents = new Map();
  for (const id of order) for (const c of byId.get(id).children || []) if (layerOf.has(c)) parents.set(c, (parents.get(c) || 0) + 1);
  const layers = [];
  for (const id of order) (layers[layerOf.get(id)] ||= []).push(id);
  const H = 50, GAPY = 40, GAPX = 14;
  const secondLine = (n) => {
    const k = parents.get(n.id) || 0;
    return n.kind + (k > 1 ? ` · ${k} arrows in` : '');
  };
  const label = (n) => (n.label.length > 30 ? n.label.slice(0, 29) + '…' : n.label);
  const widthOf = (n) => Math.max(90, 7.4 * label(n).length + 16, 6.6 * secondLine(n).length + 16, 6 * transformText(n.transform).length + 16);
  // A layer wider than the frame wraps onto further rows.
  const frameW = Math.max(frame.clientWidth - 24, 400);
  const pos = new Map();
  let svgW = 0;
  let y = 10;
  for (const ids of layers) {
    let row = [];
    let x = 10;
    const flush = () => {
      const shift = Math.max(0, (frameW - x) / 2);
      for (const id of row) pos.get(id).x += shift;
      row = [];
      x = 10;
      y += H + GAPY;
    };
    for (const id of ids) {
      const w = widthOf(byId.get(id));
      if (row.length && x + w > frameW) flush();
      pos.set(id, { x, y, w });
      row.push(id);
      x += w + GAPX;
      svgW = Math.max(svgW, x);
    }
    flush();
  }
  svgW = Math.max(svgW, frameW);
  const svgH = y - GAPY + 10;
  const NS = 'http://www.w3.org/2000/svg';
  const svg = document.createElementNS(NS, 'svg');
  svg.setAttribute('width', svgW + 10);
  svg.setAttribute('height', svgH);
  svg.setAttribute('id', 'graph-svg');
  const mk = (tag, attrs) => { const e = document.createElementNS(NS, tag); for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v); return e; };
  const defs = mk('defs', {});
  const marker = mk('marker', { id: 'arrow', viewBox: '0 0 10 10', refX: 10, refY: 5, markerWidth: 7, markerHeight: 7, orient: 'auto-start-reverse' });
  marker.append(mk('path', { d: 'M0,0 L10,5 L0,10 z', fill: '#57606a' }));
  defs.append(marker);
  svg.append(defs);
  for (const id of order) {
    const a = pos.get(id);
    for (const c of byId.get(id).children || []) {
      const b = pos.get(c);
      if (!b) continue;
      const x1 = a.x + a.w / 2, y1 = a.y + H, x2 = b.x + b.w / 2, y2 = b.y;
      const shared = (parents.get(c) || 0) > 1;
      svg.append(mk('path', {
        d: `M${x1},${y1} C${x1},${(y1 + y2) / 2} ${x2},${(y1 + y2) / 2} ${x2},${y2}`, fill: 'none',
        stroke: shared ? '#b08800' : '#57606a', 'stroke-width': shared ? 1.8 : 1.2, 'marker-end': 'url(#arrow)',
        'data-from': id, 'data-to': c,
      }));
    }
  }
  for (const id of order) {
    const n = byId.get(id);
    const p = pos.get(id);
    const gnode = mk('g', { 'data-id': id, 'data-kind': n.kind, class: 'graph-node' });
    gnode.append(mk('rect', { x: p.x, y: p.y, width: p.w, height: H, rx: 6, fill: KIND_COLOR[n.kind] || '#eee', stroke: '#8c959f' }));
    const t1 = mk('text', { x: p.x + p.w / 2, y: p.y + 16, 'text-anchor': 'middle', 'font-weight': 600 });
    t1.textContent = label(n);
    const t2 = mk('text', { x: p.x + p.w / 2, y: p.y + 30, 'text-anchor': 'middle', fill: '#57606a' });
    t2.textContent = secondLine(n);
    const t3 = mk('text', { x: p.x + p.w / 2, y: p.y + 44, 'text-anchor': 'middle', fill: '#0550ae', 'font-size': 11 });
    t3.textContent = transformText(n.transform);
    const title = mk('title', {});
    title.textContent = `${n.kind} ${n.id}: ${n.label}` + (n.transform ? '\n' + n.transform.map((r) => r.map(fmt).join('  ')).join('\n') : '');
    gnode.append(t1, t2, t3, title);
    svg.append(gnode);
  }
  frame.append(svg);

  const f = g.flattening || {};
  const box = $('flattening');
  box.append(el('h3', { text: data.instancing === 'nested' ? 'Nesting' : 'Flattening' }));
  if (g.counts) box.append(el('p', { class: 'graph-counts', text: `As placed: ${g.counts.placements} placements, ${g.counts.primitives} primitives (${g.counts.unique_primitives} stored once each).` }));
  if (f.baked !== undefined) box.append(el('p', { text: `${f.baked} surfaces baked into world space.` }));
  if (f.shared && f.shared.length) {
    box.append(el('p', { text: 'Kept shared (one copy, placed by its transforms):' }));
    const ul = el('ul');
    for (const s of f.shared) {
      ul.append(el('li', { text: `${s.label}: ` + (s.primitives !== undefined ? `${s.primitives} primitives, ` : '') +
        `${s.placements} placement${s.placements === 1 ? '' : 's'}` }));
    }
    box.append(ul);
  }
  if (f.summary && f.summary.length) {
    const ul = el('ul');
    for (const line of f.summary) ul.append(el('li', { text: line }));
    box.append(ul);
  }
  const legend = $('legend-graph');
  for (const [kind, color] of Object.entries(KIND_COLOR)) legend.append(swatch(color, kind));
  legend.append(swatch('#b08800', 'arrows into a shared definition', true));
}

// ---------------------------------------------------------------- notes, start
function fillNotes() {
  const ul = $('notes');
  for (const line of data.notes || []) ul.append(el('li', { text: line }));
  for (const line of pageNotes) ul.append(el('li', { class: 'page-note', text: line }));
  if (!ul.children.length) ul.append(el('li', { text: 'Nothing: this page holds all of it.' }));
}

drawSceneGraph();
resize3d();
resetView();
if (state.accel) $('structure').value = state.accel;
if (picks.length) pickPixel(image.width / 2, image.height / 2);
else { updateDepthControl(); $('picked-pixel').textContent = 'This page holds no traced rays.'; }
fillNotes();
document.body.dataset.ready = 'true';
