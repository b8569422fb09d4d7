// The template source's controls: the surface, its sliders (ranges from
// GET /api/templates, outside the FE database marked as extrapolation),
// x0, and the FE model on demand (POST /api/simulate) drawn beside the
// CAE estimate.

import { $ } from './dom.js';
import { postJson } from './api.js';
import { fmt } from './format.js';
import { emit } from './hub.js';
import { showError } from './messages.js';
import { state } from './state.js';
import { validateField } from './feedback.js';
import { databaseNote, parseNumber } from './validation.js';

/** The POST /api/predict body from the template controls. */
export function templateBody() {
  const t = state.template;
  return {
    surface: t.surface, x0_mm: t.x0_mm,
    width_mm: t.width_mm, height_mm: t.height_mm, velocity_mm_s: t.velocity_mm_s,
  };
}

let templateTimer = null;
/** Loads the template source's profile again (sources.js's loadSource, given to buildTemplateControls). */
let reload = null;

function scheduleTemplate() {
  clearTimeout(templateTimer);
  templateTimer = setTimeout(() => reload().catch(showError), 40);
}

/** Builds the sliders of the selected surface (ranges from /api/templates). */
function buildTemplateSliders() {
  const info = state.templates.templates.find((t) => t.name === state.template.surface);
  $('surface-formula').textContent = info.formula;
  const box = $('template-params');
  box.textContent = '';
  info.parameters.forEach((p) => {
    const wrap = document.createElement('div');
    wrap.className = 'slider';
    const label = document.createElement('label');
    label.htmlFor = `template-${p.name}`;
    const name = document.createElement('span');
    name.textContent = `${p.label} (${p.unit})`;
    const out = document.createElement('output');
    out.htmlFor = `template-${p.name}`;
    label.append(name, out);
    const input = document.createElement('input');
    Object.assign(input, {
      type: 'range', id: `template-${p.name}`, min: p.slider[0], max: p.slider[1], step: p.step,
    });
    input.dataset.templateParam = p.name;
    const current = state.template[p.name] ?? p.default;
    input.value = String(current);
    const note = document.createElement('p');
    note.className = 'range-note';
    const show = () => {
      const v = Number(input.value);
      state.template[p.name] = v;
      out.value = `${fmt(v)} ${p.unit}`;
      const { outside, text } = databaseNote(p, v);
      wrap.classList.toggle('outside', outside);
      note.textContent = text;
    };
    input.addEventListener('input', () => { show(); scheduleTemplate(); });
    show();
    wrap.append(label, input, note);
    box.append(wrap);
  });
}

/**
 * Sets the template controls as a recipe or a link gives them (recipes.js):
 * the surface, x0 and the slider values in `values` ({surface, x0_mm,
 * width_mm, ...}, checked already; those left out stay), without loading
 * the profile. The sliders are built again for the surface.
 */
export function setTemplate(values) {
  clearTimeout(templateTimer);
  Object.assign(state.template, values);
  $('surface').value = state.template.surface;
  $('x0').value = String(state.template.x0_mm);
  buildTemplateSliders();
}

/** The surface selector, the sliders, x0 and the FE button; `load()` loads the template profile again. */
export function buildTemplateControls(templates, load) {
  reload = load;
  state.templates = templates;
  const select = $('surface');
  templates.templates.forEach((t) => {
    const option = document.createElement('option');
    option.value = t.name;
    option.textContent = `${t.name} (${t.rows} FE runs)`;
    select.append(option);
  });
  if (!templates.fe.simulate) {
    $('run-fe').hidden = true;
    $('fe-info').textContent = `FE model on demand: not available (${templates.fe.simulate_unavailable}).`;
  }
  state.template.surface = templates.templates[0].name;
  state.template.x0_mm = templates.x0_mm.default;
  $('x0').value = String(templates.x0_mm.default);
  if (templates.x0_mm.accepted) [$('x0').min, $('x0').max] = templates.x0_mm.accepted.map(String);
  buildTemplateSliders();
  select.addEventListener('change', () => {
    state.template.surface = select.value;
    buildTemplateSliders();
    reload().catch(showError);
  });
  $('run-fe').addEventListener('click', () => runFe().catch(showError));
  $('x0').addEventListener('input', () => {
    // Checked as typed (feedback.js): a refused x0 is said beside the field and not sent.
    if (validateField($('x0'))) return;
    const x0 = parseNumber($('x0').value);
    state.template.x0_mm = x0;
    scheduleTemplate();
  });
}

/** Runs the FE model for the template parameters shown (POST /api/simulate). */
export async function runFe() {
  const body = templateBody();
  const key = JSON.stringify(body);
  const button = $('run-fe');
  button.disabled = true;
  $('fe-info').textContent = 'Running the FE model…';
  try {
    const answer = await (await postJson('/api/simulate', body)).json();
    state.fe = { key, mu: answer.mu, seconds: answer.fe_seconds, rms: answer.cae_rms_difference };
    showFe();
    if (state.voltage) emit('draw');
  } catch (error) {
    $('fe-info').textContent = '';
    throw error;
  } finally {
    button.disabled = false;
  }
}

/** The FE result, when it is for the template parameters shown. */
export function currentFe() {
  const fe = state.fe;
  return fe && state.source === 'template' && state.drawn && state.drawn.key === fe.key ? fe : null;
}

export function showFe() {
  if ($('run-fe').hidden) return; // the note says why the FE model is not available
  const fe = state.fe && state.fe.key === JSON.stringify(templateBody()) ? state.fe : null;
  $('fe-info').textContent = fe
    ? `FE model: ${fe.seconds.toFixed(2)} s; the estimate differs from it by ${fmt(fe.rms)} RMS in mu ` +
      '(dashed green in the friction plot).'
    : '';
}
