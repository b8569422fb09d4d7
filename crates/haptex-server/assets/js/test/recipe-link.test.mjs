// The recipe in a link (js/recipe-link.js): base64url, the #recipe= hash, the source in words.
import test from 'node:test';
import assert from 'node:assert/strict';
import {
  fromBase64Url, isRecipeHash, recipeFromHash, recipeHash, recipeSourceText, toBase64Url,
} from '../recipe-link.js';

test('toBase64Url: the URL alphabet, no padding', () => {
  assert.equal(toBase64Url(''), '');
  assert.equal(toBase64Url('f'), 'Zg');
  assert.equal(toBase64Url('foobar'), 'Zm9vYmFy');
  // Standard base64 would write "Pz4/" and "w78=".
  assert.equal(toBase64Url('?>?'), 'Pz4_');
  assert.equal(toBase64Url('ÿ'), 'w78');
  assert.equal(toBase64Url('>>>'), 'Pj4-');
});

test('fromBase64Url: back to the text, UTF-8 included', () => {
  for (const text of ['', 'a', 'µ_HD = 1', 'U → 100 V', '{"x_mm":[0,0.1]}', '😀 emoji', '?>?']) {
    assert.equal(fromBase64Url(toBase64Url(text)), text);
  }
  assert.equal(fromBase64Url('w78'), 'ÿ');
});

test('fromBase64Url: invalid UTF-8 becomes U+FFFD; what is not base64 throws', () => {
  assert.equal(fromBase64Url('_w'), '\ufffd');
  assert.throws(() => fromBase64Url('a'));
  assert.throws(() => fromBase64Url('ab$c'));
});

test('recipeHash and recipeFromHash: a recipe survives the link', () => {
  const r = {
    format: 'haptex-recipe/1', source: { kind: 'upload', file: 'ä b.csv' },
    downloads: [{ method: 'POST', path: '/api/voltage?format=csv', body: { profile: { x_mm: [0, 1e-7], mu: [0.5, -0] } } }],
  };
  const hash = recipeHash(r);
  assert.ok(hash.startsWith('#recipe='));
  assert.ok(/^#recipe=[A-Za-z0-9_-]+$/.test(hash));
  assert.ok(isRecipeHash(hash));
  assert.deepEqual(recipeFromHash(hash), JSON.parse(JSON.stringify(r)));
});

test('isRecipeHash and recipeFromHash: other hashes and broken recipes', () => {
  assert.equal(isRecipeHash(''), false);
  assert.equal(isRecipeHash('#recipes'), false);
  assert.equal(isRecipeHash('#Recipe=abc'), false);
  assert.throws(() => recipeFromHash('#recipe=%%%'));
  assert.throws(() => recipeFromHash(`#recipe=${toBase64Url('{"format":')}`), SyntaxError);
});

test('recipeSourceText: each source kind in words', () => {
  assert.equal(recipeSourceText({ kind: 'template', surface: 'bump', width_mm: 1.3, height_mm: 0.27, velocity_mm_s: 20 }),
    'bump r_w 1.3 mm, r_h 0.27 mm, 20 mm/s');
  assert.equal(recipeSourceText({ kind: 'library', material: 'velvet', seed: '18446744073709551615' }),
    'velvet, stroke seed 18446744073709551615');
  assert.equal(recipeSourceText({ kind: 'upload', file: 'a.csv' }), 'a.csv');
  assert.equal(recipeSourceText({}), 'a profile');
  assert.equal(recipeSourceText({ kind: 'template', surface: 'ridge' }), 'ridge r_w – mm, r_h – mm, – mm/s');
});
