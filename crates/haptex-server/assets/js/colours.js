// The pages' colours: one per pinned design (apart from the current
// design's blue, red, purple, grey, orange and green), and the categorical
// palette of the "Your display" figures (one per carrier).

/** One colour per pin, apart from the current design's (blue, red, purple, grey, orange, green). */
export const PIN_COLORS = ['#d81b60', '#00897b', '#8d6e63', '#f9a825', '#3949ab', '#7cb342'];

/** The categorical palette of the "Your display" figures (matplotlib's tab10, its first eight). */
export const COLOURS = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f'];
