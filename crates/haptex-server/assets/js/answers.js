// Pure readings of the API's answers: the equation of a summary, the
// other method, U_max of a voltage answer, the first trial of a check and
// a check's refusal in the page's words. No DOM: unit-tested by node
// (js/test/answers.test.mjs).

/** "eq. (8)" or "eq. (9)": the method of a summary. */
export function equation(summary) {
  return summary.method === 'physical' ? 'eq. (8)' : 'eq. (9)';
}

/** The other voltage method: eq. (8) beside eq. (9) and back. */
export const otherMethod = (method) => (method === 'physical' ? 'normalized' : 'physical');

/** U_max of an answer: the electrovibration answer's, or the combined display's (null without voltage). */
export function uMaxOf(v) {
  const s = v.summary;
  if (s.u_max_v !== undefined) return s.u_max_v;
  return s.electrovibration ? s.electrovibration.u_max_v : null;
}

/**
 * The first trial of a check: eq. (8)'s voltage (`eq8`), or the combined
 * display's design (`design`, with its a(x)), with the page's name for it.
 */
export function checkTrial(r) {
  return r.eq8 ? { ...r.eq8, name: 'eq. (8)' } : { ...r.design, name: 'combined' };
}

/**
 * A refusal of the check or the compensation as the check box says it:
 * a busy server (503: its heavy slots are taken, before any FE run) or
 * the part of the page at fault (the friction profile, the load, max
 * runs), with the server's message.
 */
export function checkRefusal(error) {
  if (error.status === 503) return `The server is busy: ${error.message}`;
  const f = error.field || '';
  const part = f.startsWith('profile.') ? 'Friction profile'
    : f === 'load_n_per_mm' || f === 'load_n' ? 'Load'
      : f === 'direction_deg' ? 'Direction'
        : f === 'model' || f === 'mesh' ? 'Finger'
          : f === 'max_runs' ? 'Max runs'
            : f.startsWith('device.') ? 'Device' : null;
  return part ? `${part}: ${error.message}` : error.message;
}
