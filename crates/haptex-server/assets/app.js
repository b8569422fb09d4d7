// haptex GUI, the main page's entry module: pick a friction profile (a
// surface template predicted from the FE database, a texture-library
// material or your own CSV file), set the device and finger constants,
// see the surface, friction and voltage profiles (paper eqs. 8 and 9,
// computed by the server; optionally relative to the flat-surface
// friction, as the paper's Fig. 2 does), check and compensate the voltage
// on the finger model, feel it along a strip, download CSV / JSON / WAV,
// for the combined, ultrasonic or electrovibration display.
//
// Every number comes from the JSON API (docs/web.md); the modules under
// js/ (native ES modules, no bundler: docs/web.md, "The front-end") only
// gather inputs, draw and offer downloads. js/main.js starts the page,
// js/display-calibration.js the "Your display" panel, in that order.

import './js/token.js';
import { start } from './js/main.js';
import { setup as setupYourDisplay } from './js/display-calibration.js';

document.addEventListener('DOMContentLoaded', start);
document.addEventListener('DOMContentLoaded', setupYourDisplay);
