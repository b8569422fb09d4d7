// Interpolation, pure: linear in a profile (the feel strip reads U and a
// at a position) and bilinear in a map (the map page reads mu and U at
// the pointer, as the core's MapGrid::sample does), the edges held. No
// DOM: unit-tested by node (js/test/interpolate.test.mjs).

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

/** The cell index and fraction along one axis of n points from v0 in steps of d, ends held (the core's `axis`). */
export function gridAxis(v, v0, d, n) {
  const s = (v - v0) / d;
  if (Number.isNaN(s) || s <= 0) return [0, 0];
  if (s >= n - 1) return [n - 1, 0];
  const i = Math.floor(s);
  return [i, s - i];
}

/**
 * `values` (row by row, nx per row) of the grid {x0_mm, y0_mm, dx_mm,
 * dy_mm, nx, ny} at (x, y), bilinear, the edge held: MapGrid::sample's
 * arithmetic.
 */
export function bilinear(g, values, x, y) {
  const [i, tx] = gridAxis(x, g.x0_mm, g.dx_mm, g.nx);
  const [j, ty] = gridAxis(y, g.y0_mm, g.dy_mm, g.ny);
  const row = (r) => {
    const a = values[r * g.nx + i];
    return tx === 0 ? a : a + tx * (values[r * g.nx + i + 1] - a);
  };
  const r0 = row(j);
  return ty === 0 ? r0 : r0 + ty * (row(j + 1) - r0);
}
