// Recipes (docs/web.md, "Recipes"): the design shown as the API requests
// of its downloads with the source's provenance, the data's SHA-256 and
// the page's controls (the recipe download), the design's link (its
// parameters, #design=, or a whole recipe, #recipe=, where the profile is
// data: an upload), and a recipe or a link opened as the page's design,
// each source as itself.

import { $ } from './dom.js';
import { ApiError, postJson } from './api.js';
import { setBoth, setDisplay, setMethod, setRelative, showDisplayControls } from './displays.js';
import { downloadSpec, offerDownload } from './downloads.js';
import { numberIn, readDevice } from './fields.js';
import { say, showError } from './messages.js';
import {
  DESIGN_LINK, checkDesign, designHash, designPairs, designRanges, isRecipeHash, recipeDesign, recipeFromHash,
  recipeHash, recipeSourceText,
} from './recipe-link.js';
import { dropPendingLoad, openSource, showSourcePanel } from './sources.js';
import { state } from './state.js';
import { audio } from './strip.js';
import { setTemplate } from './template.js';
import { dataRows, parseNumber } from './validation.js';
import { updateVoltage } from './voltage.js';

/** The downloads a recipe replays: each the API request that answers it. */
const RECIPE_KINDS = ['profile-csv', 'voltage-csv', 'voltage-json', 'stroke-wav', 'stroke-sidecar'];

/** How many hex digits of the data's SHA-256 a design link carries (`data`). */
const DATA_PIN = 12;

/** A number typed (finite) or null: blank, or not a number. */
const finite = (v) => (Number.isFinite(v) ? v : null);

/**
 * The page's design (a recipe's `page`, a link's parameters): the source
 * and its parameters (a template's surface, x0 and sliders; a material and
 * its stroke seed), the method and mapping (relative, mu_flat, eq. 8
 * beside eq. 9), the display with its strategy, weight and a_max, every
 * device field (null: blank, the server's default) and the playback's
 * velocity and carrier.
 */
export function pageDesign() {
  const d = { source: state.source };
  if (state.source === 'template') {
    const t = state.template;
    const info = state.templates.templates.find((x) => x.name === t.surface);
    d.template = { surface: t.surface, x0_mm: t.x0_mm };
    info.parameters.forEach((p) => { d.template[p.name] = t[p.name]; });
  } else if (state.source === 'library' && state.profile) {
    d.library = { material: state.profile.material, seed: String(state.profile.seed) };
  }
  Object.assign(d, {
    method: state.method, relative: state.relative, flat_mu: finite(numberIn('flat-mu')), both: state.both,
    display: state.display, strategy: state.strategy, weight: finite(numberIn('weight')),
    a_max_um: finite(numberIn('a-max')),
  });
  d.device = Object.fromEntries(state.config.device_params.map((p) =>
    [p.name, finite(parseNumber($(`param-${p.name}`).value))]));
  d.play = { velocity_mm_s: state.velocity, carrier_hz: state.carrierHz };
  return d;
}

/**
 * The recipe of the design shown (docs/web.md, "Recipes"): the requests
 * of its downloads, the source's provenance, the page's design (`page`),
 * the haptex version and the SHA-256 of the data served. `kinds` chooses
 * the downloads.
 */
export function recipe(kinds = RECIPE_KINDS) {
  const data = state.config.data || {};
  const source = state.profile.provenance || {};
  const r = {
    format: 'haptex-recipe/1',
    haptex_version: state.config.version,
    source,
    page: pageDesign(),
    downloads: kinds.map(downloadSpec),
  };
  // Every data set the server serves: the downloads depend on each (a
  // library stroke, a template, and the data's SHA-256 in the voltage
  // CSV's and the sidecar's recipe), and a replay refuses an unpinned one.
  if (data.library_sha256) r.library_sha256 = data.library_sha256;
  if (data.database_sha256) r.database_sha256 = data.database_sha256;
  // The device file the parameters started from (haptex serve --device-file).
  if (data.device_file_sha256) {
    r.device_file = data.device_file;
    r.device_file_sha256 = data.device_file_sha256;
  }
  return r;
}

/** The SHA-256 of the data set a source's profile comes from (the FE database, the library), or null. */
function sourceData(source) {
  const data = state.config.data || {};
  return (source === 'template' ? data.database_sha256 : source === 'library' ? data.library_sha256 : null) || null;
}

/**
 * Why the design shown cannot travel as parameters (its profile or a file
 * it uses is data), or null when it can.
 */
function dataInDesign() {
  if (state.source !== 'template' && state.source !== 'library') return 'an uploaded profile';
  if (state.calibration) return 'an ultrasonic calibration file';
  if (state.deviceFile) return 'a device file';
  return null;
}

/**
 * A link that opens this design in the page, shown in #share-link: its
 * parameters (#design=, a few hundred bytes) for a template or a library
 * stroke, else the whole recipe of its voltage request (#recipe=, with the
 * profile's data). `window.haptex.shareLink()`.
 */
export function shareLink() {
  if (!state.profile || !state.voltage) throw new ApiError('nothing to link to yet', null, 0);
  const why = dataInDesign();
  const data = sourceData(state.source);
  const hash = why ? recipeHash(recipe(['voltage-csv']))
    : designHash(pageDesign(), { haptex: state.config.version, data: data && data.slice(0, DATA_PIN) });
  const link = `${location.origin}${location.pathname}${hash}`;
  const a = $('share-link');
  a.href = link;
  a.hidden = false;
  a.textContent = why
    ? `link to this design (${Math.ceil(link.length / 1024)} KB: it carries the data of ${why})`
    : `link to this design (its parameters, ${link.length} bytes)`;
  return link;
}

/** What a link's or a recipe's design is checked against (designRanges), from the page's server. */
function ranges() {
  const materials = Array.from(document.querySelectorAll('#material option'), (o) => o.value);
  return designRanges(state.config, state.templates, materials, state.template.surface || null);
}

/** The text of a field's value (null: blank). */
const text = (v) => (v === null || v === undefined ? '' : String(v));

/** Sets the controls of a checked design (the keys it holds; the others stay as they are). */
function applyControls(d) {
  if (d.method) setMethod(d.method);
  if (d.relative !== undefined || d.flat_mu !== undefined) {
    setRelative(d.relative ?? state.relative, d.flat_mu === undefined ? $('flat-mu').value : text(d.flat_mu));
  }
  if (d.both !== undefined) setBoth(d.both);
  if (d.device) {
    Object.entries(d.device).forEach(([name, v]) => {
      const input = $(`param-${name}`);
      input.value = text(v);
      input.dispatchEvent(new Event('explain'));
    });
    state.device = readDevice();
  }
  if (d.strategy) { state.strategy = d.strategy; $('strategy').value = d.strategy; }
  if (d.weight !== undefined) $('weight').value = text(d.weight);
  if (d.a_max_um !== undefined) $('a-max').value = text(d.a_max_um);
  if (d.display) setDisplay(d.display); else showDisplayControls();
  const play = d.play || {};
  if (play.velocity_mm_s !== undefined) {
    state.velocity = play.velocity_mm_s;
    $('velocity').value = String(play.velocity_mm_s);
  }
  if (play.carrier_hz !== undefined) {
    state.carrierHz = play.carrier_hz;
    $('carrier').value = String(play.carrier_hz);
    audio.setFrequency(play.carrier_hz);
  }
}

/**
 * Opens a checked design's source as itself: a template's surface, x0 and
 * sliders, a material and its stroke seed; the profile loaded by the
 * server from them (POST /api/predict, GET /api/materials/.../sample).
 * Returns the profile, or null when the user chose another meanwhile.
 */
async function openDesignSource(d) {
  if (d.source === 'template') {
    setTemplate(d.template || {});
  } else if (d.source === 'library' && d.library) {
    if (d.library.material !== undefined) $('material').value = d.library.material;
    if (d.library.seed !== undefined) $('seed').value = d.library.seed;
  }
  return openSource(d.source);
}

/** Whether two profiles have the same points (exactly: a prediction or a stroke the server answers again). */
function samePoints(a, b) {
  const same = (x, y) => Array.isArray(x) && Array.isArray(y) && x.length === y.length && x.every((v, i) => v === y[i]);
  const fnA = a.fn_n || null;
  const fnB = b.fn_n || null;
  return same(a.x_mm, b.x_mm) && same(a.mu, b.mu) && (fnA === null ? fnB === null : same(fnA, fnB));
}

/**
 * Opens a recipe's profile as data (the *your profile* source, labelled
 * with the recipe's provenance): an upload's, or a template's or library
 * stroke's that this server does not give again (other data).
 */
async function openData(r, body) {
  const p = body.profile;
  // The server checks the profile (points, ranges) as for an upload.
  const checked = await (await postJson('/api/profile', p)).json();
  const source = r.source || {};
  const what = recipeSourceText(source);
  const profileBody = { x_mm: p.x_mm, mu: p.mu };
  if (p.fn_n) profileBody.fn_n = p.fn_n;
  const profile = {
    x_mm: p.x_mm, mu: p.mu, fn_n: p.fn_n || null,
    label: `recipe: ${what}`,
    synthetic: Boolean(source.synthetic),
    spec: { file: 'recipe-profile.csv', method: 'POST', path: '/api/profile?format=csv', body: profileBody },
    provenance: r.source && typeof r.source === 'object' ? r.source : undefined,
  };
  // The upload source, showing the recipe's profile (no file to read).
  const input = document.querySelector("input[name='source'][value='upload']");
  if (!input) throw new ApiError('this server offers no profile upload', 'recipe', 0);
  input.checked = true;
  state.source = 'upload';
  showSourcePanel('upload');
  dropPendingLoad(); // a profile still loading is dropped
  state.profiles.upload = profile;
  state.profile = profile;
  $('upload-info').textContent = `${profile.label}: ${checked.n_points} points, opened from a recipe ` +
    `(haptex ${r.haptex_version}).`;
  return profile;
}

/** Checks a design's pairs (a link's, a recipe's page's): the design, or an ApiError listing every problem. */
function checked(pairs, what, withData) {
  const result = checkDesign(pairs, ranges(), { withData });
  if (result.problems.length) {
    throw new ApiError(`${what} cannot be opened: ${result.problems.join('; ')}`, 'recipe', 0);
  }
  return result;
}

/**
 * Opens a design link's parameters (#design=): every value checked as a
 * typed one (any problem refuses the link, naming each), the controls set,
 * the source opened as itself. A link made by another haptex or with other
 * data (its `haptex`, `data`) is opened and the difference said.
 */
async function openLink(pairs) {
  const { design, pins } = checked(pairs, "the link's design", false);
  // A design link holds no file: a calibration or a device file the page
  // uses (a link pasted into the open page) is not the link's.
  if (state.deviceFile && $('yd-stop')) $('yd-stop').click();
  state.calibration = null;
  $('calibration').value = '';
  applyControls(design);
  const profile = await openDesignSource(design);
  if (!profile) return;
  const what = profile.label;
  profile.label = `recipe: ${what}`;
  const notes = [];
  if (pins.haptex && pins.haptex !== state.config.version) {
    notes.push(`the link was made by haptex ${pins.haptex}, this is ${state.config.version}`);
  }
  const data = sourceData(design.source);
  if (pins.data && !(data || '').startsWith(pins.data)) {
    notes.push(`the link was made with ${design.source === 'template' ? 'an FE database' : 'a library'} of ` +
      `SHA-256 ${pins.data}…, this server's is ${data ? `${data.slice(0, DATA_PIN)}…` : 'none'}`);
  }
  await updateVoltage();
  say(`Opened the link's design: ${what}.` +
    (notes.length ? ` Note: ${notes.join('; ')}: the profile may differ from the one the link was made with.` : ''));
}

/**
 * Opens a recipe (an uploaded file, a link's #recipe=, or a link's
 * #design= parameters) as the page's design. Its `page` (or, for a recipe
 * of an older page, what its source and voltage request say) sets the
 * controls and opens the source as itself: a template with its sliders,
 * a library material with its stroke seed, each loaded again and kept
 * only when it gives the recipe's own profile (else the recipe's profile
 * is shown as *your profile*, with the reason); an upload is its data.
 */
export async function openRecipe(r) {
  if (r && r.format === DESIGN_LINK && Array.isArray(r.pairs)) return openLink(r.pairs);
  if (!r || r.format !== 'haptex-recipe/1' || !Array.isArray(r.downloads)) {
    throw new ApiError('not a haptex recipe (format haptex-recipe/1)', 'recipe', 0);
  }
  const request = r.downloads.find((d) => d && d.body && typeof d.path === 'string' &&
    d.path.startsWith('/api/voltage'));
  if (!request || !request.body.profile) throw new ApiError('the recipe has no voltage request', 'recipe', 0);
  const body = request.body;
  let page = recipeDesign(r, request, state.config.device_params.map((p) => p.name));
  if (page === null || typeof page !== 'object' || Array.isArray(page)) {
    throw new ApiError('the recipe\'s page is not an object', 'recipe', 0);
  }
  let note = '';
  if ((page.source === 'template' || page.source === 'library') &&
      !state.config.sources.some((s) => s.id === page.source)) {
    // This server has no such source: the recipe's profile is data here.
    note = ` This server offers no ${page.source === 'template' ? 'surface templates' : 'library'}: the recipe's ` +
      'own profile is shown as your profile.';
    const { template: _t, library: _l, ...rest } = page;
    page = { ...rest, source: 'upload' };
  }
  const { design } = checked(designPairs(page), 'the recipe\'s page', true);
  applyControls(design);
  state.calibration = body.ultrasonic_calibration
    ? { name: 'the recipe\'s calibration', text: body.ultrasonic_calibration, rows: dataRows(body.ultrasonic_calibration) }
    : null;
  showDisplayControls();
  let profile = null;
  let what = '';
  if (design.source === 'template' || design.source === 'library') {
    profile = await openDesignSource(design);
    if (!profile) return;
    if (!samePoints(profile, body.profile)) {
      note = ` This server gives another profile for the recipe's ${design.source === 'template' ? 'template' : 'stroke'} ` +
        '(other data or another haptex): the recipe\'s own profile is shown as your profile.';
      profile = null;
    } else {
      what = profile.label;
      profile.label = `recipe: ${what}`;
    }
  }
  if (!profile) {
    profile = await openData(r, body);
    what = profile.label.replace(/^recipe: /, '');
  }
  await updateVoltage();
  say(`Opened the recipe: ${what}.${note}`);
}

/**
 * An error of opening a link, which belongs to no field of the page (the
 * recipe file field is for files): said in the header.
 */
export function linkError(error) {
  if (!(error instanceof ApiError) || error.field !== 'recipe') return error;
  return new ApiError(error.message.charAt(0).toUpperCase() + error.message.slice(1), null, error.status);
}

/** Opens the link in the address's hash (#recipe=, #design=), reporting what cannot be read or opened. */
async function openHash() {
  let opened;
  try {
    opened = recipeFromHash(location.hash);
  } catch (error) {
    throw new ApiError(`The link's recipe cannot be read (${error.message})`, null, 0);
  }
  await openRecipe(opened);
}

// A link pasted into the page's address bar changes only the hash: opened too.
window.addEventListener('hashchange', () => {
  if (isRecipeHash(location.hash)) openHash().catch((error) => showError(linkError(error)));
});

// The recipe download: the recipe of the design shown, and its link shown.
offerDownload('recipe', () => {
  const text = `${JSON.stringify(recipe(), null, 1)}\n`;
  const file = { blob: new Blob([text], { type: 'application/json' }), name: 'haptex-recipe.json' };
  shareLink();
  return file;
});

// For the browser tests and the console: the design's link (returned, and shown in #share-link).
Object.assign(window.haptex, { shareLink });
