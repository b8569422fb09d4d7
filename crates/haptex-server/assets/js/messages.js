// The page's message line (the header's status): say() a line, and
// showError() an error there, its field outlined (aria-invalid) and the
// API's display field names in the page's words; a panel that owns the
// field may take the error first (the cancelable haptex:error event).

import { $ } from './dom.js';
import { ApiError } from './api.js';
import { clearInvalid, fieldInput } from './fields.js';
import { state } from './state.js';

export function say(text, isError = false) {
  const el = $('message');
  el.textContent = text;
  el.classList.toggle('error', isError);
}

/** The page's name of the display fields (the server names the API's fields). */
export const DISPLAY_FIELDS = {
  display: 'Display',
  strategy: 'Strategy (Display)',
  weight: 'Weight w (Display)',
  a_max_um: 'a_max (Display)',
  ultrasonic_calibration: 'Ultrasonic calibration (Display)',
};

export function showError(error) {
  clearInvalid();
  // A panel that owns the field shows the error beside its control (display-calibration.js).
  if (error instanceof ApiError && error.field &&
      !document.dispatchEvent(new CustomEvent('haptex:error', { detail: error, cancelable: true }))) return;
  if (error instanceof ApiError) {
    const name = error.field ? error.field.replace(/^device\./, '') : null;
    const input = name ? fieldInput(name) : null;
    if (input) input.setAttribute('aria-invalid', 'true');
    if (name && DISPLAY_FIELDS[name]) {
      // A calibration error names the line and column of the file chosen.
      const message = name === 'ultrasonic_calibration' && state.calibration
        ? error.message.replace(/^ultrasonic_calibration/, state.calibration.name) : error.message;
      say(`${DISPLAY_FIELDS[name]}: ${message}`, true);
      return;
    }
    say(error.field ? `${error.field}: ${error.message}` : error.message, true);
  } else {
    say(String(error && error.message ? error.message : error), true);
    console.error(error);
  }
}
