// The main figures of the design shown: surface height, friction (with
// the display's band and the FE model's profile), voltage and amplitude,
// with the pinned designs on the same axes; cleared when there is no
// profile, resized with the window.

import { $ } from './dom.js';
import { equation, uMaxOf } from './answers.js';
import { on } from './hub.js';
import { constant, replot, resizePlots as resizeEach, withPins } from './plots.js';
import { plots, state } from './state.js';
import { drawStrip } from './strip.js';
import { currentFe } from './template.js';

/**
 * Draws the answer: the height (templates), the friction with the display's
 * band, the voltage(s) and the amplitude a(x), with the pinned designs.
 */
export function draw() {
  const v = state.voltage;
  const s = v.summary;
  const x = v.x_mm;
  const r = s.relative;
  const frictionData = [x, v.mu];
  const frictionSeries = [{ label: r ? 'μ_RS / μ_flat · μ_HD' : 'μ_RS', stroke: '#1f5fa8', width: 1.5 }];
  if (s.display) {
    // The renderable band of the display (summary.band_mu).
    frictionData.push(constant(x, s.mu_hd), constant(x, s.band_mu[0]), constant(x, s.band_mu[1]));
    frictionSeries.push(
      { label: 'μ_HD', stroke: '#888', dash: [6, 4], width: 1 },
      { label: 'band min (μ_HD ρ_min)', stroke: '#00838f', dash: [2, 4], width: 1.5 },
      { label: s.electrovibration ? 'band max (μ at U_max)' : 'band max (μ_HD)', stroke: '#c77700',
        dash: [2, 4], width: 1.5 });
  } else if (s.method === 'physical') {
    frictionData.push(constant(x, s.mu_hd), constant(x, s.mu_at_u_max));
    frictionSeries.push(
      { label: 'μ_HD', stroke: '#888', dash: [6, 4], width: 1 },
      { label: 'μ at U_max', stroke: '#c77700', dash: [2, 4], width: 1 });
  }
  const fe = currentFe();
  if (fe && fe.mu.length === x.length) {
    // On the plotted scale: relative like the profile when it is.
    frictionData.push(r ? fe.mu.map((m) => m / r.flat_mu * r.mu_hd) : fe.mu);
    frictionSeries.push({ label: 'μ FE model', stroke: '#2e7d32', dash: [5, 3], width: 1.5 });
  }
  const voltageData = [x, v.voltage_v];
  const voltageSeries = [{ label: s.display ? 'U(x)' : `U ${equation(s)}`, stroke: '#b3261e', width: 1.5 }];
  const c = state.companion;
  if (c && c.voltage_v.length === x.length) {
    voltageData.push(c.voltage_v);
    voltageSeries.push({ label: `U ${equation(c.summary)}`, stroke: '#6a3d9a', dash: [5, 3], width: 1.5 });
  }
  voltageData.push(constant(x, uMaxOf(v)));
  voltageSeries.push({ label: 'U_max', stroke: '#888', dash: [6, 4], width: 1 });
  $('voltage-caption').textContent = c
    ? `: ${equation(s)} and ${equation(c.summary)} side by side, as in the paper's Fig. 2b`
    : '';
  const h = state.drawn && state.drawn.h_mm;
  if (h && h.length === x.length) {
    const height = withPins(state.pins, [{ label: 'h (mm)', stroke: '#444', width: 1.5, fill: 'rgba(0,0,0,0.06)' }],
      [x, h], (p) => ({ x: p.x_mm, lines: p.h ? [{ label: 'h', data: p.h }] : [] }));
    plots.height = replot(plots.height, 'height-plot', height.series, height.data);
  } else if (plots.height) {
    plots.height.destroy();
    plots.height = null;
  }
  const friction = withPins(state.pins, frictionSeries, frictionData,
    (p) => ({ x: p.x_mm, lines: [{ label: 'μ', data: p.mu }] }));
  plots.friction = replot(plots.friction, 'friction-plot', friction.series, friction.data);
  // The ultrasonic display alone has no voltage (a pinned design may have).
  const voltage = v.voltage_v
    ? withPins(state.pins, voltageSeries, voltageData, (p) => ({ x: p.x_mm, lines: p.voltages }))
    : withPins(state.pins, [], null, (p) => ({ x: p.x_mm, lines: p.voltages }));
  const hasVoltage = Boolean(voltage.data);
  $('voltage-figure').hidden = !hasVoltage;
  if (hasVoltage) {
    plots.voltage = replot(plots.voltage, 'voltage-plot', voltage.series, voltage.data);
  } else if (plots.voltage) {
    plots.voltage.destroy();
    plots.voltage = null;
  }
  const a = v.amplitude_um;
  const pinnedAmplitude = (p) => ({ x: p.x_mm, lines: p.amplitude ? [{ label: 'a(x)', data: p.amplitude }] : [] });
  const amplitude = a
    ? withPins(state.pins, [
      { label: 'a(x) (µm)', stroke: '#00838f', width: 1.5 },
      { label: 'a_max', stroke: '#888', dash: [6, 4], width: 1 },
    ], [x, a, constant(x, s.ultrasonic.a_max_um)], pinnedAmplitude)
    : withPins(state.pins, [], null, pinnedAmplitude);
  $('amplitude-figure').hidden = !amplitude.data;
  if (amplitude.data) {
    plots.amplitude = replot(plots.amplitude, 'amplitude-plot', amplitude.series, amplitude.data);
  } else if (plots.amplitude) {
    plots.amplitude.destroy();
    plots.amplitude = null;
  }
}

export function clearPlots() {
  $('check-results').hidden = true;
  ['height', 'friction', 'voltage', 'amplitude'].forEach((k) => {
    if (plots[k]) { plots[k].destroy(); plots[k] = null; }
  });
  $('amplitude-figure').hidden = true;
  $('summary').textContent = '';
  state.voltage = null;
  state.companion = null;
  drawStrip();
}

/** Fits the plots (and the feel strip) to the page's new width. */
export function resizePlots() {
  const ids = { height: 'height-plot', friction: 'friction-plot', voltage: 'voltage-plot',
    amplitude: 'amplitude-plot', check: 'check-plot', checkVoltage: 'check-voltage-plot' };
  resizeEach(plots, ids);
  drawStrip();
}

on('draw', draw);
