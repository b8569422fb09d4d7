// haptex GUI, "Your display" (issue 36): calibrate the page's device
// from measurements made on your own display (POST /api/calibrate: the
// fit drawn with its 95% bands, the estimates with their intervals, what
// the measurements cannot identify), save and load the device file, use
// it for the next designs (POST /api/voltage with device_file), and bring
// a design closer to its target from strokes measured on the display
// (POST /api/compensate/measured: the next design and the iteration
// history). Every number comes from the server; this module gathers the
// files, draws and says where each error is: beside the control that
// caused it (docs/web.md, "Your display"). It hears the main page through
// its DOM events: haptex:error (an error it may show beside its controls)
// and haptex:voltage (each design drawn).

import { ApiError, postJson } from './api.js';
import { COLOURS } from './colours.js';
import { $ } from './dom.js';
import { fmt } from './format.js';
import { voltageBody } from './requests.js';
import { plots, state } from './state.js';
import { scheduleVoltage } from './voltage.js';

const yd = {
  fit: null,        // last POST /api/calibrate answer, and the file's name
  fitName: null,
  loaded: null,     // the device file loaded or fitted: {name, text}
  design: null,     // the design whose strokes are measured: {csv, label}
  history: null,    // last POST /api/compensate/measured answer
  saved: null,      // the device fields' values before "Use for designs"
};
window.haptex.calibration = yd; // the browser tests' hook

// ------------------------------------------------------------- errors

/** The control each API field belongs to, and the note beside it. */
function errorPlace(field) {
  if (!field) return null;
  if (field === 'measurements' || field === 'name' || field === 'ultrasonic_model' || field === 'u_max_v' ||
      field.startsWith('stack')) return { note: 'yd-measurements-error', input: 'yd-measurements' };
  if (field === 'device_file' || field === 'carrier' || field.startsWith('carrier.')) {
    return { note: 'yd-device-error', input: 'yd-load' };
  }
  if (field === 'design' || field.startsWith('strokes') || field === 'gain') {
    return { note: 'yd-strokes-error', input: 'yd-strokes' };
  }
  return null;
}

/** The error beside its control, in the page's words; the field marked. */
function showBeside(placeId, error, prefix) {
  const place = typeof placeId === 'string' ? { note: placeId } : placeId;
  const note = $(place.note);
  const where = error.file ? `${error.file}: ` : '';
  const message = error.message || String(error);
  note.textContent = `${prefix}${message.startsWith(error.file || '\u0000') ? '' : where}${message}`;
  note.hidden = false;
  if (place.input) $(place.input).setAttribute('aria-invalid', 'true');
  document.body.dataset.ydErrors = String(Number(document.body.dataset.ydErrors || 0) + 1);
}

function clearBeside(noteId, inputId) {
  $(noteId).textContent = '';
  $(noteId).hidden = true;
  if (inputId) $(inputId).removeAttribute('aria-invalid');
}

// A design error about the device file (the page's voltage request)
// lands beside "Load device file", not in the header.
document.addEventListener('haptex:error', (e) => {
  const error = e.detail;
  if (!state.deviceFile) return;
  const field = error.field || '';
  if (field === 'device_file' || field.startsWith('carrier') || field.startsWith('device.') ||
      (field === 'ultrasonic_calibration' && error.message.includes('device file'))) {
    e.preventDefault();
    showBeside({ note: 'yd-device-error', input: 'yd-load' }, error,
      `The device file ${state.deviceFile.name} cannot design this: `);
  }
});

// ----------------------------------------------------------- calibrate

async function fitMeasurements() {
  const file = $('yd-measurements').files[0];
  if (!file) return;
  clearBeside('yd-measurements-error', 'yd-measurements');
  $('yd-fit-info').textContent = `Fitting ${file.name}…`;
  const body = { measurements: await file.text(), name: file.name };
  const u = $('yd-u-max').value.trim();
  if (u !== '') body.u_max_v = Number(u);
  body.ultrasonic_model = $('yd-ultrasonic-model').value;
  let answer;
  try {
    answer = await (await postJson('/api/calibrate', body)).json();
  } catch (error) {
    $('yd-fit-info').textContent = '';
    const place = errorPlace(error.field) || { note: 'yd-measurements-error', input: 'yd-measurements' };
    if (error.field === 'u_max_v') place.input = 'yd-u-max';
    showBeside(place, error, 'Not fitted: ');
    return;
  }
  yd.fit = answer;
  yd.fitName = file.name;
  if (answer.device_file) {
    yd.loaded = { name: file.name.replace(/\.[^.]*$/, '') + '.toml', text: answer.device_file, from: 'fit' };
  }
  showFit(answer);
  showDeviceControls();
  document.body.dataset.ydFits = String(Number(document.body.dataset.ydFits || 0) + 1);
}

/** "0.601 (95%: 0.583 .. 0.619)", or "not identified". */
function estimateText(e) {
  if (!e) return '–';
  if (!e.identified) {
    return `not identified${e.low !== null && e.high !== null ? ` (95%: ${fmt(e.low)} .. ${fmt(e.high)})` : ''}`;
  }
  return `${fmt(e.value)} (95%: ${fmt(e.low)} .. ${fmt(e.high)})`;
}

function showFit(a) {
  const m = a.measurements;
  const ev = a.electrovibration;
  const model = a.device_model === 'circuit' ? 'the circuit model (any carrier)'
    : a.device_model === 'eq3' ? 'eq. (3) per measured carrier' : 'no electrovibration constants';
  $('yd-fit-info').textContent = `${m.file}: ${m.rows} rows. ` +
    (a.identified ? `The device file holds ${model}` +
      `${a.ultrasonic && a.ultrasonic.table.length > 1 ? ` and the plate's rho(a) (${a.ultrasonic.chosen})` : ''}.`
      : 'The measurements identify no constant of the display: see below what to measure.') +
    (a.intervals_rest_on ? ` Intervals rest on ${a.intervals_rest_on}.` : '');
  $('yd-fit-results').hidden = false;
  // The estimates table.
  const rows = [];
  const add = (name, unit, e) => rows.push([name, unit, e]);
  if (ev && ev.circuit) {
    const c = ev.circuit;
    add('μ_HD (circuit model)', '', c.mu_hd);
    add('c, eq. (3)\'s force coefficient', '1/V²', c.c_per_v2);
    add('ρ_sc, stratum corneum resistivity', 'Ω m', c.rho_sc_ohm_m);
    add('g, air gap', 'µm', c.gap_um);
  }
  if (ev) {
    add('μ_HD (eq. 3 per carrier)', '', ev.eq3.mu_hd);
    ev.eq3.carriers.forEach((c) => add(`c on ${c.name}`, '1/V²', c.c_per_v2));
  }
  if (a.ultrasonic) {
    const u = a.ultrasonic;
    if (u.exponential) {
      add('ρ_∞, plate: friction left at large amplitude', '', u.exponential.rho_inf);
      add('a_c, plate: decay amplitude', 'µm', u.exponential.a_c_um);
    }
    add(`ρ_min = ρ(a_max = ${fmt(u.a_max_um)} µm)`, '', u.rho_min);
  }
  const table = $('yd-estimates');
  table.textContent = '';
  const head = table.createTHead().insertRow();
  ['constant', 'unit', 'estimate (95% interval)', 'identified'].forEach((h) => {
    const th = document.createElement('th');
    th.scope = 'col';
    th.textContent = h;
    head.append(th);
  });
  const body = table.createTBody();
  rows.forEach(([name, unit, e]) => {
    const tr = body.insertRow();
    tr.className = e.identified ? 'identified' : 'not-identified';
    [name, unit || '–', estimateText(e), e.identified ? 'yes' : 'no: see below'].forEach((t) => {
      tr.insertCell().textContent = t;
    });
  });
  // What the measurements cannot tell, in the server's words.
  const list = $('yd-verdicts');
  list.textContent = '';
  if (!a.verdicts.length) {
    const li = document.createElement('li');
    li.textContent = 'Every constant the models need is identified by these measurements.';
    list.append(li);
  }
  a.verdicts.forEach((v) => {
    const li = document.createElement('li');
    li.textContent = v;
    list.append(li);
  });
  const outliers = ((ev && (ev.circuit || ev.eq3)) || {}).outliers || [];
  $('yd-outliers').textContent = outliers.length
    ? `${outliers.length} measurement${outliers.length === 1 ? '' : 's'} more than 3 robust SD from the model, ` +
      `down-weighted (kept): line${outliers.length === 1 ? '' : 's'} ` +
      `${outliers.slice(0, 20).map((o) => o.line).join(', ')}${outliers.length > 20 ? ', …' : ''}.`
    : 'No outlier: every measurement is within 3 robust SD of the model.';
  drawFit(a);
}

// --------------------------------------------------------------- plots

function destroy(name) {
  if (plots[name]) { plots[name].destroy(); plots[name] = null; }
}

function width(id) {
  return Math.max(260, $(id).clientWidth || $(id).parentElement.clientWidth || 320);
}

/** Scatter points drawn over a plot (uPlot joins series on one x; points have their own). */
function pointsHook(sets) {
  return (u) => {
    const ctx = u.ctx;
    ctx.save();
    sets.forEach(({ x, y, colour }) => {
      ctx.fillStyle = colour;
      for (let i = 0; i < x.length; i += 1) {
        if (y[i] === null || x[i] === null) continue;
        const px = u.valToPos(x[i], 'x', true);
        const py = u.valToPos(y[i], 'y', true);
        ctx.beginPath();
        ctx.arc(px, py, 2.5 * (window.devicePixelRatio || 1), 0, 2 * Math.PI);
        ctx.fill();
      }
    });
    ctx.restore();
  };
}

function extent(arrays) {
  let lo = Infinity;
  let hi = -Infinity;
  arrays.forEach((a) => a.forEach((v) => {
    if (v !== null && Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  }));
  if (!Number.isFinite(lo)) return [0, 1];
  const pad = 0.05 * (hi - lo || Math.abs(hi) || 1);
  return [lo - pad, hi + pad];
}

function drawFit(a) {
  ['ydFit', 'ydResiduals', 'ydPlate'].forEach(destroy);
  const curves = a.electrovibration && a.electrovibration.curves;
  $('yd-fit-figure').hidden = !curves || !curves.carriers.length;
  $('yd-residual-figure').hidden = $('yd-fit-figure').hidden;
  if (curves && curves.carriers.length) {
    $('yd-fit-caption').textContent = curves.model === 'circuit'
      ? 'the circuit model across carriers, with its 95% band' : 'eq. (3) per carrier, with its 95% band';
    // One x for the model curves (the voltage grids), points drawn by the hook.
    const tables = curves.carriers.map((c) => [c.model.u_v, c.model.rise, c.model.low, c.model.high]);
    const data = uPlot.join(tables);
    const series = [{ label: 'U (V RMS)' }];
    const bands = [];
    curves.carriers.forEach((c, k) => {
      const colour = COLOURS[k % COLOURS.length];
      const base = series.length;
      series.push({ label: c.name, stroke: colour, width: 1.5, spanGaps: true },
        { label: `${c.name} 95% low`, stroke: 'transparent', spanGaps: true, show: true },
        { label: `${c.name} 95% high`, stroke: 'transparent', spanGaps: true, show: true });
      bands.push({ series: [base + 2, base + 1], fill: `${colour}33` });
    });
    const points = curves.carriers.map((c, k) => ({ x: c.data.u_v, y: c.data.rise, colour: COLOURS[k % COLOURS.length] }));
    const y = extent([...curves.carriers.map((c) => c.data.rise), ...curves.carriers.map((c) => c.model.high),
      ...curves.carriers.map((c) => c.model.low)]);
    plots.ydFit = new uPlot({
      width: width('yd-fit-plot'), height: 260, scales: { x: { time: false }, y: { range: y } },
      axes: [{ label: 'U (V RMS)' }, { label: 'μ / μ(0 V) − 1' }], legend: { live: false },
      series, bands, hooks: { draw: [pointsHook(points)] },
    }, data, $('yd-fit-plot'));
    plots.ydFit.measured = points;
    // Residuals against the fitted friction.
    const fitted = curves.carriers.flatMap((c) => c.residuals.fitted);
    const residuals = curves.carriers.map((c, k) => ({ x: c.residuals.fitted, y: c.residuals.residual,
      colour: COLOURS[k % COLOURS.length] }));
    const [x0, x1] = extent([fitted]);
    plots.ydResiduals = new uPlot({
      width: width('yd-residual-plot'), height: 200,
      scales: { x: { time: false, range: [x0, x1] }, y: { range: extent(residuals.map((r) => r.y)) } },
      axes: [{ label: 'fitted μ' }, { label: 'measured − fitted' }], legend: { live: false },
      series: [{ label: 'fitted μ' }, { label: 'zero', stroke: '#999', width: 1 }],
      hooks: { draw: [pointsHook(residuals)] },
    }, [[x0, x1], [0, 0]], $('yd-residual-plot'));
    plots.ydResiduals.measured = residuals;
  }
  const plate = a.ultrasonic && a.ultrasonic.curves;
  $('yd-plate-figure').hidden = !plate;
  if (plate) {
    const tables = [[plate.table.amplitude_um, plate.table.rho]];
    const series = [{ label: 'a (µm)' }, { label: 'monotone table', stroke: COLOURS[1], width: 1.5, spanGaps: true }];
    const bands = [];
    if (plate.exponential) {
      const e = plate.exponential;
      tables.push([e.amplitude_um, e.rho, e.low, e.high]);
      series.push({ label: 'exponential', stroke: COLOURS[0], width: 1.5, spanGaps: true },
        { label: 'exponential 95% low', stroke: 'transparent', spanGaps: true },
        { label: 'exponential 95% high', stroke: 'transparent', spanGaps: true });
      bands.push({ series: [5, 4], fill: `${COLOURS[0]}33` });
    }
    const points = [{ x: plate.data.amplitude_um, y: plate.data.rho, colour: COLOURS[7] }];
    plots.ydPlate = new uPlot({
      width: width('yd-plate-plot'), height: 220,
      scales: { x: { time: false }, y: { range: extent([plate.data.rho, plate.table.rho]) } },
      axes: [{ label: 'a (µm, peak)' }, { label: 'ρ = μ(a) / μ(0)' }], legend: { live: false },
      series, bands, hooks: { draw: [pointsHook(points)] },
    }, uPlot.join(tables), $('yd-plate-plot'));
  }
}

// --------------------------------------------------------- device file

function showDeviceControls() {
  const using = Boolean(state.deviceFile);
  $('yd-save').disabled = !yd.loaded;
  $('yd-use').disabled = !yd.loaded || using;
  $('yd-stop').hidden = !using;
  $('yd-device-info').textContent = using
    ? `Designs use ${state.deviceFile.name}${deviceWords(state.deviceFile)}.`
    : yd.loaded
      ? `${yd.loaded.name} ${yd.loaded.from === 'fit' ? 'from the fit' : 'loaded'}: "use for designs" makes the ` +
        'next design use its constants.'
      : 'No device file yet: fit your measurements, or load a device file.';
}

function deviceWords(file) {
  const p = file.provenance;
  if (!p) return '';
  return ` (${p.model ? `${p.model} model` : 'no electrovibration model'}, measurements ${p.measurements.file}, ` +
    `U_max ${fmt(p.u_max_v)} V, for the carrier sine ${fmt(p.carrier.frequency_hz)} Hz)`;
}

function saveDeviceFile() {
  if (!yd.loaded) return;
  const blob = new Blob([yd.loaded.text], { type: 'application/toml' });
  const link = $('yd-save-link');
  if (link.href) URL.revokeObjectURL(link.href);
  link.href = URL.createObjectURL(blob);
  link.download = yd.loaded.name;
  link.textContent = `save ${yd.loaded.name}`;
  link.hidden = false;
  link.dataset.count = String(Number(link.dataset.count || 0) + 1);
  link.click();
}

async function loadDeviceFile() {
  const file = $('yd-load').files[0];
  if (!file) return;
  clearBeside('yd-device-error', 'yd-load');
  if (file.size > 4 * 1024 * 1024) {
    showBeside({ note: 'yd-device-error', input: 'yd-load' },
      { message: `${file.name} is ${file.size} bytes, more than the limit of 4 MiB of a device file` }, 'Not loaded: ');
    return;
  }
  yd.loaded = { name: file.name, text: await file.text(), from: 'upload' };
  showDeviceControls();
}

/** "Use for designs": the next design uses the file; the device fields show its constants. */
function useDeviceFile() {
  if (!yd.loaded) return;
  clearBeside('yd-device-error', 'yd-load');
  if (!yd.saved) {
    yd.saved = {};
    document.querySelectorAll('[data-param]').forEach((input) => { yd.saved[input.dataset.param] = input.value; });
  }
  state.deviceFile = { name: yd.loaded.name, text: yd.loaded.text };
  yd.design = null; // a new device: the measured iterations start again
  document.querySelectorAll('[data-param]').forEach((input) => { input.readOnly = true; });
  $('reset-device').disabled = true;
  showDeviceControls();
  scheduleVoltage();
}

function stopDeviceFile() {
  state.deviceFile = null;
  yd.design = null;
  document.querySelectorAll('[data-param]').forEach((input) => {
    input.readOnly = false;
    if (yd.saved && input.dataset.param in yd.saved) input.value = yd.saved[input.dataset.param];
    input.dispatchEvent(new Event('input'));
  });
  yd.saved = null;
  $('reset-device').disabled = false;
  const note = $('device-file-note');
  if (note) note.remove();
  clearBeside('yd-device-error', 'yd-load');
  showDeviceControls();
  scheduleVoltage();
}

// Each design made with the file: the device fields show the constants it used, and say where they came from.
document.addEventListener('haptex:voltage', (e) => {
  const answer = e.detail;
  // Before the first iteration the strokes are of the page's design: follow it.
  if (!yd.history) yd.design = null;
  if (!state.deviceFile || !answer.device_file) return;
  clearBeside('yd-device-error', 'yd-load');
  state.deviceFile.provenance = answer.device_file;
  Object.entries(answer.parameters).forEach(([name, value]) => {
    const input = document.querySelector(`[data-param="${name}"]`);
    if (input) { input.value = String(Number(value.toPrecision(6))); input.dispatchEvent(new Event('explain')); }
  });
  let note = $('device-file-note');
  if (!note) {
    note = document.createElement('p');
    note.id = 'device-file-note';
    note.className = 'note device-file-note';
    $('device-params').insertAdjacentElement('beforebegin', note);
  }
  const p = answer.device_file;
  note.textContent = `From the device file ${state.deviceFile.name} (${p.model || 'no electrovibration'} ` +
    `model, measurements ${p.measurements.file}, sha256 ${p.sha256.slice(0, 12)}…), for the carrier ` +
    `${p.carrier.shape} ${fmt(p.carrier.frequency_hz)} Hz: μ_HD, the layer stack, k and U_max. ` +
    '"Stop using it" in Your display gives the fields back.';
  showDeviceControls();
});

// ----------------------------------------------------- measured strokes

/** The page's current design as CSV (the voltage CSV download's request). */
async function currentDesign() {
  if (yd.design) return yd.design;
  if (!state.profile) throw new ApiError('there is no design yet: choose a friction profile first', 'design', 0);
  const response = await postJson('/api/voltage?format=csv', voltageBody());
  yd.design = { csv: await response.text(), label: state.profile.label };
  return yd.design;
}

async function nextDesign() {
  clearBeside('yd-strokes-error', 'yd-strokes');
  const files = Array.from($('yd-strokes').files);
  if (files.length < 2) {
    showBeside({ note: 'yd-strokes-error', input: 'yd-strokes' },
      { message: `${files.length} stroke${files.length === 1 ? '' : 's'} chosen: the noise floor needs at least ` +
        '2 strokes of the design (6 to 10 are better)' }, 'No next design: ');
    return;
  }
  let answer;
  try {
    const design = await currentDesign();
    const body = voltageBody();
    ['profile', 'method', 'relative', 'flat_mu', 'source'].forEach((k) => delete body[k]);
    body.design = design.csv;
    body.strokes = await Promise.all(files.map(async (f) => ({ name: f.name, csv: await f.text() })));
    $('yd-ilc-info').textContent = `Comparing ${files.length} strokes with the design…`;
    answer = await (await postJson('/api/compensate/measured', body)).json();
  } catch (error) {
    $('yd-ilc-info').textContent = '';
    const place = errorPlace(error.field) || { note: 'yd-strokes-error', input: 'yd-strokes' };
    const prefix = error.field === 'design' ? 'The current design cannot be iterated: ' : 'No next design: ';
    showBeside(place, error, prefix);
    return;
  }
  yd.history = answer;
  yd.design = { csv: answer.design_csv, label: `next design (iteration ${answer.iteration + 1})` };
  showIteration(answer);
  document.body.dataset.ydIterations = String(Number(document.body.dataset.ydIterations || 0) + 1);
}

const LIMITS = {
  noise_floor: 'the noise floor: more strokes per iteration lower it, nothing else helps',
  not_renderable: 'the part of the target outside the display\'s band; the rest is at the noise floor',
  u_max: 'the display\'s limit: the update asks for more than U_max (or a_max) somewhere',
  iterations: 'the iterations: measure the next design and iterate again',
};

function showIteration(a) {
  $('yd-ilc-results').hidden = false;
  const e = a.history[a.history.length - 1];
  const kept = a.kept === 'at_noise_floor'
    ? 'At the noise floor: a further iteration would chase noise; the design is unchanged.'
    : a.kept === 'iteration_limit' ? 'The iteration limit is reached; the design is unchanged.'
      : `Next design: voltage ${fmt(Math.min(...a.voltage_next_v))} .. ${fmt(Math.max(...a.voltage_next_v))} V ` +
        `(U_max ${fmt(a.u_max_v)} V).`;
  $('yd-ilc-info').textContent = `Iteration ${e.iteration} (${e.strokes} strokes): RMS error ` +
    `${e.rms_error.toExponential(3)}, noise floor ${e.noise_floor.toExponential(3)}, lag ${fmt(e.lag_mm)} mm, ` +
    `plant gain ${fmt(e.plant_gain)}. ${kept} Limited by ${LIMITS[e.limited_by] || e.limited_by}.` +
    (a.warnings.length ? ` Warning: ${a.warnings.join(' ')}` : '');
  $('yd-download-next').disabled = false;
  ['ydIlc', 'ydIlcVoltage', 'ydHistory'].forEach(destroy);
  plots.ydIlc = new uPlot({
    width: width('yd-ilc-plot'), height: 230, scales: { x: { time: false } },
    axes: [{ label: 'x (mm)' }, { label: 'Ft/Fn' }], legend: { live: false },
    series: [{ label: 'x (mm)' }, { label: 'target', stroke: '#1b2430', width: 1.5 },
      { label: 'measured mean', stroke: COLOURS[3], width: 1.5 },
      { label: 'mean − 2 SE', stroke: 'transparent' }, { label: 'mean + 2 SE', stroke: 'transparent' }],
    bands: [{ series: [4, 3], fill: `${COLOURS[3]}33` }],
  }, [a.x_mm, a.target, a.mean, a.mean_minus_2se, a.mean_plus_2se], $('yd-ilc-plot'));
  plots.ydIlcVoltage = new uPlot({
    width: width('yd-ilc-voltage-plot'), height: 200, scales: { x: { time: false } },
    axes: [{ label: 'x (mm)' }, { label: 'U (V RMS)' }], legend: { live: false },
    series: [{ label: 'x (mm)' }, { label: 'design played', stroke: '#7f7f7f', width: 1.5, dash: [6, 4] },
      { label: 'next design', stroke: COLOURS[2], width: 1.5 }],
  }, [a.x_mm, a.voltage_played_v, a.voltage_next_v], $('yd-ilc-voltage-plot'));
  const k = a.history.map((h) => h.iteration);
  plots.ydHistory = new uPlot({
    width: width('yd-history-plot'), height: 200, scales: { x: { time: false }, y: { distr: 3 } },
    axes: [{ label: 'iteration' }, { label: 'Ft/Fn' }], legend: { live: false },
    series: [{ label: 'iteration' },
      { label: 'RMS error', stroke: COLOURS[3], width: 1.5, points: { show: true, size: 7 } },
      { label: 'noise floor', stroke: '#7f7f7f', width: 1.5, dash: [6, 4], points: { show: true, size: 7 } }],
  }, [k, a.history.map((h) => h.rms_error), a.history.map((h) => h.noise_floor)], $('yd-history-plot'));
}

function downloadNext() {
  if (!yd.history) return;
  const blob = new Blob([yd.history.design_csv], { type: 'text/csv' });
  const link = $('yd-next-link');
  if (link.href) URL.revokeObjectURL(link.href);
  link.href = URL.createObjectURL(blob);
  link.download = `design-iteration-${yd.history.iteration + 1}.csv`;
  link.textContent = link.download;
  link.hidden = false;
  link.dataset.count = String(Number(link.dataset.count || 0) + 1);
  link.click();
}

function startAgain() {
  yd.design = null;
  yd.history = null;
  ['ydIlc', 'ydIlcVoltage', 'ydHistory'].forEach(destroy);
  $('yd-ilc-results').hidden = true;
  $('yd-download-next').disabled = true;
  $('yd-ilc-info').textContent = 'The next strokes are compared with the page\'s current design.';
  clearBeside('yd-strokes-error', 'yd-strokes');
}

// --------------------------------------------------------------- start

/** Wires the panel's controls (the page calls it on DOMContentLoaded, after its own start). */
export function setup() {
  $('yd-measurements').addEventListener('change', () => fitMeasurements());
  $('yd-u-max').addEventListener('change', () => { clearBeside('yd-measurements-error', 'yd-u-max'); fitMeasurements(); });
  $('yd-ultrasonic-model').addEventListener('change', () => fitMeasurements());
  $('yd-save').addEventListener('click', saveDeviceFile);
  $('yd-load').addEventListener('change', () => loadDeviceFile());
  $('yd-use').addEventListener('click', useDeviceFile);
  $('yd-stop').addEventListener('click', stopDeviceFile);
  $('yd-next').addEventListener('click', () => nextDesign());
  $('yd-download-next').addEventListener('click', downloadNext);
  $('yd-start-again').addEventListener('click', startAgain);
  // The file's force coefficient depends on the carrier: a new carrier, a new design.
  $('carrier').addEventListener('change', () => { if (state.deviceFile) scheduleVoltage(); });
  showDeviceControls();
}
