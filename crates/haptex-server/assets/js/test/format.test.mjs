// fmt, pct and safeName (js/format.js): the page's numbers and file names.
import test from 'node:test';
import assert from 'node:assert/strict';
import { fmt, pct, safeName } from '../format.js';

test('fmt: 4 significant digits, trailing zeros dropped', () => {
  assert.equal(fmt(1.23456), '1.235');
  assert.equal(fmt(0.5), '0.5');
  assert.equal(fmt(100), '100');
  assert.equal(fmt(-0.030303), '-0.0303');
  assert.equal(fmt(12345.6), '12350');
});

test('fmt: exponential below 1e-3 and from 1e5 in magnitude, zero plain', () => {
  assert.equal(fmt(0), '0');
  assert.equal(fmt(-0), '0');
  assert.equal(fmt(0.001), '0.001');
  assert.equal(fmt(0.000999), '9.990e-4');
  assert.equal(fmt(-2e-4), '-2.000e-4');
  assert.equal(fmt(2.4e-16), '2.400e-16');
  assert.equal(fmt(1e5), '1.000e+5');
  assert.equal(fmt(-123456), '-1.235e+5');
  // Just below 1e5 the rounding to 4 digits reaches it, written plainly.
  assert.equal(fmt(99999), '100000');
});

test('fmt: none, NaN and infinities', () => {
  assert.equal(fmt(null), '–');
  assert.equal(fmt(undefined), '–');
  assert.equal(fmt(NaN), 'NaN');
  assert.equal(fmt(Infinity), 'Infinity');
  assert.equal(fmt(-Infinity), '-Infinity');
});

test('pct: a fraction as a percentage with two decimals', () => {
  assert.equal(pct(0), '0.00%');
  assert.equal(pct(1), '100.00%');
  assert.equal(pct(0.2370), '23.70%');
  assert.equal(pct(1 / 3), '33.33%');
  assert.equal(pct(-0.0123), '-1.23%');
  assert.equal(pct(NaN), 'NaN%');
});

test('safeName: letters, digits, dot, underscore and hyphen only; no leading dots; never empty', () => {
  assert.equal(safeName('velvet-stroke-29.csv'), 'velvet-stroke-29.csv');
  assert.equal(safeName('my file (1).csv'), 'my_file__1_.csv');
  assert.equal(safeName('µ/../x.csv'), '__.._x.csv'); // no separator left, so no path
  assert.equal(safeName('..hidden.csv'), '_hidden.csv');
  assert.equal(safeName(''), 'profile.csv');
  const long = safeName(`${'a'.repeat(300)}.csv`);
  assert.equal(long.length, 200);
  assert.ok(/^[A-Za-z0-9._-]+$/.test(safeName('日本語 ✓.csv')));
});

test('fmtPlain (the map page): 4 significant digits, never exponential', async () => {
  const { fmtPlain } = await import('../format.js');
  assert.equal(fmtPlain(51.2), '51.2');
  assert.equal(fmtPlain(1.23456), '1.235');
  assert.equal(fmtPlain(0), '0');
  assert.equal(fmtPlain(-12.345), '-12.35');
  assert.equal(fmtPlain(1e-4), '0.0001');
  assert.equal(fmtPlain(123456), '123500');
  assert.equal(fmtPlain(NaN), 'NaN');
  assert.equal(fmtPlain(-Infinity), '-Infinity');
  assert.equal(fmtPlain(null), 'null');
  assert.equal(fmtPlain(undefined), 'undefined');
});
