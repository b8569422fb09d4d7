// Readings of the API's answers (js/answers.js).
import test from 'node:test';
import assert from 'node:assert/strict';
import { checkRefusal, checkTrial, equation, otherMethod, uMaxOf } from '../answers.js';

test('equation: eq. (8) for the physical method, eq. (9) otherwise', () => {
  assert.equal(equation({ method: 'physical' }), 'eq. (8)');
  assert.equal(equation({ method: 'normalized' }), 'eq. (9)');
  assert.equal(equation({}), 'eq. (9)');
});

test('otherMethod: physical and normalized swap', () => {
  assert.equal(otherMethod('physical'), 'normalized');
  assert.equal(otherMethod('normalized'), 'physical');
  assert.equal(otherMethod(otherMethod('physical')), 'physical');
});

test('uMaxOf: the electrovibration answer, the combined display, the ultrasonic one (none)', () => {
  assert.equal(uMaxOf({ summary: { u_max_v: 100 } }), 100);
  // 0 V is a U_max, not a missing one.
  assert.equal(uMaxOf({ summary: { u_max_v: 0 } }), 0);
  assert.equal(uMaxOf({ summary: { display: 'combined', electrovibration: { u_max_v: 60 } } }), 60);
  assert.equal(uMaxOf({ summary: { display: 'ultrasonic', ultrasonic: {} } }), null);
  // The electrovibration answer's own field wins over a nested one.
  assert.equal(uMaxOf({ summary: { u_max_v: 90, electrovibration: { u_max_v: 60 } } }), 90);
});

test('checkTrial: eq. (8) named, else the combined design, the answer untouched', () => {
  const eq8 = { felt_mu: [1, 2], voltage_v: [0, 5], metrics: { rms_error: 0.1 } };
  const r = { eq8, design: null };
  const first = checkTrial(r);
  assert.equal(first.name, 'eq. (8)');
  assert.deepEqual(first.felt_mu, [1, 2]);
  assert.equal(eq8.name, undefined);
  const combined = checkTrial({ eq8: null, design: { felt_mu: [3], amplitude_um: [0.4] } });
  assert.equal(combined.name, 'combined');
  assert.deepEqual(combined.amplitude_um, [0.4]);
});

test('checkRefusal: a busy server, then the part of the page at fault', () => {
  const at = (status, field, message = 'm') => checkRefusal({ status, field, message });
  assert.equal(at(503, 'load_n_per_mm', 'all 2 slots busy'), 'The server is busy: all 2 slots busy');
  assert.equal(at(400, 'profile.mu[3]', 'not finite'), 'Friction profile: not finite');
  assert.equal(at(400, 'load_n_per_mm', 'must be positive'), 'Load: must be positive');
  assert.equal(at(400, 'max_runs', 'at most 8'), 'Max runs: at most 8');
  // The 3D fingertip's fields, in the words of the check box's labels.
  assert.equal(at(400, 'load_n', 'at most 2 N'), 'Load: at most 2 N');
  assert.equal(at(400, 'direction_deg', 'out of range'), 'Direction: out of range');
  assert.equal(at(400, 'mesh', 'unknown'), 'Finger: unknown');
  assert.equal(at(400, 'device.mu_hd', 'out of range'), 'Device: out of range');
  assert.equal(at(400, 'velocity_mm_s', 'too fast'), 'too fast');
  assert.equal(at(400, null, 'no field'), 'no field');
  assert.equal(at(400, undefined, ''), '');
});
