// The pure parts of the plots (js/plots.js): their options and their text description.
import test from 'node:test';
import assert from 'node:assert/strict';
import { constant, lineOptions, plotSummary, withPins } from '../plots.js';

test('lineOptions: numeric x, the axis labels, the x series named, other options kept', () => {
  const hooks = { draw: [] };
  const o = lineOptions({ width: 300, height: 180, x: 't (s)', y: 'N', live: false, series: [{ label: 'Fn' }], hooks });
  assert.deepEqual(o, {
    width: 300, height: 180, scales: { x: { time: false } }, axes: [{ label: 't (s)' }, { label: 'N' }],
    legend: { live: false }, hooks, series: [{ label: 't (s)' }, { label: 'Fn' }],
  });
  const plain = lineOptions({ width: 240, height: 240, x: 'x (mm)', series: [] });
  assert.deepEqual(plain.axes, [{ label: 'x (mm)' }, {}]);
  assert.equal(plain.legend.live, true);
  assert.deepEqual(plain.series, [{ label: 'x (mm)' }]);
});

test('plotSummary: the x range and each series\' extrema with where they are', () => {
  const text = plotSummary([{ label: 'mu' }, { label: 'U' }], [[0, 0.5, 1], [0.4, 0.9, 0.6], [-5, 0, 5]]);
  assert.equal(text, 'x from 0 to 1 mm; mu: min 0.4 at x = 0 mm, max 0.9 at x = 0.5 mm; ' +
    'U: min -5 at x = 0 mm, max 5 at x = 1 mm.');
});

test('plotSummary: constant series, gaps, series without a value, ties', () => {
  const data = [[1, 2, 3, 4], [100, 100, 100, 100], [null, 2, undefined, 1], [null, null, null, null], [7, 9, 9, 7]];
  const series = [{ label: 'U_max' }, { label: 'gappy' }, { label: 'empty' }, { label: 'ties' }];
  assert.equal(plotSummary(series, data), 'x from 1 to 4 mm; U_max: 100 throughout; ' +
    'gappy: min 1 at x = 4 mm, max 2 at x = 2 mm; ties: min 7 at x = 1 mm, max 9 at x = 2 mm.');
});

test('constant: one value per x', () => {
  assert.deepEqual(constant([0, 1, 2], 0.5), [0.5, 0.5, 0.5]);
  assert.deepEqual(constant([], 1), []);
});

test('withPins: without pins (or pins with nothing for this plot) the current design as it is', () => {
  const series = [{ label: 'mu' }];
  const data = [[0, 1], [0.5, 0.6]];
  assert.deepEqual(withPins([], series, data, () => null), { series, data });
  const none = withPins([{ name: 'P1', color: '#000' }], series, data, () => ({ x: [0], lines: [] }));
  assert.equal(none.series, series);
  assert.equal(none.data, data);
});

test('plotHeight: the surface, friction and voltage fit a 900 px desktop window; a phone keeps its sizes', async () => {
  const { plotHeight } = await import('../plots.js');
  assert.equal(plotHeight('height-plot', 1366, 900), 150);
  assert.equal(plotHeight('friction-plot', 1366, 900), 195);
  assert.equal(plotHeight('friction-plot', 1920, 1200), 240);
  assert.equal(plotHeight('friction-plot', 1280, 700), 160);
  assert.equal(plotHeight('voltage-plot', 390, 844), 190);
  assert.equal(plotHeight('height-plot', 390, 844), 140);
});
