// haptex GUI: pick a friction profile (a surface template predicted from
// the FE database, a texture-library material or your own CSV file), set
// the device and finger constants, see the surface, friction and voltage
// profiles (paper eqs. 8 and 9, computed by the server; optionally on the
// profile relative to its flat-surface friction, as the paper's Fig. 2
// does, with eq. 8 and eq. 9 side by side for templates), check eq. 8's
// voltage on the finger model and compensate it (the FE finger sliding on
// the display, POST /api/check and /api/compensate, streamed with their
// progress), feel the voltage along a strip, download CSV / JSON / WAV.
// The display selector designs for the combined display (the page's
// default, so that every source renders with its physical values), an
// ultrasonic friction-reduction plate alone or the electrovibration
// display (POST /api/voltage with `display`): the
// renderable band on the friction plot, a(x) beside U(x), both channels in
// the feel strip and the two-channel stroke WAV.
//
// Every number comes from the JSON API (docs/web.md); this script only
// gathers inputs, draws and offers downloads. Sources are a registry
// (SOURCES): each entry's load() returns a profile.
'use strict';

(function () {
  const $ = (id) => document.getElementById(id);

  const state = {
    config: null,
    templates: null,       // GET /api/templates answer, when the server has the FE database
    template: {},          // surface, x0_mm and the slider values of the template source
    fe: null,              // last POST /api/simulate answer and the template request it was for
    check: null,           // last check or compensation: {key, mode, result} (key: the request it was for)
    checkProgress: null,   // progress lines of the check running or last run: {lines, maxRun}
    source: null,          // id of the active source
    profile: null,         // {x_mm, mu, fn_n, label, synthetic, download()}
    profiles: {},          // last profile of each source, kept when switching
    voltage: null,         // last /api/voltage answer
    companion: null,       // the same profile by the other method (templates: eq. 8 and 9 side by side, Fig. 2b)
    drawn: null,           // the profile whose voltage is drawn
    method: 'physical',
    relative: false,       // map the profile relative to its flat-surface friction (Fig. 2)
    // The friction display designed for (GET /api/config, displays). The
    // page opens on the combined display, so that the library's materials
    // and the templates render with their physical values (docs/web.md,
    // "Defaults"); the API's default stays electrovibration, the paper's.
    display: 'combined',
    strategy: 'split',     // the combined display's strategy
    calibration: null,     // the ultrasonic calibration file chosen: {name, text}
    device: {},            // parameter name -> number (only valid ones)
    velocity: 50,
    carrierHz: 1000,
    both: false,           // eq. (8) and eq. (9) together (Fig. 2b): the companion drawn dashed
    pins: [],              // pinned designs, overlaid on the plots (pinDesign)
    deviceFile: null,      // a device file used for designs: {name, text} (display-calibration.js, "Your display")
    updates: 0,
  };
  const plots = { height: null, friction: null, voltage: null, amplitude: null, check: null, checkVoltage: null,
    recordings: [] }; // recordings: the processing reports' plots of the last upload
  window.haptex = { state, plots };

  // ---------------------------------------------------------------- API

  class ApiError extends Error {
    constructor(message, field, status, file = null) {
      super(message);
      this.field = field;
      this.status = status;
      this.file = file; // the uploaded file at fault (POST /api/recordings)
    }
  }

  async function api(path, options = {}) {
    const response = await fetch(path, options);
    if (!response.ok) {
      let message = `${response.status} ${response.statusText}`;
      let field = null;
      let file = null;
      try {
        const body = await response.json();
        message = body.error || message;
        field = body.field || null;
        file = body.file || null;
      } catch (_) { /* not JSON */ }
      throw new ApiError(message, field, response.status, file);
    }
    return response;
  }

  const postJson = (path, body) =>
    api(path, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });

  /**
   * POSTs `body` and reads the answer's JSON lines (application/x-ndjson):
   * each {progress} goes to onProgress, the {result} line is returned, an
   * {error} line is thrown as an ApiError (a 4xx or 503 before the stream
   * is thrown by api() as usual).
   */
  async function postStream(path, body, onProgress) {
    const response = await postJson(path, body);
    const reader = response.body.getReader();
    const decoder = new TextDecoder();
    let buffer = '';
    for (;;) {
      const { value, done } = await reader.read();
      buffer += decoder.decode(value || new Uint8Array(), { stream: !done });
      let end;
      while ((end = buffer.indexOf('\n')) >= 0) {
        const line = buffer.slice(0, end).trim();
        buffer = buffer.slice(end + 1);
        if (!line) continue;
        const message = JSON.parse(line);
        if (message.progress) onProgress(message.progress);
        else if (message.result) return message.result;
        else if (message.error) throw new ApiError(message.error, message.field, message.status);
      }
      if (done) throw new ApiError(`${path}: the answer ended without a result`, null, 0);
    }
  }

  // ------------------------------------------------------------ messages

  function say(text, isError = false) {
    const el = $('message');
    el.textContent = text;
    el.classList.toggle('error', isError);
  }

  /** The page's name of the display fields (the server names the API's fields). */
  const DISPLAY_FIELDS = {
    display: 'Display',
    strategy: 'Strategy (Display)',
    weight: 'Weight w (Display)',
    a_max_um: 'a_max (Display)',
    ultrasonic_calibration: 'Ultrasonic calibration (Display)',
  };

  function showError(error) {
    document.querySelectorAll('[aria-invalid="true"]').forEach((el) => el.removeAttribute('aria-invalid'));
    // A panel that owns the field shows the error beside its control (display-calibration.js).
    if (error instanceof ApiError && error.field &&
        !document.dispatchEvent(new CustomEvent('haptex:error', { detail: error, cancelable: true }))) return;
    if (error instanceof ApiError) {
      const name = error.field ? error.field.replace(/^device\./, '') : null;
      const input = name ? document.querySelector(`[data-param="${name}"], [data-field="${name}"]`) : null;
      if (input) input.setAttribute('aria-invalid', 'true');
      if (name && DISPLAY_FIELDS[name]) {
        // A calibration error names the line and column of the file chosen.
        const message = name === 'ultrasonic_calibration' && state.calibration
          ? error.message.replace(/^ultrasonic_calibration/, state.calibration.name) : error.message;
        say(`${DISPLAY_FIELDS[name]}: ${message}`, true);
        return;
      }
      say(error.field ? `${error.field}: ${error.message}` : error.message, true);
    } else {
      say(String(error && error.message ? error.message : error), true);
      console.error(error);
    }
  }

  // ------------------------------------------------------------- sources

  const SOURCES = {
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
          : `CAE estimate over the FE database; typical error ${fmt(answer.loo_rmse)} in mu ` +
            `(${Math.round(100 * answer.loo_rmse_relative_to_range)}% of a profile's range, leave-one-out).`;
        info.append(source);
        info.classList.toggle('warning', answer.extrapolation);
        answer.warnings.forEach((w) => {
          const line = document.createElement('div');
          line.textContent = `Extrapolation: ${w}`;
          info.append(line);
        });
        const p = answer.parameters;
        showFe();
        return {
          key: JSON.stringify(body),
          x_mm: answer.x_mm, mu: answer.mu, fn_n: null, h_mm: answer.h_mm,
          label: `${answer.surface} r_w ${fmt(p.width_mm)} mm, r_h ${fmt(p.height_mm)} mm, ` +
            `${fmt(p.velocity_mm_s)} mm/s (${answer.fe_exact ? 'FE' : 'CAE'}` +
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
        const profile = await (await api('/api/profile', {
          method: 'POST', headers: { 'Content-Type': 'text/csv' }, body: text,
        })).json();
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

  let loadRequest = 0;

  async function loadSource(options) {
    const id = ++loadRequest;
    const sourceId = state.source;
    say('Loading the profile…');
    const profile = await SOURCES[sourceId].load(options);
    if (id !== loadRequest) return; // a newer profile is on its way
    state.profiles[sourceId] = profile;
    state.profile = profile;
    if (!profile) {
      clearPlots();
      say('Choose a profile file (CSV).');
      return;
    }
    await updateVoltage();
  }

  /** Shows the panel of source `id` (and the height plot for templates). */
  function showSourcePanel(id) {
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
  function applySourceMapping(id) {
    const source = SOURCES[id];
    if (source.method) setMethod(source.method);
    const fig2 = Boolean(source.fig2) && isElectrovibration();
    setRelative(fig2, source.flatMu());
    setBoth(fig2);
  }

  function selectSource(id) {
    state.source = id;
    showSourcePanel(id);
    loadRequest += 1; // a profile still loading for the previous source is dropped
    applySourceMapping(id);
    state.profile = state.profiles[id] || null;
    if (state.profile) {
      updateVoltage().catch(showError);
    } else {
      loadSource().catch(showError);
    }
  }

  /** The material choices: the library's materials (the selection kept when still there). */
  function fillMaterials(materials) {
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

  // --------------------------------------------------- recordings upload

  /**
   * Uploads the chosen recording files (or zips) into the library
   * (POST /api/recordings, a writable library only), draws the processing
   * report of each recording over its raw forces and shows the first
   * uploaded material.
   */
  async function uploadRecordings() {
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

  function showRecordingsError(error) {
    const info = $('recordings-info');
    info.classList.add('error');
    const at = error instanceof ApiError && error.field && !error.message.includes(error.field)
      ? ` (${error.field === 'provenance' ? 'The data are' : error.field})` : '';
    info.textContent = `Not added: ${error.message}${at}`;
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
    const options = {
      width: Math.max(240, $('recordings-report').clientWidth || 320),
      height: 180,
      scales: { x: { time: false } },
      axes: [{ label: 't (s)' }, { label: 'N' }],
      legend: { live: false },
      series: [{ label: 't (s)' },
        { label: 'Fn (N)', stroke: '#1f5fa8', width: 1 },
        { label: 'Ft (N)', stroke: '#b3261e', width: 1 }],
      hooks: { drawClear: [bands] },
    };
    plots.recordings.push(new uPlot(options, [f.t_s, f.fn_n, f.ft_n], holder));
  }

  // ------------------------------------------------------- template source

  /** The POST /api/predict body from the template controls. */
  function templateBody() {
    const t = state.template;
    return {
      surface: t.surface, x0_mm: t.x0_mm,
      width_mm: t.width_mm, height_mm: t.height_mm, velocity_mm_s: t.velocity_mm_s,
    };
  }

  let templateTimer = null;

  function scheduleTemplate() {
    clearTimeout(templateTimer);
    templateTimer = setTimeout(() => loadSource().catch(showError), 40);
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
        const outside = v < p.database[0] || v > p.database[1];
        wrap.classList.toggle('outside', outside);
        note.textContent = outside
          ? `outside the FE database (${fmt(p.database[0])} .. ${fmt(p.database[1])} ${p.unit}): extrapolation`
          : `FE database: ${fmt(p.database[0])} .. ${fmt(p.database[1])} ${p.unit}`;
      };
      input.addEventListener('input', () => { show(); scheduleTemplate(); });
      show();
      wrap.append(label, input, note);
      box.append(wrap);
    });
  }

  function buildTemplateControls(templates) {
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
    buildTemplateSliders();
    select.addEventListener('change', () => {
      state.template.surface = select.value;
      buildTemplateSliders();
      loadSource().catch(showError);
    });
    $('run-fe').addEventListener('click', () => runFe().catch(showError));
    $('x0').addEventListener('input', () => {
      const text = $('x0').value.trim();
      if (text === '' || !Number.isFinite(Number(text))) return;
      state.template.x0_mm = Number(text);
      scheduleTemplate();
    });
  }

  // ------------------------------------------------- FE model on demand

  /** Runs the FE model for the template parameters shown (POST /api/simulate). */
  async function runFe() {
    const body = templateBody();
    const key = JSON.stringify(body);
    const button = $('run-fe');
    button.disabled = true;
    $('fe-info').textContent = 'Running the FE model…';
    try {
      const answer = await (await postJson('/api/simulate', body)).json();
      state.fe = { key, mu: answer.mu, seconds: answer.fe_seconds, rms: answer.cae_rms_difference };
      showFe();
      if (state.voltage) draw();
    } catch (error) {
      $('fe-info').textContent = '';
      throw error;
    } finally {
      button.disabled = false;
    }
  }

  /** The FE result, when it is for the template parameters shown. */
  function currentFe() {
    const fe = state.fe;
    return fe && state.source === 'template' && state.drawn && state.drawn.key === fe.key ? fe : null;
  }

  function showFe() {
    if ($('run-fe').hidden) return; // the note says why the FE model is not available
    const fe = state.fe && state.fe.key === JSON.stringify(templateBody()) ? state.fe : null;
    $('fe-info').textContent = fe
      ? `FE model: ${fe.seconds.toFixed(2)} s; the CAE estimate differs from it by ${fmt(fe.rms)} RMS in mu ` +
        '(dashed green in the friction plot).'
      : '';
  }

  // ------------------------------------- check on the finger model

  /**
   * The POST /api/check body for the profile shown: the voltage request
   * (eq. 8: the check has a force to compare only for the physical method)
   * and the finger's load; a template's sliding velocity, the velocity its
   * profile was computed at.
   */
  function checkBody() {
    // The combined display's design is checked with its plate and strategy.
    const body = voltageBody('physical', state.display === 'combined');
    delete body.method;
    const load = $('check-load').value.trim();
    if (load !== '') body.load_n_per_mm = Number(load);
    if (state.source === 'template' && state.template.velocity_mm_s) body.velocity_mm_s = state.template.velocity_mm_s;
    return body;
  }

  /** Whether the electrovibration display is selected (eq. 9 and the compensation are its). */
  const isElectrovibration = () => state.display === 'electrovibration';
  /** Whether the display selected can be checked on the finger model (electrovibration, combined). */
  const isCheckable = () => state.display === 'electrovibration' || state.display === 'combined';

  /** The last check, when it is for the profile, device, display and load shown. */
  function currentCheck() {
    if (!isCheckable()) return null;
    const c = state.check;
    return c && state.profile && state.drawn === state.profile && c.key === JSON.stringify(checkBody()) ? c : null;
  }

  /** The compensated voltage (as POST /api/voltage answers it), when it is current. */
  function currentCompensated() {
    const c = currentCheck();
    return c && c.mode === 'compensate' ? c.result.voltage : null;
  }

  /** Runs the check (`mode` check) or the compensation, showing its progress. */
  async function runCheck(mode) {
    if (!state.profile) throw new ApiError('no profile to check yet', null, 0);
    const body = checkBody();
    const key = JSON.stringify(body);
    if (mode === 'compensate') {
      const runs = $('check-runs').value.trim();
      if (runs !== '') body.max_runs = Number(runs);
    }
    const buttons = [$('run-check'), $('run-compensate')];
    buttons.forEach((b) => { b.disabled = true; });
    const bar = $('check-progress');
    bar.hidden = false;
    bar.value = 0;
    const progress = { lines: 0, maxRun: 0 };
    state.checkProgress = progress;
    const what = mode === 'compensate' ? 'Compensating' : 'Checking';
    $('check-info').textContent = `${what} on the finger model: waiting for the FE model…`;
    const started = performance.now();
    try {
      const result = await postStream(`/api/${mode}`, body, (p) => {
        progress.lines += 1;
        progress.maxRun = Math.max(progress.maxRun, p.run);
        const runs = mode === 'compensate' ? p.max_runs : 1;
        bar.value = Math.min(1, ((p.run - 1) + p.step / p.steps) / runs);
        $('check-info').textContent = (mode === 'compensate' ? `${what}: FE run ${p.run} of at most ${p.max_runs}` : what) +
          `, step ${p.step} of ${p.steps} (x = ${p.x_mm.toFixed(2)} mm)…`;
      });
      state.check = { key, mode, result };
      const seconds = (performance.now() - started) / 1000;
      $('check-info').textContent = `${mode === 'compensate' ? 'Compensated' : 'Checked'} in ${seconds.toFixed(2)} s ` +
        `(${result.fe_runs} FE run${result.fe_runs > 1 ? 's' : ''}, ${result.fe_seconds.toFixed(2)} s; ` +
        `steps of ${fmt(result.settings.step_mm)} mm).`;
      if (mode === 'compensate') $('play-compensated').checked = true;
      showCheck();
      drawStrip();
      say(`${state.profile.label}: ${mode === 'compensate' ? 'compensated' : 'checked'} on the finger model.`);
    } catch (error) {
      // A refusal is said beside the buttons that asked, in the page's words.
      $('check-info').textContent = error instanceof ApiError && error.status ? checkRefusal(error) : '';
      throw error;
    } finally {
      bar.hidden = true;
      $('run-check').disabled = !isCheckable();
      $('run-compensate').disabled = !isElectrovibration();
    }
  }

  /**
   * A refusal of the check or the compensation as the check box says it:
   * a busy server (503: its heavy slots are taken, before any FE run) or
   * the part of the page at fault (the friction profile, the load, max
   * runs), with the server's message.
   */
  function checkRefusal(error) {
    if (error.status === 503) return `The server is busy: ${error.message}`;
    const f = error.field || '';
    const part = f.startsWith('profile.') ? 'Friction profile'
      : f === 'load_n_per_mm' ? 'Load'
        : f === 'max_runs' ? 'Max runs'
          : f.startsWith('device.') ? 'Device' : null;
    return part ? `${part}: ${error.message}` : error.message;
  }

  /** Shows the current check (plots, metrics, playback), or hides a stale one. */
  function showCheck() {
    const c = currentCheck();
    const box = $('check-results');
    const compensated = currentCompensated();
    $('play-compensated').disabled = !compensated;
    if (!compensated) $('play-compensated').checked = false;
    document.querySelector('[data-download="compensated-csv"]').disabled = !compensated;
    $('feel-source').textContent = played() === state.voltage ? '' : ' (compensated voltage)';
    if (!c) {
      box.hidden = true;
      return;
    }
    box.hidden = false;
    const r = c.result;
    const x = r.x_mm;
    const comp = r.compensated;
    const first = checkTrial(r);
    const frictionSeries = [
      { label: 'target', stroke: '#1f5fa8', width: 1.5 },
      { label: `felt, ${first.name}`, stroke: '#b3261e', dash: [5, 3], width: 1.5 },
    ];
    const frictionData = [x, r.target_mu, first.felt_mu];
    const voltageSeries = [{ label: r.eq8 ? 'U eq. (8)' : 'U(x), combined', stroke: '#b3261e', width: 1.5 }];
    const voltageData = [x, first.voltage_v];
    if (comp) {
      frictionSeries.push({ label: 'felt, compensated', stroke: '#2e7d32', width: 1.5 });
      frictionData.push(comp.felt_mu);
      voltageSeries.push({ label: 'U compensated', stroke: '#2e7d32', width: 1.5 });
      voltageData.push(comp.voltage_v);
    }
    frictionSeries.push({ label: 'mu_HD', stroke: '#888', dash: [6, 4], width: 1 });
    frictionData.push(constant(x, r.settings.mu_hd));
    voltageSeries.push({ label: 'U_max', stroke: '#888', dash: [6, 4], width: 1 });
    const summary = r.voltage.summary;
    voltageData.push(constant(x, summary.u_max_v ?? summary.electrovibration.u_max_v));
    const felt = withPins(frictionSeries, frictionData,
      (p) => ({ x: p.felt ? p.felt.x_mm : null, lines: p.felt ? [{ label: p.felt.label, data: p.felt.mu }] : [] }));
    plots.check = replot(plots.check, 'check-plot', felt.series, felt.data);
    plots.checkVoltage = replot(plots.checkVoltage, 'check-voltage-plot', voltageSeries, voltageData);
    showCheckMetrics(r);
  }

  /**
   * The first trial of a check: eq. (8)'s voltage (`eq8`), or the combined
   * display's design (`design`, with its a(x)), with the page's name for it.
   */
  function checkTrial(r) {
    return r.eq8 ? { ...r.eq8, name: 'eq. (8)' } : { ...r.design, name: 'combined' };
  }

  /** The error figures of eq. (8) (or the combined design) and the compensated voltage, side by side. */
  function showCheckMetrics(r) {
    const box = $('check-summary');
    box.textContent = '';
    const first = checkTrial(r);
    const columns = [[first.name, first.metrics]];
    if (r.compensated) columns.push([`compensated (run ${r.compensated.trial})`, r.compensated.metrics]);
    const rows = [
      ['RMS error', (m) => fmt(m.rms_error)],
      ['max error', (m) => fmt(m.max_error)],
      ['lag', (m) => `${fmt(m.lag_mm)} mm`],
      ['detail kept', (m) => (m.detail_retained === null ? '–' : pct(m.detail_retained))],
      ['k_FE', (m) => `${fmt(m.k_fe_mm2_per_n)} mm²/N`],
    ];
    const table = document.createElement('table');
    table.className = 'metrics';
    table.id = 'check-metrics';
    const head = table.insertRow();
    ['', ...columns.map((c) => c[0])].forEach((text) => {
      const th = document.createElement('th');
      th.textContent = text;
      head.append(th);
    });
    rows.forEach(([label, value]) => {
      const row = table.insertRow();
      const th = document.createElement('th');
      th.textContent = label;
      row.append(th);
      columns.forEach(([, m]) => { row.insertCell().textContent = value(m); });
    });
    const m = first.metrics;
    const title = document.createElement('div');
    const regions = document.createElement('div');
    const finger = `load ${fmt(r.settings.load_n_per_mm)} N/mm, ${fmt(r.settings.velocity_mm_s)} mm/s`;
    if (!r.eq8) {
      // The combined display: the plate vibrating with a(x) under U(x).
      const band = r.voltage.summary.band_mu;
      title.textContent = `Felt against the target over the combined display's band (mu ${fmt(band[0])} .. ` +
        `${fmt(band[1])}), the plate vibrating with a(x) (${r.settings.strategy}) under U(x):`;
      regions.textContent = `below the band: ${pct(m.not_renderable_fraction)} of the length · above it: ` +
        `${pct(m.clipped_fraction)} · ${finger}`;
      box.append(title, table, regions);
      return;
    }
    title.textContent = 'Felt against the target over the renderable region (mu_HD ≤ target ≤ mu at U_max):';
    regions.textContent = `not renderable (target < mu_HD = ${fmt(r.settings.mu_hd)}): ${pct(m.not_renderable_fraction)} ` +
      `of the length · above mu at U_max: ${pct(m.clipped_fraction)} · ${finger}`;
    const k = document.createElement('div');
    k.textContent = `eq. (8) used k = ${fmt(r.parameters.k_mm2_per_n)} mm²/N; the FE finger's contact length per ` +
      `normal force is k_FE = ${fmt(m.k_fe_mm2_per_n)} mm²/N (per mm of width, docs/display.md) `;
    const useK = document.createElement('button');
    useK.type = 'button';
    useK.className = 'small';
    useK.id = 'use-fe-k';
    useK.textContent = 'use k_FE in eq. (8)';
    useK.addEventListener('click', () => {
      $('param-k_mm2_per_n').value = String(Number(m.k_fe_mm2_per_n.toPrecision(4)));
      readDevice();
      scheduleVoltage();
    });
    k.append(useK);
    box.append(title, table, regions, k);
  }

  // ------------------------------------------------------------ controls

  /** Selects a mapping method (its radio button too). */
  function setMethod(id) {
    state.method = id;
    const input = document.querySelector(`input[name="method"][value="${id}"]`);
    if (input) input.checked = true;
  }

  /** Draws eq. (8) and eq. (9) together (Fig. 2b) or only the method chosen (its checkbox too). */
  function setBoth(on) {
    state.both = on;
    $('both-methods').checked = on;
  }

  /** Sets the relative mapping (its checkbox too) and the flat-surface friction shown. */
  function setRelative(on, flatMu) {
    state.relative = on;
    $('relative').checked = on;
    $('flat-mu').value = flatMu;
    $('flat-mu').disabled = !on;
    $('flat-mu').dispatchEvent(new Event('explain'));
  }

  function buildControls(config) {
    const sourceBox = $('source-select');
    config.sources.filter((s) => SOURCES[s.id]).forEach((s, i) => {
      const label = document.createElement('label');
      label.title = s.description;
      const input = document.createElement('input');
      Object.assign(input, { type: 'radio', name: 'source', value: s.id, checked: i === 0 });
      input.addEventListener('change', () => selectSource(s.id));
      label.append(input, s.label);
      sourceBox.append(label);
    });

    const methodBox = $('method-select');
    config.methods.forEach((m) => {
      const label = document.createElement('label');
      label.title = m.description;
      const input = document.createElement('input');
      Object.assign(input, { type: 'radio', name: 'method', value: m.id, checked: m.id === state.method });
      input.addEventListener('change', () => { state.method = m.id; scheduleVoltage(); });
      label.append(input, m.label);
      methodBox.append(label);
    });

    buildDisplayControls(config);

    $('relative').addEventListener('change', () => {
      state.relative = $('relative').checked;
      $('flat-mu').disabled = !state.relative;
      scheduleVoltage();
    });
    $('flat-mu').addEventListener('input', scheduleVoltage);
    $('both-methods').addEventListener('change', () => { state.both = $('both-methods').checked; scheduleVoltage(); });
    $('pin-design').addEventListener('click', () => { try { pinDesign(); } catch (error) { showError(error); } });
    $('unpin-all').addEventListener('click', () => { state.pins = []; showPins(); if (state.voltage) { draw(); showCheck(); } });

    const params = $('device-params');
    config.device_params.forEach((p) => {
      const wrap = document.createElement('div');
      const label = document.createElement('label');
      label.htmlFor = `param-${p.name}`;
      label.title = `${p.description} (API field ${p.name})`;
      const explained = (config.explanations || []).find((e) => e.field === p.name);
      label.textContent = (explained ? explained.symbol : p.name) + ' ';
      const unit = document.createElement('span');
      unit.className = 'unit';
      unit.textContent = p.unit ? `(${p.unit})` : '';
      label.append(unit);
      const input = document.createElement('input');
      Object.assign(input, { type: 'number', id: `param-${p.name}`, step: 'any', min: p.min, max: p.max });
      input.dataset.param = p.name;
      input.placeholder = p.default === null ? 'optional' : String(p.default);
      if (p.default !== null) input.value = String(p.default);
      input.addEventListener('input', () => { readDevice(); scheduleVoltage(); });
      wrap.append(label, input);
      params.append(wrap);
    });
    readDevice();

    $('reset-device').addEventListener('click', () => {
      config.device_params.forEach((p) => { $(`param-${p.name}`).value = p.default === null ? '' : String(p.default); });
      readDevice();
      document.querySelectorAll('[data-explained]').forEach((input) => input.dispatchEvent(new Event('explain')));
      scheduleVoltage();
    });

    $('velocity').value = String(config.play.velocity_mm_s);
    $('carrier').value = String(config.play.carrier.frequency_hz);
    state.velocity = config.play.velocity_mm_s;
    state.carrierHz = config.play.carrier.frequency_hz;
    $('velocity').addEventListener('input', () => { state.velocity = Number($('velocity').value); showStroke(); });
    $('carrier').addEventListener('input', () => {
      const f = Number($('carrier').value);
      if (f > 0) { state.carrierHz = f; audio.setFrequency(f); }
    });
    showStroke();

    $('material').addEventListener('change', () => { $('seed').value = ''; loadSource().catch(showError); });
    $('seed').addEventListener('change', () => loadSource().catch(showError));
    $('another-stroke').addEventListener('click', () => loadSource({ newSeed: true }).catch(showError));
    $('upload-recordings').addEventListener('click', () => uploadRecordings().catch(showRecordingsError));
    $('upload').addEventListener('change', () => loadSource().catch(showError));
    $('recipe-file').addEventListener('change', async () => {
      const file = $('recipe-file').files[0];
      if (!file) return;
      try {
        let parsed;
        try {
          parsed = JSON.parse(await file.text());
        } catch (error) {
          throw new ApiError(`${file.name} is not JSON (${error.message})`, 'recipe', 0);
        }
        await openRecipe(parsed);
      } catch (error) {
        showError(error);
      }
    });
    $('controls').addEventListener('submit', (e) => e.preventDefault());

    $('check-load').value = String(config.check.load_n_per_mm);
    $('check-runs').value = String(config.check.max_runs);
    $('check-load').addEventListener('input', () => { showCheck(); drawStrip(); });
    $('run-check').addEventListener('click', () => runCheck('check').catch(showError));
    $('run-compensate').addEventListener('click', () => runCheck('compensate').catch(showError));
    $('play-compensated').addEventListener('change', () => { showCheck(); drawStrip(); });

    document.querySelectorAll('[data-download]').forEach((b) =>
      b.addEventListener('click', () => download(b.dataset.download).catch(showError)));

    (config.explanations || []).forEach(explain);
  }

  /** The display selector, the strategy, the weight, a_max and the calibration upload. */
  function buildDisplayControls(config) {
    const box = $('display-select');
    (config.displays || []).forEach((d) => {
      const label = document.createElement('label');
      label.title = d.description;
      const input = document.createElement('input');
      Object.assign(input, { type: 'radio', name: 'display', value: d.id, checked: d.id === state.display });
      // Chosen by the user: the source's mapping for that display too.
      input.addEventListener('change', () => {
        setDisplay(d.id);
        if (state.source) applySourceMapping(state.source);
        scheduleVoltage();
      });
      label.append(input, d.label);
      box.append(label);
    });
    const select = $('strategy');
    (config.strategies || []).forEach((st) => {
      const option = document.createElement('option');
      option.value = st.id;
      option.textContent = st.label;
      option.title = st.description;
      select.append(option);
    });
    select.value = state.strategy;
    select.addEventListener('change', () => { state.strategy = select.value; showDisplayControls(); scheduleVoltage(); });
    const us = config.ultrasonic || {};
    $('weight').placeholder = String(us.default_weight ?? 1);
    $('a-max').placeholder = `calibration's last amplitude, or ${us.literature_a_max_um ?? 2.3}`;
    $('weight').addEventListener('input', scheduleVoltage);
    $('a-max').addEventListener('input', scheduleVoltage);
    $('calibration').addEventListener('change', () => readCalibration().catch(showError));
    $('clear-calibration').addEventListener('click', () => {
      state.calibration = null;
      $('calibration').value = '';
      showDisplayControls();
      scheduleVoltage();
    });
    showDisplayControls();
  }

  /** Selects a display (its radio button too). */
  function setDisplay(id) {
    state.display = id;
    const input = document.querySelector(`input[name="display"][value="${id}"]`);
    if (input) input.checked = true;
    showDisplayControls();
    showCheck();
  }

  /** Shows the controls of the selected display and what it does with the others. */
  function showDisplayControls() {
    const ev = isElectrovibration();
    $('display-options').hidden = ev;
    $('strategy-row').hidden = state.display !== 'combined';
    $('weight-row').hidden = state.display !== 'combined' || state.strategy !== 'weighted';
    const strategy = (state.config.strategies || []).find((st) => st.id === state.strategy);
    $('strategy-info').textContent = strategy ? strategy.description : '';
    // eq. (9) and the compensation are the electrovibration display's; the
    // check on the finger model is also the combined display's.
    document.querySelectorAll('input[name="method"]').forEach((input) => { input.disabled = !ev; });
    $('run-check').disabled = !isCheckable();
    $('run-compensate').disabled = !ev;
    $('both-methods').disabled = !ev;
    $('display-info').textContent = ev
      ? 'Electrovibration only raises friction above mu_HD.'
      : 'Method: physical (eq. 9 is the electrovibration display\'s pattern); the compensation on the finger model ' +
        'is for the electrovibration display' +
        (isCheckable() ? '; the check applies this design to the finger on the vibrating plate.' : ', its check ' +
          'for the electrovibration and combined displays.');
    $('calibration-info').textContent = state.calibration
      ? `${state.calibration.name}: ${state.calibration.rows} rows (the server checks them: strictly increasing ` +
        'amplitudes from 0, relative friction strictly decreasing from 1).'
      : 'No calibration: the literature default stands in (a placeholder, not this device).';
  }

  /** Reads the calibration file chosen (the server checks it with the voltage). */
  async function readCalibration() {
    const file = $('calibration').files[0];
    if (!file) return;
    const max = (state.config.ultrasonic || {}).max_calibration_bytes;
    if (max && file.size > max) {
      $('calibration').value = '';
      throw new ApiError(`${file.name} is ${file.size} bytes, more than the limit of ${max}`, 'ultrasonic_calibration', 0);
    }
    const text = await file.text();
    const rows = text.split(/\r?\n/).filter((l) => l.trim() !== '' && !l.trim().startsWith('#')).length - 1;
    state.calibration = { name: file.name, text, rows };
    showDisplayControls();
    scheduleVoltage();
  }

  /**
   * Puts the server's explanation of a parameter (GET /api/config,
   * `explanations`) under its control: symbol, unit, meaning, typical range
   * and source; the control and the note turn to the warning style while the
   * value is outside the typical range (as the template sliders do outside
   * the FE database).
   */
  function explain(e) {
    const input = document.querySelector(`[data-param="${e.field}"], [data-field="${e.field}"]`);
    if (!input) return;
    const unit = e.unit ? ` ${e.unit}` : '';
    const note = document.createElement('p');
    note.className = 'explain';
    note.id = `explain-${e.field}`;
    const head = document.createElement('span');
    const range = document.createElement('span');
    range.className = 'typical';
    const source = document.createElement('span');
    source.className = 'source';
    source.textContent = ` Source: ${e.source}.`;
    note.append(head, range, source);
    input.dataset.explained = e.field;
    input.setAttribute('aria-describedby', note.id);
    input.insertAdjacentElement('afterend', note);
    const show = () => {
      const text = input.value.trim();
      const v = text === '' ? NaN : Number(text);
      const outside = e.typical !== null && Number.isFinite(v) && (v < e.typical.min || v > e.typical.max);
      head.textContent = `${e.symbol}${e.unit ? ` (${e.unit})` : ' (no unit)'}: ${e.meaning}. `;
      range.textContent = e.typical === null
        ? 'No typical range sourced.'
        : `${outside ? 'Outside the typical range' : 'Typical'} ${fmt(e.typical.min)} .. ${fmt(e.typical.max)}${unit}` +
          `${outside ? ` (accepted ${fmt(e.accepted.min)} .. ${fmt(e.accepted.max)}${unit})` : ''}.`;
      note.classList.toggle('outside', outside);
      input.classList.toggle('outside', outside);
    };
    input.addEventListener('input', show);
    input.addEventListener('explain', show);
    show();
  }

  /** The device parameters typed in; empty fields take the server's default. */
  function readDevice() {
    const device = {};
    document.querySelectorAll('[data-param]').forEach((input) => {
      const text = input.value.trim();
      if (text !== '') device[input.dataset.param] = Number(text);
    });
    state.device = device;
  }

  function showStroke() {
    $('velocity-out').textContent = `${state.velocity} mm/s`;
    const p = state.profile;
    if (!p) { $('stroke-info').textContent = ''; return; }
    const length = p.x_mm[p.x_mm.length - 1] - p.x_mm[0];
    $('stroke-info').textContent =
      `One stroke over the profile: ${fmt(length)} mm at ${state.velocity} mm/s takes ${fmt(length / state.velocity)} s.`;
  }

  // ------------------------------------------------------------- voltage

  let voltageTimer = null;
  let voltageRequest = 0;

  function scheduleVoltage() {
    clearTimeout(voltageTimer);
    voltageTimer = setTimeout(() => updateVoltage().catch(showError), 60);
  }

  /**
   * The POST /api/voltage body for the profile shown (by `method`, default
   * the one chosen), for the display selected unless `withDisplay` is false.
   */
  function voltageBody(method = state.method, withDisplay = true) {
    const p = state.profile;
    const profile = { x_mm: p.x_mm, mu: p.mu };
    if (p.fn_n) profile.fn_n = p.fn_n;
    const body = { profile, method, device: state.device };
    if (state.deviceFile) {
      // The file's constants (the device fields show them), for the playback carrier.
      body.device = {};
      body.device_file = state.deviceFile.text;
      body.carrier = { shape: 'sine', frequency_hz: state.carrierHz };
    }
    if (state.relative) {
      body.relative = true;
      const flat = $('flat-mu').value.trim();
      if (flat !== '') body.flat_mu = Number(flat);
    }
    if (withDisplay && !isElectrovibration()) {
      delete body.method; // physical, the only method of these displays
      body.display = state.display;
      if (state.display === 'combined') {
        body.strategy = state.strategy;
        const w = $('weight').value.trim();
        if (state.strategy === 'weighted' && w !== '') body.weight = Number(w);
      }
      const a = $('a-max').value.trim();
      if (a !== '') body.a_max_um = Number(a);
      if (state.calibration) body.ultrasonic_calibration = state.calibration.text;
    }
    return body;
  }

  const otherMethod = (method) => (method === 'physical' ? 'normalized' : 'physical');

  async function updateVoltage() {
    if (!state.profile) return;
    const id = ++voltageRequest;
    const both = state.both && isElectrovibration();
    const [answer, companion] = await Promise.all([
      postJson('/api/voltage', voltageBody()).then((r) => r.json()),
      both ? postJson('/api/voltage', voltageBody(otherMethod(state.method))).then((r) => r.json()) : null,
    ]);
    if (id !== voltageRequest) return; // a newer request is on its way
    state.voltage = answer;
    state.companion = companion;
    state.drawn = state.profile;
    document.querySelectorAll('[aria-invalid="true"]').forEach((el) => el.removeAttribute('aria-invalid'));
    draw();
    showSummary();
    showRelative();
    showStroke();
    showCheck();
    drawStrip();
    document.dispatchEvent(new CustomEvent('haptex:voltage', { detail: answer }));
    state.updates += 1;
    document.body.dataset.updates = String(state.updates);
    document.body.dataset.state = 'ready';
    const s = answer.summary;
    const how = s.display
      ? `display ${s.display}${s.strategy ? `, strategy ${s.strategy}` : ''}`
      : `method ${s.method}`;
    say(`${state.profile.label}: ${s.n_points} points, ${how}` +
      `${s.relative ? ', relative to the flat-surface friction (Fig. 2)' : ''}.`);
    if (state.pendingError) {
      showError(state.pendingError);
      state.pendingError = null;
    }
  }

  /** "eq. (8)" or "eq. (9)": the method of a summary. */
  function equation(summary) {
    return summary.method === 'physical' ? 'eq. (8)' : 'eq. (9)';
  }

  /** The note under the relative checkbox: mu_flat and where it came from. */
  function showRelative() {
    const r = state.voltage && state.voltage.summary.relative;
    const note = $('relative-info');
    if (!r) {
      note.textContent = state.relative ? '' : 'Off: the profile is mapped as it is.';
      return;
    }
    const origin = r.flat_mu_source === 'median'
      ? 'the median of the profile, an estimate: give it when it is known'
      : state.source === 'template' && state.templates && r.flat_mu === state.templates.fe.mu_skin
        ? 'the FE skin friction mu_skin: Ft/Fn on a flat surface'
        : 'given';
    note.textContent = `mu = mu_profile / ${fmt(r.flat_mu)} · ${fmt(r.mu_hd)} (mu_flat: ${origin}).`;
  }

  /** The warnings of the answer as the page names its controls (page_warnings). */
  function showWarnings(box) {
    const warnings = state.voltage.page_warnings || state.voltage.summary.warnings;
    if (!warnings.length) return;
    const list = document.createElement('ul');
    warnings.forEach((w) => {
      const item = document.createElement('li');
      item.className = 'warning';
      item.textContent = w;
      list.append(item);
    });
    box.append(list);
  }

  /** The summary of an ultrasonic or combined display: band, channels, regions. */
  function showDisplaySummary(box, s) {
    const line = (id, text) => {
      const div = document.createElement('div');
      div.id = id;
      div.textContent = text;
      box.append(div);
    };
    line('summary-band', `${s.display} display${s.strategy ? ` (${s.strategy})` : ''}: renderable band ` +
      `mu ${fmt(s.band_mu[0])} .. ${fmt(s.band_mu[1])} · ${s.relative ? 'relative ' : ''}mu ${fmt(s.mu_min)} .. ` +
      `${fmt(s.mu_max)} · mu_HD ${fmt(s.mu_hd)}`);
    const ev = s.electrovibration;
    if (ev) {
      line('summary-voltage', `U ${fmt(ev.voltage_min_v)} .. ${fmt(ev.voltage_max_v)} V RMS (U_max ${fmt(ev.u_max_v)} V)` +
        ` · Fe/Fn = ${ev.fe_over_fn_per_v2.toExponential(4)} U²`);
    }
    const us = s.ultrasonic;
    const model = us.source === 'calibration'
      ? `calibration ${state.calibration ? state.calibration.name : us.calibration_file}`
      : 'literature default (a placeholder: upload a calibration of your plate)';
    line('summary-amplitude', `a ${fmt(us.amplitude_min_um)} .. ${fmt(us.amplitude_max_um)} µm (a_max ` +
      `${fmt(us.a_max_um)} µm; saturation rho_min = ${fmt(us.relative_friction_min)}) · ${model}`);
    if (s.bias) {
      line('summary-bias', `bias level: a = ${fmt(s.bias.amplitude_um)} µm (rho = ${fmt(s.bias.relative_friction)})` +
        ` · lowered below it: ${pct(s.bias.lowered.fraction_of_length)} of the length`);
    }
    line('summary-regions', `above the band: ${pct(s.above_band.fraction_of_length)} of the length · below the ` +
      `band: ${pct(s.below_band.fraction_of_length)}`);
    showWarnings(box);
    // Split on a profile below mu_HD everywhere (a template's physical
    // values): the plate renders all of it and U is 0 V. Say so, and offer
    // the strategy that puts the detail on the voltage.
    if (ev && s.strategy === 'split' && ev.voltage_max_v === 0) {
      const way = document.createElement('div');
      way.className = 'way-out';
      way.id = 'summary-plate-only';
      way.append('U = 0 V: the profile lies below mu_HD everywhere, so the split strategy renders all of it with ' +
        'the plate. One click: ');
      const b = document.createElement('button');
      Object.assign(b, { type: 'button', id: 'way-out-bias', className: 'small',
        textContent: 'bias (a constant plate level, the detail on the voltage)' });
      b.addEventListener('click', () => {
        state.strategy = 'bias';
        $('strategy').value = 'bias';
        showDisplayControls();
        scheduleVoltage();
      });
      way.append(b);
      box.append(way);
    }
  }

  function showSummary() {
    const s = state.voltage.summary;
    const box = $('summary');
    box.textContent = '';
    if (s.display) {
      showDisplaySummary(box, s);
      return;
    }
    const line = document.createElement('div');
    line.textContent = `${equation(s)}: U ${fmt(s.voltage_min_v)} .. ${fmt(s.voltage_max_v)} V RMS ` +
      `(U_max ${fmt(s.u_max_v)} V) · ${s.relative ? 'relative ' : ''}mu ${fmt(s.mu_min)} .. ${fmt(s.mu_max)}` +
      (s.fe_over_fn_per_v2 ? ` · Fe/Fn = ${s.fe_over_fn_per_v2.toExponential(4)} U²` : '');
    box.append(line);
    if (s.method === 'physical') {
      const regions = document.createElement('div');
      regions.textContent = `clipped at U_max: ${pct(s.clipped.fraction_of_length)} of the length · ` +
        `mu_RS < mu_HD (not renderable, 0 V): ${pct(s.not_renderable.fraction_of_length)}`;
      box.append(regions);
    }
    if (state.companion) {
      const c = state.companion.summary;
      const other = document.createElement('div');
      other.textContent = `${equation(c)} beside it (dashed): U ${fmt(c.voltage_min_v)} .. ${fmt(c.voltage_max_v)} V RMS`;
      box.append(other);
    }
    // The server's warnings with the page's controls named, not the command line's flags.
    showWarnings(box);
    // A flat 0 V line is not a signal: say why, and offer the one-click ways out.
    if (s.method === 'physical' && s.not_renderable.fraction_of_length >= 1) {
      const way = document.createElement('div');
      way.className = 'way-out';
      way.append('U = 0 V everywhere (the profile never rises above mu_HD). One click: ');
      const button = (id, text, action) => {
        const b = document.createElement('button');
        Object.assign(b, { type: 'button', id, textContent: text, className: 'small' });
        b.addEventListener('click', () => { action(); scheduleVoltage(); });
        return b;
      };
      way.append(button('way-out-normalized', 'the pattern: normalized (eq. 9)', () => setMethod('normalized')));
      way.append(' ', button('way-out-combined', 'the combined display (ultrasonic below mu_HD)',
        () => setDisplay('combined')));
      if (!state.relative) {
        way.append(' ', button('way-out-relative', 'relative to its flat-surface friction (Fig. 2)',
          () => setRelative(true, '')));
      }
      box.append(way);
    }
  }

  // ------------------------------------------------------------- compare

  /** At most this many pinned designs (the plots stay readable). */
  const MAX_PINS = 6;
  /** One colour per pin, apart from the current design's (blue, red, purple, grey, orange, green). */
  const PIN_COLORS = ['#d81b60', '#00897b', '#8d6e63', '#f9a825', '#3949ab', '#7cb342'];
  let pinCounter = 0;

  /** What the design shown is, in the page's words: source, method or display, mapping, device changes. */
  function designLabel() {
    const s = state.voltage.summary;
    const how = s.display
      ? `${s.display} display${s.strategy ? ` (${s.strategy})` : ''}`
      : `${equation(s)}${state.companion ? ` and ${equation(state.companion.summary)}` : ''}`;
    const changed = state.config.device_params
      .filter((p) => state.device[p.name] !== undefined && state.device[p.name] !== p.default)
      .map((p) => {
        const e = (state.config.explanations || []).find((x) => x.field === p.name);
        return `${e ? e.symbol : p.name} ${fmt(state.device[p.name])}${p.unit ? ` ${p.unit}` : ''}`;
      });
    return `${state.drawn.label} · ${how}${s.relative ? `, relative (mu_flat ${fmt(s.relative.flat_mu)})` : ''}` +
      (changed.length ? ` · ${changed.join(', ')}` : '');
  }

  /**
   * Pins the design shown: its friction profile as plotted, its voltage(s)
   * (eq. 8 and eq. 9 when both are drawn), its amplitude a(x) and the
   * friction the finger model felt when a check is current; the next
   * designs are drawn over it on the same axes.
   */
  function pinDesign() {
    const v = state.voltage;
    if (!v) throw new ApiError('nothing to pin yet', null, 0);
    if (state.pins.length >= MAX_PINS) {
      throw new ApiError(`at most ${MAX_PINS} pinned designs: remove one first`, null, 0);
    }
    pinCounter += 1;
    const name = `P${pinCounter}`;
    const s = v.summary;
    const voltages = [];
    if (v.voltage_v) voltages.push({ label: s.display ? 'U(x)' : `U ${equation(s)}`, data: v.voltage_v, dash: false });
    const c = state.companion;
    if (c && c.voltage_v.length === v.x_mm.length) {
      voltages.push({ label: `U ${equation(c.summary)}`, data: c.voltage_v, dash: true });
    }
    const check = currentCheck();
    let felt = null;
    if (check) {
      const r = check.result;
      const comp = r.compensated;
      const first = checkTrial(r);
      felt = { x_mm: r.x_mm, mu: comp ? comp.felt_mu : first.felt_mu, label: comp ? 'felt, compensated' : `felt, ${first.name}` };
    }
    state.pins.push({
      name,
      color: PIN_COLORS[(pinCounter - 1) % PIN_COLORS.length],
      label: designLabel(),
      x_mm: v.x_mm,
      mu: v.mu,
      voltages,
      amplitude: v.amplitude_um || null,
      felt,
    });
    showPins();
    draw();
    showCheck();
    say(`Pinned ${name}: the next designs are drawn over it.`);
  }

  function unpin(name) {
    state.pins = state.pins.filter((p) => p.name !== name);
    showPins();
    if (state.voltage) { draw(); showCheck(); }
    say(`Removed ${name}.`);
  }

  /** The list of pinned designs: colour, name, what it is, and its remove button. */
  function showPins() {
    const list = $('pins');
    list.textContent = '';
    state.pins.forEach((p) => {
      const item = document.createElement('li');
      item.dataset.pin = p.name;
      const swatch = document.createElement('span');
      swatch.className = 'swatch';
      swatch.style.background = p.color;
      swatch.setAttribute('aria-hidden', 'true');
      const text = document.createElement('span');
      text.className = 'pin-label';
      text.textContent = `${p.name}: ${p.label}`;
      const remove = document.createElement('button');
      Object.assign(remove, { type: 'button', className: 'small remove-pin', textContent: 'remove' });
      remove.setAttribute('aria-label', `remove pinned design ${p.name}`);
      remove.addEventListener('click', () => unpin(p.name));
      item.append(swatch, text, remove);
      list.append(item);
    });
    $('unpin-all').hidden = state.pins.length < 2;
    $('pin-design').disabled = state.pins.length >= MAX_PINS;
    $('pins-info').textContent = state.pins.length
      ? `${state.pins.length} pinned (of at most ${MAX_PINS}); the legends name them P1, P2, …`
      : `Pin a design to compare the next ones with it on the same axes (up to ${MAX_PINS}).`;
  }

  /**
   * The pinned designs' series of one plot beside the current design's:
   * `pick(pin)` gives a pin's [{label, data, dash}] on its own x_mm (or
   * its x with them). Without pins the current data is drawn as it is;
   * with them the tables are joined on one x axis (uPlot.join: null where
   * a design has no sample, lines drawn across).
   */
  function withPins(series, data, pick) {
    const tables = [];
    const extra = [];
    state.pins.forEach((p) => {
      const picked = pick(p);
      if (!picked || !picked.lines.length) return;
      tables.push([picked.x, ...picked.lines.map((l) => l.data)]);
      picked.lines.forEach((l) => extra.push({
        label: `${p.name} ${l.label}`, stroke: p.color, width: 1.5, dash: l.dash ? [5, 3] : undefined,
      }));
    });
    if (!tables.length) return { series, data };
    return {
      series: [...series, ...extra].map((s) => ({ ...s, spanGaps: true })),
      data: data ? uPlot.join([data, ...tables]) : uPlot.join(tables),
    };
  }

  // --------------------------------------------------------------- plots

  function plotWidth(id) {
    return Math.max(240, $(id).clientWidth || $(id).parentElement.clientWidth);
  }

  function plotHeight() {
    return window.innerWidth < 600 ? 190 : 240;
  }

  function makePlot(id, series, data) {
    const options = {
      width: plotWidth(id),
      height: plotHeight(),
      scales: { x: { time: false } },
      axes: [{ label: 'x (mm)' }, {}],
      legend: { live: true },
      cursor: { drag: { x: true, y: false } },
      series: [{ label: 'x (mm)' }, ...series],
    };
    const plot = new uPlot(options, data, $(id));
    keyboardLegend(plot);
    return plot;
  }

  /**
   * The legend's entries as toggle buttons for the keyboard: Tab reaches
   * each series' entry, Enter or Space shows or hides it (what a click on
   * it does), and aria-pressed says whether it is shown.
   */
  function keyboardLegend(plot) {
    plot.root.querySelectorAll('.u-legend tr.u-series').forEach((row, i) => {
      const th = row.querySelector('th');
      if (i === 0 || !th) return; // the x column is no series to hide
      const pressed = () => th.setAttribute('aria-pressed', String(plot.series[i].show !== false));
      th.tabIndex = 0;
      th.setAttribute('role', 'button');
      th.setAttribute('aria-label', `show or hide ${plot.series[i].label}`);
      pressed();
      // After uPlot's own click handler (registered first): the new state.
      th.addEventListener('click', pressed);
      th.addEventListener('keydown', (e) => {
        if (e.key !== 'Enter' && e.key !== ' ') return;
        e.preventDefault();
        th.click();
      });
    });
  }

  function constant(x, value) {
    return x.map(() => value);
  }

  function draw() {
    const v = state.voltage;
    const s = v.summary;
    const x = v.x_mm;
    const r = s.relative;
    const frictionData = [x, v.mu];
    const frictionSeries = [{ label: r ? 'mu_RS / mu_flat · mu_HD' : 'mu_RS', stroke: '#1f5fa8', width: 1.5 }];
    if (s.display) {
      // The renderable band of the display (summary.band_mu).
      frictionData.push(constant(x, s.mu_hd), constant(x, s.band_mu[0]), constant(x, s.band_mu[1]));
      frictionSeries.push(
        { label: 'mu_HD', stroke: '#888', dash: [6, 4], width: 1 },
        { label: 'band min (mu_HD rho_min)', stroke: '#00838f', dash: [2, 4], width: 1.5 },
        { label: s.electrovibration ? 'band max (mu at U_max)' : 'band max (mu_HD)', stroke: '#c77700',
          dash: [2, 4], width: 1.5 });
    } else if (s.method === 'physical') {
      frictionData.push(constant(x, s.mu_hd), constant(x, s.mu_at_u_max));
      frictionSeries.push(
        { label: 'mu_HD', stroke: '#888', dash: [6, 4], width: 1 },
        { label: 'mu at U_max', stroke: '#c77700', dash: [2, 4], width: 1 });
    }
    const fe = currentFe();
    if (fe && fe.mu.length === x.length) {
      // On the plotted scale: relative like the profile when it is.
      frictionData.push(r ? fe.mu.map((m) => m / r.flat_mu * r.mu_hd) : fe.mu);
      frictionSeries.push({ label: 'mu FE model', stroke: '#2e7d32', dash: [5, 3], width: 1.5 });
    }
    const voltageData = [x, v.voltage_v];
    const voltageSeries = [{ label: s.display ? 'U(x)' : `U ${equation(s)}`, stroke: '#b3261e', width: 1.5 }];
    const c = state.companion;
    if (c && c.voltage_v.length === x.length) {
      voltageData.push(c.voltage_v);
      voltageSeries.push({ label: `U ${equation(c.summary)}`, stroke: '#6a3d9a', dash: [5, 3], width: 1.5 });
    }
    voltageData.push(constant(x, uMaxOf(v)));
    voltageSeries.push({ label: 'U_max', stroke: '#888', dash: [6, 4], width: 1 });
    $('voltage-caption').textContent = c
      ? `: ${equation(s)} and ${equation(c.summary)} side by side, as in the paper's Fig. 2b`
      : '';
    const h = state.drawn && state.drawn.h_mm;
    if (h && h.length === x.length) {
      plots.height = replot(plots.height, 'height-plot', [{ label: 'h (mm)', stroke: '#444', width: 1.5, fill: 'rgba(0,0,0,0.06)' }], [x, h]);
    } else if (plots.height) {
      plots.height.destroy();
      plots.height = null;
    }
    const friction = withPins(frictionSeries, frictionData,
      (p) => ({ x: p.x_mm, lines: [{ label: 'mu', data: p.mu }] }));
    plots.friction = replot(plots.friction, 'friction-plot', friction.series, friction.data);
    // The ultrasonic display alone has no voltage (a pinned design may have).
    const voltage = v.voltage_v
      ? withPins(voltageSeries, voltageData, (p) => ({ x: p.x_mm, lines: p.voltages }))
      : withPins([], null, (p) => ({ x: p.x_mm, lines: p.voltages }));
    const hasVoltage = Boolean(voltage.data);
    $('voltage-figure').hidden = !hasVoltage;
    if (hasVoltage) {
      plots.voltage = replot(plots.voltage, 'voltage-plot', voltage.series, voltage.data);
    } else if (plots.voltage) {
      plots.voltage.destroy();
      plots.voltage = null;
    }
    const a = v.amplitude_um;
    const pinnedAmplitude = (p) => ({ x: p.x_mm, lines: p.amplitude ? [{ label: 'a(x)', data: p.amplitude }] : [] });
    const amplitude = a
      ? withPins([
        { label: 'a(x) (µm)', stroke: '#00838f', width: 1.5 },
        { label: 'a_max', stroke: '#888', dash: [6, 4], width: 1 },
      ], [x, a, constant(x, s.ultrasonic.a_max_um)], pinnedAmplitude)
      : withPins([], null, pinnedAmplitude);
    $('amplitude-figure').hidden = !amplitude.data;
    if (amplitude.data) {
      plots.amplitude = replot(plots.amplitude, 'amplitude-plot', amplitude.series, amplitude.data);
    } else if (plots.amplitude) {
      plots.amplitude.destroy();
      plots.amplitude = null;
    }
  }

  /** U_max of an answer: the electrovibration answer's, or the combined display's (null without voltage). */
  function uMaxOf(v) {
    const s = v.summary;
    if (s.u_max_v !== undefined) return s.u_max_v;
    return s.electrovibration ? s.electrovibration.u_max_v : null;
  }

  /** Updates a plot in place when its series are unchanged, else rebuilds it; then its text summary. */
  function replot(plot, id, series, data) {
    describePlot(id, series, data);
    if (plot && plot.series.length === series.length + 1 &&
        plot.series.every((s, i) => i === 0 || s.label === series[i - 1].label)) {
      plot.setData(data, true);
      return plot;
    }
    if (plot) plot.destroy();
    return makePlot(id, series, data);
  }

  /**
   * The text a screen reader gives for a plot (the plot is an image named
   * by its caption, described by this text): the x range and each series'
   * extrema with where they are.
   */
  function describePlot(id, series, data) {
    const box = $(id);
    let note = $(`${id}-summary`);
    if (!note) {
      note = document.createElement('p');
      note.id = `${id}-summary`;
      note.className = 'sr-only plot-summary';
      box.insertAdjacentElement('afterend', note);
      box.setAttribute('role', 'img');
      box.setAttribute('aria-describedby', note.id);
    }
    const caption = box.parentElement.querySelector('figcaption');
    if (caption) box.setAttribute('aria-label', caption.textContent.trim());
    const x = data[0];
    const parts = [`x from ${fmt(x[0])} to ${fmt(x[x.length - 1])} mm`];
    series.forEach((s, i) => {
      const ys = data[i + 1];
      let lo = -1;
      let hi = -1;
      ys.forEach((y, j) => {
        if (y === null || y === undefined) return;
        if (lo < 0 || y < ys[lo]) lo = j;
        if (hi < 0 || y > ys[hi]) hi = j;
      });
      if (lo < 0) return;
      parts.push(ys[lo] === ys[hi]
        ? `${s.label}: ${fmt(ys[lo])} throughout`
        : `${s.label}: min ${fmt(ys[lo])} at x = ${fmt(x[lo])} mm, max ${fmt(ys[hi])} at x = ${fmt(x[hi])} mm`);
    });
    note.textContent = `${parts.join('; ')}.`;
  }

  function clearPlots() {
    $('check-results').hidden = true;
    ['height', 'friction', 'voltage', 'amplitude'].forEach((k) => {
      if (plots[k]) { plots[k].destroy(); plots[k] = null; }
    });
    $('amplitude-figure').hidden = true;
    $('summary').textContent = '';
    state.voltage = null;
    state.companion = null;
    drawStrip();
  }

  function resizePlots() {
    const ids = { height: 'height-plot', friction: 'friction-plot', voltage: 'voltage-plot',
      amplitude: 'amplitude-plot', check: 'check-plot', checkVoltage: 'check-voltage-plot' };
    Object.entries(ids).forEach(([k, id]) => {
      const plot = plots[k];
      if (plot) plot.setSize({ width: plotWidth(id), height: plotHeight() });
    });
    drawStrip();
  }

  // ---------------------------------------------------------- feel strip

  /**
   * The voltage the feel strip, the audio and the stroke WAV play: the
   * compensated one when it is current and chosen, else the one plotted.
   * Its samples always come with their own summary (U_max, the scale).
   */
  function played() {
    const compensated = currentCompensated();
    return compensated && $('play-compensated').checked ? compensated : state.voltage;
  }

  /** U at x by linear interpolation in the played voltage profile (held at the ends; 0 V without voltage). */
  function voltageAt(x) {
    const v = played();
    return v.voltage_v ? interpolate(v.x_mm, v.voltage_v, x) : 0;
  }

  /** a at x (µm) in the played display profile, null without an ultrasonic channel. */
  function amplitudeAt(x) {
    const v = played();
    return v.amplitude_um ? interpolate(v.x_mm, v.amplitude_um, x) : null;
  }

  /** ys at x by linear interpolation over xs (held at the ends). */
  function interpolate(xs, us, x) {
    if (x <= xs[0]) return us[0];
    if (x >= xs[xs.length - 1]) return us[us.length - 1];
    let lo = 0;
    let hi = xs.length - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (xs[mid] <= x) lo = mid; else hi = mid;
    }
    const t = (x - xs[lo]) / (xs[hi] - xs[lo]);
    return us[lo] + t * (us[hi] - us[lo]);
  }

  let strip = { marker: null, fraction: null, contact: false };

  function drawStrip() {
    live.follow();
    const canvas = $('feel-strip');
    const ratio = window.devicePixelRatio || 1;
    const width = canvas.clientWidth;
    const height = canvas.clientHeight;
    canvas.width = Math.round(width * ratio);
    canvas.height = Math.round(height * ratio);
    const ctx = canvas.getContext('2d');
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.fillStyle = '#111';
    ctx.fillRect(0, 0, width, height);
    if (!state.voltage) return;
    const v = played();
    const xs = v.x_mm;
    const x0 = xs[0];
    const span = xs[xs.length - 1] - x0;
    const uMax = uMaxOf(v);
    // With an ultrasonic channel the lower third shows a(x) in blue (brighter: more vibration, less friction).
    const aMax = v.amplitude_um ? v.summary.ultrasonic.a_max_um : null;
    const top = aMax ? Math.round(height * 2 / 3) : height;
    for (let px = 0; px < width; px += 1) {
      const xAt = x0 + (px + 0.5) / width * span;
      const u = voltageAt(xAt);
      const level = Math.round(30 + 225 * (uMax ? Math.min(1, u / uMax) : 0));
      ctx.fillStyle = `rgb(${level}, ${Math.round(level * 0.82)}, ${Math.round(level * 0.45)})`;
      ctx.fillRect(px, 0, 1, top);
      if (aMax) {
        const b = Math.round(30 + 225 * Math.min(1, amplitudeAt(xAt) / aMax));
        ctx.fillStyle = `rgb(${Math.round(b * 0.3)}, ${Math.round(b * 0.75)}, ${b})`;
        ctx.fillRect(px, top, 1, height - top);
      }
    }
    if (strip.marker !== null) {
      ctx.fillStyle = '#4fc3f7';
      ctx.fillRect(strip.marker - 1, 0, 2, height);
    }
  }

  /** Feels the strip at the viewport x `clientX` (a mouse, pen or finger); `input` says which. */
  function feelAt(clientX, input, timeStamp) {
    const rect = $('feel-strip').getBoundingClientRect();
    feelAtFraction(Math.min(Math.max((clientX - rect.left) / rect.width, 0), 1), input, timeStamp);
  }

  /** Feels the strip at `fraction` of its length (0 = the profile's first x, 1 = its last). */
  function feelAtFraction(fraction, input, timeStamp) {
    if (!state.voltage) return;
    const canvas = $('feel-strip');
    const rect = canvas.getBoundingClientRect();
    const px = fraction * rect.width;
    const v = played();
    const xs = v.x_mm;
    const x = xs[0] + px / rect.width * (xs[xs.length - 1] - xs[0]);
    const u = voltageAt(x);
    const a = amplitudeAt(x);
    const readout = $('feel-readout');
    readout.textContent = `x = ${x.toFixed(3)} mm, U = ${u.toFixed(1)} V RMS` +
      (a === null ? '' : `, a = ${a.toFixed(3)} µm`);
    readout.dataset.xMm = String(x);
    readout.dataset.input = input;
    strip.fraction = fraction;
    canvas.setAttribute('aria-valuenow', String(Math.round(100 * fraction)));
    canvas.setAttribute('aria-valuetext', readout.textContent);
    readout.dataset.voltageV = String(u);
    if (a === null) delete readout.dataset.amplitudeUm; else readout.dataset.amplitudeUm = String(a);
    strip.marker = px;
    drawStrip();
    live.touch(x, timeStamp ?? performance.now());
    // The audio plays the electrovibration channel, as the strip's brightness.
    const uMax = uMaxOf(v);
    audio.set(uMax ? u / uMax : 0);
  }

  /**
   * The strip follows a mouse or pen (pointer events), a finger (touch
   * events: the drag feels the strip instead of scrolling the page) and
   * the keyboard (arrow keys: 1% of the length, with Shift 10%; Home, End).
   */
  function setupStrip() {
    const canvas = $('feel-strip');
    // `contact`: a button, pen or finger is down (or a key moved the
    // marker): only then does the live output follow, not a hovering mouse.
    const stop = () => { audio.set(0); strip.contact = false; live.lift(); };
    const byPointer = (e) => {
      // A finger is followed by the touch events below where the browser has them.
      if (e.pointerType === 'touch' && 'ontouchstart' in window) return;
      feelAt(e.clientX, e.pointerType || 'mouse', e.timeStamp);
    };
    canvas.addEventListener('pointerdown', (e) => {
      strip.contact = true;
      if (canvas.setPointerCapture) canvas.setPointerCapture(e.pointerId);
      byPointer(e);
    });
    canvas.addEventListener('pointermove', byPointer);
    canvas.addEventListener('pointerup', stop);
    canvas.addEventListener('pointerleave', (e) => { if (e.pointerType !== 'touch') stop(); });
    const byTouch = (e) => {
      if (!e.touches.length) return;
      strip.contact = true;
      e.preventDefault(); // no scrolling, no emulated mouse events
      feelAt(e.touches[0].clientX, 'touch', e.timeStamp);
    };
    canvas.addEventListener('touchstart', byTouch, { passive: false });
    canvas.addEventListener('touchmove', byTouch, { passive: false });
    canvas.addEventListener('touchend', stop);
    canvas.addEventListener('touchcancel', stop);
    canvas.addEventListener('keydown', (e) => {
      const step = e.shiftKey ? 0.1 : 0.01;
      const at = strip.fraction ?? 0;
      const to = { ArrowRight: at + step, ArrowUp: at + step, ArrowLeft: at - step, ArrowDown: at - step,
        Home: 0, End: 1 }[e.key];
      if (to === undefined) return;
      e.preventDefault();
      strip.contact = true;
      feelAtFraction(Math.min(Math.max(to, 0), 1), 'keyboard');
    });
    canvas.addEventListener('blur', stop);
    $('audio').addEventListener('change', () => ($('audio').checked ? audio.start() : audio.stop()));
  }

  // The browser's audio output (audio.js): a sine at the carrier
  // frequency whose level follows U / U_max.
  const audio = window.haptexAudio.create(() => state.carrierHz, (text) => say(text, true));

  // ------------------------------------------------------------ live output

  /**
   * The server's live output (haptex serve --live, docs/live.md): while
   * live, the design the strip plays is sent over a WebSocket, and every
   * position the strip takes (pointer, finger or keyboard) is sent as a
   * `t_s,x_mm` line stamped with the event's own time; the server plays it
   * on its audio device and answers the figures (position, voltage played,
   * latency) every 100 ms. Lifting the finger sends `lift`.
   */
  const live = {
    info: null,
    socket: null,
    sent: null,
    /** Shows the panel when the server has a live output. */
    async setup() {
      let answer;
      try {
        answer = await (await api('/api/live')).json();
      } catch (error) {
        return; // an older server: no live mode
      }
      if (!answer.available) return;
      this.info = answer.output;
      const o = answer.output;
      $('live-output').textContent = `${o.device}, ${o.sample_rate_hz} Hz, U_max ${o.u_max_v} V, ` +
        `${fmt(o.volts_per_full_scale)} V per full scale` + (o.a_max_um ? `, ultrasonic a_max ${o.a_max_um} µm` : '');
      $('live-box').hidden = false;
      $('live-toggle').addEventListener('click', () => (this.socket ? this.stop() : this.start()));
    },
    start() {
      const scheme = location.protocol === 'https:' ? 'wss' : 'ws';
      const socket = new WebSocket(`${scheme}://${location.host}/api/live/ws`);
      this.socket = socket;
      this.sent = null;
      this.show('connecting…');
      $('live-toggle').textContent = 'Stop live';
      $('live-toggle').setAttribute('aria-pressed', 'true');
      socket.addEventListener('open', () => this.follow());
      socket.addEventListener('message', (e) => this.receive(e.data));
      socket.addEventListener('close', () => { if (this.socket === socket) this.off(); });
    },
    stop() {
      if (!this.socket) return;
      if (this.socket.readyState === WebSocket.OPEN) this.socket.send(JSON.stringify({ stop: true }));
      const socket = this.socket;
      setTimeout(() => socket.close(), 300);
      this.show('stopped: faded to 0 V');
      this.off();
    },
    /** The panel as without a connection (the socket stopped or lost). */
    off() {
      this.socket = null;
      this.sent = null;
      $('live-toggle').textContent = 'Go live';
      $('live-toggle').setAttribute('aria-pressed', 'false');
      $('live-box').dataset.live = 'off';
    },
    /** Sends the design the strip plays, when it is not the one sent last. */
    follow() {
      if (!this.socket || this.socket.readyState !== WebSocket.OPEN) return;
      const v = state.voltage ? played() : null;
      if (v === this.sent) return;
      this.sent = v;
      if (!v) {
        this.socket.send(JSON.stringify({ stop: true }));
        return;
      }
      const design = { x_mm: v.x_mm };
      if (v.voltage_v) design.voltage_v = v.voltage_v;
      if (v.amplitude_um) design.amplitude_um = v.amplitude_um;
      this.socket.send(JSON.stringify({ design }));
      this.show('opening the output…');
    },
    /** A position of the strip, at the event's time `timeStamp` (ms, the page's clock). */
    touch(x, timeStamp) {
      if (!strip.contact || !this.socket || this.socket.readyState !== WebSocket.OPEN || !this.sent) return;
      this.socket.send(`${(timeStamp / 1000).toFixed(6)},${x}`);
    },
    lift() {
      if (this.socket && this.socket.readyState === WebSocket.OPEN && this.sent) this.socket.send('lift');
    },
    receive(text) {
      let m;
      try { m = JSON.parse(text); } catch (error) { return; }
      const box = $('live-box');
      if (m.error) {
        this.show(`refused: ${m.error}`, true);
        box.dataset.error = m.error;
        return;
      }
      if (m.opened) {
        box.dataset.live = 'on';
        delete box.dataset.error;
        this.show(`live on ${m.opened.output.device}: touch the strip (peak at most ${m.opened.peak_bound_v.toFixed(1)} V)`);
      } else if (m.status) {
        const f = m.status;
        box.dataset.xMm = String(f.x_mm);
        box.dataset.outputV = String(f.output_v);
        box.dataset.events = String(f.events);
        box.dataset.touchToOutputMs = String(f.touch_to_output_max_ms);
        const latency = f.events ? `touch → sample ${f.render_latency_max_ms.toFixed(2)} ms (max), device buffer ` +
          `${f.output_latency_max_ms.toFixed(2)} ms, end to end ≤ ${f.touch_to_output_max_ms.toFixed(2)} ms` : 'no touch yet';
        this.show(`live: x = ${f.x_mm.toFixed(3)} mm, U = ${f.output_v.toFixed(1)} V RMS played` +
          (f.amplitude_um ? `, a = ${f.amplitude_um.toFixed(3)} µm` : '') + ` · ${latency} · ${f.events} touches` +
          (f.underruns ? ` · ${f.underruns} underruns` : ''));
      } else if (m.closed !== undefined) {
        box.dataset.live = 'off';
      }
    },
    show(text, isError = false) {
      const readout = $('live-readout');
      readout.textContent = text;
      readout.classList.toggle('error', isError);
    },
  };

  // ----------------------------------------------------------- downloads

  /** A file name of letters, digits, '.', '_' and '-' only (what a recipe accepts). */
  function safeName(name) {
    return name.replace(/[^A-Za-z0-9._-]/g, '_').replace(/^\.+/, '_').slice(0, 200) || 'profile.csv';
  }

  /** The downloads a recipe replays: each the API request that answers it. */
  const RECIPE_KINDS = ['profile-csv', 'voltage-csv', 'voltage-json', 'stroke-wav', 'stroke-sidecar'];

  /**
   * The request behind a download: {file, method, path, body}. The page
   * downloads exactly the server's answer to it, and a recipe lists these
   * requests, so that `haptex recipe run` gives the same bytes.
   */
  function downloadSpec(kind) {
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

  /**
   * The recipe of the design shown (docs/web.md, "Recipes"): the requests
   * of its downloads, the source's provenance, the haptex version and the
   * SHA-256 of the data served. `kinds` chooses the downloads.
   */
  function recipe(kinds = RECIPE_KINDS) {
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

  /** base64url of a text's UTF-8 bytes, and back (the recipe in a link). */
  function toBase64Url(text) {
    let binary = '';
    new TextEncoder().encode(text).forEach((b) => { binary += String.fromCharCode(b); });
    return btoa(binary).replace(/\+/g, '-').replace(/\//g, '_').replace(/=+$/, '');
  }

  function fromBase64Url(text) {
    const binary = atob(text.replace(/-/g, '+').replace(/_/g, '/'));
    return new TextDecoder().decode(Uint8Array.from(binary, (c) => c.charCodeAt(0)));
  }

  /** A link that opens this design (its voltage request) in the page. */
  function shareLink() {
    const link = `${location.origin}${location.pathname}#recipe=${toBase64Url(JSON.stringify(recipe(['voltage-csv'])))}`;
    const a = $('share-link');
    a.href = link;
    a.hidden = false;
    a.textContent = 'link to this design';
    return link;
  }

  async function download(kind) {
    if (!state.profile || !state.voltage) throw new ApiError('nothing to download yet', null, 0);
    let file;
    if (kind === 'compensated-csv') {
      const c = currentCheck();
      if (!c || c.mode !== 'compensate') throw new ApiError('compensate first', null, 0);
      file = { blob: new Blob([c.result.voltage_csv], { type: 'text/csv' }), name: 'voltage-compensated.csv' };
    } else if (kind === 'recipe') {
      const text = `${JSON.stringify(recipe(), null, 1)}\n`;
      file = { blob: new Blob([text], { type: 'application/json' }), name: 'haptex-recipe.json' };
      shareLink();
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
    say(`Downloaded ${file.name} (${file.blob.size} bytes).`);
  }

  /**
   * Opens a recipe (an uploaded file or a link's #recipe=): its voltage
   * request's profile becomes the page's profile (the *your profile*
   * source, labelled with the recipe's provenance) and its method,
   * mapping, device and display set the controls, so the page asks the
   * server the recipe's own voltage request.
   */
  async function openRecipe(r) {
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
    const what = source.kind === 'template'
      ? `${source.surface} r_w ${fmt(source.width_mm)} mm, r_h ${fmt(source.height_mm)} mm, ${fmt(source.velocity_mm_s)} mm/s`
      : source.kind === 'library' ? `${source.material}, stroke seed ${source.seed}`
        : source.kind === 'upload' ? source.file : 'a profile';
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
    loadRequest += 1; // a profile still loading is dropped
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
    readDevice();
    setDisplay(body.display || 'electrovibration');
    if (body.strategy) { state.strategy = body.strategy; $('strategy').value = body.strategy; }
    $('weight').value = body.weight === undefined ? '' : String(body.weight);
    $('a-max').value = body.a_max_um === undefined ? '' : String(body.a_max_um);
    state.calibration = body.ultrasonic_calibration
      ? { name: 'the recipe\'s calibration', text: body.ultrasonic_calibration,
        rows: body.ultrasonic_calibration.split(/\r?\n/).filter((l) => l.trim() && !l.trim().startsWith('#')).length - 1 }
      : null;
    showDisplayControls();
    await updateVoltage();
    say(`Opened the recipe: ${profile.label}.`);
  }

  // --------------------------------------------------------------- start

  function fmt(v) {
    if (v === null || v === undefined) return '–';
    const a = Math.abs(v);
    return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(3) : String(Number(v.toPrecision(4)));
  }

  function pct(fraction) {
    return `${(100 * fraction).toFixed(2)}%`;
  }

  // --------------------------------------------------------------- model

  /** A table of [label, value] rows (values as text). */
  function table(caption, head, rows) {
    const t = document.createElement('table');
    t.className = 'model-table';
    const c = document.createElement('caption');
    c.textContent = caption;
    t.append(c);
    [head, ...rows].forEach((row, i) => {
      const tr = document.createElement('tr');
      row.forEach((cell) => {
        const td = document.createElement(i === 0 ? 'th' : 'td');
        td.textContent = typeof cell === 'number' ? fmt(cell) : String(cell);
        tr.append(td);
      });
      t.append(tr);
    });
    return t;
  }

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

  async function loadModel() {
    const model = await (await api('/api/model')).json();
    buildModel(model, state.templates);
  }

  async function start() {
    try {
      state.config = await (await api('/api/config')).json();
      buildControls(state.config);
      setupStrip();
      live.setup();
      let resizeTimer = null;
      window.addEventListener('resize', () => { clearTimeout(resizeTimer); resizeTimer = setTimeout(resizePlots, 100); });
      const sources = state.config.sources.filter((s) => SOURCES[s.id]);
      if (sources.some((s) => s.id === 'template')) {
        buildTemplateControls(await (await api('/api/templates')).json());
      }
      if (sources.some((s) => s.id === 'library')) {
        const list = await (await api('/api/materials')).json();
        fillMaterials(list.materials);
        $('recordings-box').hidden = !state.config.library_writable;
      }
      loadModel().catch((error) => { $('model-body').textContent = `The model could not be loaded: ${error.message}`; });
      selectSource(sources[0].id);
      if (!state.profile && state.source === 'upload') document.body.dataset.state = 'ready';
      if (location.hash.startsWith('#recipe=')) {
        // A link's recipe that cannot be opened is reported once the
        // first source is drawn (its message would hide it); the page works on.
        let opened = null;
        try {
          opened = JSON.parse(fromBase64Url(location.hash.slice('#recipe='.length)));
        } catch (error) {
          state.pendingError = new ApiError(`the link's recipe cannot be read (${error.message})`, 'recipe', 0);
        }
        if (opened) await openRecipe(opened).catch((error) => { state.pendingError = error; });
      }
    } catch (error) {
      document.body.dataset.state = 'error';
      showError(error);
    }
  }

  // For the page's other modules (display-calibration.js).
  Object.assign(window.haptex, { api, postJson, ApiError, fmt, scheduleVoltage, voltageBody });

  document.addEventListener('DOMContentLoaded', start);
}());
