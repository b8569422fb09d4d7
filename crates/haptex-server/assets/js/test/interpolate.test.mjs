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
