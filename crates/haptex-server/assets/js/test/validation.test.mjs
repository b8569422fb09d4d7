// Typed values against ranges (js/validation.js): what the page's fields stand for and the notes under them.
import test from 'node:test';
import assert from 'node:assert/strict';
import { dataRows, databaseNote, deviceFrom, outsideRange, parseNumber, typicalNote } from '../validation.js';

test('parseNumber: blank is null, a number is itself, anything else NaN', () => {
  assert.equal(parseNumber(''), null);
  assert.equal(parseNumber('   '), null);
  assert.equal(parseNumber(' 2.5 '), 2.5);
  assert.equal(parseNumber('-1'), -1);
  assert.equal(parseNumber('1e9'), 1e9);
  assert.equal(parseNumber('0'), 0);
  assert.ok(Number.isNaN(parseNumber('abc')));
  assert.ok(Number.isNaN(parseNumber('1,5')));
  assert.equal(parseNumber('Infinity'), Infinity);
});

test('outsideRange: finite values outside [min, max]; the bounds are inside', () => {
  assert.equal(outsideRange(0.5, 0.1, 1), false);
  assert.equal(outsideRange(0.1, 0.1, 1), false);
  assert.equal(outsideRange(1, 0.1, 1), false);
  assert.equal(outsideRange(-1, 0.1, 1), true);
  assert.equal(outsideRange(1.0001, 0.1, 1), true);
  assert.equal(outsideRange(NaN, 0.1, 1), false);
  assert.equal(outsideRange(Infinity, 0.1, 1), false);
});

test('deviceFrom: blank fields left out (the server default), the others as numbers', () => {
  assert.deepEqual(deviceFrom([['mu_hd', '1'], ['u_max_v', ''], ['k_mm2_per_n', ' 200 ']]), { mu_hd: 1, k_mm2_per_n: 200 });
  assert.deepEqual(deviceFrom([]), {});
  assert.deepEqual(deviceFrom([['mu_hd', '-1']]), { mu_hd: -1 });
  // Not a number is sent as it is (NaN: the server refuses it).
  assert.ok(Number.isNaN(deviceFrom([['mu_hd', 'x']]).mu_hd));
});

const muHd = {
  field: 'mu_hd', symbol: 'μ_HD', unit: '', meaning: 'friction of the display at 0 V',
  typical: { min: 0.3, max: 1.5 }, accepted: { min: 0.001, max: 10 },
};
const uMax = { ...muHd, field: 'u_max_v', symbol: 'U_max', unit: 'V RMS', meaning: 'largest voltage',
  typical: { min: 50, max: 200 }, accepted: { min: 1e-3, max: 1e4 } };

test('typicalNote: inside, outside (with the accepted range) and blank', () => {
  assert.deepEqual(typicalNote(muHd, '1'), {
    head: 'μ_HD (no unit): friction of the display at 0 V. ', range: 'Typical 0.3 .. 1.5.', outside: false,
  });
  const out = typicalNote(muHd, '-1');
  assert.equal(out.outside, true);
  assert.equal(out.range, 'Outside the typical range 0.3 .. 1.5 (accepted 0.001 .. 10).');
  assert.equal(typicalNote(muHd, '').outside, false);
  assert.equal(typicalNote(muHd, 'abc').outside, false);
  const volts = typicalNote(uMax, '1e9');
  assert.equal(volts.head, 'U_max (V RMS): largest voltage. ');
  assert.equal(volts.range, 'Outside the typical range 50 .. 200 V RMS (accepted 0.001 .. 10000 V RMS).');
});

test('typicalNote: a parameter without a sourced range is never outside', () => {
  const note = typicalNote({ ...muHd, typical: null }, '1e9');
  assert.equal(note.outside, false);
  assert.equal(note.range, 'No typical range sourced.');
});

test('databaseNote: the FE database range, extrapolation outside it', () => {
  const width = { database: [0.5, 2], unit: 'mm' };
  assert.deepEqual(databaseNote(width, 1.3), { outside: false, text: 'FE database: 0.5 .. 2 mm' });
  assert.deepEqual(databaseNote(width, 2), { outside: false, text: 'FE database: 0.5 .. 2 mm' });
  assert.deepEqual(databaseNote(width, 2.1),
    { outside: true, text: 'outside the FE database (0.5 .. 2 mm): extrapolation' });
  assert.equal(databaseNote(width, -1).outside, true);
});

test('dataRows: lines less blanks, comments and the header', () => {
  assert.equal(dataRows('amplitude_um,relative_friction\n0,1\n1,0.8\n2,0.6\n'), 3);
  assert.equal(dataRows('# a comment\r\namplitude_um,relative_friction\r\n\r\n0,1\r\n  # indented comment\r\n1,0.8'), 2);
  assert.equal(dataRows('header only'), 0);
});
