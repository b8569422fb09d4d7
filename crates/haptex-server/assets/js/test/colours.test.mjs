// The map page's heat scale and the pins' colours (js/colours.js).
import test from 'node:test';
import assert from 'node:assert/strict';
import { COLOURS, HEAT_STOPS, PIN_COLORS, heatColour } from '../colours.js';

test('heatColour: the first and last stops at 0 and 1, clamped beyond', () => {
  assert.deepEqual(heatColour(0), [13, 8, 135]);
  assert.deepEqual(heatColour(1), [240, 249, 33]);
  assert.deepEqual(heatColour(-3), [13, 8, 135]);
  assert.deepEqual(heatColour(7), [240, 249, 33]);
  assert.deepEqual(heatColour(-Infinity), [13, 8, 135]);
  assert.deepEqual(heatColour(Infinity), [240, 249, 33]);
});

test('heatColour: each inner stop at k / 7, linear (rounded) between', () => {
  const n = HEAT_STOPS.length - 1;
  HEAT_STOPS.forEach((stop, k) => assert.deepEqual(heatColour(k / n), stop));
  // Halfway between stops 3 [185, 50, 137] and 4 [219, 92, 104].
  assert.deepEqual(heatColour(3.5 / n), [202, 71, 121]);
});

test('heatColour: integer channels in 0..255, brighter (more green) towards 1', () => {
  let green = -1;
  for (let i = 0; i <= 100; i += 1) {
    const c = heatColour(i / 100);
    c.forEach((v) => assert.ok(Number.isInteger(v) && v >= 0 && v <= 255));
    assert.ok(c[1] >= green - 6, `green falls at ${i / 100}`);
    green = c[1];
  }
});

test('the palettes: distinct colours written #rrggbb', () => {
  for (const palette of [PIN_COLORS, COLOURS]) {
    assert.equal(new Set(palette).size, palette.length);
    palette.forEach((c) => assert.match(c, /^#[0-9a-f]{6}$/));
  }
  assert.equal(PIN_COLORS.length, 6);
});
