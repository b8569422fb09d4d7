// The line plots (uPlot, a global of vendor/uPlot.iife.min.js): made
// with a legend the keyboard can toggle, updated in place when their
// series are unchanged, described in text for screen readers, pinned
// designs joined on one x axis, resized to their holders.

import { $ } from './dom.js';
import { fmt } from './format.js';

/**
 * The pinned designs' series of one plot beside the current design's:
 * `pins` are the pinned designs (state.pins), `pick(pin)` gives a pin's [{label, data, dash}] on its own x_mm (or
 * its x with them). Without pins the current data is drawn as it is;
 * with them the tables are joined on one x axis (uPlot.join: null where
 * a design has no sample, lines drawn across).
 */
export function withPins(pins, series, data, pick) {
  const tables = [];
  const extra = [];
  pins.forEach((p) => {
    const picked = pick(p);
    if (!picked || !picked.lines.length) return;
    tables.push([picked.x, ...picked.lines.map((l) => l.data)]);
    picked.lines.forEach((l) => extra.push({
      label: `${p.name} ${l.label}`, stroke: p.color, width: 1.5, dash: l.dash ? [5, 3] : undefined,
    }));
  });
  if (!tables.length) return { series, data };
  return {
    series: [...series, ...extra].map((s) => ({ ...s, spanGaps: true })),
    data: data ? uPlot.join([data, ...tables]) : uPlot.join(tables),
  };
}

/** The width of the plot in holder `id`: the holder's (or its parent's), at least 240 px. */
export function plotWidth(id) {
  return Math.max(240, $(id).clientWidth || $(id).parentElement.clientWidth);
}

/**
 * The height of the plot in holder `id` for a window of `width` x `height`
 * px: on a phone 190 px (the surface's 140); on a desktop the surface's
 * 150 px and the others what lets the surface, the friction and the
 * voltage fit the window together (160 to 240 px), so that the first
 * screen shows the design whole.
 */
export function plotHeight(id, width = window.innerWidth, height = window.innerHeight) {
  if (width < 600) return id === 'height-plot' ? 140 : 190;
  if (id === 'height-plot') return 150;
  return Math.max(160, Math.min(240, Math.floor((height - 510) / 2)));
}

/**
 * The options of a line plot over a numeric x (not time): its size, the x
 * axis label `x` (also the x series' name), the y axis label `y` (none
 * when undefined), the series, a live legend unless `live` is false, and
 * any other uPlot option (`cursor`, `hooks`, ...) as given. Pure.
 */
export function lineOptions({ width, height, x, y, series, live = true, ...more }) {
  return {
    width,
    height,
    scales: { x: { time: false } },
    axes: [{ label: x }, y === undefined ? {} : { label: y }],
    legend: { live },
    ...more,
    series: [{ label: x }, ...series],
  };
}

/** A plot of `series` over x (mm) in the holder `id`, zoomed by dragging along x, its legend keyboard-toggled. */
export function makePlot(id, series, data) {
  const options = lineOptions({
    width: plotWidth(id), height: plotHeight(id), x: 'x (mm)', series, cursor: { drag: { x: true, y: false } },
  });
  const plot = new uPlot(options, data, $(id));
  keyboardLegend(plot);
  return plot;
}

/**
 * The legend's entries as toggle buttons for the keyboard: Tab reaches
 * each series' entry, Enter or Space shows or hides it (what a click on
 * it does), and aria-pressed says whether it is shown.
 */
export function keyboardLegend(plot) {
  plot.root.querySelectorAll('.u-legend tr.u-series').forEach((row, i) => {
    const th = row.querySelector('th');
    if (i === 0 || !th) return; // the x column is no series to hide
    const pressed = () => th.setAttribute('aria-pressed', String(plot.series[i].show !== false));
    th.tabIndex = 0;
    th.setAttribute('role', 'button');
    th.setAttribute('aria-label', `show or hide ${plot.series[i].label}`);
    pressed();
    // After uPlot's own click handler (registered first): the new state.
    th.addEventListener('click', pressed);
    th.addEventListener('keydown', (e) => {
      if (e.key !== 'Enter' && e.key !== ' ') return;
      e.preventDefault();
      th.click();
    });
  });
}

export function constant(x, value) {
  return x.map(() => value);
}

/** Updates a plot in place when its series are unchanged, else rebuilds it; then its text summary. */
export function replot(plot, id, series, data) {
  describePlot(id, series, data);
  if (plot && plot.series.length === series.length + 1 &&
      plot.series.every((s, i) => i === 0 || s.label === series[i - 1].label)) {
    plot.setData(data, true);
    return plot;
  }
  if (plot) plot.destroy();
  return makePlot(id, series, data);
}

/**
 * The text a screen reader gives for a plot (the plot is an image named
 * by its caption, described by this text): the x range and each series'
 * extrema with where they are.
 */
export function describePlot(id, series, data) {
  const box = $(id);
  let note = $(`${id}-summary`);
  if (!note) {
    note = document.createElement('p');
    note.id = `${id}-summary`;
    note.className = 'sr-only plot-summary';
    box.insertAdjacentElement('afterend', note);
    box.setAttribute('role', 'img');
    box.setAttribute('aria-describedby', note.id);
  }
  const caption = box.parentElement.querySelector('figcaption');
  if (caption) box.setAttribute('aria-label', caption.textContent.trim());
  note.textContent = plotSummary(series, data);
}

/**
 * A plot's description, pure: the x range (mm), then each series' minimum
 * and maximum with their x (the first where several are equal), or its
 * value "throughout" when constant; series without a value are left out.
 */
export function plotSummary(series, data) {
  const x = data[0];
  const parts = [`x from ${fmt(x[0])} to ${fmt(x[x.length - 1])} mm`];
  series.forEach((s, i) => {
    const ys = data[i + 1];
    let lo = -1;
    let hi = -1;
    ys.forEach((y, j) => {
      if (y === null || y === undefined) return;
      if (lo < 0 || y < ys[lo]) lo = j;
      if (hi < 0 || y > ys[hi]) hi = j;
    });
    if (lo < 0) return;
    parts.push(ys[lo] === ys[hi]
      ? `${s.label}: ${fmt(ys[lo])} throughout`
      : `${s.label}: min ${fmt(ys[lo])} at x = ${fmt(x[lo])} mm, max ${fmt(ys[hi])} at x = ${fmt(x[hi])} mm`);
  });
  return `${parts.join('; ')}.`;
}

/** Resizes the plots of `plots` (key: plot) drawn in the holders `ids` (key: element id) to their holders. */
export function resizePlots(plots, ids) {
  Object.entries(ids).forEach(([k, id]) => {
    const plot = plots[k];
    if (plot) plot.setSize({ width: plotWidth(id), height: plotHeight(id) });
  });
}
