// haptex map view (issue 19): a grayscale image turned into a friction map
// and a voltage map by the server (POST /api/map: haptex map from-image,
// then haptex map voltage), drawn as a heat map with a colour bar; the
// pointer or a finger over it reads x, y, mu and U there (bilinear, as the
// core samples a map); a path drawn with the pointer (press and drag) is
// sent with the image to POST /api/map/path, whose U(t) (haptex map
// sample-path) is plotted below and offered as CSV with the path itself.
// The server keeps nothing: every request carries the image.
// It is a module sharing the main page's (js/): the audio output, the
// heat colours, the number format, the bilinear sampling and the plot
// options. Every field is checked as typed (js/map-fields.js, against the
// server's ranges): a refused value is said in red under its control and
// blocks the request, an unusual one in amber; the server's errors land
// under the control they concern, in the page's words; only an error of
// no field goes to the header line. On a phone the result of an action is
// scrolled into view and announced.

import './js/token.js';
import { createAudio } from './js/audio.js';
import { $ } from './js/dom.js';
import { errorNote } from './js/feedback.js';
import { heatColour as colour } from './js/colours.js';
import { fmtPlain as fmt, pct } from './js/format.js';
import { bilinear } from './js/interpolate.js';
import { lineOptions } from './js/plots.js';
import { FIELDS, checkExtent, checkField, pageError, withConfig } from './js/map-fields.js';

/** Most samples of a drawn path (the server takes up to its max_points). */
const MAX_PATH_POINTS = 20000;
/** The finger speed of a path drawn with the keyboard, mm/s (the templates' sliding velocity). */
const KEY_SPEED_MM_S = 20;
const BAR_WIDTH = 64;

/** The numeric fields, with the device ranges of GET /api/config once read. */
let fields = FIELDS;

const state = {
  image: null, // base64 of the chosen PNG
  size: null, // [width, height] of the chosen PNG, from its header
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
window.haptexMap = { state, plots, sample, audio, validate: () => validateAll() };

function say(text, error) {
  const m = $('message');
  m.textContent = text;
  m.classList.toggle('error', Boolean(error));
}

function bump() {
  document.body.dataset.updates = String(Number(document.body.dataset.updates) + 1);
}

// ------------------------------------------------------------ requests

// ------------------------------------------------------------- fields

/** Whether the layout is one column (a phone): results are then scrolled to. */
const narrow = () => window.matchMedia('(max-width: 899px)').matches;

/** The notes under a control: its error (red) and its warning (amber). */
function notesOf(id) {
  const input = $(id);
  const error = errorNote(input);
  let warning = $(`${id}-warning`);
  if (!warning && id !== 'image') {
    warning = document.createElement('p');
    warning.id = `${id}-warning`;
    warning.className = 'field-warning';
    warning.hidden = true;
    error.insertAdjacentElement('afterend', warning);
  }
  return { input, error, warning };
}

/** Shows `level` ('ok', 'warning', 'error') with `text` under control `id` (its aria-describedby set here). */
function mark(id, level, text) {
  const { input, error, warning } = notesOf(id);
  error.hidden = level !== 'error';
  error.textContent = level === 'error' ? text : '';
  if (warning) {
    warning.hidden = level !== 'warning';
    warning.textContent = level === 'warning' ? text : '';
  }
  if (level === 'error') input.setAttribute('aria-invalid', 'true'); else input.removeAttribute('aria-invalid');
  input.classList.toggle('outside', level === 'warning');
  const described = [level === 'error' && error.id, level === 'warning' && warning && warning.id,
    id === 'image' && 'image-status'].filter(Boolean);
  if (described.length) input.setAttribute('aria-describedby', described.join(' '));
  else input.removeAttribute('aria-describedby');
}

/** The numbers typed (the fields that hold one). */
function typedValues() {
  const values = {};
  Object.keys(fields).forEach((id) => {
    const text = $(id).value.trim();
    if (/^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/.test(text)) values[id] = Number(text);
  });
  return values;
}

/** The band of the last eq. (8) map, while its device is the one typed. */
function bandTyped(values) {
  const m = state.map;
  if (!m || !m.band_mu || !state.request) return null;
  const d = state.request.device;
  return d.mu_hd === values.mu_hd && d.u_max_v === values.u_max_v ? m.band_mu : null;
}

/**
 * Checks every field as typed and shows the result under each; true when
 * none is refused (the request may be sent).
 */
function validateAll() {
  const values = typedValues();
  const context = { values, method: $('method').value, band: bandTyped(values) };
  let ok = true;
  Object.keys(fields).forEach((id) => {
    const r = checkField(fields, id, $(id).value, context);
    mark(id, r.level, r.text);
    if (r.level === 'error') ok = false;
  });
  if (ok && state.size) {
    const far = checkExtent(fields, values, state.size[0], state.size[1]);
    if (far) { mark(far.id, 'error', far.text); ok = false; }
  }
  return ok;
}

/** The first control with a refused value, or null. */
const firstRefused = () => Object.keys(fields).map($).find((e) => e.getAttribute('aria-invalid') === 'true') || null;

/** Brings `element` into view when it is not (smoothly off: tests read the geometry at once). */
function bringIntoView(element, block = 'nearest') {
  const r = element.getBoundingClientRect();
  if (r.bottom <= 0 || r.top >= window.innerHeight || r.top < 0 || r.bottom > window.innerHeight) {
    element.scrollIntoView({ block, inline: 'nearest' });
  }
}

// ------------------------------------------------------------ requests

/** The body of POST /api/map from the controls (the image as chosen); the fields were validated. */
function mapBody() {
  const number = (id) => Number($(id).value.trim());
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

async function post(url, body) {
  const response = await fetch(url, {
    method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body),
  });
  if (!response.ok) {
    let error = { error: `the server answered ${response.status} ${response.statusText}`, field: null };
    try { error = await response.json(); } catch (_) { /* not JSON */ }
    const e = new Error(error.error);
    e.api = error;
    throw e;
  }
  return response;
}

/** Hides the notes an earlier action left (the header line, the button's, the path's). */
function clearActionNotes() {
  say('');
  ['build-error', 'path-error'].forEach((id) => { $(id).hidden = true; $(id).textContent = ''; });
}

/**
 * A failed request, said where it belongs: under the control its field
 * concerns (in the page's words), under the path plot for a path, in the
 * header line only for an error of no field; brought into view.
 */
function showError(e) {
  const api = e.api || { error: e.message || String(e), field: null };
  const { control, text } = pageError(fields, api, state.imageName);
  let shown;
  if (control === 'image') {
    mark('image', 'error', text);
    $('image-status').textContent = `${state.imageName || 'The image'}: not mapped (see below).`;
    state.map = null;
    clearMap();
    shown = $('image-error');
  } else if (control === 'path') {
    $('path-error').textContent = text;
    $('path-error').hidden = false;
    shown = $('path-error');
  } else if (control && $(control)) {
    mark(control, 'error', text);
    shown = $(`${control}-error`);
  } else {
    say(text, true);
    shown = $('message');
  }
  document.body.dataset.state = state.map ? 'ready' : 'empty';
  document.body.dataset.error = String(Number(document.body.dataset.error || 0) + 1);
  bringIntoView(shown, 'center');
  bump();
}

/** Says why the map was not made, under the button and the control at fault. */
function refuseBuild(text) {
  const note = $('build-error');
  note.textContent = text;
  note.hidden = false;
  document.body.dataset.refused = String(Number(document.body.dataset.refused || 0) + 1);
  bringIntoView(note);
  bump();
}

function clearMap() {
  const canvas = $('map-canvas');
  canvas.getContext('2d').clearRect(0, 0, canvas.width, canvas.height);
  $('colour-bar').getContext('2d').clearRect(0, 0, $('colour-bar').width, $('colour-bar').height);
  $('map-summary').textContent = '';
  $('map-title').textContent = 'Map';
  $('fit-band').disabled = true;
}

/**
 * Maps the image with the fields (POST /api/map). `from` is the control
 * that asked: the button, the file field or a field edit; a refused field
 * blocks the request (said under it and, from the button, under the
 * button too).
 */
async function build(from = 'button', edited = null) {
  clearActionNotes();
  const ok = validateAll();
  if (!state.image) {
    if (from === 'button') {
      mark('image', 'error', 'Choose a grayscale PNG first: the map is made from it.');
      refuseBuild('Not mapped: no image chosen yet (see the file field).');
    }
    return;
  }
  if (!ok) {
    const bad = firstRefused();
    const label = bad ? document.querySelector(`label[for="${bad.id}"]`).textContent.replace(/\s+/g, ' ').trim() : '';
    if (from === 'upload') $('image-status').textContent = `${state.imageName}: not mapped yet, a field is refused.`;
    if (from === 'button') refuseBuild(`Not mapped: ${label} is refused (see the note under it).`);
    else if (bad) { bringIntoView($(`${bad.id}-error`)); bump(); }
    return;
  }
  const body = mapBody();
  document.body.dataset.state = 'loading';
  $('map-summary').textContent = 'Mapping the image…';
  const answer = await (await post('/api/map', body)).json();
  state.map = answer;
  state.request = body;
  mark('image', 'ok', '');
  const g = answer.grid;
  $('image-status').textContent = `${state.imageName}: ${g.nx} x ${g.ny} pixels (${answer.bits} bit), ` +
    `${fmt(g.nx * g.dx_mm)} x ${fmt(g.ny * g.dy_mm)} mm.`;
  validateAll(); // the band's warnings, now that it is known
  const summary = $('map-summary');
  if (answer.method === 'physical') {
    const [lo, hi] = answer.band_mu;
    summary.textContent = `Eq. (8): the display renders μ from ${fmt(lo)} (μ_HD, 0 V) to ${fmt(hi)} ` +
      `(U_max = ${fmt(answer.u_max_v)} V). ${pct(answer.not_renderable_fraction)} of the image is below μ_HD ` +
      `(0 V, not rendered), ${pct(answer.clipped_fraction)} is clipped at U_max.`;
    summary.classList.toggle('warning', answer.not_renderable_fraction + answer.clipped_fraction > 0.25);
  } else {
    summary.textContent = `Eq. (9): the lowest μ of the image at 0 V, the highest at U_max = ${fmt(answer.u_max_v)} V ` +
      '(the pattern only, not the friction itself).';
    summary.classList.remove('warning');
  }
  $('fit-band').disabled = !answer.band_mu;
  drawMap();
  document.body.dataset.state = 'ready';
  document.body.dataset.builds = String(Number(document.body.dataset.builds || 0) + 1);
  // On a phone the map is above the controls: bring it (and its summary)
  // into view, unless the field just edited has a note to read.
  const noted = edited && ($(`${edited}-warning`) || {}).hidden === false;
  if (narrow() && !noted) bringIntoView($('map-figure'), 'start');
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
  $('path-error').hidden = true;
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
    return { values: m.mu, lo, hi, label: 'μ', unit: '' };
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
  $('map-title').textContent = state.show === 'friction' ? 'Friction map μ(x, y)' : 'Voltage map U(x, y)';
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
  readout.textContent = `x = ${x.toFixed(3)} mm, y = ${y.toFixed(3)} mm, μ = ${mu.toFixed(3)}, ` +
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

/** The size a PNG's header (IHDR) claims, or null when the bytes are no PNG. */
function pngSize(base64) {
  let head = '';
  try { head = atob(base64.slice(0, 44)); } catch (_) { return null; }
  if (head.length < 24 || head.slice(1, 4) !== 'PNG' || head.slice(12, 16) !== 'IHDR') return null;
  const be = (k) => ((head.charCodeAt(k) << 24) >>> 0) + (head.charCodeAt(k + 1) << 16) +
    (head.charCodeAt(k + 2) << 8) + head.charCodeAt(k + 3);
  return [be(16), be(20)];
}

async function init() {
  try {
    const config = await (await fetch('/api/config')).json();
    const n = config.limits && config.limits.max_map_pixels;
    if (config.play && config.play.carrier) carrierHz = config.play.carrier.frequency_hz;
    if (n) $('max-pixels').textContent = `${n} (${Math.floor(Math.sqrt(n))} x ${Math.floor(Math.sqrt(n))})`;
    fields = withConfig(FIELDS, config);
  } catch (_) { /* the default text and ranges stay */ }
  Object.keys(fields).forEach((id) => notesOf(id));
  notesOf('image');
  $('image').addEventListener('change', async () => {
    const file = $('image').files[0];
    if (!file) return;
    clearActionNotes();
    mark('image', 'ok', '');
    state.imageName = file.name;
    $('image-status').textContent = `${file.name}: reading…`;
    try {
      state.image = await readImage(file);
    } catch (e) {
      state.image = null;
      showError({ api: { error: `cannot read the file: ${e.message}`, field: 'image_png_base64' } });
      return;
    }
    state.size = pngSize(state.image);
    state.path = null;
    state.sampled = null;
    build('upload').catch(showError);
  });
  let timer = null;
  Object.keys(fields).forEach((id) => {
    // As typed: the note under the field; on change (Enter or leaving it): a new map.
    $(id).addEventListener('input', () => { validateAll(); bump(); });
    $(id).addEventListener('change', () => {
      clearTimeout(timer);
      timer = setTimeout(() => build('field', id).catch(showError), 50);
    });
  });
  $('method').addEventListener('change', () => {
    clearTimeout(timer);
    timer = setTimeout(() => build('field').catch(showError), 50);
  });
  $('build').addEventListener('click', () => build('button').catch(showError));
  // Black at the band's bottom (mu_HD, 0 V), white at its top (U_max), four decimals inside it.
  $('fit-band').addEventListener('click', () => {
    const band = state.map && state.map.band_mu;
    if (!band) return;
    $('mu_black').value = String(Math.ceil(band[0] * 1e4) / 1e4);
    $('mu_white').value = String(Math.floor(band[1] * 1e4) / 1e4);
    build('button').catch(showError);
  });
  $('fit-band').disabled = true;
  validateAll();
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
