// Downloads: each is the server's answer to one API request (the
// profile CSV, the voltage CSV and JSON, the stroke WAV and its sidecar),
// the request kept so that a recipe can list it, or a file the page makes
// (the compensated voltage's CSV, the recipe).

import { $ } from './dom.js';
import { DESIGN_FIELDS, blocked, setStatus } from './feedback.js';
import { ApiError, api, postJson } from './api.js';
import { uMaxOf } from './answers.js';
import { currentCheck, played } from './check.js';
import { isElectrovibration } from './displays.js';
import { voltageBody } from './requests.js';
import { state } from './state.js';

/** Downloads the page makes itself, by kind: () => {blob, name} (offerDownload). */
const pageFiles = {};

/** Offers the download `kind`, a file the page makes: `make()` gives {blob, name} (recipes.js: the recipe). */
export function offerDownload(kind, make) {
  pageFiles[kind] = make;
}

/**
 * The request behind a download: {file, method, path, body}. The page
 * downloads exactly the server's answer to it, and a recipe lists these
 * requests, so that `haptex recipe run` gives the same bytes.
 */
export function downloadSpec(kind) {
  if (kind === 'profile-csv') return state.profile.spec;
  // The voltage downloads carry the recipe: the source's provenance goes
  // with the request, and the server writes it with the haptex version,
  // the settings, the parameters and the data's SHA-256 into the CSV's
  // comments and the JSON's `recipe`.
  const withSource = (body) => (state.profile.provenance ? { ...body, source: state.profile.provenance } : body);
  if (kind === 'voltage-csv') {
    const file = isElectrovibration() ? 'voltage.csv' : `display-${state.display}.csv`;
    return { file, method: 'POST', path: '/api/voltage?format=csv', body: withSource(voltageBody()) };
  }
  if (kind === 'voltage-json') {
    const file = isElectrovibration() ? 'voltage.json' : `display-${state.display}.json`;
    return { file, method: 'POST', path: '/api/voltage', body: withSource(voltageBody()) };
  }
  if (kind === 'stroke-wav' || kind === 'stroke-sidecar') {
    const v = played();
    const body = {
      voltage: { x_mm: v.x_mm, voltage_v: v.voltage_v || v.x_mm.map(() => 0) },
      stroke: { velocity_mm_s: state.velocity },
      carrier: { shape: 'sine', frequency_hz: state.carrierHz },
    };
    const uMax = uMaxOf(v);
    if (uMax !== null) body.u_max_v = uMax;
    let which = v === state.voltage ? '' : '-compensated';
    if (v.amplitude_um) {
      // Two channels: 2 is the plate's amplitude, full scale a_max.
      body.voltage.amplitude_um = v.amplitude_um;
      body.a_max_um = v.summary.ultrasonic.a_max_um;
      which = `-${v.summary.display}-2ch`;
    }
    if (kind === 'stroke-sidecar') {
      // The WAV's sidecar (scales of both channels, sample hash), as haptex play writes it.
      body.format = 'sidecar';
      if (state.profile.provenance) body.source = state.profile.provenance; // the recipe, in the sidecar
      return { file: `stroke-${state.velocity}mm_s${which}.wav.json`, method: 'POST', path: '/api/play', body };
    }
    return { file: `stroke-${state.velocity}mm_s${which}.wav`, method: 'POST', path: '/api/play', body };
  }
  throw new Error(`unknown download ${kind}`);
}

/** The server's answer to a download's request, as a blob. */
async function fetchSpec(spec) {
  const response = spec.method === 'GET' ? await api(spec.path) : await postJson(spec.path, spec.body);
  return response.blob();
}

/** Downloads `kind`: the server's answer to its request, or a file the page makes (a check's CSV, a recipe). */
export async function download(kind) {
  if (!state.profile || !state.voltage) throw new ApiError('nothing to download yet', null, 0);
  // A field refused as typed (red, beside it) stops the download, said beside the buttons.
  const refused = blocked(`${DESIGN_FIELDS}, #play-box`);
  if (refused.length) throw new ApiError(`Not downloaded: ${refused.map((r) => r.text).join('; ')}.`, null, 0);
  let file;
  if (kind === 'compensated-csv') {
    const c = currentCheck();
    if (!c || c.mode !== 'compensate') throw new ApiError('compensate first', null, 0);
    file = { blob: new Blob([c.result.voltage_csv], { type: 'text/csv' }), name: 'voltage-compensated.csv' };
  } else if (pageFiles[kind]) {
    file = pageFiles[kind]();
  } else {
    const spec = downloadSpec(kind);
    file = { blob: await fetchSpec(spec), name: spec.file };
  }
  const link = $('download-link');
  if (link.href) URL.revokeObjectURL(link.href);
  link.href = URL.createObjectURL(file.blob);
  link.download = file.name;
  link.textContent = file.name;
  link.dataset.kind = kind;
  link.dataset.count = String(Number(link.dataset.count || 0) + 1);
  link.click();
  setStatus($('download-info'), `Downloaded ${file.name} (${file.blob.size} bytes).`);
}
