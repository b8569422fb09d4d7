// The event hub (js/hub.js): calls by name, in order, and a name nobody handles is an error.
import test from 'node:test';
import assert from 'node:assert/strict';
import { emit, on } from '../hub.js';

test('emit: every handler of the name, in the order registered, with the arguments', () => {
  const calls = [];
  on('test-order', (a, b) => calls.push(['first', a, b]));
  on('test-order', (a) => calls.push(['second', a]));
  on('test-other', () => calls.push(['other']));
  emit('test-order', 1, 'two');
  assert.deepEqual(calls, [['first', 1, 'two'], ['second', 1]]);
});

test('emit: runs the handlers at once (synchronously), as a direct call would', () => {
  let done = false;
  on('test-sync', () => { done = true; });
  emit('test-sync');
  assert.equal(done, true);
});

test('emit: a name nobody registered throws, naming it', () => {
  assert.throws(() => emit('test-nobody'), /nothing handles test-nobody/);
});
