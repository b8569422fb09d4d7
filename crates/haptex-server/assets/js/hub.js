// A small event hub for the calls that would close an import cycle: a
// module that cannot import another (because that one imports it) asks
// for the work by name (emit) and the module doing it has registered it
// (on). Handlers run at once, in the order registered, as direct calls
// would; a name nobody registered is a programming error, thrown.

const handlers = new Map();

/** Registers `handler` for `name`. */
export function on(name, handler) {
  if (!handlers.has(name)) handlers.set(name, []);
  handlers.get(name).push(handler);
}

/** Calls the handlers of `name` with `args`, in the order registered. */
export function emit(name, ...args) {
  const list = handlers.get(name);
  if (!list || !list.length) throw new Error(`hub: nothing handles ${name}`);
  list.forEach((handler) => handler(...args));
}
