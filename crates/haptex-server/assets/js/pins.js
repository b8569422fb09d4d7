// Pinned designs: the design shown kept (friction, voltages, amplitude,
// the friction the finger felt) and drawn under the next ones on the same
// axes, at most MAX_PINS, each with its colour and its name P1, P2, …

import { $ } from './dom.js';
import { ApiError } from './api.js';
import { checkTrial, equation } from './answers.js';
import { currentCheck, showCheck } from './check.js';
import { PIN_COLORS } from './colours.js';
import { draw } from './figures.js';
import { fmt } from './format.js';
import { say } from './messages.js';
import { state } from './state.js';

/** At most this many pinned designs (the plots stay readable). */
export const MAX_PINS = 6;
let pinCounter = 0;

/** What the design shown is, in the page's words: source, method or display, mapping, device changes. */
function designLabel() {
  const s = state.voltage.summary;
  const how = s.display
    ? `${s.display} display${s.strategy ? ` (${s.strategy})` : ''}`
    : `${equation(s)}${state.companion ? ` and ${equation(state.companion.summary)}` : ''}`;
  const changed = state.config.device_params
    .filter((p) => state.device[p.name] !== undefined && state.device[p.name] !== p.default)
    .map((p) => {
      const e = (state.config.explanations || []).find((x) => x.field === p.name);
      return `${e ? e.symbol : p.name} ${fmt(state.device[p.name])}${p.unit ? ` ${p.unit}` : ''}`;
    });
  return `${state.drawn.label} · ${how}${s.relative ? `, relative (mu_flat ${fmt(s.relative.flat_mu)})` : ''}` +
    (changed.length ? ` · ${changed.join(', ')}` : '');
}

/**
 * Pins the design shown: its friction profile as plotted, its voltage(s)
 * (eq. 8 and eq. 9 when both are drawn), its amplitude a(x) and the
 * friction the finger model felt when a check is current; the next
 * designs are drawn over it on the same axes.
 */
export function pinDesign() {
  const v = state.voltage;
  if (!v) throw new ApiError('nothing to pin yet', null, 0);
  if (state.pins.length >= MAX_PINS) {
    throw new ApiError(`at most ${MAX_PINS} pinned designs: remove one first`, null, 0);
  }
  pinCounter += 1;
  const name = `P${pinCounter}`;
  const s = v.summary;
  const voltages = [];
  if (v.voltage_v) voltages.push({ label: s.display ? 'U(x)' : `U ${equation(s)}`, data: v.voltage_v, dash: false });
  const c = state.companion;
  if (c && c.voltage_v.length === v.x_mm.length) {
    voltages.push({ label: `U ${equation(c.summary)}`, data: c.voltage_v, dash: true });
  }
  const check = currentCheck();
  let felt = null;
  if (check) {
    const r = check.result;
    const comp = r.compensated;
    const first = checkTrial(r);
    felt = { x_mm: r.x_mm, mu: comp ? comp.felt_mu : first.felt_mu, label: comp ? 'felt, compensated' : `felt, ${first.name}` };
  }
  state.pins.push({
    name,
    color: PIN_COLORS[(pinCounter - 1) % PIN_COLORS.length],
    label: designLabel(),
    x_mm: v.x_mm,
    mu: v.mu,
    voltages,
    amplitude: v.amplitude_um || null,
    // A template's surface, drawn on the h(x) plot with the next designs'.
    h: state.drawn && state.drawn.h_mm && state.drawn.h_mm.length === v.x_mm.length ? state.drawn.h_mm : null,
    felt,
  });
  showPins();
  draw();
  showCheck();
  say(`Pinned ${name}: the next designs are drawn over it.`);
}

function unpin(name) {
  state.pins = state.pins.filter((p) => p.name !== name);
  showPins();
  if (state.voltage) { draw(); showCheck(); }
  say(`Removed ${name}.`);
}

/** The list of pinned designs: colour, name, what it is, and its remove button. */
export function showPins() {
  const list = $('pins');
  list.textContent = '';
  state.pins.forEach((p) => {
    const item = document.createElement('li');
    item.dataset.pin = p.name;
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = p.color;
    swatch.setAttribute('aria-hidden', 'true');
    const text = document.createElement('span');
    text.className = 'pin-label';
    text.textContent = `${p.name}: ${p.label}`;
    const remove = document.createElement('button');
    Object.assign(remove, { type: 'button', className: 'small remove-pin', textContent: 'remove' });
    remove.setAttribute('aria-label', `remove pinned design ${p.name}`);
    remove.addEventListener('click', () => unpin(p.name));
    item.append(swatch, text, remove);
    list.append(item);
  });
  $('unpin-all').hidden = state.pins.length < 2;
  $('pin-design').disabled = state.pins.length >= MAX_PINS;
  $('pins-info').textContent = state.pins.length
    ? `${state.pins.length} pinned (of at most ${MAX_PINS}); the legends name them P1, P2, …`
    : `Pin a design to compare the next ones with it on the same axes (up to ${MAX_PINS}).`;
}

/** Removes every pinned design. */
export function unpinAll() {
  state.pins = [];
  showPins();
  if (state.voltage) { draw(); showCheck(); }
}
