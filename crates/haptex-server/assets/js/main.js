// The main page's start: GET /api/config, the controls, the feel strip,
// the live output, the template and library controls, the model section,
// the first source's design, and the recipe of a link's #recipe=.

import { $ } from './dom.js';
import { ApiError, api, postJson } from './api.js';
import { buildControls } from './controls.js';
import { resizePlots } from './figures.js';
import { fmt } from './format.js';
import { live } from './live.js';
import { showError } from './messages.js';
import { loadModel } from './model.js';
import { isRecipeHash, recipeFromHash } from './recipe-link.js';
import { linkError, openRecipe } from './recipes.js';
import { voltageBody } from './requests.js';
import { SOURCES, fillMaterials, loadSource, selectSource } from './sources.js';
import { state } from './state.js';
import { setupStrip } from './strip.js';
import { buildTemplateControls } from './template.js';
import { scheduleVoltage } from './voltage.js';

/** Starts the page: the configuration, the controls, the first source's design, a link's recipe. */
export async function start() {
  try {
    state.config = await (await api('/api/config')).json();
    buildControls(state.config);
    setupStrip();
    live.setup();
    let resizeTimer = null;
    window.addEventListener('resize', () => { clearTimeout(resizeTimer); resizeTimer = setTimeout(resizePlots, 100); });
    const sources = state.config.sources.filter((s) => SOURCES[s.id]);
    if (sources.some((s) => s.id === 'template')) {
      buildTemplateControls(await (await api('/api/templates')).json(), loadSource);
    }
    if (sources.some((s) => s.id === 'library')) {
      const list = await (await api('/api/materials')).json();
      fillMaterials(list.materials);
      $('recordings-box').hidden = !state.config.library_writable;
    }
    loadModel().catch((error) => { $('model-body').textContent = `The model could not be loaded: ${error.message}`; });
    selectSource(sources[0].id);
    if (!state.profile && state.source === 'upload') document.body.dataset.state = 'ready';
    if (isRecipeHash(location.hash)) {
      // A link's recipe that cannot be opened is reported once the
      // first source is drawn (its message would hide it); the page works on.
      let opened = null;
      try {
        opened = recipeFromHash(location.hash);
      } catch (error) {
        // A link belongs to no field of the page: said in the header.
        state.pendingError = new ApiError(`The link's recipe cannot be read (${error.message})`, null, 0);
      }
      if (opened) await openRecipe(opened).catch((error) => { state.pendingError = linkError(error); });
    }
  } catch (error) {
    document.body.dataset.state = 'error';
    showError(error);
  }
}


// For the browser tests and the console, beside window.haptex's state and plots.
Object.assign(window.haptex, { api, postJson, ApiError, fmt, scheduleVoltage, voltageBody });
