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

/**
 * What is wrong with the text typed in a numeric field, in the page's
 * words, or null when nothing is: `rule` is {label, unit, min, max,
 * integer, optional, badInput} (`badInput`: the browser could not read the
 * text as a number, as <input type=number> says of letters). A blank field
 * is refused unless `optional` (it then takes the server's default).
 */
export function refusal(text, rule) {
  const { label, unit = '', min = -Infinity, max = Infinity, integer = false, optional = false, badInput = false } = rule;
  const u = unit ? ` ${unit}` : '';
  if (badInput) return `${label}: not a number`;
  const v = parseNumber(text);
  if (v === null) return optional ? null : `${label} is needed`;
  if (!Number.isFinite(v)) return `${label}: "${String(text).trim()}" is not a number`;
  if (integer && !Number.isInteger(v)) return `${label} must be a whole number, got ${fmt(v)}`;
  if (v < min || v > max) {
    const range = Number.isFinite(min) && Number.isFinite(max)
      ? `from ${fmt(min)} to ${fmt(max)}${u}`
      : Number.isFinite(min) ? `at least ${fmt(min)}${u}` : `at most ${fmt(max)}${u}`;
    return `${label} must be ${range}, got ${String(text).trim()}`;
  }
  return null;
}

/**
 * A symbol as the page writes it: the Greek letters of the paper's
 * symbols (mu_HD -> μ_HD, rho_min -> ρ_min, eps_sc -> ε_sc), the rest as is.
 */
export function prettySymbol(symbol) {
  return String(symbol).replace(/^mu(?=_|$)/, 'μ').replace(/^rho(?=_|$)/, 'ρ').replace(/^eps(?=_|$)/, 'ε');
}

/**
 * A message of the server in the page's words: `field` is the API's name
 * of the field at fault (e.g. device.mu_hd), `label` the name the page
 * shows for it, `file` the name of the file the request carried (what the
 * server calls the request body). The field's prefix goes, the API's name
 * becomes the label, "(field x)" notes go.
 */
export function inPageWords(message, { field = null, label = null, file = null } = {}) {
  let text = String(message);
  const names = field ? [field, field.split('.').pop()] : [];
  names.forEach((name) => {
    if (text.startsWith(`${name}: `)) text = text.slice(name.length + 2);
  });
  text = text.replace(/\s*\(field [^)]*\)/g, '');
  if (file) text = text.replace(/\b(the )?request body\b/g, file);
  else text = text.replace(/\bthe request body\b/g, 'the request').replace(/\brequest body\b/g, 'the request');
  // serde's words for a file's fields: "unknown field `x`, expected one of `a`, `b`".
  text = text.replace(/unknown field `([^`]*)`, expected one of ((?:`[^`]*`(?:, | or )?)+)/g,
    (_, name, list) => `unknown field "${name}" (the fields are ${list.replace(/`/g, '')})`);
  text = text.replace(/unknown field `([^`]*)`, expected `([^`]*)`/g, 'unknown field "$1" (the field is $2)');
  text = text.replace(/`([^`]*)`/g, '"$1"');
  if (label) {
    names.forEach((name) => {
      const escaped = name.replace(/[.*+?^${}()|[\]\\]/g, '\\$&');
      text = text.replace(new RegExp(`(^|[^A-Za-z0-9_.])${escaped}(?![A-Za-z0-9_])`, 'g'), `$1${label}`);
    });
  }
  return text;
}
