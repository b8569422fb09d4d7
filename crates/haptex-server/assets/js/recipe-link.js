// A recipe in a link and in words, pure: base64url of its JSON's UTF-8
// bytes after `#recipe=` in the page's address, read back, and what its
// source was (the label of a recipe opened); a design in a link by its
// parameters (`#design=`), checked as typed values are, and the design a
// recipe records (its `page`). No DOM: unit-tested by node
// (js/test/recipe-link.test.mjs).

import { fmt } from './format.js';

/** What starts a page address's hash that carries a recipe. */
export const RECIPE_HASH = '#recipe=';

/** base64url of a text's UTF-8 bytes (no padding), and back (the recipe in a link). */
export function toBase64Url(text) {
  let binary = '';
  new TextEncoder().encode(text).forEach((b) => { binary += String.fromCharCode(b); });
  return btoa(binary).replace(/\+/g, '-').replace(/\//g, '_').replace(/=+$/, '');
}

/** The text of base64url bytes (invalid UTF-8 becomes U+FFFD); throws when it is not base64. */
export function fromBase64Url(text) {
  const binary = atob(text.replace(/-/g, '+').replace(/_/g, '/'));
  return new TextDecoder().decode(Uint8Array.from(binary, (c) => c.charCodeAt(0)));
}

/** The hash of a link to recipe `r` (an object): `#recipe=` and its JSON in base64url. */
export function recipeHash(r) {
  return `${RECIPE_HASH}${toBase64Url(JSON.stringify(r))}`;
}

/** Whether an address's hash carries a recipe: a whole one (#recipe=) or a design's parameters (#design=). */
export function isRecipeHash(hash) {
  return hash.startsWith(RECIPE_HASH) || isDesignHash(hash);
}

/** The `format` of what recipeFromHash gives for a `#design=` link: its checked-later [key, text] pairs. */
export const DESIGN_LINK = 'haptex-design-link/1';

/**
 * The recipe a `#recipe=` hash carries, or for a `#design=` hash
 * {format: DESIGN_LINK, pairs} (its values not checked yet: checkDesign);
 * throws when it is not base64url of JSON, or not a design link of format 1.
 */
export function recipeFromHash(hash) {
  if (isDesignHash(hash)) return { format: DESIGN_LINK, pairs: parseDesignHash(hash) };
  return JSON.parse(fromBase64Url(hash.slice(RECIPE_HASH.length)));
}

/** What a recipe's source was, in the page's words (its `source`, the provenance of a profile). */
export function recipeSourceText(source) {
  return source.kind === 'template'
    ? `${source.surface} r_w ${fmt(source.width_mm)} mm, r_h ${fmt(source.height_mm)} mm, ${fmt(source.velocity_mm_s)} mm/s`
    : source.kind === 'library' ? `${source.material}, stroke seed ${source.seed}`
      : source.kind === 'upload' ? source.file : 'a profile';
}

// A design in a link, by its parameters (docs/web.md, "Recipes"): the
// page's controls as `key=value` pairs after `#design=1` (the format),
// nested keys with a dot (`template.width_mm=1.3`, `device.mu_hd=1`),
// booleans 1 or 0, a blank field an empty value, every value
// percent-encoded. A few hundred bytes where a recipe carries the
// profile's data (20 KB and more). Read back strictly: every key must be
// known and every value is checked as the page checks a typed value
// (ranges from GET /api/config and GET /api/templates, designRanges), a
// problem is reported, never dropped.

/** What starts a page address's hash that carries a design's parameters. */
export const DESIGN_HASH = '#design=';
/** The design links this page writes and reads. */
export const DESIGN_FORMAT = '1';
/** The keys beside the design's: the haptex that wrote the link and the start of its data's SHA-256. */
export const PIN_KEYS = ['haptex', 'data'];
/** The largest u64 (a library stroke's seed). */
const MAX_SEED = 18446744073709551615n;

/** The text of a value in a link: 1 or 0, '' for blank (null), a number as JavaScript writes it (exact). */
function linkText(v) {
  if (v === true) return '1';
  if (v === false) return '0';
  if (v === null || v === undefined) return '';
  return String(v);
}

/** A design's [key, value] pairs, nested objects flattened with a dot, in the design's order. */
export function flattenDesign(design) {
  const pairs = [];
  Object.entries(design).forEach(([key, v]) => {
    if (v !== null && typeof v === 'object' && !Array.isArray(v)) {
      Object.entries(v).forEach(([inner, w]) => pairs.push([`${key}.${inner}`, w]));
    } else {
      pairs.push([key, v]);
    }
  });
  return pairs;
}

/** The hash of a link to `design` (its parameters), with the pins (`haptex`, `data`) first. */
export function designHash(design, pins = {}) {
  const pairs = [['design', DESIGN_FORMAT], ...PIN_KEYS.filter((k) => pins[k]).map((k) => [k, pins[k]]),
    ...flattenDesign(design)];
  return `#${pairs.map(([k, v]) => `${k}=${encodeURIComponent(linkText(v))}`).join('&')}`;
}

/** Whether an address's hash carries a design's parameters. */
export function isDesignHash(hash) {
  return hash.startsWith(DESIGN_HASH);
}

/**
 * The [key, text] pairs of a `#design=` hash (values decoded), less the
 * format; throws when it is not a design link of format 1 or a value's
 * percent-encoding is broken.
 */
export function parseDesignHash(hash) {
  const pairs = hash.slice(1).split('&').filter((p) => p !== '').map((p) => {
    const at = p.indexOf('=');
    const [key, text] = at < 0 ? [p, ''] : [p.slice(0, at), p.slice(at + 1)];
    try {
      return [decodeURIComponent(key), decodeURIComponent(text)];
    } catch (_) {
      throw new Error(`${p} is not percent-encoded text`);
    }
  });
  if (!pairs.length || pairs[0][0] !== 'design') throw new Error('not a design link (#design=1&...)');
  if (pairs[0][1] !== DESIGN_FORMAT) {
    throw new Error(`a design link of format ${JSON.stringify(pairs[0][1])}; this page reads format ${DESIGN_FORMAT}`);
  }
  return pairs.slice(1);
}

/** The entry of id `id` in a list of {id} (config.sources, methods, displays, strategies). */
const ids = (list) => (list || []).map((x) => x.id);

/**
 * What a design's values are checked against, from the server's answers:
 * GET /api/config (`config`: sources, methods, displays, strategies,
 * device parameters, the accepted ranges of the explanations), GET
 * /api/templates (`templates`, or null: the surfaces, each slider's range
 * and step, x0's accepted range), the library's material names, and the
 * surface selected (`surface`: the sliders checked when a design names none).
 */
export function designRanges(config, templates, materials, surface = null) {
  const explained = Object.fromEntries((config.explanations || []).map((e) => [e.field, e]));
  const number = (field, label) => {
    const e = explained[field];
    return e ? { min: e.accepted.min, max: e.accepted.max, unit: e.unit || '', label: e.symbol || label }
      : { min: -Infinity, max: Infinity, unit: '', label };
  };
  const device = {};
  (config.device_params || []).forEach((p) => {
    device[p.name] = { min: p.min, max: p.max, unit: p.unit || '', label: explained[p.name] ? explained[p.name].symbol : p.name };
  });
  const surfaces = {};
  ((templates && templates.templates) || []).forEach((t) => {
    surfaces[t.name] = Object.fromEntries(t.parameters.map((p) => [p.name,
      { min: p.slider[0], max: p.slider[1], step: p.step, unit: p.unit, label: p.label, slider: true }]));
  });
  const x0 = templates ? templates.x0_mm.accepted : [-Infinity, Infinity];
  return {
    sources: ids(config.sources),
    methods: ids(config.methods),
    displays: ids(config.displays),
    strategies: ids(config.strategies),
    device,
    numbers: {
      flat_mu: number('flat_mu', 'mu_flat'),
      weight: number('weight', 'w'),
      a_max_um: number('a_max_um', 'a_max'),
      'play.velocity_mm_s': number('velocity_mm_s', 'velocity'),
      'play.carrier_hz': number('carrier_hz', 'carrier frequency'),
    },
    x0: { min: x0[0], max: x0[1], unit: 'mm', label: 'x0' },
    surfaces,
    surface: surface || Object.keys(surfaces)[0] || null,
    materials: materials || [],
  };
}

/** Whether `v` lies on a slider's steps from its minimum (within rounding). */
export function onStep(v, min, step) {
  const k = (v - min) / step;
  return Math.abs(k - Math.round(k)) <= 1e-6 * Math.max(1, Math.abs(k));
}

/**
 * Checks a number's text against a range: [value, problem]. Blank is
 * null, allowed only when `blank`; a slider's value must also lie on its steps.
 */
function checkNumber(key, text, range, blank) {
  const unit = range.unit ? ` ${range.unit}` : '';
  const trimmed = text.trim();
  if (trimmed === '') return blank ? [null, null] : [null, `${key}: ${range.label} needs a number, got nothing`];
  const v = Number(trimmed);
  if (!Number.isFinite(v)) return [null, `${key}: ${range.label} must be a number, got ${JSON.stringify(text)}`];
  if (v < range.min || v > range.max) {
    return [null, `${key}: ${range.label} must be from ${fmt(range.min)} to ${fmt(range.max)}${unit}` +
      `${range.slider ? ' (its slider)' : ''}, got ${trimmed}`];
  }
  if (range.step && !onStep(v, range.min, range.step)) {
    return [null, `${key}: ${range.label} must be on its slider's steps of ${fmt(range.step)}${unit} from ` +
      `${fmt(range.min)}, got ${trimmed}`];
  }
  return [v, null];
}

/** One of `choices`, or a problem naming them. */
function checkChoice(key, text, choices, what) {
  return choices.includes(text) ? [text, null]
    : [null, `${key}: ${JSON.stringify(text)} is not ${what} (${choices.join(', ') || 'none offered'})`];
}

/**
 * The design of a link's (or a recipe's page's) [key, text] pairs, checked
 * against `ranges` (designRanges): {design, pins, problems}. The design
 * holds the keys given, as values (numbers, booleans, null for a blank
 * field); a key left out leaves its control as it is. `problems` lists,
 * in the page's words, every unknown or repeated key, every bad value and
 * every key the design's source does not use; `source` is required, and
 * `upload` only where the profile's data come with the design (`withData`).
 */
export function checkDesign(pairs, ranges, { withData = false } = {}) {
  const design = {};
  const pins = {};
  const problems = [];
  const seen = new Set();
  const put = (key, v) => {
    const at = key.indexOf('.');
    if (at < 0) { design[key] = v; return; }
    const [outer, inner] = [key.slice(0, at), key.slice(at + 1)];
    design[outer] = design[outer] || {};
    design[outer][inner] = v;
  };
  const surfacePair = pairs.find(([k]) => k === 'template.surface');
  const surface = surfacePair && ranges.surfaces[surfacePair[1]] ? surfacePair[1] : ranges.surface;
  const sources = withData ? ranges.sources : ranges.sources.filter((s) => s !== 'upload');
  pairs.forEach(([key, text]) => {
    if (seen.has(key)) { problems.push(`${key}: given more than once`); return; }
    seen.add(key);
    let result;
    const [outer, inner] = key.includes('.') ? [key.slice(0, key.indexOf('.')), key.slice(key.indexOf('.') + 1)]
      : [key, null];
    if (PIN_KEYS.includes(key)) {
      pins[key] = text;
      return;
    } else if (key === 'source') {
      result = checkChoice(key, text, sources, withData ? 'a source of this page'
        : 'a source a link can name (an uploaded profile travels in a recipe, with its data)');
    } else if (key === 'method') {
      result = checkChoice(key, text, ranges.methods, 'a mapping method');
    } else if (key === 'display') {
      result = checkChoice(key, text, ranges.displays, 'a display');
    } else if (key === 'strategy') {
      result = checkChoice(key, text, ranges.strategies, 'a strategy');
    } else if (key === 'relative' || key === 'both') {
      result = text === '1' || text === '0' ? [text === '1', null]
        : [null, `${key}: 1 (on) or 0 (off), got ${JSON.stringify(text)}`];
    } else if (key === 'flat_mu' || key === 'weight' || key === 'a_max_um') {
      result = checkNumber(key, text, ranges.numbers[key], true);
    } else if (outer === 'play' && ranges.numbers[key]) {
      result = checkNumber(key, text, ranges.numbers[key], false);
    } else if (outer === 'device' && ranges.device[inner]) {
      result = checkNumber(key, text, ranges.device[inner], true);
    } else if (key === 'template.surface') {
      result = checkChoice(key, text, Object.keys(ranges.surfaces), 'a surface template of this server');
    } else if (key === 'template.x0_mm') {
      result = checkNumber(key, text, ranges.x0, false);
    } else if (outer === 'template' && surface && ranges.surfaces[surface][inner]) {
      result = checkNumber(key, text, ranges.surfaces[surface][inner], false);
    } else if (key === 'library.material') {
      result = checkChoice(key, text, ranges.materials, 'a material of the library');
    } else if (key === 'library.seed') {
      result = /^[0-9]{1,20}$/.test(text) && BigInt(text) <= MAX_SEED ? [text, null]
        : [null, `${key}: a stroke seed is a whole number from 0 to ${MAX_SEED}, got ${JSON.stringify(text)}`];
    } else {
      result = [null, `${key}: not a key of a design link${outer === 'template' && surface
        ? ` (the ${surface} template's are ${['surface', 'x0_mm', ...Object.keys(ranges.surfaces[surface])].join(', ')})`
        : ''}`];
    }
    const [v, problem] = result;
    if (problem) problems.push(problem); else put(key, v);
  });
  if (!seen.has('source')) {
    problems.push('source: missing (template or library)');
  } else if (design.source) {
    ['template', 'library'].filter((s) => s !== design.source && design[s]).forEach((s) => {
      problems.push(`${Object.keys(design[s]).map((k) => `${s}.${k}`).join(', ')}: not used by the ` +
        `${design.source} source`);
    });
  }
  return { design, pins, problems };
}

/** A design's [key, text] pairs, as a link writes them (a recipe's page is checked as its link would be). */
export function designPairs(design) {
  return flattenDesign(design).map(([k, v]) => [k, linkText(v)]);
}

/**
 * The page's design a recipe records (its `page`), or for a recipe of an
 * older page (none) the design its source and requests say: the source
 * as itself (a template's parameters, a material and its stroke seed, else
 * the upload), the voltage request's method, mapping, display and device
 * (the device fields it does not give, `deviceNames`, blank as before), the
 * playback's velocity and carrier; eq. (8) beside eq. (9) off (not recorded).
 */
export function recipeDesign(r, voltageRequest, deviceNames = []) {
  if (r.page !== undefined) return r.page;
  const body = voltageRequest.body;
  const source = r.source && typeof r.source === 'object' ? r.source : {};
  const design = {};
  if (source.kind === 'template') {
    const { kind, fe_exact: _exact, extrapolation: _extrapolated, ...template } = source;
    Object.assign(design, { source: 'template', template });
  } else if (source.kind === 'library') {
    Object.assign(design, { source: 'library', library: { material: source.material, seed: String(source.seed) } });
  } else {
    design.source = 'upload';
  }
  Object.assign(design, {
    method: body.method || 'physical', relative: Boolean(body.relative), flat_mu: body.flat_mu ?? null, both: false,
    display: body.display || 'electrovibration',
  });
  if (body.strategy) design.strategy = body.strategy;
  Object.assign(design, { weight: body.weight ?? null, a_max_um: body.a_max_um ?? null });
  const device = body.device || {};
  design.device = Object.fromEntries([...new Set([...deviceNames, ...Object.keys(device)])]
    .map((name) => [name, device[name] ?? null]));
  const play = (r.downloads || []).find((d) => d && d.body && typeof d.path === 'string' && d.path.startsWith('/api/play'));
  if (play) {
    design.play = {};
    if (play.body.stroke && play.body.stroke.velocity_mm_s !== undefined) design.play.velocity_mm_s = play.body.stroke.velocity_mm_s;
    if (play.body.carrier && play.body.carrier.frequency_hz !== undefined) design.play.carrier_hz = play.body.carrier.frequency_hz;
  }
  return design;
}
