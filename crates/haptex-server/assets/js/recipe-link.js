// A recipe in a link and in words, pure: base64url of its JSON's UTF-8
// bytes after `#recipe=` in the page's address, read back, and what its
// source was (the label of a recipe opened). No DOM: unit-tested by node
// (js/test/recipe-link.test.mjs).

import { fmt } from './format.js';

/** What starts a page address's hash that carries a recipe. */
export const RECIPE_HASH = '#recipe=';

/** base64url of a text's UTF-8 bytes (no padding), and back (the recipe in a link). */
export function toBase64Url(text) {
  let binary = '';
  new TextEncoder().encode(text).forEach((b) => { binary += String.fromCharCode(b); });
  return btoa(binary).replace(/\+/g, '-').replace(/\//g, '_').replace(/=+$/, '');
}

/** The text of base64url bytes (invalid UTF-8 becomes U+FFFD); throws when it is not base64. */
export function fromBase64Url(text) {
  const binary = atob(text.replace(/-/g, '+').replace(/_/g, '/'));
  return new TextDecoder().decode(Uint8Array.from(binary, (c) => c.charCodeAt(0)));
}

/** The hash of a link to recipe `r` (an object): `#recipe=` and its JSON in base64url. */
export function recipeHash(r) {
  return `${RECIPE_HASH}${toBase64Url(JSON.stringify(r))}`;
}

/** Whether an address's hash carries a recipe. */
export function isRecipeHash(hash) {
  return hash.startsWith(RECIPE_HASH);
}

/** The recipe a `#recipe=` hash carries; throws when it is not base64url of JSON. */
export function recipeFromHash(hash) {
  return JSON.parse(fromBase64Url(hash.slice(RECIPE_HASH.length)));
}

/** What a recipe's source was, in the page's words (its `source`, the provenance of a profile). */
export function recipeSourceText(source) {
  return source.kind === 'template'
    ? `${source.surface} r_w ${fmt(source.width_mm)} mm, r_h ${fmt(source.height_mm)} mm, ${fmt(source.velocity_mm_s)} mm/s`
    : source.kind === 'library' ? `${source.material}, stroke seed ${source.seed}`
      : source.kind === 'upload' ? source.file : 'a profile';
}
