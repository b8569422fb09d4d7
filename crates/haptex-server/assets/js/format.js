// Number and text formatting shared by the pages: numbers in 4
// significant digits (the main page's fmt, the map page's fmtPlain),
// percentages, safe file names, and the model section's tables. Pure but
// for table(), which builds (does not insert) an element.

/** A number in 4 significant digits (exponential below 1e-3 and from 1e5), '–' for none. */
export function fmt(v) {
  if (v === null || v === undefined) return '–';
  const a = Math.abs(v);
  return a !== 0 && (a < 1e-3 || a >= 1e5) ? v.toExponential(3) : String(Number(v.toPrecision(4)));
}

/**
 * A number in 4 significant digits, never exponential; a non-finite value
 * (NaN, an infinity, null, undefined) as JavaScript writes it. The map
 * page's format.
 */
export function fmtPlain(v) {
  return Number.isFinite(v) ? String(Number(v.toPrecision(4))) : String(v);
}

/** A fraction as a percentage with two decimals. */
export function pct(fraction) {
  return `${(100 * fraction).toFixed(2)}%`;
}

/** A file name of letters, digits, '.', '_' and '-' only (what a recipe accepts). */
export function safeName(name) {
  return name.replace(/[^A-Za-z0-9._-]/g, '_').replace(/^\.+/, '_').slice(0, 200) || 'profile.csv';
}

/** A table of [label, value] rows (values as text). */
export function table(caption, head, rows) {
  const t = document.createElement('table');
  t.className = 'model-table';
  const c = document.createElement('caption');
  c.textContent = caption;
  t.append(c);
  [head, ...rows].forEach((row, i) => {
    const tr = document.createElement('tr');
    row.forEach((cell) => {
      const td = document.createElement(i === 0 ? 'th' : 'td');
      td.textContent = typeof cell === 'number' ? fmt(cell) : String(cell);
      tr.append(td);
    });
    t.append(tr);
  });
  return t;
}
