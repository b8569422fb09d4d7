// The main page's state: the inputs gathered, the server's last answers
// and the plots drawn. `window.haptex = {state, plots}` is the test hook
// the browser tests read (crates/haptex-server/tests/browser*.rs): every
// property name here is part of it.

export const state = {
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
  // The friction display designed for (GET /api/config, displays). Each
  // source opens on its own until the user chooses one (displayChosen):
  // the templates on the paper's Fig. 2 view (electrovibration, relative,
  // eq. 8 beside eq. 9), a material or an upload on the display whose band
  // holds it (sources.js, defaultDisplay; docs/web.md, "Defaults").
  display: 'electrovibration',
  displayChosen: false,
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
export const plots = { height: null, friction: null, voltage: null, amplitude: null, check: null, checkVoltage: null,
  recordings: [] }; // recordings: the processing reports' plots of the last upload
window.haptex = { state, plots };
