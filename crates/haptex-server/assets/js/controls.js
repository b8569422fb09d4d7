// The page's controls, built from GET /api/config (sources, methods,
// displays, device parameters with their explanations, playback, check)
// and wired to the modules that act on them.

import { $ } from './dom.js';
import { ApiError } from './api.js';
import { runCheck, showCheck, showFingerFields } from './check.js';
import { buildDisplayControls } from './displays.js';
import { download } from './downloads.js';
import { explain, readDevice } from './fields.js';
import { setStatus, setupFieldChecks, validateField } from './feedback.js';
import { prettySymbol } from './validation.js';
import { showError } from './messages.js';
import { pinDesign, unpinAll } from './pins.js';
import { openRecipe, shareLink } from './recipes.js';
import { showRecordingsError, uploadRecordings } from './recordings.js';
import { SOURCES, applySourceMapping, loadSource, selectSource, showUploadError } from './sources.js';
import { state } from './state.js';
import { audio, drawStrip, showStroke } from './strip.js';
import { scheduleVoltage } from './voltage.js';

/** Builds the page's controls from GET /api/config and wires every control to what it changes. */
export function buildControls(config) {
  const sourceBox = $('source-select');
  config.sources.filter((s) => SOURCES[s.id]).forEach((s, i) => {
    const label = document.createElement('label');
    label.title = s.description;
    const input = document.createElement('input');
    Object.assign(input, { type: 'radio', name: 'source', value: s.id, checked: i === 0 });
    input.addEventListener('change', () => selectSource(s.id));
    label.append(input, s.label);
    sourceBox.append(label);
  });

  const methodBox = $('method-select');
  config.methods.forEach((m) => {
    const label = document.createElement('label');
    label.title = m.description;
    const input = document.createElement('input');
    Object.assign(input, { type: 'radio', name: 'method', value: m.id, checked: m.id === state.method });
    input.addEventListener('change', () => { state.method = m.id; scheduleVoltage(); });
    label.append(input, m.label);
    methodBox.append(label);
  });

  buildDisplayControls(config, () => {
    state.displayChosen = true; // from now on the sources keep the user's display
    if (state.source) applySourceMapping(state.source);
  });

  $('relative').addEventListener('change', () => {
    state.relative = $('relative').checked;
    $('flat-mu').disabled = !state.relative;
    scheduleVoltage();
  });
  $('flat-mu').addEventListener('input', scheduleVoltage);
  $('both-methods').addEventListener('change', () => { state.both = $('both-methods').checked; scheduleVoltage(); });
  $('pin-design').addEventListener('click', () => { try { pinDesign(); } catch (error) { showError(error); } });
  $('unpin-all').addEventListener('click', unpinAll);

  const params = $('device-params');
  config.device_params.forEach((p) => {
    const wrap = document.createElement('div');
    const label = document.createElement('label');
    label.htmlFor = `param-${p.name}`;
    label.title = p.description;
    const explained = (config.explanations || []).find((e) => e.field === p.name);
    label.textContent = `${prettySymbol(explained ? explained.symbol : p.name)} `;
    const unit = document.createElement('span');
    unit.className = 'unit';
    unit.textContent = p.unit ? `(${p.unit})` : '';
    label.append(unit);
    const input = document.createElement('input');
    Object.assign(input, { type: 'number', id: `param-${p.name}`, step: 'any', min: p.min, max: p.max });
    input.dataset.param = p.name;
    input.dataset.label = prettySymbol(explained ? explained.symbol : p.name);
    input.dataset.unit = p.unit || '';
    input.placeholder = p.default === null ? 'optional' : String(p.default);
    if (p.default !== null) input.value = String(p.default);
    input.addEventListener('input', () => { state.device = readDevice(); scheduleVoltage(); });
    wrap.append(label, input);
    params.append(wrap);
  });
  state.device = readDevice();

  $('reset-device').addEventListener('click', () => {
    config.device_params.forEach((p) => { $(`param-${p.name}`).value = p.default === null ? '' : String(p.default); });
    state.device = readDevice();
    document.querySelectorAll('[data-explained]').forEach((input) => input.dispatchEvent(new Event('explain')));
    scheduleVoltage();
  });

  $('velocity').value = String(config.play.velocity_mm_s);
  $('carrier').value = String(config.play.carrier.frequency_hz);
  state.velocity = config.play.velocity_mm_s;
  state.carrierHz = config.play.carrier.frequency_hz;
  $('velocity').addEventListener('input', () => { state.velocity = Number($('velocity').value); showStroke(); });
  $('carrier').addEventListener('input', () => {
    // Checked as typed (feedback.js): a refused frequency is not played, and the downloads say why.
    if (validateField($('carrier'))) return;
    const f = Number($('carrier').value);
    state.carrierHz = f;
    audio.setFrequency(f);
  });
  showStroke();

  $('material').addEventListener('change', () => { $('seed').value = ''; loadSource().catch(showError); });
  $('seed').addEventListener('change', () => loadSource().catch(showError));
  $('another-stroke').addEventListener('click', () => loadSource({ newSeed: true }).catch(showError));
  $('upload-recordings').addEventListener('click', () => uploadRecordings().catch(showRecordingsError));
  $('upload').addEventListener('change', () => loadSource().catch((error) => showUploadError(error)));
  $('recipe-file').addEventListener('change', async () => {
    const file = $('recipe-file').files[0];
    if (!file) return;
    try {
      let parsed;
      try {
        parsed = JSON.parse(await file.text());
      } catch (error) {
        throw new ApiError(`${file.name} is not JSON (${error.message})`, 'recipe', 0);
      }
      await openRecipe(parsed);
    } catch (error) {
      showError(error);
    }
  });
  $('controls').addEventListener('submit', (e) => e.preventDefault());

  $('check-load').value = String(config.check.load_n_per_mm);
  $('check-load-3d').value = String(config.check.load_n);
  $('check-direction').value = String(config.check.direction_deg);
  $('check-runs').value = String(config.check.max_runs);
  ['check-load', 'check-load-3d', 'check-direction'].forEach((id) => {
    $(id).addEventListener('input', () => { showCheck(); drawStrip(); });
  });
  $('check-model').addEventListener('change', () => { showFingerFields(); showCheck(); drawStrip(); });
  const checkStatus = { status: $('check-info') };
  $('run-check').addEventListener('click', () => runCheck('check').catch((e) => showError(e, checkStatus)));
  $('run-compensate').addEventListener('click', () => runCheck('compensate').catch((e) => showError(e, checkStatus)));
  $('play-compensated').addEventListener('change', () => { showCheck(); drawStrip(); });

  const downloadStatus = { status: $('download-info') };
  $('make-link').addEventListener('click', () => {
    try {
      shareLink();
      setStatus($('download-info'), 'The link below opens this design: copy it, or bookmark it.');
    } catch (error) {
      showError(error, downloadStatus);
    }
  });
  document.querySelectorAll('[data-download]').forEach((b) =>
    b.addEventListener('click', () => download(b.dataset.download).catch((e) => showError(e, downloadStatus))));

  (config.explanations || []).forEach(explain);
  setupFieldChecks();
}
