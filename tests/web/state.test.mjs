// The viewer's URL state and transfer-function strings, without a browser:
//   node --test state.test.mjs
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { applyHash, datasetsFromHash, defaultState, encodeState, parseBox, parseHash } from '../../web/state.js';
import { evaluate, presetPoints, tfFromString, tfToString } from '../../web/transfer-function.js';
import { hashLabelColor, hexToRgb, rgbToHex } from '../../web/colors.js';

const scalar = { id: 0, slug: 'ct', kind: 'scalar', dims: [64, 48, 32], spacing: [1, 1, 2], rank: 8, value_range: [-10, 90] };
const labels = { id: 1, slug: 'atlas', kind: 'labels', dims: [64, 48, 32], spacing: [1, 1, 2], rank: 0 };

function edited() {
  const state = defaultState(scalar, labels);
  Object.assign(state, {
    camera: { az: 123.45, el: -33.3, dist: 187.25, target: [10.5, 20, 31.125] },
    cursor: [1, 47, 31],
    tf: [
      { v: -10, color: '#000000', a: 0 },
      { v: 12.3457, color: '#ff8000', a: 0.0123 },
      { v: 90, color: '#ffffff', a: 0.9 },
    ],
    tfPreset: '',
    rank: 3,
    lod: 2,
    featureScale: 0.02,
    step: 0.25,
    shading: false,
    window: [-1.5, 42.25],
    sliceMap: 'tf',
    source3d: 'labels',
    scalarVisible: false,
    labelOpacity: 0.35,
    labelDefault: '#112233',
    labelColors: { 7: '#ff0000', 12: '#00ff7f' },
    hiddenLabels: [3, 9],
    selectedLabels: [12, 40],
    labelsOnly: true,
    layout: 'xz',
    box: [0, 1, 2, 30, 40, 20],
  });
  return state;
}

test('a state survives the round trip through the URL hash', () => {
  const state = edited();
  const hash = encodeState(state);
  const fields = parseHash(`#${hash}`);
  assert.deepEqual(datasetsFromHash(fields), { scalar: 'ct', labels: 'atlas' });
  assert.match(hash, /v=ct&l=atlas/);
  const restored = applyHash(defaultState(scalar, labels), fields, scalar);
  assert.deepEqual(restored, state);
});

test('the hash stays readable: no escaped commas, colons or semicolons', () => {
  const hash = encodeState(edited());
  assert.doesNotMatch(hash, /%2C|%3A|%3B/i);
  assert.match(hash, /cam=123\.45,-33\.3,187\.25/);
  assert.match(hash, /lc=7:ff0000,12:00ff7f/);
});

test('damaged or out-of-range fields fall back to the defaults', () => {
  const defaults = defaultState(scalar, labels);
  const fields = parseHash('#cam=abc&cur=1,2&tf=1:2&rank=99&lod=0&fs=2&step=9&win=5,1&lc=x:zz,4:12345g&layout=grid&src=nope');
  const state = applyHash(defaultState(scalar, labels), fields, scalar);
  assert.deepEqual(state, defaults);
});

test('the cursor is clamped into the volume', () => {
  const state = applyHash(defaultState(scalar, labels), parseHash('#cur=-5,100,31.6'), scalar);
  assert.deepEqual(state.cursor, [0, 47, 31]);
});

test('"none" datasets and a camera without distance', () => {
  const fields = parseHash('#v=none&l=atlas&cam=10,95');
  assert.deepEqual(datasetsFromHash(fields), { scalar: null, labels: 'atlas' });
  const state = applyHash(defaultState(null, labels), fields, labels);
  assert.deepEqual(state.camera, { az: 10, el: 90, dist: null, target: null });
  assert.equal(state.source3d, 'labels');
});

test('TF strings: the format of docs/viewer.md, and back', () => {
  const points = presetPoints('ct', [0, 200]);
  const text = tfToString(points);
  assert.match(text, /^0:0:0:0:0;50:/);
  assert.equal(text.split(';').length, 6);
  assert.deepEqual(tfFromString(text), points);
  assert.equal(tfFromString('0:0:0:0:0'), null, 'one point is not enough');
  assert.equal(tfFromString('5:0:0:0:0;1:1:1:1:1'), null, 'values must ascend');
  assert.equal(tfFromString('0:0:0:0:0;1:1:x:1:1'), null);
});

test('TF evaluation interpolates colour and opacity', () => {
  const points = [
    { v: 0, color: '#000000', a: 0 },
    { v: 10, color: '#ffffff', a: 1 },
  ];
  assert.deepEqual(evaluate(points, 5), { color: '#808080', a: 0.5 });
  assert.deepEqual(evaluate(points, -1), { color: '#000000', a: 0 });
  assert.deepEqual(evaluate(points, 11), { color: '#ffffff', a: 1 });
});

test('hash colours are deterministic, saturated and distinct for neighbours', () => {
  assert.equal(hashLabelColor(17), hashLabelColor(17));
  const colors = new Set([...Array(50).keys()].map((l) => hashLabelColor(l + 1)));
  assert.ok(colors.size >= 49);
  for (const color of colors) assert.ok(Math.max(...hexToRgb(color)) >= 0.74, `${color} too dark`);
  assert.equal(rgbToHex(hexToRgb('#12abef')), '#12abef');
});

test('a malformed escape or an impossible box in a hand-edited link falls back to the defaults', () => {
  const fields = parseHash('#v=ct&l=atlas&cam=%E0&rank=3&box=0,0,0,99,10,10');
  assert.equal(fields.cam, undefined);
  const state = applyHash(defaultState(scalar, labels), fields, scalar);
  assert.equal(state.rank, 3);
  assert.deepEqual(state.box, defaultState(scalar, labels).box);
  assert.deepEqual(parseBox('1,2,3,4,5,6', scalar.dims), { box: [1, 2, 3, 4, 5, 6] });
  assert.ok(parseBox('4,2,3,1,5,6', scalar.dims).error);
  assert.ok(parseBox('0,0,0,1.5,1,1', scalar.dims).error);
});

test('a TF string whose first and last values coincide is refused (no range to map)', () => {
  assert.equal(tfFromString('5:0:0:0:0;5:1:1:1:1'), null);
});

test('a dataset opens with the preset and percentile window the server read from its data', () => {
  const mri = { ...scalar, defaults: { tf: 'mri', window: [2.5, 61] } };
  const state = defaultState(mri, null);
  assert.equal(state.tfPreset, 'mri');
  assert.deepEqual(state.tf, presetPoints('mri', mri.value_range));
  assert.deepEqual(state.window, [2.5, 61]);
  // An older server (no defaults) or an unknown preset name: the ct preset over the full range.
  const old = defaultState({ ...scalar, defaults: { tf: 'sepia' } }, null);
  assert.equal(old.tfPreset, 'ct');
  assert.deepEqual(old.window, scalar.value_range);
});

test('anatomical letters follow the file\'s world space and axis directions', async () => {
  const { axisLetters, scaleBar } = await import('../../web/orientation.js');
  const identity = [1, 0, 0, 0, 1, 0, 0, 0, 1];
  assert.equal(axisLetters({ geometry: { space: 'unspecified', direction: identity } }), null);
  assert.deepEqual(axisLetters({ geometry: { space: 'RAS', direction: identity } }).map((l) => l.plus + l.minus), ['RL', 'AP', 'SI']);
  assert.deepEqual(axisLetters({ geometry: { space: 'LPS', direction: identity } }).map((l) => l.plus + l.minus), ['LR', 'PA', 'SI']);
  // A radiological volume: x runs to the left, an oblique y mostly posterior, z inferior.
  const flipped = [-1, 0, 0, 0, -0.9, 0.1, 0, 0.3, -1];
  assert.deepEqual(axisLetters({ geometry: { space: 'RAS', direction: flipped } }).map((l) => l.plus), ['L', 'P', 'I']);
  assert.deepEqual(scaleBar(4, 80, 'mm'), { pixels: 80, label: '20 mm' });
  assert.deepEqual(scaleBar(0.3, 80, 'um'), { pixels: 60, label: '200 µm' });
  assert.deepEqual(scaleBar(33, 80, ''), { pixels: 66, label: '2 units' });
});
