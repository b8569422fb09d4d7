// haptex map view (issue 19): a grayscale image turned into a friction map
// and a voltage map by the server (POST /api/map: haptex map from-image,
// then haptex map voltage), drawn as a heat map with a colour bar; the
// pointer or a finger over it reads x, y, mu and U there (bilinear, as the
// core samples a map); a path drawn with the pointer (press and drag) is
// sent with the image to POST /api/map/path, whose U(t) (haptex map
// sample-path) is plotted below and offered as CSV with the path itself.
// The server keeps nothing: every request carries the image.
// It is a module sharing the main page's (js/): the audio output, the
// heat colours, the number format, the bilinear sampling, the plot
// options and the fields' error outline.

import { createAudio } from './js/audio.js';
import { heatColour as colour } from './js/colours.js';
import { clearInvalid } from './js/fields.js';
import { fmtPlain as fmt, pct } from './js/format.js';
import { bilinear } from './js/interpolate.js';
import { lineOptions } from './js/plots.js';

const $ = (id) => document.getElementById(id);
/** Most samples of a drawn path (the server takes up to its max_points). */
const MAX_PATH_POINTS = 20000;
/** The finger speed of a path drawn with the keyboard, mm/s (the templates' sliding velocity). */
const KEY_SPEED_MM_S = 20;
const BAR_WIDTH = 64;

const state = {
  image: null, // base64 of the chosen PNG
  imageName: null,
  map: null, // the answer of POST /api/map
  request: null, // the settings the map was made with
  show: 'voltage',
  path: null, // { t_s, x_mm, y_mm } drawn
  drawing: null, // the path being drawn: { t0, points }
  sampled: null, // the answer of POST /api/map/path
  hover: null, // { x_mm, y_mm } under the pointer
};
const plots = { path: null };
/** The carrier of the browser's audio (the server's, from /api/config). */
let carrierHz = 1000;
// The browser's audio output (audio.js): U / U_max at the reading.
const audio = createAudio(() => carrierHz, (text) => say(text, true));
window.haptexMap = { state, plots, sample, audio };

function say(text, error) {
  const m = $('message');
  m.textContent = text;
  m.classList.toggle('error', Boolean(error));
}

function bump() {
  document.body.dataset.updates = String(Number(document.body.dataset.updates) + 1);
}

// ------------------------------------------------------------ requests

/** The body of POST /api/map from the controls (the image as chosen). */
function mapBody() {
  const number = (id) => Number($(id).value);
  return {
    image_png_base64: state.image,
    mu_black: number('mu_black'),
    mu_white: number('mu_white'),
    gamma: number('gamma'),
    pixel_mm: number('pixel_mm'),
    x0_mm: number('x0_mm'),
    y0_mm: number('y0_mm'),
    method: $('method').value,
    device: { mu_hd: number('mu_hd'), u_max_v: number('u_max_v') },
  };
}

/** The control a server error's field names, if the page has one. */
function controlOf(field) {
  if (!field) return null;
  const name = field.replace(/^device\./, '').replace(/^pixel_mm_y$/, 'pixel_mm');
  if (name === 'image_png_base64') return $('image');
  return $(name);
}

async function post(url, body) {
  const response = await fetch(url, {
    method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body),
  });
  if (!response.ok) {
    let error = { error: `${response.status} ${response.statusText}`, field: null };
    try { error = await response.json(); } catch (_) { /* not JSON */ }
    const e = new Error(error.error + (error.field ? ` (field ${error.field})` : ''));
    e.field = error.field;
    throw e;
  }
  return response;
}

function showError(e) {
  clearInvalid();
  const control = controlOf(e.field);
  if (control) control.setAttribute('aria-invalid', 'true');
  say(e.message, true);
  document.body.dataset.error = String(Number(document.body.dataset.error || 0) + 1);
  bump();
}

async function build() {
  if (!state.image) { say('Choose a grayscale PNG first.', true); return; }
  const body = mapBody();
  say('Mapping the image…');
  document.body.dataset.state = 'loading';
  const answer = await (await post('/api/map', body)).json();
  clearInvalid();
  state.map = answer;
  state.request = body;
  const g = answer.grid;
  say(`${state.imageName}: ${g.nx} x ${g.ny} pixels (${answer.bits} bit), ` +
    `${fmt(g.nx * g.dx_mm)} x ${fmt(g.ny * g.dy_mm)} mm.`);
  $('map-summary').textContent = answer.method === 'physical'
    ? `eq. (8): ${pct(answer.not_renderable_fraction)} of the area below mu_HD (0 V, not renderable), ` +
      `${pct(answer.clipped_fraction)} clipped at U_max = ${fmt(answer.u_max_v)} V.`
    : `eq. (9): the lowest mu at 0 V, the highest at U_max = ${fmt(answer.u_max_v)} V.`;
  drawMap();
  document.body.dataset.state = 'ready';
  bump();
  if (state.path) await samplePath();
}

async function samplePath() {
  const body = Object.assign({}, state.request, { path: state.path });
  const answer = await (await post('/api/map/path', body)).json();
  state.sampled = answer;
  drawPathPlot();
  const u = answer.voltage_v;
  $('path-info').textContent = `${u.length} samples over ${fmt(answer.t_s[u.length - 1] - answer.t_s[0])} s; ` +
    `U ${fmt(Math.min(...u))} .. ${fmt(Math.max(...u))} V RMS` +
    (answer.outside ? `; ${answer.outside} samples outside the map (the edge's voltage held)` : '');
  ['download-path', 'download-voltage', 'clear-path'].forEach((id) => { $(id).disabled = false; });
  document.body.dataset.path = String(Number(document.body.dataset.path || 0) + 1);
  bump();
}

// ------------------------------------------------------------ sampling

/** `values` of the map at (x, y), bilinear, the edge held: MapGrid::sample's arithmetic. */
function sample(values, x, y) {
  return bilinear(state.map.grid, values, x, y);
}

// ------------------------------------------------------------- drawing

/** The values shown, their range and their unit. */
function shown() {
  const m = state.map;
  if (state.show === 'friction') {
    const lo = Math.min(m.mapping.mu_black, m.mapping.mu_white);
    const hi = Math.max(m.mapping.mu_black, m.mapping.mu_white);
    return { values: m.mu, lo, hi, label: 'mu', unit: '' };
  }
  return { values: m.voltage_v, lo: 0, hi: m.u_max_v, label: 'U', unit: 'V RMS' };
}

let layout = null; // { width, height } of the map canvas in CSS px

function drawMap() {
  const canvas = $('map-canvas');
  const bar = $('colour-bar');
  const frame = canvas.parentElement;
  if (!state.map) return;
  const g = state.map.grid;
  const spanX = g.nx * g.dx_mm;
  const spanY = g.ny * g.dy_mm;
  const room = Math.max(frame.clientWidth - BAR_WIDTH - 8, 60);
  const maxHeight = Math.max(window.innerHeight * 0.6, 160);
  let width = room;
  let height = width * spanY / spanX;
  if (height > maxHeight) { height = maxHeight; width = height * spanX / spanY; }
  width = Math.floor(width);
  height = Math.max(Math.floor(height), 2);
  layout = { width, height };
  const ratio = window.devicePixelRatio || 1;
  canvas.style.width = `${width}px`;
  canvas.style.height = `${height}px`;
  canvas.width = Math.round(width * ratio);
  canvas.height = Math.round(height * ratio);
  const s = shown();
  // One pixel per cell, the top row at the largest y, then scaled.
  const cells = document.createElement('canvas');
  cells.width = g.nx;
  cells.height = g.ny;
  const cctx = cells.getContext('2d');
  const image = cctx.createImageData(g.nx, g.ny);
  const span = s.hi - s.lo || 1;
  for (let j = 0; j < g.ny; j += 1) {
    const r = g.ny - 1 - j;
    for (let i = 0; i < g.nx; i += 1) {
      const c = colour((s.values[j * g.nx + i] - s.lo) / span);
      const k = 4 * (r * g.nx + i);
      image.data[k] = c[0]; image.data[k + 1] = c[1]; image.data[k + 2] = c[2]; image.data[k + 3] = 255;
    }
  }
  cctx.putImageData(image, 0, 0);
  const ctx = canvas.getContext('2d');
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.imageSmoothingEnabled = false;
  ctx.drawImage(cells, 0, 0, width, height);
  drawOverlay(ctx);
  // The colour bar: the scale with its unit.
  bar.style.width = `${BAR_WIDTH}px`;
  bar.style.height = `${height}px`;
  bar.width = Math.round(BAR_WIDTH * ratio);
  bar.height = Math.round(height * ratio);
  const b = bar.getContext('2d');
  b.setTransform(ratio, 0, 0, ratio, 0, 0);
  b.clearRect(0, 0, BAR_WIDTH, height);
  const top = 16;
  const bottom = height - 16;
  for (let y = top; y <= bottom; y += 1) {
    const c = colour((bottom - y) / Math.max(bottom - top, 1));
    b.fillStyle = `rgb(${c[0]}, ${c[1]}, ${c[2]})`;
    b.fillRect(0, y, 14, 1);
  }
  b.fillStyle = '#1b2430';
  b.font = '11px system-ui, sans-serif';
  b.textBaseline = 'middle';
  const unit = s.unit ? ` ${s.unit.split(' ')[0]}` : '';
  b.fillText(`${fmt(s.hi)}${unit}`, 18, top);
  b.fillText(`${fmt((s.hi + s.lo) / 2)}${unit}`, 18, (top + bottom) / 2);
  b.fillText(`${fmt(s.lo)}${unit}`, 18, bottom);
  b.textBaseline = 'top';
  b.fillText(s.unit ? `${s.label} (${s.unit})` : s.label, 0, 0);
  bar.setAttribute('aria-label', `colour bar: ${s.label} from ${fmt(s.lo)} (dark) to ${fmt(s.hi)} (bright)` +
    (s.unit ? ` ${s.unit}` : ''));
  $('map-title').textContent = state.show === 'friction' ? 'Friction map mu(x, y)' : 'Voltage map U(x, y)';
}

/** Canvas position (CSS px) of the map point (x, y): cell centres at the grid points. */
function toCanvas(x, y) {
  const g = state.map.grid;
  return [((x - g.x0_mm) / g.dx_mm + 0.5) / g.nx * layout.width,
    (1 - ((y - g.y0_mm) / g.dy_mm + 0.5) / g.ny) * layout.height];
}

/** The map point (x, y) under the canvas position (CSS px). */
function fromCanvas(px, py) {
  const g = state.map.grid;
  return [g.x0_mm + (px / layout.width * g.nx - 0.5) * g.dx_mm,
    g.y0_mm + ((1 - py / layout.height) * g.ny - 0.5) * g.dy_mm];
}

function drawOverlay(ctx) {
  const points = state.drawing ? state.drawing.points : (state.path ? zip(state.path) : []);
  if (points.length > 1) {
    ctx.strokeStyle = '#ffffff';
    ctx.lineWidth = 3;
    ctx.beginPath();
    points.forEach(([, x, y], k) => {
      const [px, py] = toCanvas(x, y);
      if (k === 0) ctx.moveTo(px, py); else ctx.lineTo(px, py);
    });
    ctx.stroke();
    ctx.strokeStyle = '#0b3d91';
    ctx.lineWidth = 1.5;
    ctx.stroke();
  }
  if (state.hover) {
    const [px, py] = toCanvas(state.hover.x_mm, state.hover.y_mm);
    ctx.strokeStyle = '#4fc3f7';
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.arc(px, py, 6, 0, 2 * Math.PI);
    ctx.stroke();
  }
}

function zip(p) {
  return p.t_s.map((t, k) => [t, p.x_mm[k], p.y_mm[k]]);
}

function redrawOverlay() {
  // The cells are redrawn with the overlay (cheap at the page's pixel limit).
  drawMap();
}

function drawPathPlot() {
  const a = state.sampled;
  const holder = $('path-plot');
  const width = Math.max(holder.clientWidth, 200);
  const data = [a.t_s, a.voltage_v];
  if (plots.path) plots.path.destroy();
  plots.path = new uPlot(lineOptions({
    width, height: 220, x: 't (s)', y: 'U (V RMS)', series: [{ label: 'U (V RMS)', stroke: '#1f5fa8', width: 1.5 }],
  }), data, holder);
  holder.setAttribute('aria-label', `voltage along the path: ${a.t_s.length} samples over ` +
    `${fmt(a.t_s[a.t_s.length - 1] - a.t_s[0])} s, U from ${fmt(Math.min(...a.voltage_v))} to ` +
    `${fmt(Math.max(...a.voltage_v))} V RMS`);
}

// ---------------------------------------------------- pointer and finger

/** Reads the map at the canvas position of event `e`. */
function readAt(e) {
  if (!state.map || !layout) return null;
  const rect = $('map-canvas').getBoundingClientRect();
  const [x, y] = fromCanvas(e.clientX - rect.left, e.clientY - rect.top);
  return readPoint(x, y, e.pointerType || 'mouse');
}

/** Reads the map at (x, y) mm, from `input` (mouse, pen, touch or keyboard). */
function readPoint(x, y, input) {
  const mu = sample(state.map.mu, x, y);
  const u = sample(state.map.voltage_v, x, y);
  const readout = $('map-readout');
  readout.textContent = `x = ${x.toFixed(3)} mm, y = ${y.toFixed(3)} mm, mu = ${mu.toFixed(3)}, ` +
    `U = ${u.toFixed(1)} V RMS`;
  Object.assign(readout.dataset, { xMm: String(x), yMm: String(y), mu: String(mu), voltageV: String(u), input });
  $('map-canvas').setAttribute('aria-description', readout.textContent);
  state.hover = { x_mm: x, y_mm: y };
  audio.set(state.map.u_max_v ? u / state.map.u_max_v : 0);
  return [x, y];
}

function setupPointer() {
  const canvas = $('map-canvas');
  canvas.addEventListener('pointerdown', (e) => {
    if (!state.map || (e.pointerType === 'mouse' && e.button !== 0)) return;
    e.preventDefault();
    if (canvas.setPointerCapture) canvas.setPointerCapture(e.pointerId);
    const at = readAt(e);
    state.drawing = { t0: e.timeStamp, last: -Infinity, points: [] };
    record(e.timeStamp, at);
    redrawOverlay();
  });
  canvas.addEventListener('pointermove', (e) => {
    const at = readAt(e);
    if (!at) return;
    if (state.drawing) {
      const events = e.getCoalescedEvents ? e.getCoalescedEvents() : [];
      if (events.length > 1) {
        events.forEach((c) => {
          const rect = canvas.getBoundingClientRect();
          record(c.timeStamp, fromCanvas(c.clientX - rect.left, c.clientY - rect.top));
        });
      } else {
        record(e.timeStamp, at);
      }
    }
    redrawOverlay();
  });
  const finish = () => {
    const d = state.drawing;
    if (!d) return;
    state.drawing = null;
    if (d.points.length < 2) { redrawOverlay(); return; }
    state.path = {
      t_s: d.points.map((p) => p[0]), x_mm: d.points.map((p) => p[1]), y_mm: d.points.map((p) => p[2]),
    };
    redrawOverlay();
    samplePath().catch(showError);
  };
  canvas.addEventListener('pointerup', (e) => {
    if (e.pointerType === 'touch') audio.set(0); // the finger left the screen
    finish();
  });
  // The keyboard: the arrows move the reading one cell (Shift: ten);
  // Enter or Space starts a path at the reading and ends it, each arrow
  // step between adding a sample at KEY_SPEED_MM_S; Escape drops it.
  canvas.addEventListener('keydown', (e) => {
    if (!state.map || !layout) return;
    const g = state.map.grid;
    const moves = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
    const keyboardDrawing = state.drawing && state.drawing.keyboard;
    if (moves[e.key]) {
      e.preventDefault();
      const cells = e.shiftKey ? 10 : 1;
      const h = state.hover || { x_mm: g.x0_mm + 0.5 * (g.nx - 1) * g.dx_mm, y_mm: g.y0_mm + 0.5 * (g.ny - 1) * g.dy_mm };
      const clamp = (v, lo, n, d) => Math.min(lo + (n - 1) * d, Math.max(lo, v));
      const x = clamp(h.x_mm + moves[e.key][0] * cells * g.dx_mm, g.x0_mm, g.nx, g.dx_mm);
      const y = clamp(h.y_mm + moves[e.key][1] * cells * g.dy_mm, g.y0_mm, g.ny, g.dy_mm);
      readPoint(x, y, 'keyboard');
      if (keyboardDrawing) {
        const d = state.drawing;
        const [t, x0, y0] = d.points[d.points.length - 1];
        record(d.t0 + 1000 * (t + Math.hypot(x - x0, y - y0) / KEY_SPEED_MM_S), [x, y]);
      }
      redrawOverlay();
    } else if (e.key === 'Enter' || e.key === ' ') {
      e.preventDefault();
      if (keyboardDrawing) {
        finish();
      } else if (!state.drawing) {
        const h = state.hover || { x_mm: g.x0_mm, y_mm: g.y0_mm };
        const at = readPoint(h.x_mm, h.y_mm, 'keyboard');
        state.drawing = { t0: 0, last: -Infinity, points: [], keyboard: true };
        record(0, at);
        redrawOverlay();
      }
    } else if (e.key === 'Escape' && keyboardDrawing) {
      state.drawing = null;
      redrawOverlay();
    }
  });
  canvas.addEventListener('pointercancel', finish);
  canvas.addEventListener('pointerleave', (e) => {
    if (e.pointerType !== 'touch') audio.set(0);
    if (!state.drawing && e.pointerType !== 'touch') { state.hover = null; redrawOverlay(); }
  });
  canvas.addEventListener('blur', () => audio.set(0));
}

/** Adds a sample to the path drawn: times strictly increasing, in s from the press. */
function record(timeStamp, at) {
  const d = state.drawing;
  const t = (timeStamp - d.t0) / 1000;
  if (!(t > d.last) || d.points.length >= MAX_PATH_POINTS) return;
  d.last = t;
  d.points.push([t, at[0], at[1]]);
}

// ------------------------------------------------------------ downloads

function offer(blob, name, kind) {
  const link = $('download-link');
  if (link.href) URL.revokeObjectURL(link.href);
  link.href = URL.createObjectURL(blob);
  link.download = name;
  link.dataset.kind = kind;
  link.dataset.count = String(Number(link.dataset.count || 0) + 1);
  link.click();
}

function pathCsv() {
  const p = state.path;
  const rows = p.t_s.map((t, k) => `${t},${p.x_mm[k]},${p.y_mm[k]}`);
  return `t_s,x_mm,y_mm\n${rows.join('\n')}\n`;
}

async function downloadVoltage() {
  const body = Object.assign({}, state.request, { path: state.path });
  const response = await post('/api/map/path?format=csv', body);
  offer(await response.blob(), 'map-path-voltage.csv', 'voltage-csv');
}

// ---------------------------------------------------------------- setup

function readImage(file) {
  return new Promise((resolve, reject) => {
    const reader = new FileReader();
    reader.onload = () => resolve(String(reader.result).replace(/^data:[^,]*,/, ''));
    reader.onerror = () => reject(new Error(`cannot read ${file.name}`));
    reader.readAsDataURL(file);
  });
}

async function init() {
  try {
    const config = await (await fetch('/api/config')).json();
    const n = config.limits && config.limits.max_map_pixels;
    if (config.play && config.play.carrier) carrierHz = config.play.carrier.frequency_hz;
    if (n) $('max-pixels').textContent = `${n} (${Math.floor(Math.sqrt(n))} x ${Math.floor(Math.sqrt(n))})`;
  } catch (_) { /* the default text stays */ }
  $('image').addEventListener('change', async () => {
    const file = $('image').files[0];
    if (!file) return;
    state.image = await readImage(file);
    state.imageName = file.name;
    state.path = null;
    state.sampled = null;
    build().catch(showError);
  });
  let timer = null;
  document.querySelectorAll('#controls input[type=number], #controls select').forEach((e) => {
    e.addEventListener('change', () => {
      clearTimeout(timer);
      timer = setTimeout(() => { if (state.image) build().catch(showError); }, 50);
    });
  });
  $('build').addEventListener('click', () => build().catch(showError));
  $('show').addEventListener('change', () => { state.show = $('show').value; drawMap(); bump(); });
  $('download-path').addEventListener('click', () => {
    if (state.path) offer(new Blob([pathCsv()], { type: 'text/csv' }), 'map-path.csv', 'path-csv');
  });
  $('download-voltage').addEventListener('click', () => { if (state.path) downloadVoltage().catch(showError); });
  $('clear-path').addEventListener('click', () => {
    state.path = null;
    state.sampled = null;
    if (plots.path) { plots.path.destroy(); plots.path = null; }
    $('path-info').textContent = '';
    ['download-path', 'download-voltage', 'clear-path'].forEach((id) => { $(id).disabled = true; });
    redrawOverlay();
    bump();
  });
  $('audio').addEventListener('change', () => ($('audio').checked ? audio.start() : audio.stop()));
  setupPointer();
  let resizeTimer = null;
  window.addEventListener('resize', () => {
    clearTimeout(resizeTimer);
    resizeTimer = setTimeout(() => { drawMap(); if (state.sampled) drawPathPlot(); }, 100);
  });
}

init();
