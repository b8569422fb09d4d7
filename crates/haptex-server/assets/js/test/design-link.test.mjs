// A design in a link by its parameters (js/recipe-link.js, #design=): written,
// read back, every value checked as a typed value, its size; and the design a
// recipe records (its page, or what a recipe of an older page says).
import test from 'node:test';
import assert from 'node:assert/strict';
import {
  DESIGN_LINK, checkDesign, designHash, designPairs, designRanges, flattenDesign, isDesignHash, isRecipeHash,
  onStep, parseDesignHash, recipeDesign, recipeFromHash,
} from '../recipe-link.js';

// The parts of GET /api/config and GET /api/templates the checks read, as the server answers them.
const explanation = (field, symbol, min, max, unit = '') => ({ field, symbol, unit, accepted: { min, max } });
const CONFIG = {
  version: '0.1.0',
  sources: [{ id: 'template' }, { id: 'library' }, { id: 'upload' }],
  methods: [{ id: 'physical' }, { id: 'normalized' }],
  displays: [{ id: 'electrovibration' }, { id: 'ultrasonic' }, { id: 'combined' }],
  strategies: [{ id: 'split' }, { id: 'bias' }, { id: 'weighted' }],
  device_params: [
    { name: 'mu_hd', default: 1, min: 0.001, max: 10, unit: '' },
    { name: 'u_max_v', default: 100, min: 0.001, max: 10000, unit: 'V' },
    { name: 'eps_sc', default: 1650, min: 1, max: 1e6, unit: '' },
    { name: 'eps_i', default: 10, min: 1, max: 1e6, unit: '' },
    { name: 'd_sc_mm', default: 0.2, min: 1e-6, max: 10, unit: 'mm' },
    { name: 'd_i_mm', default: 0.001, min: 1e-6, max: 10, unit: 'mm' },
    { name: 'k_mm2_per_n', default: 200, min: 1e-6, max: 1e6, unit: 'mm^2/N' },
    { name: 'area_exponent', default: 1, min: 0.001, max: 2, unit: '' },
    { name: 'fn_n', default: null, min: 1e-6, max: 100, unit: 'N' },
  ],
  explanations: [
    explanation('mu_hd', 'mu_HD', 0.001, 10),
    explanation('u_max_v', 'U_max', 0.001, 10000, 'V'),
    explanation('flat_mu', 'mu_flat', 0.001, 10),
    explanation('a_max_um', 'a_max', 0.001, 100, 'µm'),
    explanation('weight', 'w', 0, 1e6),
    explanation('velocity_mm_s', 'v', 1e-6, 10000, 'mm/s'),
    explanation('carrier_hz', 'f_c', 0.001, 1e6, 'Hz'),
  ],
};
const parameters = (width) => [
  { name: 'width_mm', label: width, unit: 'mm', slider: [0.14, 3], step: 0.02 },
  { name: 'height_mm', label: 'height r_h', unit: 'mm', slider: [0.025, 0.6], step: 0.005 },
  { name: 'velocity_mm_s', label: 'sliding velocity', unit: 'mm/s', slider: [3, 122], step: 1 },
];
const TEMPLATES = {
  x0_mm: { default: 5, accepted: [-1000, 1000] },
  templates: [{ name: 'bump', parameters: parameters('bump width r_w') },
    { name: 'sine', parameters: parameters('sine period r_w') }],
};
const RANGES = designRanges(CONFIG, TEMPLATES, ['latex', 'velvet fabric'], 'bump');
const SHA = '3345eb31d679c58804aadd2d4e2eb1ad4f2125d2946ae0eeb15b199ae05cd09b';

/** The page's design of a template (recipes.js, pageDesign): Fig. 2 with eq. (9) chosen, r_w moved. */
const TEMPLATE_DESIGN = {
  source: 'template',
  template: { surface: 'bump', x0_mm: 5, width_mm: 2.14, height_mm: 0.27, velocity_mm_s: 20 },
  method: 'normalized', relative: true, flat_mu: 0.5, both: true,
  display: 'electrovibration', strategy: 'split', weight: null, a_max_um: null,
  device: { mu_hd: 1, u_max_v: 100, eps_sc: 1650, eps_i: 10, d_sc_mm: 0.2, d_i_mm: 0.001, k_mm2_per_n: 200,
    area_exponent: 1, fn_n: null },
  play: { velocity_mm_s: 50, carrier_hz: 1000 },
};

/** The design and problems of a hash, read as the page reads a link. */
const read = (hash, withData = false) => checkDesign(parseDesignHash(hash), RANGES, { withData });
/** The problems of a template link with `extra` appended (its pairs as text). */
const problemsWith = (extra) => read(`${designHash(TEMPLATE_DESIGN)}&${extra}`).problems;

test('a template design survives its link, value for value', () => {
  const hash = designHash(TEMPLATE_DESIGN, { haptex: '0.1.0', data: SHA.slice(0, 12) });
  assert.ok(isDesignHash(hash) && isRecipeHash(hash));
  assert.ok(hash.startsWith('#design=1&haptex=0.1.0&data=3345eb31d679&source=template&template.surface=bump&'));
  const { design, pins, problems } = read(hash);
  assert.deepEqual(problems, []);
  assert.deepEqual(design, TEMPLATE_DESIGN);
  assert.deepEqual(pins, { haptex: '0.1.0', data: '3345eb31d679' });
  // What main.js hands to openRecipe for such a hash.
  assert.deepEqual(recipeFromHash(hash), { format: DESIGN_LINK, pairs: parseDesignHash(hash) });
});

test('a typical template link is a few hundred bytes (at most 1 KB)', () => {
  const link = `http://127.0.0.1:65535/${designHash(TEMPLATE_DESIGN, { haptex: '0.1.0', data: SHA.slice(0, 12) })}`;
  assert.ok(link.length < 1024, `${link.length} bytes: ${link}`);
  assert.ok(link.length < 600, `${link.length} bytes: ${link}`);
  // Numbers are written exactly: shortest round trip, not rounded.
  const odd = { ...TEMPLATE_DESIGN, flat_mu: 0.1 + 0.2, device: { ...TEMPLATE_DESIGN.device, mu_hd: 1 / 3 } };
  assert.deepEqual(read(designHash(odd)).design, odd);
});

test('a library design survives its link; text values are percent-encoded', () => {
  const d = { source: 'library', library: { material: 'velvet fabric', seed: '18446744073709551615' },
    method: 'physical', display: 'combined', strategy: 'weighted', weight: 0.5, a_max_um: 2.3 };
  const hash = designHash(d);
  assert.ok(hash.includes('library.material=velvet%20fabric&library.seed=18446744073709551615'));
  assert.ok(/^#[A-Za-z0-9_.~%=&*'()!-]+$/.test(hash), hash);
  assert.deepEqual(read(hash), { design: d, pins: {}, problems: [] });
});

test('keys left out leave their controls as they are; blank optional fields are null', () => {
  const { design, problems } = read('#design=1&source=template&template.surface=sine&device.fn_n=&weight=');
  assert.deepEqual(problems, []);
  assert.deepEqual(design, { source: 'template', template: { surface: 'sine' }, device: { fn_n: null }, weight: null });
});

test('bad values are reported as typed values are, each naming its key', () => {
  const bad = (pair) => read(`#design=1&source=template&${pair}`).problems;
  assert.deepEqual(bad('device.mu_hd=-1'), ['device.mu_hd: mu_HD must be from 0.001 to 10, got -1']);
  assert.deepEqual(bad('device.u_max_v=abc'), ['device.u_max_v: U_max must be a number, got "abc"']);
  assert.deepEqual(bad('device.eps_i=1e9'), ['device.eps_i: eps_i must be from 1 to 1.000e+6, got 1e9']);
  assert.deepEqual(bad('play.carrier_hz=-3'), ['play.carrier_hz: f_c must be from 0.001 to 1.000e+6 Hz, got -3']);
  assert.deepEqual(bad('play.velocity_mm_s='), ['play.velocity_mm_s: v needs a number, got nothing']);
  assert.deepEqual(bad('flat_mu=Infinity'), ['flat_mu: mu_flat must be a number, got "Infinity"']);
  assert.deepEqual(bad('template.x0_mm=1e9'), ['template.x0_mm: x0 must be from -1000 to 1000 mm, got 1e9']);
  assert.deepEqual(bad('template.width_mm=5'),
    ['template.width_mm: bump width r_w must be from 0.14 to 3 mm (its slider), got 5']);
  assert.deepEqual(bad('template.width_mm=1.234'),
    ['template.width_mm: bump width r_w must be on its slider\'s steps of 0.02 mm from 0.14, got 1.234']);
  assert.deepEqual(bad('template.surface=ridge'),
    ['template.surface: "ridge" is not a surface template of this server (bump, sine)']);
  assert.deepEqual(bad('method=eq10'), ['method: "eq10" is not a mapping method (physical, normalized)']);
  assert.deepEqual(bad('display=haptic'), ['display: "haptic" is not a display (electrovibration, ultrasonic, combined)']);
  assert.deepEqual(bad('strategy=both'), ['strategy: "both" is not a strategy (split, bias, weighted)']);
  assert.deepEqual(bad('relative=yes'), ['relative: 1 (on) or 0 (off), got "yes"']);
  assert.deepEqual(bad('both=2'), ['both: 1 (on) or 0 (off), got "2"']);
});

test('unknown and repeated keys, keys of another source and a missing source are reported', () => {
  assert.deepEqual(problemsWith('colour=red'), ['colour: not a key of a design link']);
  assert.deepEqual(problemsWith('device.mu=1'), ['device.mu: not a key of a design link']);
  assert.deepEqual(problemsWith('template.depth_mm=1'), ['template.depth_mm: not a key of a design link (the bump ' +
    'template\'s are surface, x0_mm, width_mm, height_mm, velocity_mm_s)']);
  assert.deepEqual(problemsWith('method=physical'), ['method: given more than once']);
  assert.deepEqual(problemsWith('library.material=latex&library.seed=3'),
    ['library.material, library.seed: not used by the template source']);
  assert.deepEqual(read('#design=1&method=physical').problems, ['source: missing (template or library)']);
  const lib = read('#design=1&source=library&library.material=felt&library.seed=-1&library.seed=2').problems;
  assert.deepEqual(lib, [
    'library.material: "felt" is not a material of the library (latex, velvet fabric)',
    'library.seed: a stroke seed is a whole number from 0 to 18446744073709551615, got "-1"',
    'library.seed: given more than once',
  ]);
  assert.deepEqual(read('#design=1&source=library&library.seed=18446744073709551616').problems,
    ['library.seed: a stroke seed is a whole number from 0 to 18446744073709551615, got "18446744073709551616"']);
});

test('an upload is named only where its data come with the design (a recipe)', () => {
  assert.match(read('#design=1&source=upload').problems[0],
    /^source: "upload" is not a source a link can name \(an uploaded profile travels in a recipe, with its data\)/);
  assert.deepEqual(read('#design=1&source=upload', true).problems, []);
});

test('the template\'s sliders are checked for the surface the link names', () => {
  // sine's r_w slider is bump's here, but its label is its own.
  assert.deepEqual(read('#design=1&source=template&template.surface=sine&template.width_mm=9').problems,
    ['template.width_mm: sine period r_w must be from 0.14 to 3 mm (its slider), got 9']);
  // On the slider's steps, within rounding (2.14 = 0.14 + 100 x 0.02).
  assert.ok(onStep(2.14, 0.14, 0.02) && onStep(0.14, 0.14, 0.02) && onStep(122, 3, 1));
  assert.ok(!onStep(2.15, 0.14, 0.02) && !onStep(3.5, 3, 1));
});

test('what is not a design link of format 1 throws (the link cannot be read)', () => {
  assert.throws(() => parseDesignHash('#design=2&source=template'), /format "2"; this page reads format 1/);
  assert.throws(() => parseDesignHash('#design=1&source=%E0%A4%A'), /not percent-encoded/);
  assert.throws(() => recipeFromHash('#design=&source=template'), /format ""/);
  assert.equal(isDesignHash('#designs=1'), false);
  assert.deepEqual(parseDesignHash('#design=1&&source=template&'), [['source', 'template']]);
});

test('flattenDesign and designPairs: nested keys with a dot, values as a link writes them', () => {
  assert.deepEqual(flattenDesign({ a: 1, b: { c: null, d: true } }), [['a', 1], ['b.c', null], ['b.d', true]]);
  assert.deepEqual(designPairs({ relative: false, flat_mu: null, device: { mu_hd: 0.5 } }),
    [['relative', '0'], ['flat_mu', ''], ['device.mu_hd', '0.5']]);
});

test('designRanges: the server\'s accepted ranges, a range-less field only finite', () => {
  assert.deepEqual(RANGES.numbers.flat_mu, { min: 0.001, max: 10, unit: '', label: 'mu_flat' });
  assert.deepEqual(RANGES.device.fn_n, { min: 1e-6, max: 100, unit: 'N', label: 'fn_n' });
  assert.deepEqual(RANGES.x0, { min: -1000, max: 1000, unit: 'mm', label: 'x0' });
  const bare = designRanges({ sources: [{ id: 'upload' }], methods: [], displays: [], strategies: [] }, null, []);
  assert.deepEqual(bare.numbers.weight, { min: -Infinity, max: Infinity, unit: '', label: 'w' });
  assert.equal(bare.surface, null);
  assert.deepEqual(checkDesign([['source', 'template'], ['template.width_mm', '1']], bare).problems, [
    'source: "template" is not a source a link can name (an uploaded profile travels in a recipe, with its data) ' +
      '(none offered)',
    'template.width_mm: not a key of a design link',
  ]);
});

test('recipeDesign: a recipe\'s page as recorded', () => {
  const r = { format: 'haptex-recipe/1', page: TEMPLATE_DESIGN, downloads: [] };
  assert.equal(recipeDesign(r, { body: {} }), TEMPLATE_DESIGN);
  // A page is checked as its link would be.
  assert.deepEqual(checkDesign(designPairs(TEMPLATE_DESIGN), RANGES, { withData: true }).design, TEMPLATE_DESIGN);
});

test('recipeDesign: a recipe of an older page reopens its source as itself', () => {
  const voltage = { path: '/api/voltage?format=csv', body: {
    profile: { x_mm: [0, 1], mu: [0.5, 0.6] }, method: 'normalized', relative: true, flat_mu: 0.5,
    device: { mu_hd: 1, u_max_v: 80 } } };
  const play = { path: '/api/play', body: { stroke: { velocity_mm_s: 30 }, carrier: { shape: 'sine', frequency_hz: 250 } } };
  const template = {
    format: 'haptex-recipe/1', downloads: [voltage, play],
    source: { kind: 'template', surface: 'bump', x0_mm: 5, width_mm: 1.3, height_mm: 0.27, velocity_mm_s: 20,
      fe_exact: false, extrapolation: false },
  };
  const d = recipeDesign(template, voltage, ['mu_hd', 'u_max_v', 'fn_n']);
  assert.deepEqual(d, {
    source: 'template', template: { surface: 'bump', x0_mm: 5, width_mm: 1.3, height_mm: 0.27, velocity_mm_s: 20 },
    method: 'normalized', relative: true, flat_mu: 0.5, both: false, display: 'electrovibration',
    weight: null, a_max_um: null, device: { mu_hd: 1, u_max_v: 80, fn_n: null },
    play: { velocity_mm_s: 30, carrier_hz: 250 },
  });
  assert.deepEqual(checkDesign(designPairs(d), RANGES, { withData: true }).problems, []);
  const library = { format: 'haptex-recipe/1', downloads: [voltage],
    source: { kind: 'library', material: 'latex', seed: 3, stroke_id: 7 } };
  const lib = recipeDesign(library, { body: { profile: {}, display: 'combined', strategy: 'bias', a_max_um: 2 } });
  assert.deepEqual([lib.source, lib.library, lib.method, lib.display, lib.strategy, lib.a_max_um, lib.play],
    ['library', { material: 'latex', seed: '3' }, 'physical', 'combined', 'bias', 2, undefined]);
  const upload = recipeDesign({ source: { kind: 'upload', file: 'a.csv' } }, { body: { profile: {} } });
  assert.equal(upload.source, 'upload');
  assert.equal(recipeDesign({}, { body: {} }).source, 'upload');
});
