// A recipe in a link, pure: base64url of its JSON's UTF-8 bytes after
// `#recipe=` in the page's address. No DOM: unit-tested by node.

/** base64url of a text's UTF-8 bytes, and back (the recipe in a link). */
export function toBase64Url(text) {
  let binary = '';
  new TextEncoder().encode(text).forEach((b) => { binary += String.fromCharCode(b); });
  return btoa(binary).replace(/\+/g, '-').replace(/\//g, '_').replace(/=+$/, '');
}

export function fromBase64Url(text) {
  const binary = atob(text.replace(/-/g, '+').replace(/_/g, '/'));
  return new TextDecoder().decode(Uint8Array.from(binary, (c) => c.charCodeAt(0)));
}
