// Recordings upload (a writable library only): the recording files or
// zips go to POST /api/recordings, each recording's processing report is
// drawn over its raw forces (the sliding segments kept and dropped), and
// a stroke of the first material uploaded is shown.

import { $ } from './dom.js';
import { inPageWords } from './validation.js';
import { ApiError, api } from './api.js';
import { fmt } from './format.js';
import { lineOptions } from './plots.js';
import { fillMaterials, loadSource } from './sources.js';
import { plots, state } from './state.js';

/**
 * Uploads the chosen recording files (or zips) into the library
 * (POST /api/recordings, a writable library only), draws the processing
 * report of each recording over its raw forces and shows the first
 * uploaded material.
 */
export async function uploadRecordings() {
  const files = Array.from($('recording-files').files);
  const provenance = document.querySelector('input[name="provenance"]:checked');
  if (!files.length) throw new ApiError('choose the recording files (or a zip) first', 'files', 0);
  if (!provenance) {
    throw new ApiError('say whether the data are measured or synthetic: it is required', 'provenance', 0);
  }
  const form = new FormData();
  form.append('provenance', provenance.value);
  files.forEach((f) => form.append('files', f, f.name));
  $('recordings-info').classList.remove('error');
  $('recordings-info').textContent = `Uploading ${files.length} file${files.length === 1 ? '' : 's'}…`;
  clearRecordingsReport();
  const report = await (await api('/api/recordings', { method: 'POST', body: form })).json();
  state.recordings = report;
  const names = [...new Set(report.recordings.map((r) => r.material))];
  $('recordings-info').textContent = `${report.added} stroke${report.added === 1 ? '' : 's'} added to the ` +
    `library (material${names.length === 1 ? '' : 's'} ${names.join(', ')}), ${report.duplicates} already there` +
    (report.unused_files.length ? `; not used: ${report.unused_files.join(', ')}` : '') + '.';
  fillMaterials(report.materials);
  report.recordings.forEach(showRecordingReport);
  // The library changed: a recipe records its new SHA-256.
  state.config.data = (await (await api('/api/config')).json()).data;
  document.body.dataset.recordings = String(Number(document.body.dataset.recordings || 0) + 1);
  // Show a stroke of the first material uploaded.
  $('material').value = names[0];
  $('seed').value = '';
  await loadSource();
}

/** A refused upload, said under the recordings' controls. */
export function showRecordingsError(error) {
  const info = $('recordings-info');
  info.classList.add('error');
  // In the page's words: the field of the choice by its label, serde's backticks as quotes.
  const message = error instanceof ApiError ? inPageWords(error.message) : String(error.message || error);
  const at = error instanceof ApiError && error.field === 'provenance' && !message.includes('provenance')
    ? ' (The data are)' : '';
  info.textContent = `Not added: ${message}${at}`;
  document.body.dataset.recordingsError = String(Number(document.body.dataset.recordingsError || 0) + 1);
}

function clearRecordingsReport() {
  plots.recordings.forEach((p) => p.destroy());
  plots.recordings = [];
  $('recordings-report').textContent = '';
}

/** One recording's report: the raw forces with the sliding segments kept (green) and dropped (grey). */
function showRecordingReport(r) {
  const figure = document.createElement('figure');
  figure.className = 'recording-report';
  const caption = document.createElement('figcaption');
  caption.textContent = `${r.file}: ${r.material}, participant ${r.participant}, stroke ${r.stroke} → ` +
    (r.duplicate ? `already in the library as stroke ${r.stroke_id}` : `stroke ${r.stroke_id}`) +
    ` · ${r.profile.points} points over ${fmt(r.profile.x_end_mm - r.profile.x_start_mm)} mm, mean mu ` +
    `${fmt(r.profile.mean_mu)}, Fn_RS ${fmt(r.profile.mean_fn_n)} N`;
  figure.append(caption);
  const holder = document.createElement('div');
  holder.className = 'recording-plot';
  holder.setAttribute('role', 'img');
  figure.append(holder);
  const list = document.createElement('ul');
  r.segments.forEach((s, i) => {
    const li = document.createElement('li');
    li.className = 'kept';
    li.textContent = `kept ${i + 1}: ${s.direction}, t ${fmt(s.t_start_s)} … ${fmt(s.t_end_s)} s, x ` +
      `${fmt(s.x_start_mm)} → ${fmt(s.x_end_mm)} mm, ${fmt(s.mean_speed_mm_s)} mm/s, Fn ${fmt(s.mean_fn_n)} N`;
    list.append(li);
  });
  r.dropped.forEach((d) => {
    const li = document.createElement('li');
    li.className = 'dropped';
    li.textContent = `dropped: ${d.direction}, t ${fmt(d.t_start_s)} … ${fmt(d.t_end_s)} s: ${d.reason}`;
    list.append(li);
  });
  figure.append(list);
  $('recordings-report').append(figure);
  const f = r.forces;
  holder.setAttribute('aria-label', `raw forces of ${r.file} over ${fmt(f.t_s[0])} … ` +
    `${fmt(f.t_s[f.t_s.length - 1])} s (${f.samples} samples${f.decimated ? ', min/max per bucket' : ''}), ` +
    `${r.segments.length} sliding segments kept, ${r.dropped.length} dropped`);
  const bands = (u) => {
    const ctx = u.ctx;
    ctx.save();
    const paint = (items, colour) => items.forEach((s) => {
      const a = u.valToPos(s.t_start_s, 'x', true);
      const b = u.valToPos(s.t_end_s, 'x', true);
      ctx.fillStyle = colour;
      ctx.fillRect(Math.min(a, b), u.bbox.top, Math.max(1, Math.abs(b - a)), u.bbox.height);
    });
    paint(r.segments, 'rgba(40, 150, 70, 0.18)');
    paint(r.dropped, 'rgba(120, 120, 120, 0.22)');
    ctx.restore();
  };
  const options = lineOptions({
    width: Math.max(240, $('recordings-report').clientWidth || 320),
    height: 180,
    x: 't (s)',
    y: 'N',
    live: false,
    series: [{ label: 'Fn (N)', stroke: '#1f5fa8', width: 1 }, { label: 'Ft (N)', stroke: '#b3261e', width: 1 }],
    hooks: { drawClear: [bands] },
  });
  plots.recordings.push(new uPlot(options, [f.t_s, f.fn_n, f.ft_n], holder));
}
