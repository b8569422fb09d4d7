// The pages' colours: one per pinned design (apart from the current
// design's blue, red, purple, grey, orange and green), the categorical
// palette of the "Your display" figures (one per carrier), and the map
// page's heat scale. Pure: unit-tested by node (js/test/colours.test.mjs).

/** One colour per pin, apart from the current design's (blue, red, purple, grey, orange, green). */
export const PIN_COLORS = ['#d81b60', '#00897b', '#8d6e63', '#f9a825', '#3949ab', '#7cb342'];

/** The categorical palette of the "Your display" figures (matplotlib's tab10, its first eight). */
export const COLOURS = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f'];

/** The heat scale's stops, dark blue to yellow (perceptually ordered), as [r, g, b]. */
export const HEAT_STOPS = [[13, 8, 135], [84, 2, 163], [139, 10, 165], [185, 50, 137], [219, 92, 104], [244, 136, 73],
  [254, 188, 43], [240, 249, 33]];

/** The heat scale's colour of t in [0, 1] (clamped), as [r, g, b] integers. */
export function heatColour(t) {
  const s = Math.min(Math.max(t, 0), 1) * (HEAT_STOPS.length - 1);
  const k = Math.min(Math.floor(s), HEAT_STOPS.length - 2);
  const f = s - k;
  return HEAT_STOPS[k].map((c, m) => Math.round(c + f * (HEAT_STOPS[k + 1][m] - c)));
}
