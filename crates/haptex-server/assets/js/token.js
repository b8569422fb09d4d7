// The access token out of the address bar (docs/web.md, "Safety"): a
// server that needs one is opened once at the address it printed,
// `/?token=...`; the server answers the page with its session cookie, and
// this module, imported first by the pages' entry modules, replaces the
// address with the same one without the token, so that it is not kept in
// the history, bookmarked or copied along with the page's address.

const url = new URL(window.location.href);
if (url.searchParams.has('token')) {
  url.searchParams.delete('token');
  window.history.replaceState(window.history.state, '', url.pathname + url.search + url.hash);
}
