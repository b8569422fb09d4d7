// Feedback beside the control that caused it: a field's refusal (red,
// under the field, the request not sent) or the server's, in the page's
// words; an action's status beside its button; and bringing either into
// view when it lies outside the window (a phone's long column, the
// desktop's scrolling results).
//
// Every numeric field of the controls is checked as it is typed against
// its range (its min and max, set from GET /api/config where the server
// has them), so that nothing the server would refuse or ignore is sent
// or silently dropped: `blocked(scope)` says which fields of a part of the
// page stand in the way of its request.

import { $ } from './dom.js';
import { refusal } from './validation.js';

/** The parts of the page whose fields make the design (its voltage request). */
export const DESIGN_FIELDS = '#source-box, #method-box, #display-box, #device-box';

/** The name the page shows for a field: its data-label, else its label's text less the unit. */
export function fieldLabel(input) {
  if (input.dataset.label) return input.dataset.label;
  if (input.type === 'file' && input.files && input.files[0]) return input.files[0].name;
  const label = input.id ? document.querySelector(`label[for="${input.id}"]`) : null;
  if (!label) return input.name || input.id;
  const copy = label.cloneNode(true);
  copy.querySelectorAll('.unit, output, input').forEach((e) => e.remove());
  return copy.textContent.replace(/\s*\([^)]*\)\s*$/, '').replace(/\s+/g, ' ').trim();
}

/** The unit of a field for its messages: its data-unit, else its label's unit note without brackets. */
function fieldUnit(input) {
  if (input.dataset.unit !== undefined) return input.dataset.unit;
  const unit = input.id ? document.querySelector(`label[for="${input.id}"] .unit`) : null;
  return unit ? unit.textContent.replace(/[()]/g, '').replace(/,.*$/, '').trim() : '';
}

/** The element under `input` that holds its error (made on first use; the map page's fields too). */
export function errorNote(input) {
  const id = `${input.id}-error`;
  let note = $(id);
  if (!note) {
    note = document.createElement('p');
    note.id = id;
    note.className = 'field-error';
    note.setAttribute('role', 'alert');
    note.hidden = true;
    input.insertAdjacentElement('afterend', note);
    const described = (input.getAttribute('aria-describedby') || '').split(' ').filter(Boolean);
    input.setAttribute('aria-describedby', [id, ...described].join(' '));
  }
  return note;
}

/**
 * Shows `text` as the refusal of `input`, under it, and outlines it.
 * `origin` is 'typed' (the page's own check, cleared when the value is
 * fixed) or 'server' (cleared by the next answer).
 */
export function setFieldError(input, text, origin = 'server') {
  const note = errorNote(input);
  note.textContent = text;
  note.dataset.origin = origin;
  note.hidden = false;
  input.setAttribute('aria-invalid', 'true');
}

/** Removes the refusal of `input` (of either origin). */
export function clearFieldError(input) {
  const note = input.id ? $(`${input.id}-error`) : null;
  if (note) {
    note.hidden = true;
    note.textContent = '';
  }
  input.removeAttribute('aria-invalid');
}

/** Removes the server's refusals (its next answer replaces them); the page's own stay until fixed. */
export function clearServerErrors() {
  document.querySelectorAll('.field-error[data-origin="server"]').forEach((note) => {
    const input = $(note.id.replace(/-error$/, ''));
    if (input) clearFieldError(input);
  });
}

/** Whether the page checks `input` as it is typed: the controls' number fields. */
function checked(input) {
  return input instanceof HTMLInputElement && input.type === 'number' && Boolean(input.closest('#controls'));
}

/** What is wrong with the value of `input`, or null. */
function problem(input) {
  const min = input.min === '' ? -Infinity : Number(input.min);
  const max = input.max === '' ? Infinity : Number(input.max);
  return refusal(input.value, {
    label: fieldLabel(input),
    unit: fieldUnit(input),
    min,
    max,
    integer: input.step === '1',
    optional: input.dataset.optional === 'true' || input.placeholder !== '',
    badInput: input.validity.badInput,
  });
}

/** Checks `input` as typed: its refusal shown or cleared. Returns the refusal or null. */
export function validateField(input) {
  if (!checked(input) || input.disabled) return null;
  const text = problem(input);
  if (text) setFieldError(input, text, 'typed');
  else clearFieldError(input);
  return text;
}

/**
 * The fields in `scope` (a CSS selector of parts of the page) that are
 * refused, each checked again: [{input, text}], shown fields only.
 */
export function blocked(scope) {
  const found = [];
  document.querySelectorAll(scope).forEach((part) => {
    part.querySelectorAll('input[type="number"]').forEach((input) => {
      if (!input.getClientRects().length) return; // an option hidden is not sent
      const text = validateField(input);
      if (text) found.push({ input, text });
    });
  });
  return found;
}

/** An action's status beside its button: `text`, red when `isError`. */
export function setStatus(el, text, isError = false) {
  el.textContent = text;
  el.classList.add('action-status');
  el.classList.toggle('error', isError);
}

/**
 * Brings `el` into view when it is outside the window (smoothly, as a
 * user scrolls): the results column on a desktop, the page on a phone.
 */
export function bringIntoView(el) {
  if (!el || !el.getClientRects().length) return;
  const r = el.getBoundingClientRect();
  if (r.bottom > 0 && r.top < window.innerHeight) {
    // In the window, but maybe not in its scrolling column.
    const column = el.closest('.results');
    if (!column) return;
    const c = column.getBoundingClientRect();
    if (r.bottom > c.top && r.top < c.bottom) return;
  }
  el.scrollIntoView({ block: 'nearest' });
}

/** Checks every field of the controls as it is typed (before the field's own handler acts on it). */
export function setupFieldChecks() {
  const controls = $('controls');
  const check = (e) => { if (checked(e.target)) validateField(e.target); };
  controls.addEventListener('input', check, true);
  controls.addEventListener('change', check, true);
}
