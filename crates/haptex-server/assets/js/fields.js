// The helpers that read and outline inputs: the number in a field, the
// device parameters typed in, the error outline (aria-invalid) and the
// server's explanation under a parameter (symbol, meaning, typical range,
// source), which turns to the warning style outside the typical range.

import { $ } from './dom.js';
import { deviceFrom, parseNumber, typicalNote } from './validation.js';

/** The control of an API field name (a device parameter or another field), or null. */
export function fieldInput(name) {
  return document.querySelector(`[data-param="${name}"], [data-field="${name}"]`);
}

/** The number typed in field `id`, or null when it is empty (NaN when it is not a number). */
export function numberIn(id) {
  return parseNumber($(id).value);
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
    const typical = typicalNote(e, input.value);
    const { outside } = typical;
    head.textContent = typical.head;
    range.textContent = typical.range;
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
  return deviceFrom(Array.from(document.querySelectorAll('[data-param]'), (input) => [input.dataset.param, input.value]));
}
