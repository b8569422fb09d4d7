// Interpolation, pure: linear in a profile (the feel strip reads U and a
// at a position) with the ends held. No DOM: unit-tested by node.

/** ys at x by linear interpolation over xs (held at the ends). */
export function interpolate(xs, us, x) {
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
