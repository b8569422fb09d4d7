// The model section: the paper's equations and the FE finger (GET
// /api/model), the FE database's runs and the leave-one-out errors of its
// estimates (GET /api/templates), as the server uses them.

import { $ } from './dom.js';
import { api } from './api.js';
import { fmt, table } from './format.js';
import { state } from './state.js';

/**
 * The model section: equations and the FE finger (GET /api/model), the
 * database's grid and leave-one-out errors (GET /api/templates), as the
 * server uses them.
 */
function buildModel(model, templates) {
  const body = $('model-body');
  body.textContent = '';
  body.append(table('Equations (paper numbering)', ['eq.', 'formula', 'meaning'],
    model.equations.map((e) => [`(${e.id})`, e.text, e.meaning])));
  const d = model.paper_device;
  const fig2 = document.createElement('p');
  fig2.className = 'note';
  fig2.textContent = `With ${d.source} (eps_sc = ${fmt(d.eps_sc)}, eps_i = ${fmt(d.eps_i)}, d_sc = ${fmt(d.d_sc_mm)} mm, ` +
    `d_i = ${fmt(d.d_i_mm)} mm, k = ${fmt(d.k_mm2_per_n)} mm^2/N, mu_HD = ${fmt(d.mu_hd)}, U_max = ${fmt(d.u_max_v)} V): ` +
    `Fe/Fn = ${d.fe_over_fn_per_v2.toExponential(4)} U^2, and eq. (8) reads ` +
    `U = sqrt(${d.eq8_u2_per_unit_excess_v2.toFixed(1)} (mu_RS/mu_HD - 1)) V.`;
  body.append(fig2);
  const f = model.finger;
  const g = f.geometry;
  body.append(table(`FE finger model: geometry (${f.file}, 2D plane strain)`, ['quantity', 'value'], [
    ['cross-section half-width', `${fmt(g.half_width_mm)} mm`],
    ['cross-section half-height', `${fmt(g.half_height_mm)} mm`],
    ['bone half-width x half-height', `${fmt(g.bone_half_width_mm)} x ${fmt(g.bone_half_height_mm)} mm`],
    ['bone centre above the pad', `${fmt(g.bone_center_height_mm)} mm`],
    ['nail thickness, half-angle', `${fmt(g.nail_thickness_mm)} mm, ${fmt(g.nail_half_angle_deg)}°`],
    ['stratum corneum', `${fmt(f.layers.stratum_corneum_mm)} mm`],
    ['viable epidermis', `${fmt(f.layers.viable_epidermis_mm)} mm`],
    ['dermis', `${fmt(f.layers.dermis_mm)} mm`],
    ['hypodermis', 'fills to the bone'],
    ['skin friction mu_skin', fmt(f.contact.mu_skin)],
    ['contact region half-arc', `${fmt(f.contact.contact_half_arc_mm)} mm`],
  ]));
  body.append(table('FE finger model: materials', ['subdomain', 'E (MPa)', 'nu'],
    f.materials.map((m) => [m.name.replace('_', ' '), m.e_mpa, m.nu])));
  body.append(table('Visco-elasticity of the soft tissues (Prony series on the deviatoric stress)', ['g', 'tau (s)'],
    f.viscoelasticity.prony.map((p) => [p.g, p.tau_s])));
  const file = document.createElement('details');
  const fileSummary = document.createElement('summary');
  fileSummary.textContent = `Sources: ${f.file} as shipped (its comments cite each value)`;
  const pre = document.createElement('pre');
  pre.id = 'model-finger-file';
  pre.textContent = f.file_text;
  file.append(fileSummary, pre);
  body.append(file);
  if (!templates) {
    const none = document.createElement('p');
    none.className = 'note';
    none.textContent = 'This server has no FE database of surface templates.';
    body.append(none);
    return;
  }
  const fe = templates.fe;
  body.append(table('FE database: the runs', ['setting', 'value'], [
    ['finger model', fe.finger_model], ['mesh', fe.mesh], ['material', fe.material],
    ['indentation', `${fmt(fe.indent_mm)} mm`], ['mu_skin', fmt(fe.mu_skin)],
    ['profile grid', `${fmt(templates.grid.points)} points, ${fmt(templates.grid.xi_min_mm)} .. ${fmt(templates.grid.xi_max_mm)} mm about x0`],
  ]));
  body.append(table('FE database: templates and the leave-one-out error of their estimates',
    ['template', 'FE runs', 'parameters (database range)', 'LOO RMSE (mu)', '% of a profile\'s range'],
    templates.templates.map((t) => [t.name, t.rows,
      t.parameters.map((p) => `${p.name} ${fmt(p.database[0])} .. ${fmt(p.database[1])} ${p.unit}`).join('; '),
      t.loo_rmse, `${(100 * t.loo_rmse_relative_to_range).toFixed(1)}%`])));
}

/** Loads the model section (GET /api/model). */
export async function loadModel() {
  const model = await (await api('/api/model')).json();
  buildModel(model, state.templates);
}
