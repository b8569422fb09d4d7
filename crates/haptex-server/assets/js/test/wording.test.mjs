// The page's words for refusals (js/validation.js): typed values refused
// with the field's label, and the server's messages rewritten with the
// labels the page shows instead of the API's field names.
import test from 'node:test';
import assert from 'node:assert/strict';
import { inPageWords, prettySymbol, refusal } from '../validation.js';

const carrier = { label: 'Carrier frequency', unit: 'Hz', min: 1, max: 20000 };

test('refusal: inside the range, nothing; outside, the label, the range and the text typed', () => {
  assert.equal(refusal('1000', carrier), null);
  assert.equal(refusal('1', carrier), null);
  assert.equal(refusal('20000', carrier), null);
  assert.equal(refusal('-3', carrier), 'Carrier frequency must be from 1 to 20000 Hz, got -3');
  assert.equal(refusal('99999', carrier), 'Carrier frequency must be from 1 to 20000 Hz, got 99999');
  assert.equal(refusal(' 1e9 ', { label: 'x0', min: -1000, max: 1000, unit: 'mm' }),
    'x0 must be from -1000 to 1000 mm, got 1e9');
});

test('refusal: blank is refused unless optional; letters and infinities are not numbers', () => {
  assert.equal(refusal('', carrier), 'Carrier frequency is needed');
  assert.equal(refusal('  ', { ...carrier, optional: true }), null);
  assert.equal(refusal('', { ...carrier, badInput: true }), 'Carrier frequency: not a number');
  assert.equal(refusal('abc', carrier), 'Carrier frequency: "abc" is not a number');
  assert.equal(refusal('Infinity', carrier), 'Carrier frequency: "Infinity" is not a number');
  assert.equal(refusal('NaN', carrier), 'Carrier frequency: "NaN" is not a number');
});

test('refusal: one-sided ranges and whole numbers', () => {
  assert.equal(refusal('0', { label: 'Pixel size', unit: 'mm', min: 1e-6 }), 'Pixel size must be at least 1.000e-6 mm, got 0');
  assert.equal(refusal('7', { label: 'n', max: 5 }), 'n must be at most 5, got 7');
  assert.equal(refusal('2.5', { label: 'max runs', min: 1, max: 8, integer: true }), 'max runs must be a whole number, got 2.5');
  assert.equal(refusal('3', { label: 'max runs', min: 1, max: 8, integer: true }), null);
});

test('prettySymbol: the Greek letters of the paper, only at the start of a symbol', () => {
  assert.equal(prettySymbol('mu_HD'), 'μ_HD');
  assert.equal(prettySymbol('rho_min'), 'ρ_min');
  assert.equal(prettySymbol('eps_sc'), 'ε_sc');
  assert.equal(prettySymbol('mu'), 'μ');
  assert.equal(prettySymbol('U_max'), 'U_max');
  assert.equal(prettySymbol('music'), 'music');
  assert.equal(prettySymbol('d_sc'), 'd_sc');
});

test('inPageWords: the API field becomes the label, its prefix and "(field ...)" notes go', () => {
  assert.equal(inPageWords('mu_hd must be from 0.001 to 10, got -1', { field: 'device.mu_hd', label: 'μ_HD' }),
    'μ_HD must be from 0.001 to 10, got -1');
  assert.equal(inPageWords('device.mu_hd: mu_hd must be from 0.001 to 10, got -1', { field: 'device.mu_hd', label: 'μ_HD' }),
    'μ_HD must be from 0.001 to 10, got -1');
  assert.equal(inPageWords('load_n_per_mm must be at most 0.05 (field load_n_per_mm)', { field: 'load_n_per_mm', label: 'load' }),
    'load must be at most 0.05');
  // Only whole names: mu_hd_x or a.mu_hd are other things.
  assert.equal(inPageWords('mu_hd_x and mu_hd', { field: 'mu_hd', label: 'μ_HD' }), 'mu_hd_x and μ_HD');
});

test('inPageWords: the request body is the file the user chose, or the request', () => {
  assert.equal(inPageWords('request body, line 3, column \'mu\': not a number: "foo"', { field: 'mu', file: 'f.csv' }),
    'f.csv, line 3, column \'mu\': not a number: "foo"');
  assert.equal(inPageWords('the request body is empty', { field: 'body', file: 'empty.csv' }), 'empty.csv is empty');
  assert.equal(inPageWords('body: the request body is empty', { field: 'body' }), 'the request is empty');
  assert.equal(inPageWords('no field here'), 'no field here');
});

test("inPageWords: serde's backticks become quotes, its list of fields plain words", () => {
  assert.equal(inPageWords('s.recording.json: invalid metadata: unknown field `not`, expected one of `format`, `material`, `participant` at line 3 column 7'),
    's.recording.json: invalid metadata: unknown field "not" (the fields are format, material, participant) at line 3 column 7');
  assert.equal(inPageWords('unknown field `x`, expected `y`'), 'unknown field "x" (the field is y)');
  assert.equal(inPageWords('missing field `participant` at line 2'), 'missing field "participant" at line 2');
});
