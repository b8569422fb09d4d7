// The map page's fields (map.html), pure: what each accepts (the ranges
// POST /api/map checks: the core's friction and position ranges, the gray
// mapping's gamma, a positive pixel size, and the device parameters'
// ranges from GET /api/config), what is unusual but accepted, and the
// server's errors said in the page's words beside the field they concern.
// No DOM: unit-tested by node (js/test/map-fields.test.mjs); map.js shows
// the results under the controls.

import { fmt } from './format.js';

/** A decimal number as typed: digits, an optional point and exponent (no hex, no "Infinity"). */
const DECIMAL = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;

/**
 * The page's numeric fields by control id: the label the user sees, the
 * request field (`api`), the name the server's messages use for it
 * (`server`), the unit, the accepted range (`positive`: more than min),
 * the typical range (outside it the value is unusual but accepted) and an
 * example for the "not a number" message. The device parameters' ranges
 * are replaced by GET /api/config's (withConfig).
 */
export const FIELDS = {
  mu_black: {
    label: 'μ of black', api: 'mu_black', server: 'mu of black', unit: '',
    accepted: [-1000, 1000], typical: [0, 3], example: '1',
  },
  mu_white: {
    label: 'μ of white', api: 'mu_white', server: 'mu of white', unit: '',
    accepted: [-1000, 1000], typical: [0, 3], example: '1.2',
  },
  gamma: {
    label: 'Gamma γ', api: 'gamma', server: 'gamma', unit: '',
    accepted: [0.05, 20], typical: [0.2, 5], example: '1',
  },
  pixel_mm: {
    label: 'Pixel size', api: 'pixel_mm', server: 'pixel size', unit: 'mm',
    accepted: [0, 1e6], positive: true, typical: [0.005, 2], example: '0.1',
  },
  x0_mm: {
    label: 'x of the first column', api: 'x0_mm', server: 'x of the first column', unit: 'mm',
    accepted: [-1e6, 1e6], typical: [-1000, 1000], example: '0',
  },
  y0_mm: {
    label: 'y of the bottom row', api: 'y0_mm', server: 'y of the bottom row', unit: 'mm',
    accepted: [-1e6, 1e6], typical: [-1000, 1000], example: '0',
  },
  mu_hd: {
    label: 'μ_HD', api: 'device.mu_hd', server: 'mu_HD', unit: '',
    accepted: [0.001, 10], typical: [0.4, 1], example: '1',
  },
  u_max_v: {
    label: 'U_max', api: 'device.u_max_v', server: 'U_max', unit: 'V',
    accepted: [0.001, 10000], typical: null, example: '100',
  },
};

/**
 * FIELDS with the device parameters' accepted ranges (`device_params`)
 * and typical ranges (`explanations`) of GET /api/config.
 */
export function withConfig(fields, config) {
  const out = {};
  Object.entries(fields).forEach(([id, f]) => {
    const name = f.api.startsWith('device.') ? f.api.slice('device.'.length) : null;
    const param = name && (config.device_params || []).find((p) => p.name === name);
    const explained = name && (config.explanations || []).find((e) => e.field === name);
    out[id] = Object.assign({}, f,
      param ? { accepted: [param.min, param.max] } : {},
      explained ? { typical: explained.typical ? [explained.typical.min, explained.typical.max] : null } : {});
  });
  return out;
}

/** The text of a field: {blank: true}, {value} or {bad: true} (not a number). */
export function readNumber(text) {
  const t = String(text).trim();
  if (t === '') return { blank: true };
  if (!DECIMAL.test(t)) return { bad: true };
  const value = Number(t);
  return Number.isFinite(value) ? { value } : { bad: true };
}

const withUnit = (v, unit) => `${fmt(v)}${unit ? ` ${unit}` : ''}`;

/**
 * The check of field `id`'s text: {level: 'ok' | 'warning' | 'error',
 * text, value}. `context` holds what other fields and the last map say:
 * {values: {id: number}, method, band: [mu_HD, mu at U_max] or null}.
 * A blank field and letters are refused; a value outside the accepted
 * range is refused; outside the typical range, or (eq. 8) a friction the
 * display cannot render, is a warning.
 */
export function checkField(fields, id, text, context = {}) {
  const f = fields[id];
  const read = readNumber(text);
  const unitText = f.unit ? ` of ${f.unit}` : '';
  if (read.blank) {
    return { level: 'error', text: `${f.label} must be given: type a number${unitText} (it is blank).` };
  }
  if (read.bad) {
    return { level: 'error', text: `${f.label} must be a number such as ${f.example}, not “${String(text).trim()}”.` };
  }
  const v = read.value;
  const [lo, hi] = f.accepted;
  if (f.positive && !(v > lo && v <= hi)) {
    return { level: 'error', value: v, text: `${f.label} must be more than 0${f.unit ? ` ${f.unit}` : ''}, got ${fmt(v)}.` };
  }
  if (!f.positive && !(v >= lo && v <= hi)) {
    return {
      level: 'error', value: v,
      text: `${f.label} must be from ${fmt(lo)} to ${withUnit(hi, f.unit)}, got ${fmt(v)}.`,
    };
  }
  const values = context.values || {};
  if (id === 'mu_white' && Number.isFinite(values.mu_black) && v === values.mu_black) {
    return { level: 'error', value: v, text: `${f.label} must differ from ${fields.mu_black.label} (both ${fmt(v)}).` };
  }
  if ((id === 'mu_black' || id === 'mu_white') && context.method === 'physical') {
    const band = context.band;
    const muHd = band ? band[0] : values.mu_hd;
    if (Number.isFinite(muHd) && v < muHd) {
      return {
        level: 'warning', value: v,
        text: `${f.label} ${fmt(v)} is below μ_HD (${fmt(muHd)}): eq. (8) gives it 0 V, so it is not rendered.`,
      };
    }
    if (band && v > band[1] * (1 + 1e-9)) {
      return {
        level: 'warning', value: v,
        text: `${f.label} ${fmt(v)} is above the top of the band (μ ${fmt(band[1])} at U_max): it is clipped at U_max.`,
      };
    }
  }
  if (f.typical && (v < f.typical[0] || v > f.typical[1])) {
    return {
      level: 'warning', value: v,
      text: `${f.label} ${fmt(v)} is unusual (typically ${fmt(f.typical[0])} to ${withUnit(f.typical[1], f.unit)}); ` +
        'it is used as typed.',
    };
  }
  return { level: 'ok', value: v, text: '' };
}

/**
 * The grid's far edge from the image's size: the last column and the top
 * row must lie within the accepted positions (as the server checks the
 * grid). An error {id, text} on the pixel size, or null.
 */
export function checkExtent(fields, values, nx, ny) {
  const [lo, hi] = fields.x0_mm.accepted;
  const { pixel_mm: d, x0_mm: x0, y0_mm: y0 } = values;
  if (![d, x0, y0, nx, ny].every(Number.isFinite)) return null;
  const x1 = x0 + d * (nx - 1);
  const y1 = y0 + d * (ny - 1);
  if (x1 < lo || x1 > hi || y1 < lo || y1 > hi) {
    return {
      id: 'pixel_mm',
      text: `${fields.pixel_mm.label} ${fmt(d)} mm puts the image's far corner at x = ${fmt(x1)}, y = ${fmt(y1)} mm, ` +
        `beyond the positions accepted (${fmt(lo)} to ${fmt(hi)} mm).`,
    };
  }
  return null;
}

/** The control a server error's field concerns: a field's id, 'image', 'method', 'path' or null (none). */
export function controlOf(fields, field) {
  if (!field) return null;
  if (field === 'image_png_base64') return 'image';
  if (field === 'pixel_mm_y') return 'pixel_mm';
  if (field === 'method') return 'method';
  if (field === 'path' || field.startsWith('path.') || field.startsWith('path[')) return 'path';
  const id = Object.keys(fields).find((k) => fields[k].api === field);
  return id || null;
}

/** API names and paths the server's words may hold, and the page's words for them. */
const WORDS = [
  [/\(field [^)]*\)/g, ''],
  [/^image_png_base64(, [a-z0-9_]+)?: /, ''],
  [/\bd[xy]_mm\b/g, 'pixel size'],
  [/\bimage_png_base64\b/g, 'the image'],
  [/\bdevice\.mu_hd\b|\bmu_hd\b/g, 'μ_HD'],
  [/\bdevice\.u_max_v\b|\bu_max_v\b/g, 'U_max'],
  [/\bdevice\.area_exponent\b|\barea_exponent\b/g, 'the contact-area exponent n'],
  [/\bmu_black\b/g, 'μ of black'],
  [/\bmu_white\b/g, 'μ of white'],
  [/\bmu of black\b/g, 'μ of black'],
  [/\bmu of white\b/g, 'μ of white'],
  [/\bpixel_mm_y\b/g, 'pixel height'],
  [/\bpixel_mm\b/g, 'pixel size'],
  [/\bx0_mm\b/g, 'x of the first column'],
  [/\by0_mm\b/g, 'y of the bottom row'],
  [/\bpath\.(t_s|x_mm|y_mm)\[(\d+)\]/g, (_, c, k) => `sample ${Number(k) + 1} of the path`],
  [/\bt_s\b/g, 't'],
  [/\bx_mm\b/g, 'x'],
  [/\by_mm\b/g, 'y'],
  [/\bdevice\./g, ''],
  [/^body: /, ''],
  [/\brequest body\b/g, 'request'],
];

/** The server's words with API names replaced by the page's (see WORDS). */
export function readable(message) {
  let text = String(message);
  WORDS.forEach(([pattern, words]) => { text = text.replace(pattern, words); });
  return text.replace(/\s+/g, ' ').trim();
}

/**
 * A server error ({error, field}) in the page's words, with where it
 * goes: {control, text}. A field's error is said with its label ("Pixel
 * size must be a positive number of mm, got -5"), the image's with the
 * file's name, a path's as the path's; control is null for an error that
 * belongs to no field (the page's header line).
 */
export function pageError(fields, error, fileName) {
  const control = controlOf(fields, error.field);
  const message = String(error.error || '');
  const f = control && fields[control];
  if (f) {
    const server = [f.server, f.server.toLowerCase()].find((name) => message.startsWith(`${name} `));
    const label = error.field === 'pixel_mm_y' ? 'Pixel size (its height)' : f.label;
    const text = server ? `${label} ${readable(message.slice(server.length))}` : `${label}: ${readable(message)}`;
    return { control, text };
  }
  if (control === 'image') return { control, text: `${fileName || 'The image'}: ${readable(message)}` };
  if (control === 'path') return { control, text: `The path drawn: ${readable(message)}` };
  if (control === 'method') return { control, text: `Method: ${readable(message)}` };
  return { control: null, text: readable(message) };
}
