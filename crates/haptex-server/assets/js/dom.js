// The pages' DOM shorthand: $(id) is document.getElementById(id).

export const $ = (id) => document.getElementById(id);
