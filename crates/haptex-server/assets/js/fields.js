// The helpers that read and outline inputs: the number in a field, the
// device parameters typed in, the error outline (aria-invalid) and the
// server's explanation under a parameter (symbol, meaning, typical range,
// source), which turns to the warning style outside the typical range.

import { $ } from './dom.js';
import { fmt } from './format.js';

/** Removes every field's error outline (aria-invalid). */
export function clearInvalid() {
  document.querySelectorAll('[aria-invalid="true"]').forEach((el) => el.removeAttribute('aria-invalid'));
}

/** The control of an API field name (a device parameter or another field), or null. */
export function fieldInput(name) {
  return document.querySelector(`[data-param="${name}"], [data-field="${name}"]`);
}

/** The number typed in field `id`, or null when it is empty (NaN when it is not a number). */
export function numberIn(id) {
  const text = $(id).value.trim();
  return text === '' ? null : Number(text);
}

/**
 * Puts the server's explanation of a parameter (GET /api/config,
 * `explanations`) under its control: symbol, unit, meaning, typical range
 * and source; the control and the note turn to the warning style while the
 * value is outside the typical range (as the template sliders do outside
 * the FE database).
 */
export function explain(e) {
  const input = fieldInput(e.field);
  if (!input) return;
  const unit = e.unit ? ` ${e.unit}` : '';
  const note = document.createElement('p');
  note.className = 'explain';
  note.id = `explain-${e.field}`;
  const head = document.createElement('span');
  const range = document.createElement('span');
  range.className = 'typical';
  const source = document.createElement('span');
  source.className = 'source';
  source.textContent = ` Source: ${e.source}.`;
  note.append(head, range, source);
  input.dataset.explained = e.field;
  input.setAttribute('aria-describedby', note.id);
  input.insertAdjacentElement('afterend', note);
  const show = () => {
    const text = input.value.trim();
    const v = text === '' ? NaN : Number(text);
    const outside = e.typical !== null && Number.isFinite(v) && (v < e.typical.min || v > e.typical.max);
    head.textContent = `${e.symbol}${e.unit ? ` (${e.unit})` : ' (no unit)'}: ${e.meaning}. `;
    range.textContent = e.typical === null
      ? 'No typical range sourced.'
      : `${outside ? 'Outside the typical range' : 'Typical'} ${fmt(e.typical.min)} .. ${fmt(e.typical.max)}${unit}` +
        `${outside ? ` (accepted ${fmt(e.accepted.min)} .. ${fmt(e.accepted.max)}${unit})` : ''}.`;
    note.classList.toggle('outside', outside);
    input.classList.toggle('outside', outside);
  };
  input.addEventListener('input', show);
  input.addEventListener('explain', show);
  show();
}

/**
 * The device parameters typed in, as {name: number}; empty fields are left
 * out (they take the server's default).
 */
export function readDevice() {
  const device = {};
  document.querySelectorAll('[data-param]').forEach((input) => {
    const text = input.value.trim();
    if (text !== '') device[input.dataset.param] = Number(text);
  });
  return device;
}
