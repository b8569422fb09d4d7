// The feel strip: the voltage played (and the plate's amplitude) along the
// profile as brightness, followed by a mouse, pen, finger or the keyboard,
// with the reading, the browser's audio output and the live output
// following the position; and the stroke's length and duration.

import { $ } from './dom.js';
import { uMaxOf } from './answers.js';
import { createAudio } from './audio.js';
import { played } from './check.js';
import { fmt } from './format.js';
import { on } from './hub.js';
import { interpolate } from './interpolate.js';
import { live } from './live.js';
import { say } from './messages.js';
import { state } from './state.js';

/** The velocity and how long one stroke over the profile takes. */
export function showStroke() {
  $('velocity-out').textContent = `${state.velocity} mm/s`;
  const p = state.profile;
  if (!p) { $('stroke-info').textContent = ''; return; }
  const length = p.x_mm[p.x_mm.length - 1] - p.x_mm[0];
  $('stroke-info').textContent =
    `One stroke over the profile: ${fmt(length)} mm at ${state.velocity} mm/s takes ${fmt(length / state.velocity)} s.`;
}

/** U at x by linear interpolation in the played voltage profile (held at the ends; 0 V without voltage). */
function voltageAt(x) {
  const v = played();
  return v.voltage_v ? interpolate(v.x_mm, v.voltage_v, x) : 0;
}

/** a at x (µm) in the played display profile, null without an ultrasonic channel. */
function amplitudeAt(x) {
  const v = played();
  return v.amplitude_um ? interpolate(v.x_mm, v.amplitude_um, x) : null;
}

/** The strip's marker (px), its position (0 .. 1) and whether a button, pen, finger or key is down. */
const strip = { marker: null, fraction: null, contact: false };

/** Draws the strip: U as brightness (and a(x) in blue below), with the marker. */
export function drawStrip() {
  live.follow();
  const canvas = $('feel-strip');
  const ratio = window.devicePixelRatio || 1;
  const width = canvas.clientWidth;
  const height = canvas.clientHeight;
  canvas.width = Math.round(width * ratio);
  canvas.height = Math.round(height * ratio);
  const ctx = canvas.getContext('2d');
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.fillStyle = '#111';
  ctx.fillRect(0, 0, width, height);
  if (!state.voltage) return;
  const v = played();
  const xs = v.x_mm;
  const x0 = xs[0];
  const span = xs[xs.length - 1] - x0;
  const uMax = uMaxOf(v);
  // With an ultrasonic channel the lower third shows a(x) in blue (brighter: more vibration, less friction).
  const aMax = v.amplitude_um ? v.summary.ultrasonic.a_max_um : null;
  const top = aMax ? Math.round(height * 2 / 3) : height;
  for (let px = 0; px < width; px += 1) {
    const xAt = x0 + (px + 0.5) / width * span;
    const u = voltageAt(xAt);
    const level = Math.round(30 + 225 * (uMax ? Math.min(1, u / uMax) : 0));
    ctx.fillStyle = `rgb(${level}, ${Math.round(level * 0.82)}, ${Math.round(level * 0.45)})`;
    ctx.fillRect(px, 0, 1, top);
    if (aMax) {
      const b = Math.round(30 + 225 * Math.min(1, amplitudeAt(xAt) / aMax));
      ctx.fillStyle = `rgb(${Math.round(b * 0.3)}, ${Math.round(b * 0.75)}, ${b})`;
      ctx.fillRect(px, top, 1, height - top);
    }
  }
  if (strip.marker !== null) {
    ctx.fillStyle = '#4fc3f7';
    ctx.fillRect(strip.marker - 1, 0, 2, height);
  }
}

/** Feels the strip at the viewport x `clientX` (a mouse, pen or finger); `input` says which. */
function feelAt(clientX, input, timeStamp) {
  const rect = $('feel-strip').getBoundingClientRect();
  feelAtFraction(Math.min(Math.max((clientX - rect.left) / rect.width, 0), 1), input, timeStamp);
}

/** Feels the strip at `fraction` of its length (0 = the profile's first x, 1 = its last). */
function feelAtFraction(fraction, input, timeStamp) {
  if (!state.voltage) return;
  const canvas = $('feel-strip');
  const rect = canvas.getBoundingClientRect();
  const px = fraction * rect.width;
  const v = played();
  const xs = v.x_mm;
  const x = xs[0] + px / rect.width * (xs[xs.length - 1] - xs[0]);
  const u = voltageAt(x);
  const a = amplitudeAt(x);
  const readout = $('feel-readout');
  readout.textContent = `x = ${x.toFixed(3)} mm, U = ${u.toFixed(1)} V RMS` +
    (a === null ? '' : `, a = ${a.toFixed(3)} µm`);
  readout.dataset.xMm = String(x);
  readout.dataset.input = input;
  strip.fraction = fraction;
  canvas.setAttribute('aria-valuenow', String(Math.round(100 * fraction)));
  canvas.setAttribute('aria-valuetext', readout.textContent);
  readout.dataset.voltageV = String(u);
  if (a === null) delete readout.dataset.amplitudeUm; else readout.dataset.amplitudeUm = String(a);
  strip.marker = px;
  drawStrip();
  if (strip.contact) live.touch(x, timeStamp ?? performance.now());
  // The audio plays the electrovibration channel, as the strip's brightness.
  const uMax = uMaxOf(v);
  audio.set(uMax ? u / uMax : 0);
}

/**
 * The strip follows a mouse or pen (pointer events), a finger (touch
 * events: the drag feels the strip instead of scrolling the page) and
 * the keyboard (arrow keys: 1% of the length, with Shift 10%; Home, End).
 */
export function setupStrip() {
  const canvas = $('feel-strip');
  // `contact`: a button, pen or finger is down (or a key moved the
  // marker): only then does the live output follow, not a hovering mouse.
  const stop = () => { audio.set(0); strip.contact = false; live.lift(); };
  const byPointer = (e) => {
    // A finger is followed by the touch events below where the browser has them.
    if (e.pointerType === 'touch' && 'ontouchstart' in window) return;
    feelAt(e.clientX, e.pointerType || 'mouse', e.timeStamp);
  };
  canvas.addEventListener('pointerdown', (e) => {
    strip.contact = true;
    if (canvas.setPointerCapture) canvas.setPointerCapture(e.pointerId);
    byPointer(e);
  });
  canvas.addEventListener('pointermove', byPointer);
  canvas.addEventListener('pointerup', stop);
  canvas.addEventListener('pointerleave', (e) => { if (e.pointerType !== 'touch') stop(); });
  const byTouch = (e) => {
    if (!e.touches.length) return;
    strip.contact = true;
    e.preventDefault(); // no scrolling, no emulated mouse events
    feelAt(e.touches[0].clientX, 'touch', e.timeStamp);
  };
  canvas.addEventListener('touchstart', byTouch, { passive: false });
  canvas.addEventListener('touchmove', byTouch, { passive: false });
  canvas.addEventListener('touchend', stop);
  canvas.addEventListener('touchcancel', stop);
  canvas.addEventListener('keydown', (e) => {
    const step = e.shiftKey ? 0.1 : 0.01;
    const at = strip.fraction ?? 0;
    const to = { ArrowRight: at + step, ArrowUp: at + step, ArrowLeft: at - step, ArrowDown: at - step,
      Home: 0, End: 1 }[e.key];
    if (to === undefined) return;
    e.preventDefault();
    strip.contact = true;
    feelAtFraction(Math.min(Math.max(to, 0), 1), 'keyboard');
  });
  canvas.addEventListener('blur', stop);
  $('audio').addEventListener('change', () => ($('audio').checked ? audio.start() : audio.stop()));
}

// The browser's audio output (audio.js): a sine at the carrier
// frequency whose level follows U / U_max.
export const audio = createAudio(() => state.carrierHz, (text) => say(text, true));

on('draw-strip', drawStrip);
