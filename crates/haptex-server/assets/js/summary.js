// The text beside the plots: the summary of the voltage answer (range,
// clipped and not renderable regions, the display's band and channels),
// the server's warnings in the page's words, the note under the relative
// checkbox, and the one-click ways out of a flat 0 V.

import { $ } from './dom.js';
import { equation } from './answers.js';
import { setDisplay, setMethod, setRelative, showDisplayControls } from './displays.js';
import { fmt, pct } from './format.js';
import { emit } from './hub.js';
import { state } from './state.js';

const scheduleVoltage = () => emit('schedule-voltage');

/** The note under the relative checkbox: mu_flat and where it came from. */
export function showRelative() {
  const r = state.voltage && state.voltage.summary.relative;
  const note = $('relative-info');
  if (!r) {
    note.textContent = state.relative ? '' : 'Off: the profile is mapped as it is.';
    return;
  }
  const origin = r.flat_mu_source === 'median'
    ? 'the median of the profile, an estimate: give it when it is known'
    : state.source === 'template' && state.templates && r.flat_mu === state.templates.fe.mu_skin
      ? 'the FE finger\'s skin friction, Ft/Fn on a flat surface'
      : 'given';
  note.textContent = `μ = μ of the profile / ${fmt(r.flat_mu)} · ${fmt(r.mu_hd)} (μ_flat: ${origin}).`;
}

/** The warnings of the answer as the page names its controls (page_warnings). */
export function showWarnings(box) {
  const warnings = state.voltage.page_warnings || state.voltage.summary.warnings;
  if (!warnings.length) return;
  const list = document.createElement('ul');
  warnings.forEach((w) => {
    const item = document.createElement('li');
    item.className = 'warning';
    item.textContent = w;
    list.append(item);
  });
  box.append(list);
}

/** The summary of an ultrasonic or combined display: band, channels, regions. */
export function showDisplaySummary(box, s) {
  const line = (id, text) => {
    const div = document.createElement('div');
    div.id = id;
    div.textContent = text;
    box.append(div);
  };
  line('summary-band', `${s.display} display${s.strategy ? ` (${s.strategy})` : ''}: renderable band ` +
    `mu ${fmt(s.band_mu[0])} .. ${fmt(s.band_mu[1])} · ${s.relative ? 'relative ' : ''}mu ${fmt(s.mu_min)} .. ` +
    `${fmt(s.mu_max)} · mu_HD ${fmt(s.mu_hd)}`);
  const ev = s.electrovibration;
  if (ev) {
    line('summary-voltage', `U ${fmt(ev.voltage_min_v)} .. ${fmt(ev.voltage_max_v)} V RMS (U_max ${fmt(ev.u_max_v)} V)` +
      ` · Fe/Fn = ${ev.fe_over_fn_per_v2.toExponential(4)} U²`);
  }
  const us = s.ultrasonic;
  const model = us.source === 'calibration'
    ? `calibration ${state.calibration ? state.calibration.name : us.calibration_file}`
    : 'literature default (a placeholder: upload a calibration of your plate)';
  line('summary-amplitude', `a ${fmt(us.amplitude_min_um)} .. ${fmt(us.amplitude_max_um)} µm (a_max ` +
    `${fmt(us.a_max_um)} µm; saturation rho_min = ${fmt(us.relative_friction_min)}) · ${model}`);
  if (s.bias) {
    line('summary-bias', `bias level: a = ${fmt(s.bias.amplitude_um)} µm (rho = ${fmt(s.bias.relative_friction)})` +
      ` · lowered below it: ${pct(s.bias.lowered.fraction_of_length)} of the length`);
  }
  line('summary-regions', `above the band: ${pct(s.above_band.fraction_of_length)} of the length · below the ` +
    `band: ${pct(s.below_band.fraction_of_length)}`);
  showWarnings(box);
  // Split on a profile below mu_HD everywhere (a template's physical
  // values): the plate renders all of it and U is 0 V. Say so, and offer
  // the strategy that puts the detail on the voltage.
  if (ev && s.strategy === 'split' && ev.voltage_max_v === 0) {
    const way = document.createElement('div');
    way.className = 'way-out';
    way.id = 'summary-plate-only';
    way.append('U = 0 V: the profile lies below mu_HD everywhere, so the split strategy renders all of it with ' +
      'the plate. One click: ');
    const b = document.createElement('button');
    Object.assign(b, { type: 'button', id: 'way-out-bias', className: 'small',
      textContent: 'bias (a constant plate level, the detail on the voltage)' });
    b.addEventListener('click', () => {
      state.strategy = 'bias';
      $('strategy').value = 'bias';
      showDisplayControls();
      scheduleVoltage();
    });
    way.append(b);
    box.append(way);
  }
}

/** The summary under the plots: the voltage's range, its regions, the warnings and the ways out of 0 V. */
export function showSummary() {
  const s = state.voltage.summary;
  const box = $('summary');
  box.textContent = '';
  if (s.display) {
    showDisplaySummary(box, s);
    return;
  }
  const line = document.createElement('div');
  line.textContent = `${equation(s)}: U ${fmt(s.voltage_min_v)} .. ${fmt(s.voltage_max_v)} V RMS ` +
    `(U_max ${fmt(s.u_max_v)} V) · ${s.relative ? 'relative ' : ''}mu ${fmt(s.mu_min)} .. ${fmt(s.mu_max)}` +
    (s.fe_over_fn_per_v2 ? ` · Fe/Fn = ${s.fe_over_fn_per_v2.toExponential(4)} U²` : '');
  box.append(line);
  if (s.method === 'physical') {
    const regions = document.createElement('div');
    regions.textContent = `clipped at U_max: ${pct(s.clipped.fraction_of_length)} of the length · ` +
      `mu_RS < mu_HD (not renderable, 0 V): ${pct(s.not_renderable.fraction_of_length)}`;
    box.append(regions);
  }
  if (state.companion) {
    const c = state.companion.summary;
    const other = document.createElement('div');
    other.textContent = `${equation(c)} beside it (dashed): U ${fmt(c.voltage_min_v)} .. ${fmt(c.voltage_max_v)} V RMS`;
    box.append(other);
  }
  // The server's warnings with the page's controls named, not the command line's flags.
  showWarnings(box);
  // A flat 0 V line is not a signal: say why, and offer the one-click ways out.
  if (s.method === 'physical' && s.not_renderable.fraction_of_length >= 1) {
    const way = document.createElement('div');
    way.className = 'way-out';
    way.append('U = 0 V everywhere (the profile never rises above mu_HD). One click: ');
    const button = (id, text, action) => {
      const b = document.createElement('button');
      Object.assign(b, { type: 'button', id, textContent: text, className: 'small' });
      b.addEventListener('click', () => { action(); scheduleVoltage(); });
      return b;
    };
    way.append(button('way-out-normalized', 'the pattern: normalized (eq. 9)', () => setMethod('normalized')));
    way.append(' ', button('way-out-combined', 'the combined display (ultrasonic below mu_HD)',
      () => setDisplay('combined')));
    if (!state.relative) {
      way.append(' ', button('way-out-relative', 'relative to its flat-surface friction (Fig. 2)',
        () => setRelative(true, '')));
    }
    box.append(way);
  }
}
