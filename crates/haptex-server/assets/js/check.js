// The check on the finger model and the compensation (POST /api/check,
// /api/compensate, streamed with their progress): the request for the
// design shown, whether the last result is still current, its plots and
// error figures, and the voltage played (the compensated one when chosen).

import { $ } from './dom.js';
import { ApiError, postStream } from './api.js';
import { checkRefusal, checkTrial } from './answers.js';
import { isCheckable, isElectrovibration } from './displays.js';
import { numberIn, readDevice } from './fields.js';
import { fmt, pct } from './format.js';
import { emit, on } from './hub.js';
import { showError } from './messages.js';
import { DESIGN_FIELDS, blocked, bringIntoView, setStatus } from './feedback.js';
import { constant, replot, withPins } from './plots.js';
import { voltageBody } from './requests.js';
import { plots, state } from './state.js';

/**
 * The POST /api/check body for the profile shown: the voltage request
 * (eq. 8: the check has a force to compare only for the physical method)
 * and the finger's load; a template's sliding velocity, the velocity its
 * profile was computed at.
 */
export function checkBody() {
  // The combined display's design is checked with its plate and strategy.
  const body = voltageBody('physical', state.display === 'combined');
  delete body.method;
  const [model, mesh] = $('check-model').value.split('-');
  if (model === '3d') {
    // The 3D fingertip: its load in N, its direction and its mesh.
    body.model = '3d';
    body.mesh = mesh;
    const load = numberIn('check-load-3d');
    if (load !== null) body.load_n = load;
    const direction = numberIn('check-direction');
    if (direction !== null) body.direction_deg = direction;
  } else {
    const load = numberIn('check-load');
    if (load !== null) body.load_n_per_mm = load;
  }
  if (state.source === 'template' && state.template.velocity_mm_s) body.velocity_mm_s = state.template.velocity_mm_s;
  return body;
}

/** Shows the chosen finger's fields (load in N/mm or N, the 3D fingertip's direction), hides the other's. */
export function showFingerFields() {
  const threeD = $('check-model').value.startsWith('3d');
  document.querySelectorAll('#check-box .finger-2d').forEach((e) => { e.hidden = threeD; });
  document.querySelectorAll('#check-box .finger-3d').forEach((e) => { e.hidden = !threeD; });
}

/** The last check, when it is for the profile, device, display and load shown. */
export function currentCheck() {
  if (!isCheckable()) return null;
  const c = state.check;
  return c && state.profile && state.drawn === state.profile && c.key === JSON.stringify(checkBody()) ? c : null;
}

/** The compensated voltage (as POST /api/voltage answers it), when it is current. */
export function currentCompensated() {
  const c = currentCheck();
  return c && c.mode === 'compensate' ? c.result.voltage : null;
}

/** Runs the check (`mode` check) or the compensation, showing its progress. */
export async function runCheck(mode) {
  const info = $('check-info');
  if (!state.profile) throw new ApiError('no profile to check yet', null, 0);
  // A field refused as typed stops the run here, said beside the buttons.
  const refused = blocked(`${DESIGN_FIELDS}, #check-box`);
  if (refused.length) {
    setStatus(info, `Not run: ${refused.map((r) => r.text).join('; ')}.`, true);
    bringIntoView(info);
    return;
  }
  const body = checkBody();
  const key = JSON.stringify(body);
  if (mode === 'compensate') {
    const runs = numberIn('check-runs');
    if (runs !== null) body.max_runs = runs;
  }
  const buttons = [$('run-check'), $('run-compensate')];
  buttons.forEach((b) => { b.disabled = true; });
  const bar = $('check-progress');
  bar.hidden = false;
  bar.value = 0;
  const progress = { lines: 0, maxRun: 0 };
  state.checkProgress = progress;
  const what = mode === 'compensate' ? 'Compensating' : 'Checking';
  delete info.dataset.result;
  setStatus(info, `${what} on the finger model: waiting for the FE model…`);
  const started = performance.now();
  try {
    const result = await postStream(`/api/${mode}`, body, (p) => {
      progress.lines += 1;
      progress.maxRun = Math.max(progress.maxRun, p.run);
      const runs = mode === 'compensate' ? p.max_runs : 1;
      bar.value = Math.min(1, ((p.run - 1) + p.step / p.steps) / runs);
      info.textContent = (mode === 'compensate' ? `${what}: FE run ${p.run} of at most ${p.max_runs}` : what) +
        `, step ${p.step} of ${p.steps} (x = ${p.x_mm.toFixed(2)} mm)…`;
    });
    state.check = { key, mode, result };
    const seconds = (performance.now() - started) / 1000;
    setStatus(info, `${mode === 'compensate' ? 'Compensated' : 'Checked'} in ${seconds.toFixed(2)} s ` +
      `(${result.fe_runs} FE run${result.fe_runs > 1 ? 's' : ''}, ${result.fe_seconds.toFixed(2)} s; ` +
      `steps of ${fmt(result.settings.step_mm)} mm)` +
      // Why the compensation stopped, as haptex check --compensate says it.
      (result.stopped ? `; ${result.stopped.message}.` : '.'));
    info.dataset.result = key;
    if (mode === 'compensate') $('play-compensated').checked = true;
    showCheck();
    emit('draw-strip');
    // The results, brought into view (the results column on a desktop, up the page on a phone).
    bringIntoView($('check-summary'));
  } catch (error) {
    // A refusal is said beside the buttons that asked (and beside its field), in the page's words.
    info.textContent = '';
    if (error instanceof ApiError && error.status === 503) setStatus(info, checkRefusal(error), true);
    else showError(error, { status: info });
  } finally {
    bar.hidden = true;
    $('run-check').disabled = !isCheckable();
    $('run-compensate').disabled = !isElectrovibration();
  }
}

/** Shows the current check (plots, metrics, playback), or hides a stale one. */
export function showCheck() {
  const c = currentCheck();
  const box = $('check-results');
  const compensated = currentCompensated();
  $('play-compensated').disabled = !compensated;
  if (!compensated) $('play-compensated').checked = false;
  document.querySelector('[data-download="compensated-csv"]').disabled = !compensated;
  $('feel-source').textContent = played() === state.voltage ? '' : ' (compensated voltage)';
  if (!c) {
    box.hidden = true;
    // The note about results no longer shown goes with them.
    const info = $('check-info');
    if (info.dataset.result) {
      info.textContent = '';
      delete info.dataset.result;
    }
    return;
  }
  box.hidden = false;
  showCaveat(c.result);
  const r = c.result;
  const x = r.x_mm;
  const comp = r.compensated;
  const first = checkTrial(r);
  const frictionSeries = [
    { label: 'target', stroke: '#1f5fa8', width: 1.5 },
    { label: `felt, ${first.name}`, stroke: '#b3261e', dash: [5, 3], width: 1.5 },
  ];
  const frictionData = [x, r.target_mu, first.felt_mu];
  const voltageSeries = [{ label: r.eq8 ? 'U eq. (8)' : 'U(x), combined', stroke: '#b3261e', width: 1.5 }];
  const voltageData = [x, first.voltage_v];
  if (comp) {
    frictionSeries.push({ label: 'felt, compensated', stroke: '#2e7d32', width: 1.5 });
    frictionData.push(comp.felt_mu);
    voltageSeries.push({ label: 'U compensated', stroke: '#2e7d32', width: 1.5 });
    voltageData.push(comp.voltage_v);
  }
  frictionSeries.push({ label: 'μ_HD', stroke: '#888', dash: [6, 4], width: 1 });
  frictionData.push(constant(x, r.settings.mu_hd));
  voltageSeries.push({ label: 'U_max', stroke: '#888', dash: [6, 4], width: 1 });
  const summary = r.voltage.summary;
  voltageData.push(constant(x, summary.u_max_v ?? summary.electrovibration.u_max_v));
  const felt = withPins(state.pins, frictionSeries, frictionData,
    (p) => ({ x: p.felt ? p.felt.x_mm : null, lines: p.felt ? [{ label: p.felt.label, data: p.felt.mu }] : [] }));
  plots.check = replot(plots.check, 'check-plot', felt.series, felt.data);
  plots.checkVoltage = replot(plots.checkVoltage, 'check-voltage-plot', voltageSeries, voltageData);
  showCheckMetrics(r);
}

/**
 * Where the check agrees by construction, says so beside its figure: on
 * the combined display the plate's part is, in the model, the friction
 * coefficient mu_HD rho(a) on a pad that slips throughout, so the finger
 * feels it exactly (docs/display.md); only the voltage's part is tested.
 */
function showCaveat(r) {
  const note = $('check-caveat');
  if (r.eq8) {
    note.hidden = true;
    note.textContent = '';
    return;
  }
  note.hidden = false;
  note.textContent = 'Where the plate alone renders the target (U = 0 V), the felt friction agrees by construction: ' +
    'the model takes the plate\'s effect as the friction coefficient μ_HD ρ(a) of a pad that slips throughout (no ' +
    'squeeze film is simulated), so an error near zero there confirms the design is applied consistently, not the ' +
    'plate\'s physics. The voltage\'s part, above μ_HD, is a real test of eq. (8) on the finger.';
}

/** The error figures of eq. (8) (or the combined design) and the compensated voltage, side by side. */
function showCheckMetrics(r) {
  const box = $('check-summary');
  box.textContent = '';
  const first = checkTrial(r);
  const columns = [[first.name, first.metrics]];
  if (r.compensated) columns.push([`compensated (run ${r.compensated.trial})`, r.compensated.metrics]);
  const rows = [
    ['RMS error', (m) => fmt(m.rms_error)],
    ['max error', (m) => fmt(m.max_error)],
    ['lag', (m) => `${fmt(m.lag_mm)} mm`],
    ['detail kept', (m) => (m.detail_retained === null ? '–' : pct(m.detail_retained))],
    ['k_FE', (m) => `${fmt(m.k_fe_mm2_per_n)} mm²/N`],
  ];
  const table = document.createElement('table');
  table.className = 'metrics';
  table.id = 'check-metrics';
  const head = table.insertRow();
  ['', ...columns.map((c) => c[0])].forEach((text) => {
    const th = document.createElement('th');
    th.textContent = text;
    head.append(th);
  });
  rows.forEach(([label, value]) => {
    const row = table.insertRow();
    const th = document.createElement('th');
    th.textContent = label;
    row.append(th);
    columns.forEach(([, m]) => { row.insertCell().textContent = value(m); });
  });
  const m = first.metrics;
  const title = document.createElement('div');
  const regions = document.createElement('div');
  const s = r.settings;
  const finger = s.model === '3d'
    ? `3D fingertip (${s.mesh} mesh) sliding at ${fmt(s.direction_deg)}°, load ${fmt(s.load_n)} N, ` +
      `${fmt(s.velocity_mm_s)} mm/s`
    : `2D finger, load ${fmt(s.load_n_per_mm)} N/mm, ${fmt(s.velocity_mm_s)} mm/s`;
  if (!r.eq8) {
    // The combined display: the plate vibrating with a(x) under U(x).
    const band = r.voltage.summary.band_mu;
    title.textContent = `Felt against the target over the combined display's band (mu ${fmt(band[0])} .. ` +
      `${fmt(band[1])}), the plate vibrating with a(x) (${r.settings.strategy}) under U(x):`;
    regions.textContent = `below the band: ${pct(m.not_renderable_fraction)} of the length · above it: ` +
      `${pct(m.clipped_fraction)} · ${finger}`;
    box.append(title, table, regions);
    return;
  }
  title.textContent = 'Felt against the target over the renderable region (mu_HD ≤ target ≤ mu at U_max):';
  regions.textContent = `not renderable (target < mu_HD = ${fmt(r.settings.mu_hd)}): ${pct(m.not_renderable_fraction)} ` +
    `of the length · above mu at U_max: ${pct(m.clipped_fraction)} · ${finger}`;
  const k = document.createElement('div');
  k.textContent = `eq. (8) used k = ${fmt(r.parameters.k_mm2_per_n)} mm²/N; ` + (s.model === '3d'
    ? `the 3D fingertip's real contact area per normal force is k_FE = ${fmt(m.k_fe_mm2_per_n)} mm²/N `
    : `the FE finger's contact length per normal force is k_FE = ${fmt(m.k_fe_mm2_per_n)} mm²/N (per mm of width: ` +
      'the 2D finger has no width) ');
  const useK = document.createElement('button');
  useK.type = 'button';
  useK.className = 'small';
  useK.id = 'use-fe-k';
  useK.textContent = 'use k_FE in eq. (8)';
  useK.addEventListener('click', () => {
    $('param-k_mm2_per_n').value = String(Number(m.k_fe_mm2_per_n.toPrecision(4)));
    state.device = readDevice();
    emit('schedule-voltage');
  });
  k.append(useK);
  box.append(title, table, regions, k);
}

/**
 * The voltage the feel strip, the audio and the stroke WAV play: the
 * compensated one when it is current and chosen, else the one plotted.
 * Its samples always come with their own summary (U_max, the scale).
 */
export function played() {
  const compensated = currentCompensated();
  return compensated && $('play-compensated').checked ? compensated : state.voltage;
}

on('show-check', showCheck);
