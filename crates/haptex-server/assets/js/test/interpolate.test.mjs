// Linear interpolation in a profile (js/interpolate.js): the feel strip's reading.
import test from 'node:test';
import assert from 'node:assert/strict';
import { interpolate } from '../interpolate.js';

const xs = [0, 1, 3, 7];
const us = [0, 10, 30, -10];

test('interpolate: the samples themselves at the grid points', () => {
  xs.forEach((x, i) => assert.equal(interpolate(xs, us, x), us[i]));
});

test('interpolate: linear between them on an uneven grid', () => {
  assert.equal(interpolate(xs, us, 0.5), 5);
  assert.equal(interpolate(xs, us, 2), 20);
  assert.equal(interpolate(xs, us, 5), 10);
  assert.ok(Math.abs(interpolate(xs, us, 6.9) - -9) < 1e-12);
});

test('interpolate: the ends held outside the profile', () => {
  assert.equal(interpolate(xs, us, -5), 0);
  assert.equal(interpolate(xs, us, 100), -10);
  assert.equal(interpolate(xs, us, -Infinity), 0);
  assert.equal(interpolate(xs, us, Infinity), -10);
});

test('interpolate: negative positions and a one-point profile', () => {
  assert.equal(interpolate([-4, -2], [1, 3], -3), 2);
  assert.equal(interpolate([2], [7], 1), 7);
  assert.equal(interpolate([2], [7], 5), 7);
});

test('interpolate: NaN in, NaN out (no position)', () => {
  assert.ok(Number.isNaN(interpolate(xs, us, NaN)));
});

// A 3 x 2 grid from (1, -1) mm in steps of 0.5 mm (x) and 2 mm (y), row by row from the bottom.
const grid = { x0_mm: 1, y0_mm: -1, dx_mm: 0.5, dy_mm: 2, nx: 3, ny: 2 };
const values = [0, 10, 20, 100, 110, 120];

test('gridAxis: cell and fraction, the ends held, NaN at the first cell', async () => {
  const { gridAxis } = await import('../interpolate.js');
  assert.deepEqual(gridAxis(1, 1, 0.5, 3), [0, 0]);
  assert.deepEqual(gridAxis(1.25, 1, 0.5, 3), [0, 0.5]);
  assert.deepEqual(gridAxis(1.5, 1, 0.5, 3), [1, 0]);
  assert.deepEqual(gridAxis(2, 1, 0.5, 3), [2, 0]);
  assert.deepEqual(gridAxis(9, 1, 0.5, 3), [2, 0]);
  assert.deepEqual(gridAxis(-9, 1, 0.5, 3), [0, 0]);
  assert.deepEqual(gridAxis(NaN, 1, 0.5, 3), [0, 0]);
});

test('bilinear: the grid values at the grid points', async () => {
  const { bilinear } = await import('../interpolate.js');
  assert.equal(bilinear(grid, values, 1, -1), 0);
  assert.equal(bilinear(grid, values, 2, -1), 20);
  assert.equal(bilinear(grid, values, 1.5, 1), 110);
  assert.equal(bilinear(grid, values, 2, 1), 120);
});

test('bilinear: between them along x, y and both', async () => {
  const { bilinear } = await import('../interpolate.js');
  assert.equal(bilinear(grid, values, 1.25, -1), 5);
  assert.equal(bilinear(grid, values, 1, 0), 50);
  assert.equal(bilinear(grid, values, 1.75, 0.5), 90);
});

test('bilinear: the edge held outside the map, NaN positions at its first cell', async () => {
  const { bilinear } = await import('../interpolate.js');
  assert.equal(bilinear(grid, values, -100, -100), 0);
  assert.equal(bilinear(grid, values, 100, 100), 120);
  assert.equal(bilinear(grid, values, 1.25, 100), 105);
  assert.equal(bilinear(grid, values, NaN, 1), 100);
});

test('bilinear: a one-cell map is its value everywhere', async () => {
  const { bilinear } = await import('../interpolate.js');
  const one = { x0_mm: 0, y0_mm: 0, dx_mm: 1, dy_mm: 1, nx: 1, ny: 1 };
  assert.equal(bilinear(one, [0.7], 5, -5), 0.7);
});
