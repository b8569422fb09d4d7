// The map page's fields (js/map-fields.js): what is refused, what is unusual, and the server's words made the page's.
import test from 'node:test';
import assert from 'node:assert/strict';
import { FIELDS, checkExtent, checkField, controlOf, pageError, readNumber, readable, withConfig } from '../map-fields.js';

const SNAKE = /\b[a-z][a-z0-9]*_[a-z0-9_]+\b/;

test('readNumber: blank, letters and non-decimal text are told apart from numbers', () => {
  assert.deepEqual(readNumber(''), { blank: true });
  assert.deepEqual(readNumber('  '), { blank: true });
  assert.deepEqual(readNumber(' 0.25 '), { value: 0.25 });
  assert.deepEqual(readNumber('-5'), { value: -5 });
  assert.deepEqual(readNumber('1e9'), { value: 1e9 });
  assert.deepEqual(readNumber('.5'), { value: 0.5 });
  for (const bad of ['abc', '0.4x', '1,5', '0x10', 'Infinity', 'NaN', '1e999', '--1']) {
    assert.deepEqual(readNumber(bad), { bad: true }, bad);
  }
});

test('checkField: blank and letters are refused with the label, never as 0', () => {
  const blank = checkField(FIELDS, 'mu_black', '');
  assert.equal(blank.level, 'error');
  assert.match(blank.text, /^μ of black must be given/);
  const letters = checkField(FIELDS, 'mu_black', 'abc');
  assert.equal(letters.level, 'error');
  assert.match(letters.text, /^μ of black must be a number/);
  assert.match(letters.text, /abc/);
});

test('checkField: the accepted ranges refuse, the typical ranges warn', () => {
  const pixel = checkField(FIELDS, 'pixel_mm', '-5');
  assert.deepEqual([pixel.level, pixel.text], ['error', 'Pixel size must be more than 0 mm, got -5.']);
  assert.equal(checkField(FIELDS, 'pixel_mm', '0').level, 'error');
  assert.equal(checkField(FIELDS, 'pixel_mm', '0.1').level, 'ok');
  assert.equal(checkField(FIELDS, 'pixel_mm', '50').level, 'warning');
  assert.equal(checkField(FIELDS, 'gamma', '0.01').level, 'error');
  assert.equal(checkField(FIELDS, 'gamma', '10').level, 'warning');
  assert.equal(checkField(FIELDS, 'mu_black', '1e9').level, 'error');
  assert.equal(checkField(FIELDS, 'x0_mm', '1e9').level, 'error');
  const mu = checkField(FIELDS, 'mu_hd', '-1');
  assert.equal(mu.level, 'error');
  assert.match(mu.text, /^μ_HD must be from 0\.001 to 10, got -1/);
  assert.equal(checkField(FIELDS, 'mu_hd', '2').level, 'warning');
  assert.equal(checkField(FIELDS, 'u_max_v', '0').level, 'error');
  assert.equal(checkField(FIELDS, 'u_max_v', '5000').level, 'ok');
});

test('checkField: eq. (8) warns of frictions below mu_HD and above the band; white must differ from black', () => {
  const context = { method: 'physical', values: { mu_hd: 1, mu_black: 0.4 }, band: [1, 1.2] };
  const below = checkField(FIELDS, 'mu_black', '0.4', context);
  assert.equal(below.level, 'warning');
  assert.match(below.text, /below μ_HD \(1\).*not rendered/);
  assert.equal(checkField(FIELDS, 'mu_white', '1.5', context).level, 'warning');
  assert.equal(checkField(FIELDS, 'mu_white', '1.2', context).level, 'ok');
  assert.equal(checkField(FIELDS, 'mu_black', '0.4', { method: 'normalized', values: { mu_hd: 1 } }).level, 'ok');
  const same = checkField(FIELDS, 'mu_white', '0.4', context);
  assert.equal(same.level, 'error');
  assert.match(same.text, /must differ from μ of black/);
});

test('withConfig: the device ranges are the server\'s', () => {
  const fields = withConfig(FIELDS, {
    device_params: [{ name: 'mu_hd', min: 0.01, max: 5 }],
    explanations: [{ field: 'mu_hd', typical: { min: 0.3, max: 0.9 } }, { field: 'u_max_v', typical: null }],
  });
  assert.deepEqual(fields.mu_hd.accepted, [0.01, 5]);
  assert.deepEqual(fields.mu_hd.typical, [0.3, 0.9]);
  assert.equal(fields.u_max_v.typical, null);
  assert.deepEqual(fields.pixel_mm, FIELDS.pixel_mm);
});

test('checkExtent: the image\'s far corner within the accepted positions', () => {
  const values = { pixel_mm: 0.1, x0_mm: 0, y0_mm: 0 };
  assert.equal(checkExtent(FIELDS, values, 64, 40), null);
  const far = checkExtent(FIELDS, { pixel_mm: 1e5, x0_mm: 0, y0_mm: 0 }, 64, 40);
  assert.equal(far.id, 'pixel_mm');
  assert.match(far.text, /^Pixel size/);
});

test('controlOf: API field paths to the page\'s controls', () => {
  assert.equal(controlOf(FIELDS, 'image_png_base64'), 'image');
  assert.equal(controlOf(FIELDS, 'pixel_mm'), 'pixel_mm');
  assert.equal(controlOf(FIELDS, 'pixel_mm_y'), 'pixel_mm');
  assert.equal(controlOf(FIELDS, 'device.mu_hd'), 'mu_hd');
  assert.equal(controlOf(FIELDS, 'device.u_max_v'), 'u_max_v');
  assert.equal(controlOf(FIELDS, 'path.t_s[2]'), 'path');
  assert.equal(controlOf(FIELDS, 'device.area_exponent'), null);
  assert.equal(controlOf(FIELDS, 'body'), null);
  assert.equal(controlOf(FIELDS, null), null);
});

test('pageError: each server error beside its control, in the page\'s words', () => {
  const cases = [
    [{ error: 'pixel size must be a positive number of mm, got -5', field: 'pixel_mm' }, 'pixel_mm',
      'Pixel size must be a positive number of mm, got -5'],
    // The old server's words: the image's field and a column name in front.
    [{ error: 'image_png_base64, dx_mm: spacing must be a positive number of mm, got -5', field: 'pixel_mm' },
      'pixel_mm', 'Pixel size: spacing must be a positive number of mm, got -5'],
    [{ error: 'mu_HD must be from 0.001 to 10, got -1', field: 'device.mu_hd' }, 'mu_hd',
      'μ_HD must be from 0.001 to 10, got -1'],
    [{ error: 'u_max_v must be from 0.001 to 10000 V, got 0', field: 'device.u_max_v' }, 'u_max_v',
      'U_max: U_max must be from 0.001 to 10000 V, got 0'],
    [{ error: 'mu of white must differ from mu of black', field: 'mu_white' }, 'mu_white',
      'μ of white must differ from μ of black'],
    [{ error: 'an RGB colour image: the image must be plain grayscale (8 or 16 bit), convert it first',
      field: 'image_png_base64' }, 'image',
    'photo.png: an RGB colour image: the image must be plain grayscale (8 or 16 bit), convert it first'],
    [{ error: 'times must increase', field: 'path.t_s[2]' }, 'path', 'The path drawn: times must increase'],
    [{ error: 'a friction map is mapped with the linear contact-area law', field: 'device.area_exponent' }, null,
      'a friction map is mapped with the linear contact-area law'],
    [{ error: 'body: the request body is empty (field body)', field: 'body' }, null, 'the request is empty'],
  ];
  for (const [error, control, text] of cases) {
    const e = pageError(FIELDS, error, 'photo.png');
    assert.deepEqual(e, { control, text }, JSON.stringify(error));
    assert.ok(!SNAKE.test(e.text), e.text);
  }
});

test('readable: API names and paths become words', () => {
  assert.equal(readable('device.mu_hd: mu_hd must be from 0.001 to 10 (field device.mu_hd)'),
    'μ_HD: μ_HD must be from 0.001 to 10');
  assert.equal(readable('path.x_mm[3] is not a number'), 'sample 4 of the path is not a number');
});
