// One sentence above the plots: which display the design is for and why
// (a source's default, or the user's choice), with the other displays one
// click away.

import { $ } from './dom.js';
import { fmt } from './format.js';
import { state } from './state.js';

const NAMES = {
  electrovibration: 'Electrovibration display',
  ultrasonic: 'Ultrasonic display',
  combined: 'Combined display',
};

/** What the profile is, in the page's words. */
function what() {
  if (state.source === 'template') return `the ${state.template.surface}`;
  if (state.source === 'library' && state.profile.material) return state.profile.material;
  return 'this profile';
}

/** The sentence for the design shown. */
export function whySentence() {
  const s = state.voltage.summary;
  const d = state.display;
  const name = NAMES[d] || d;
  const range = `${fmt(s.mu_min)} – ${fmt(s.mu_max)}`;
  const muHd = `μ_HD = ${fmt(s.mu_hd)}`;
  if (d === 'electrovibration' && s.relative && state.both) {
    return `${name}, as in the paper's Fig. 2: ${what()}'s friction relative to its flat-surface friction ` +
      `(μ / μ_flat · μ_HD), eq. (8) beside eq. (9).`;
  }
  const chosen = state.displayChosen ? ' (your choice)' : '';
  if (d === 'electrovibration') {
    return s.mu_min >= s.mu_hd
      ? `${name}${chosen}: ${what()}'s friction (${range}) lies above the display's own ${muHd}, which the voltage raises.`
      : `${name}${chosen}: the voltage only raises friction above the display's own ${muHd}; ${what()}'s friction ` +
        `(${range}) goes below it, where nothing is rendered (0 V).`;
  }
  if (d === 'ultrasonic') {
    return s.mu_max <= s.mu_hd
      ? `${name}${chosen}: ${what()}'s friction (${range}) lies below the display's own ${muHd}, which only the ` +
        'plate\'s vibration lowers.'
      : `${name}${chosen}: the plate only lowers friction below the display's own ${muHd}; ${what()}'s friction ` +
        `(${range}) goes above it, which only a voltage renders.`;
  }
  return `${name}${chosen}: ${what()}'s friction (${range}) is rendered around the display's own ${muHd}: the ` +
    'plate\'s vibration below it, the voltage above.';
}

/** Shows the sentence and a button for each other display (the display selector's own choice). */
export function showWhy() {
  const box = $('design-why');
  box.textContent = '';
  if (!state.voltage) return;
  box.append(`${whySentence()} `);
  const others = (state.config.displays || []).filter((d) => d.id !== state.display);
  if (!others.length) return;
  box.append('Other displays:');
  others.forEach((d) => {
    const b = document.createElement('button');
    Object.assign(b, { type: 'button', className: 'small', textContent: d.label, title: d.description });
    b.dataset.display = d.id;
    b.addEventListener('click', () => {
      const radio = document.querySelector(`input[name="display"][value="${d.id}"]`);
      if (radio) radio.click();
    });
    box.append(' ', b);
  });
}
