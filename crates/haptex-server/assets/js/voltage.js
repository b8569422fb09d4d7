// The voltage of the design shown (POST /api/voltage, debounced as the
// controls change): when it answers, the plots, the summaries, the check,
// the feel strip and the haptex:voltage event (for "Your display") follow.

import { postJson } from './api.js';
import { otherMethod } from './answers.js';
import { showCheck } from './check.js';
import { isElectrovibration } from './displays.js';
import { DESIGN_FIELDS, blocked, clearServerErrors } from './feedback.js';
import { draw } from './figures.js';
import { on } from './hub.js';
import { say, showError } from './messages.js';
import { voltageBody } from './requests.js';
import { state } from './state.js';
import { drawStrip, showStroke } from './strip.js';
import { showRelative, showSummary } from './summary.js';
import { showWhy } from './why.js';

let voltageTimer = null;
let voltageRequest = 0;

/** Asks for the voltage of the design shown in 60 ms (the latest of the changes in that time). */
export function scheduleVoltage() {
  clearTimeout(voltageTimer);
  voltageTimer = setTimeout(() => updateVoltage().catch(showError), 60);
}

/**
 * Asks the server the voltage of the design shown (and the other method's
 * beside it when both are drawn), then draws and summarises the answer.
 */
export async function updateVoltage() {
  if (!state.profile) return;
  // A field refused as typed (red, beside it) blocks the design: nothing is sent.
  if (blocked(DESIGN_FIELDS).length) {
    voltageRequest += 1; // an answer still on its way is stale too
    return;
  }
  const id = ++voltageRequest;
  const both = state.both && isElectrovibration();
  const [answer, companion] = await Promise.all([
    postJson('/api/voltage', voltageBody()).then((r) => r.json()),
    both ? postJson('/api/voltage', voltageBody(otherMethod(state.method))).then((r) => r.json()) : null,
  ]);
  if (id !== voltageRequest) return; // a newer request is on its way
  state.voltage = answer;
  state.companion = companion;
  state.drawn = state.profile;
  clearServerErrors();
  draw();
  showSummary();
  showRelative();
  showWhy();
  showStroke();
  showCheck();
  drawStrip();
  document.dispatchEvent(new CustomEvent('haptex:voltage', { detail: answer }));
  state.updates += 1;
  document.body.dataset.updates = String(state.updates);
  document.body.dataset.state = 'ready';
  const s = answer.summary;
  const how = s.display
    ? `display ${s.display}${s.strategy ? `, strategy ${s.strategy}` : ''}`
    : `method ${s.method}`;
  say(`${state.profile.label}: ${s.n_points} points, ${how}` +
    `${s.relative ? ', relative to the flat-surface friction (Fig. 2)' : ''}.`);
  if (state.pendingError) {
    showError(state.pendingError);
    state.pendingError = null;
  }
}

on('schedule-voltage', scheduleVoltage);
