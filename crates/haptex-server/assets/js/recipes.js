// Recipes (docs/web.md, "Recipes"): the design shown as the API requests
// of its downloads with the source's provenance and the data's SHA-256
// (the recipe download, the share link), and a recipe opened (a file or
// a link's #recipe=) as the page's design.

import { $ } from './dom.js';
import { ApiError, postJson } from './api.js';
import { setBoth, setDisplay, setMethod, setRelative, showDisplayControls } from './displays.js';
import { downloadSpec, offerDownload } from './downloads.js';
import { readDevice } from './fields.js';
import { say } from './messages.js';
import { recipeHash, recipeSourceText } from './recipe-link.js';
import { dropPendingLoad, showSourcePanel } from './sources.js';
import { state } from './state.js';
import { dataRows } from './validation.js';
import { updateVoltage } from './voltage.js';

/** The downloads a recipe replays: each the API request that answers it. */
const RECIPE_KINDS = ['profile-csv', 'voltage-csv', 'voltage-json', 'stroke-wav', 'stroke-sidecar'];

/**
 * The recipe of the design shown (docs/web.md, "Recipes"): the requests
 * of its downloads, the source's provenance, the haptex version and the
 * SHA-256 of the data served. `kinds` chooses the downloads.
 */
export function recipe(kinds = RECIPE_KINDS) {
  const data = state.config.data || {};
  const source = state.profile.provenance || {};
  const r = {
    format: 'haptex-recipe/1',
    haptex_version: state.config.version,
    source,
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

/** A link that opens this design (its voltage request) in the page. */
export function shareLink() {
  const link = `${location.origin}${location.pathname}${recipeHash(recipe(['voltage-csv']))}`;
  const a = $('share-link');
  a.href = link;
  a.hidden = false;
  a.textContent = 'link to this design';
  return link;
}

/**
 * Opens a recipe (an uploaded file or a link's #recipe=): its voltage
 * request's profile becomes the page's profile (the *your profile*
 * source, labelled with the recipe's provenance) and its method,
 * mapping, device and display set the controls, so the page asks the
 * server the recipe's own voltage request.
 */
export async function openRecipe(r) {
  if (!r || r.format !== 'haptex-recipe/1' || !Array.isArray(r.downloads)) {
    throw new ApiError('not a haptex recipe (format haptex-recipe/1)', 'recipe', 0);
  }
  const request = r.downloads.find((d) => d && d.body && typeof d.path === 'string' &&
    d.path.startsWith('/api/voltage'));
  if (!request || !request.body.profile) throw new ApiError('the recipe has no voltage request', 'recipe', 0);
  const body = request.body;
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
  // The controls, from the request.
  setMethod(body.method || 'physical');
  setRelative(Boolean(body.relative), body.flat_mu === undefined ? '' : String(body.flat_mu));
  setBoth(false);
  document.querySelectorAll('[data-param]').forEach((el) => {
    const v = (body.device || {})[el.dataset.param];
    el.value = v === undefined ? '' : String(v);
    el.dispatchEvent(new Event('explain'));
  });
  state.device = readDevice();
  setDisplay(body.display || 'electrovibration');
  if (body.strategy) { state.strategy = body.strategy; $('strategy').value = body.strategy; }
  $('weight').value = body.weight === undefined ? '' : String(body.weight);
  $('a-max').value = body.a_max_um === undefined ? '' : String(body.a_max_um);
  state.calibration = body.ultrasonic_calibration
    ? { name: 'the recipe\'s calibration', text: body.ultrasonic_calibration, rows: dataRows(body.ultrasonic_calibration) }
    : null;
  showDisplayControls();
  await updateVoltage();
  say(`Opened the recipe: ${profile.label}.`);
}

// The recipe download: the recipe of the design shown, and its link shown.
offerDownload('recipe', () => {
  const text = `${JSON.stringify(recipe(), null, 1)}\n`;
  const file = { blob: new Blob([text], { type: 'application/json' }), name: 'haptex-recipe.json' };
  shareLink();
  return file;
});
