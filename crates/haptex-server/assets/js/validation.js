// Validation of typed values against ranges, pure: the number a field's
// text stands for, whether a value lies outside a range, the notes the
// page puts under a device parameter (its typical range) and a template
// slider (the FE database's range), the data rows of a CSV text. No DOM:
// unit-tested by node (js/test/validation.test.mjs); fields.js applies
// them to the page's inputs.

import { fmt } from './format.js';

/** The number a field's text stands for: null when it is blank, NaN when it is not a number. */
export function parseNumber(text) {
  const trimmed = String(text).trim();
  return trimmed === '' ? null : Number(trimmed);
}

/** Whether `v` is a finite number outside [min, max] (blank or NaN is not outside anything). */
export function outsideRange(v, min, max) {
  return Number.isFinite(v) && (v < min || v > max);
}

/**
 * The device parameters typed in, from [name, text] pairs: the blank ones
 * left out (they take the server's default), the others as numbers.
 */
export function deviceFrom(pairs) {
  const device = {};
  pairs.forEach(([name, text]) => {
    const v = parseNumber(text);
    if (v !== null) device[name] = v;
  });
  return device;
}

/**
 * The explanation of a parameter (GET /api/config, `explanations`: symbol,
 * unit, meaning, typical and accepted ranges) for the text typed in its
 * field: {head, range, outside}, `outside` while the value is outside the
 * typical range.
 */
export function typicalNote(e, text) {
  const unit = e.unit ? ` ${e.unit}` : '';
  const v = parseNumber(text);
  const outside = e.typical !== null && v !== null && outsideRange(v, e.typical.min, e.typical.max);
  const head = `${e.symbol}${e.unit ? ` (${e.unit})` : ' (no unit)'}: ${e.meaning}. `;
  const range = e.typical === null
    ? 'No typical range sourced.'
    : `${outside ? 'Outside the typical range' : 'Typical'} ${fmt(e.typical.min)} .. ${fmt(e.typical.max)}${unit}` +
      `${outside ? ` (accepted ${fmt(e.accepted.min)} .. ${fmt(e.accepted.max)}${unit})` : ''}.`;
  return { head, range, outside };
}

/**
 * The note under a template slider (GET /api/templates: `database`, the
 * FE database's range, and `unit`) at value `v`: {outside, text}, outside
 * the database being an extrapolation.
 */
export function databaseNote(p, v) {
  const [lo, hi] = p.database;
  const outside = outsideRange(v, lo, hi);
  const text = outside
    ? `outside the FE database (${fmt(lo)} .. ${fmt(hi)} ${p.unit}): extrapolation`
    : `FE database: ${fmt(lo)} .. ${fmt(hi)} ${p.unit}`;
  return { outside, text };
}

/** The data rows of a CSV text: its lines that are neither blank nor comments (#), less the header. */
export function dataRows(text) {
  return text.split(/\r?\n/).filter((l) => l.trim() !== '' && !l.trim().startsWith('#')).length - 1;
}
