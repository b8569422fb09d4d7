// The POST /api/voltage request of the design shown: its profile, method
// and mapping, the device (or the device file of "Your display") and the
// display selected. The check, the downloads, the recipes and "Your
// display" ask the server with it.

import { isElectrovibration } from './displays.js';
import { numberIn } from './fields.js';
import { state } from './state.js';

/**
 * The POST /api/voltage body for the profile shown (by `method`, default
 * the one chosen), for the display selected unless `withDisplay` is false.
 */
export function voltageBody(method = state.method, withDisplay = true) {
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
    const flat = numberIn('flat-mu');
    if (flat !== null) body.flat_mu = flat;
  }
  if (withDisplay && !isElectrovibration()) {
    delete body.method; // physical, the only method of these displays
    body.display = state.display;
    if (state.display === 'combined') {
      body.strategy = state.strategy;
      const w = numberIn('weight');
      if (state.strategy === 'weighted' && w !== null) body.weight = w;
    }
    const a = numberIn('a-max');
    if (a !== null) body.a_max_um = a;
    if (state.calibration) body.ultrasonic_calibration = state.calibration.text;
  }
  return body;
}
