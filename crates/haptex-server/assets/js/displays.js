// The display selector (combined, ultrasonic, electrovibration) and its
// controls (strategy, weight, a_max, the ultrasonic calibration file), and
// the mapping controls the sources and recipes set: method, relative
// mapping, eq. (8) and eq. (9) together.

import { $ } from './dom.js';
import { ApiError } from './api.js';
import { emit } from './hub.js';
import { showError } from './messages.js';
import { state } from './state.js';
import { dataRows } from './validation.js';

const scheduleVoltage = () => emit('schedule-voltage');

/** Whether the electrovibration display is selected (eq. 9 and the compensation are its). */
export const isElectrovibration = () => state.display === 'electrovibration';
/** Whether the display selected can be checked on the finger model (electrovibration, combined). */
export const isCheckable = () => state.display === 'electrovibration' || state.display === 'combined';

/** Selects a mapping method (its radio button too). */
export function setMethod(id) {
  state.method = id;
  const input = document.querySelector(`input[name="method"][value="${id}"]`);
  if (input) input.checked = true;
}

/** Draws eq. (8) and eq. (9) together (Fig. 2b) or only the method chosen (its checkbox too). */
export function setBoth(on) {
  state.both = on;
  $('both-methods').checked = on;
}

/** Sets the relative mapping (its checkbox too) and the flat-surface friction shown. */
export function setRelative(on, flatMu) {
  state.relative = on;
  $('relative').checked = on;
  $('flat-mu').value = flatMu;
  $('flat-mu').disabled = !on;
  $('flat-mu').dispatchEvent(new Event('explain'));
}

/**
 * The display selector, the strategy, the weight, a_max and the calibration
 * upload. `chosen()` is called when the user chooses a display (before the
 * voltage is asked again): the source's mapping for that display.
 */
export function buildDisplayControls(config, chosen) {
  const box = $('display-select');
  (config.displays || []).forEach((d) => {
    const label = document.createElement('label');
    label.title = d.description;
    const input = document.createElement('input');
    Object.assign(input, { type: 'radio', name: 'display', value: d.id, checked: d.id === state.display });
    // Chosen by the user: the source's mapping for that display too.
    input.addEventListener('change', () => {
      setDisplay(d.id);
      chosen();
      scheduleVoltage();
    });
    label.append(input, d.label);
    box.append(label);
  });
  const select = $('strategy');
  (config.strategies || []).forEach((st) => {
    const option = document.createElement('option');
    option.value = st.id;
    option.textContent = st.label;
    option.title = st.description;
    select.append(option);
  });
  select.value = state.strategy;
  select.addEventListener('change', () => { state.strategy = select.value; showDisplayControls(); scheduleVoltage(); });
  const us = config.ultrasonic || {};
  $('weight').placeholder = String(us.default_weight ?? 1);
  $('a-max').placeholder = `calibration's last amplitude, or ${us.literature_a_max_um ?? 2.3}`;
  $('weight').addEventListener('input', scheduleVoltage);
  $('a-max').addEventListener('input', scheduleVoltage);
  $('calibration').addEventListener('change', () => readCalibration().catch(showError));
  $('clear-calibration').addEventListener('click', () => {
    state.calibration = null;
    $('calibration').value = '';
    showDisplayControls();
    scheduleVoltage();
  });
  showDisplayControls();
}

/** Selects a display (its radio button too). */
export function setDisplay(id) {
  state.display = id;
  const input = document.querySelector(`input[name="display"][value="${id}"]`);
  if (input) input.checked = true;
  showDisplayControls();
  emit('show-check');
}

/** Shows the controls of the selected display and what it does with the others. */
export function showDisplayControls() {
  const ev = isElectrovibration();
  $('display-options').hidden = ev;
  $('strategy-row').hidden = state.display !== 'combined';
  $('weight-row').hidden = state.display !== 'combined' || state.strategy !== 'weighted';
  const strategy = (state.config.strategies || []).find((st) => st.id === state.strategy);
  $('strategy-info').textContent = strategy ? strategy.description : '';
  // eq. (9) and the compensation are the electrovibration display's; the
  // check on the finger model is also the combined display's.
  document.querySelectorAll('input[name="method"]').forEach((input) => { input.disabled = !ev; });
  $('run-check').disabled = !isCheckable();
  $('run-compensate').disabled = !ev;
  $('both-methods').disabled = !ev;
  $('display-info').textContent = ev
    ? 'Electrovibration only raises friction above μ_HD.'
    : 'Method: physical (eq. 9 is the electrovibration display\'s pattern); the compensation on the finger model ' +
      'is for the electrovibration display' +
      (isCheckable() ? '; the check applies this design to the finger on the vibrating plate.' : ', its check ' +
        'for the electrovibration and combined displays.');
  $('calibration-info').textContent = state.calibration
    ? `${state.calibration.name}: ${state.calibration.rows} rows (the server checks them: strictly increasing ` +
      'amplitudes from 0, relative friction strictly decreasing from 1).'
    : 'No calibration: the literature default stands in (a placeholder, not this device).';
}

/** Reads the calibration file chosen (the server checks it with the voltage). */
export async function readCalibration() {
  const file = $('calibration').files[0];
  if (!file) return;
  const max = (state.config.ultrasonic || {}).max_calibration_bytes;
  if (max && file.size > max) {
    $('calibration').value = '';
    throw new ApiError(`${file.name} is ${file.size} bytes, more than the limit of ${max}`, 'ultrasonic_calibration', 0);
  }
  const text = await file.text();
  state.calibration = { name: file.name, text, rows: dataRows(text) };
  showDisplayControls();
  scheduleVoltage();
}
