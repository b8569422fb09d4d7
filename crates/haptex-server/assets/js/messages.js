// The page's message line (the header's status) and errors: say() a
// line there; showError() puts an error beside the field or the button it
// belongs to, in the page's words, and in the header only when it belongs
// to neither.

import { $ } from './dom.js';
import { ApiError } from './api.js';
import { bringIntoView, fieldLabel, setFieldError, setStatus } from './feedback.js';
import { fieldInput } from './fields.js';
import { state } from './state.js';
import { inPageWords } from './validation.js';

export function say(text, isError = false) {
  const el = $('message');
  el.textContent = text;
  el.classList.toggle('error', isError);
}

/**
 * Shows an error where the user looks: beside the field at fault (the
 * server names it; the page shows it by its label) or, for an error of no
 * field, in `status` (the status line beside the button that asked);
 * only an error of neither goes to the header. The message is in the
 * page's words (inPageWords). A panel that owns the field may take the
 * error first (the cancelable haptex:error event, "Your display").
 */
export function showError(error, { status = null, file = null } = {}) {
  // A panel that owns the field shows the error beside its control (display-calibration.js).
  if (error instanceof ApiError && error.field &&
      !document.dispatchEvent(new CustomEvent('haptex:error', { detail: error, cancelable: true }))) return;
  if (!(error instanceof ApiError)) {
    const text = String(error && error.message ? error.message : error);
    console.error(error);
    if (status) { setStatus(status, text, true); bringIntoView(status); } else say(text, true);
    return;
  }
  const name = error.field ? error.field.replace(/^device\./, '') : null;
  const input = name ? fieldInput(name) : null;
  if (input && input.getClientRects().length) {
    const calibration = name === 'ultrasonic_calibration' && state.calibration ? state.calibration.name : null;
    const text = inPageWords(error.message, { field: error.field, label: calibration || fieldLabel(input), file });
    setFieldError(input, text);
    if (status) setStatus(status, `Refused: ${text}`, true);
    bringIntoView(status || input);
    return;
  }
  const text = inPageWords(error.message, { field: error.field, file });
  if (status) {
    setStatus(status, text, true);
    bringIntoView(status);
  } else {
    say(text, true);
  }
}
