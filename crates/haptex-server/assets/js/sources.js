// The friction profile sources, a registry (SOURCES): a surface template
// predicted from the FE database (POST /api/predict), a texture-library
// material's stroke (GET /api/materials/{name}/sample) or your own CSV
// file (POST /api/profile). Each load() returns a profile {x_mm, mu, fn_n,
// label, spec (its download request), provenance (for recipes)}.

import { $ } from './dom.js';
import { ApiError, api, postJson } from './api.js';
import { isElectrovibration, setBoth, setDisplay, setMethod, setRelative } from './displays.js';
import { bringIntoView, clearFieldError, setFieldError } from './feedback.js';
import { inPageWords } from './validation.js';
import { clearPlots } from './figures.js';
import { fmt, safeName } from './format.js';
import { say, showError } from './messages.js';
import { state } from './state.js';
import { showFe, templateBody } from './template.js';
import { updateVoltage } from './voltage.js';

/** The friction profile sources: each entry's load() returns a profile (null: nothing to show yet). */
export const SOURCES = {
  template: {
    panel: 'template',
    // FE profiles are skin-on-surface friction around mu_skin (0.5),
    // below the display's own mu_HD = 1. The combined display renders
    // them as they are (the plate lowers the friction to them). On the
    // electrovibration display eq. (8) would give 0 V: there the page
    // maps them relative to their flat-surface value, mu_skin, and shows
    // eq. (8) and eq. (9) side by side, as the paper's Fig. 2b does
    // (docs/database.md).
    method: 'physical',
    fig2: true,
    flatMu: () => (state.templates ? String(state.templates.fe.mu_skin) : ''),
    async load() {
      const body = templateBody();
      const answer = await (await postJson('/api/predict', body)).json();
      const info = $('template-info');
      info.textContent = '';
      const source = document.createElement('div');
      source.textContent = answer.fe_exact
        ? `FE result: a database case (row ${answer.fe_row} of ${answer.surface}.csv), no estimate involved.`
        : answer.estimator === 'grid'
          ? 'Estimate over the FE database: interpolated between its cases (multilinear over the grid of ' +
            'width, height and velocity' +
            (answer.surface === 'sine' ? '; the sine\'s profiles blended in phase, at the same (x - x0) / width' : '') +
            ').'
          : `CAE estimate over the FE database; typical error ${fmt(answer.loo_rmse)} in mu ` +
            `(${Math.round(100 * answer.loo_rmse_relative_to_range)}% of a profile's range, leave-one-out).`;
      info.append(source);
      const v = answer.fe_exact ? null : answer.validation;
      if (v) {
        const expected = document.createElement('div');
        expected.className = 'expected-error';
        const members = v.crests_resolved
          ? `${v.members} of ${v.of_members} random members whose crests the mesh resolves`
          : `${v.members} random members`;
        expected.textContent = `On ${members} checked against fresh FE runs the estimate was off ` +
          `by ${(100 * v.relative_median).toFixed(1)}% of the profile's range (median), ` +
          `${(100 * v.relative_max).toFixed(1)}% at most.`;
        info.append(expected);
      }
      if (answer.fe_advised) {
        const advice = document.createElement('div');
        advice.className = 'fe-advice';
        advice.textContent = `For a ${answer.surface} the estimate is not good enough: press ` +
          '"check with the FE model" below.';
        info.append(advice);
      }
      if (answer.fe_caveat) {
        // The database's FE rows themselves are not mesh-converged here.
        const caveat = document.createElement('div');
        caveat.className = 'fe-caveat';
        caveat.textContent = `Not mesh-converged: ${answer.fe_caveat}.`;
        info.append(caveat);
      }
      info.classList.toggle('warning', answer.extrapolation || answer.fe_advised || Boolean(answer.fe_caveat));
      answer.warnings.forEach((w) => {
        const line = document.createElement('div');
        line.textContent = `Extrapolation: ${w}`;
        info.append(line);
      });
      if (answer.extrapolation) {
        const line = document.createElement('div');
        line.textContent = 'Outside the database the estimate leans on the nearest members only and can be jagged ' +
          'or wrong: check it with the FE model (the button below).';
        info.append(line);
      }
      const p = answer.parameters;
      showFe();
      return {
        key: JSON.stringify(body),
        x_mm: answer.x_mm, mu: answer.mu, fn_n: null, h_mm: answer.h_mm,
        label: `${answer.surface} r_w ${fmt(p.width_mm)} mm, r_h ${fmt(p.height_mm)} mm, ` +
          `${fmt(p.velocity_mm_s)} mm/s (${answer.fe_exact ? 'FE' : answer.estimator === 'grid' ? 'grid' : 'CAE'}` +
          `${answer.extrapolation ? ', extrapolated' : ''})`,
        synthetic: false,
        extrapolation: answer.extrapolation,
        spec: {
          file: `${answer.surface}-w${p.width_mm}-h${p.height_mm}-v${p.velocity_mm_s}.csv`,
          method: 'POST', path: '/api/predict?format=csv', body,
        },
        provenance: { kind: 'template', ...body, fe_exact: answer.fe_exact, extrapolation: answer.extrapolation },
      };
    },
  },
  library: {
    panel: 'library',
    method: 'physical',
    flatMu: () => '',
    async load(options = {}) {
      const name = $('material').value;
      if (!name) throw new ApiError('the library has no materials', 'material', 0);
      let seed = $('seed').value.trim();
      if (options.newSeed || seed === '') seed = null;
      const query = seed === null ? '' : `?seed=${encodeURIComponent(seed)}`;
      const base = `/api/materials/${encodeURIComponent(name)}/sample`;
      const sample = await (await api(base + query)).json();
      $('seed').value = sample.seed;
      const kind = sample.synthetic
        ? '<span class="badge">SYNTHETIC</span> generated by a model, not measured'
        : '<span class="badge measured">MEASURED</span>';
      $('material-info').innerHTML = '';
      const info = $('material-info');
      info.insertAdjacentHTML('beforeend', kind);
      info.append(` · stroke id ${sample.stroke.id} (one of ${sample.strokes_total}), ${sample.n_points} points` +
        (sample.mean_fn_n ? `, Fn_RS ${sample.mean_fn_n.toFixed(3)} N` : '') + ` · ${sample.stroke.licence}`);
      return {
        x_mm: sample.x_mm, mu: sample.mu, fn_n: sample.fn_n,
        label: `${sample.material} (${sample.synthetic ? 'synthetic' : 'measured'}), stroke ${sample.stroke.id}`,
        synthetic: sample.synthetic,
        material: sample.material,
        seed: sample.seed,
        spec: {
          file: safeName(`${sample.material}-stroke-${sample.stroke.id}.csv`),
          method: 'GET', path: `${base}?seed=${encodeURIComponent(sample.seed)}&format=csv`,
        },
        provenance: { kind: 'library', material: sample.material, seed: sample.seed, stroke_id: sample.stroke.id,
          synthetic: sample.synthetic },
      };
    },
  },
  upload: {
    panel: 'upload',
    flatMu: () => '',
    async load() {
      const file = $('upload').files[0];
      if (!file) return null; // nothing to show until a file is chosen
      const text = await file.text();
      $('upload-info').textContent = `Reading ${file.name}…`;
      const profile = await (await api('/api/profile', {
        method: 'POST', headers: { 'Content-Type': 'text/csv' }, body: text,
      })).json();
      clearFieldError($('upload'));
      $('upload-info').textContent = `${file.name}: ${profile.n_points} points, x ${fmt(profile.x_min_mm)} .. ` +
        `${fmt(profile.x_max_mm)} mm, mu ${fmt(profile.mu_min)} .. ${fmt(profile.mu_max)}` +
        (profile.fn_n ? ' (with fn_n)' : '');
      const body = { x_mm: profile.x_mm, mu: profile.mu };
      if (profile.fn_n) body.fn_n = profile.fn_n;
      return {
        x_mm: profile.x_mm, mu: profile.mu, fn_n: profile.fn_n,
        label: file.name, synthetic: false,
        spec: {
          file: safeName(file.name.replace(/\.[^.]*$/, '') + '-profile.csv'),
          method: 'POST', path: '/api/profile?format=csv', body,
        },
        provenance: { kind: 'upload', file: file.name },
      };
    },
  },
};

/**
 * An upload refused: the error under its file field, in the page's words
 * (the file's name for what the server calls the request body), and the
 * status under the field saying the file was not read.
 */
export function showUploadError(error) {
  const input = $('upload');
  const file = input.files[0];
  const name = file ? file.name : 'the file';
  const text = error instanceof ApiError
    ? inPageWords(error.message, { field: error.field, file: name })
    : String(error && error.message ? error.message : error);
  setFieldError(input, text);
  $('upload-info').textContent = `${name} was not read: its error is above. Fix the file and choose it again.`;
  bringIntoView($('upload-error'));
  say('');
}

/** The smallest and largest of `values` (a loop: a profile may be too long to spread into Math.min). */
function extent(values) {
  let lo = Infinity;
  let hi = -Infinity;
  for (const v of values) {
    if (v < lo) lo = v;
    if (v > hi) hi = v;
  }
  return [lo, hi];
}

/** The display's own friction, mu_HD, of the design: typed, or the server's default. */
export function muHd() {
  if (state.device.mu_hd !== undefined) return state.device.mu_hd;
  const p = state.config.device_params.find((d) => d.name === 'mu_hd');
  return p ? p.default : 1;
}

/**
 * The display a source's profile opens on until the user chooses one: the
 * templates the paper's Fig. 2 view (electrovibration, relative, eq. 8
 * beside eq. 9); a material or an uploaded profile the display whose band
 * holds it: electrovibration when it lies above the display's own friction
 * mu_HD (the voltage raises friction), ultrasonic when it lies below (the
 * plate lowers it), combined when it spans mu_HD.
 */
export function defaultDisplay(id, profile) {
  if (SOURCES[id].fig2) return 'electrovibration';
  const [lo, hi] = extent(profile.mu);
  const m = muHd();
  if (lo >= m) return 'electrovibration';
  if (hi <= m) return 'ultrasonic';
  return 'combined';
}

/** Opens the profile of source `id` on its default display, unless the user chose one. */
function openOnDefault(id, profile) {
  if (!profile || state.displayChosen) return;
  const display = defaultDisplay(id, profile);
  if (display === state.display) return;
  setDisplay(display);
  applySourceMapping(id);
}

let loadRequest = 0;
/** Settles when the last profile asked for is loaded or refused (openSource waits for it). */
let settled = Promise.resolve();

/** Drops a profile still loading (a recipe's profile replaces it). */
export function dropPendingLoad() {
  loadRequest += 1;
}

/** Loads the active source's profile and its voltage (a newer load wins). */
export async function loadSource(options) {
  const id = ++loadRequest;
  const sourceId = state.source;
  say('Loading the profile…');
  const loading = SOURCES[sourceId].load(options);
  settled = loading.catch(() => {});
  const profile = await loading;
  if (id !== loadRequest) return; // a newer profile is on its way
  state.profiles[sourceId] = profile;
  state.profile = profile;
  openOnDefault(sourceId, profile);
  if (!profile) {
    clearPlots();
    say('Choose a profile file (CSV).');
    return;
  }
  await updateVoltage();
}

/**
 * Opens source `id` as a recipe or a link sets it (recipes.js): its radio
 * button and panel, and its profile loaded from its controls as they are
 * (the mapping is the recipe's: none applied here), once a profile still
 * loading has settled (its notes would replace this one's). Returns the
 * profile, now the page's (null when a newer load took over).
 */
export async function openSource(id) {
  const input = document.querySelector(`input[name='source'][value='${id}']`);
  if (!input) throw new ApiError(`this server offers no ${id} source`, 'recipe', 0);
  const id0 = ++loadRequest; // a profile still loading is dropped
  await settled;
  input.checked = true;
  state.source = id;
  showSourcePanel(id);
  const loading = SOURCES[id].load();
  settled = loading.catch(() => {});
  const profile = await loading;
  if (id0 !== loadRequest) return null;
  state.profiles[id] = profile;
  state.profile = profile;
  return profile;
}

/** Shows the panel of source `id` (and the height plot for templates). */
export function showSourcePanel(id) {
  document.querySelectorAll('.source-panel').forEach((p) => { p.hidden = p.dataset.source !== SOURCES[id].panel; });
  $('height-figure').hidden = id !== 'template';
}

/**
 * The mapping a source opens with on the display selected: its method;
 * for a `fig2` source (the templates) on the electrovibration display,
 * the profile relative to its flat-surface friction with eq. (8) and
 * eq. (9) side by side (the paper's Fig. 2b); otherwise the profile as
 * it is (physical values).
 */
export function applySourceMapping(id) {
  const source = SOURCES[id];
  if (source.method) setMethod(source.method);
  const fig2 = Boolean(source.fig2) && isElectrovibration();
  setRelative(fig2, source.flatMu());
  setBoth(fig2);
}

/** Makes `id` the active source: its panel, its mapping, its last profile or a new one. */
export function selectSource(id) {
  state.source = id;
  showSourcePanel(id);
  loadRequest += 1; // a profile still loading for the previous source is dropped
  applySourceMapping(id);
  state.profile = state.profiles[id] || null;
  openOnDefault(id, state.profile);
  if (state.profile) {
    updateVoltage().catch(showError);
  } else {
    loadSource().catch(showError);
  }
}

/** The material choices: the library's materials (the selection kept when still there). */
export function fillMaterials(materials) {
  const select = $('material');
  const chosen = select.value;
  select.textContent = '';
  materials.forEach((m) => {
    const option = document.createElement('option');
    option.value = m.name;
    option.textContent = `${m.name}${m.synthetic ? ' (synthetic)' : ''} · mean mu ${m.mean_mu.toFixed(3)}`;
    select.append(option);
  });
  if (materials.some((m) => m.name === chosen)) select.value = chosen;
}
