// The whole view state, and its round trip through the URL hash so a reloaded or shared link
// shows the same view. The hash reads like a query string:
//   #v=0&l=1&cam=30,20,180.5&tgt=32,32,32&cur=32,32,32&tf=0:0:0:0:0;...&rank=8&...
import { PRESET_NAMES, presetPoints, tfFromString, tfToString } from './transfer-function.js';
import { isHexColor } from './colors.js';

export const LAYOUTS = ['quad', '3d', 'xy', 'xz', 'yz'];
// The feature-scale targets the error control offers (normalized RMSE; 0 = off).
export const FEATURE_SCALE_STEPS = [0, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2];

// The index of the step nearest to `value`.
export function nearestStep(steps, value) {
  return steps.reduce((best, v, i) => (Math.abs(v - value) < Math.abs(steps[best] - value) ? i : best), 0);
}

// Defaults for a scalar dataset (and an optional label dataset): the server's camera defaults
// (az 30, el 20, framing distance, stored rank), the cursor at the volume centre, and what the
// server read from the data (`defaults`): the TF preset for its modality over the value range,
// and the slice window from the 0.5th to the 99.5th percentile of its values.
export function defaultState(scalar, labels) {
  const reference = scalar ?? labels;
  const range = scalar?.value_range ?? [0, 1];
  const preset = PRESET_NAMES.includes(scalar?.defaults?.tf) ? scalar.defaults.tf : 'ct';
  const window = scalar?.defaults?.window?.length === 2 ? scalar.defaults.window : range;
  return {
    scalar: scalar?.slug ?? null,
    labels: labels?.slug ?? null,
    camera: { az: 30, el: 20, dist: null, target: null },
    cursor: reference ? reference.dims.map((d) => Math.floor(d / 2)) : [0, 0, 0],
    tf: presetPoints(preset, range),
    tfPreset: preset,
    rank: scalar?.rank || 0,
    lod: 1,
    featureScale: 0,
    step: 0.5,
    shading: true,
    window: [...window],
    sliceMap: 'window',
    source3d: scalar ? 'scalar' : 'labels',
    scalarVisible: true,
    labelsVisible: true,
    labelOpacity: 0.5,
    labelDefault: 'hash',
    labelColors: {},
    hiddenLabels: [],
    selectedLabels: [],
    labelsOnly: false,
    layout: 'quad',
    box: null,
  };
}

// Numbers are written in full (the shortest text that reads back the same): a link restores the
// exact view. The controls round what they set, so the URL stays short.
const fmt = (n) => String(n);
const list = (values) => values.map(fmt).join(',');

// State -> "k=v&..." (the URL hash without '#'). Fields equal to the dataset defaults are kept
// anyway: a link stays valid when the defaults change.
export function encodeState(state) {
  const fields = {
    v: state.scalar ?? 'none',
    l: state.labels ?? 'none',
    cam: [state.camera.az, state.camera.el, ...(state.camera.dist ? [state.camera.dist] : [])].map(fmt).join(','),
    tgt: state.camera.target ? list(state.camera.target) : null,
    cur: state.cursor.join(','),
    tf: tfToString(state.tf),
    preset: state.tfPreset || null,
    rank: state.rank,
    lod: fmt(state.lod),
    fs: state.featureScale > 0 ? fmt(state.featureScale) : null,
    step: fmt(state.step),
    sh: state.shading ? 1 : 0,
    win: list(state.window),
    smap: state.sliceMap,
    src: state.source3d,
    vis: `${state.scalarVisible ? 1 : 0},${state.labelsVisible ? 1 : 0}`,
    lop: fmt(state.labelOpacity),
    ldef: state.labelDefault === 'hash' ? 'hash' : state.labelDefault.slice(1),
    lc: Object.entries(state.labelColors).map(([id, c]) => `${id}:${c.slice(1)}`).join(',') || null,
    lh: state.hiddenLabels.join(',') || null,
    ls: state.selectedLabels.join(',') || null,
    lonly: state.labelsOnly ? 1 : null,
    layout: state.layout,
    box: state.box ? state.box.join(',') : null,
  };
  return Object.entries(fields)
    .filter(([, value]) => value !== null && value !== undefined)
    .map(([key, value]) => `${key}=${encodeURIComponent(value).replace(/%2C/g, ',').replace(/%3A/g, ':').replace(/%3B/g, ';')}`)
    .join('&');
}

export function parseHash(hash) {
  const fields = {};
  for (const part of hash.replace(/^#/, '').split('&')) {
    const eq = part.indexOf('=');
    if (eq <= 0) continue;
    try {
      fields[part.slice(0, eq)] = decodeURIComponent(part.slice(eq + 1));
    } catch {
      // A malformed escape (a hand-edited link): that field falls back to its default.
    }
  }
  return fields;
}

const numbers = (text, count) => {
  const values = text.split(',').map(Number);
  return values.length === count && values.every(Number.isFinite) ? values : null;
};

const datasetSlug = (text) => (text === 'none' ? null : text);

// The dataset choice a hash asks for: {scalar, labels} slugs (null = none, undefined = not
// given). Links name datasets by slug, never by index: another server's third file is not this one's.
export function datasetsFromHash(fields) {
  return {
    scalar: 'v' in fields ? datasetSlug(fields.v) : undefined,
    labels: 'l' in fields ? datasetSlug(fields.l) : undefined,
  };
}

// Applies the hash fields over `state` (defaults for the chosen datasets); a field that does not
// parse or lies out of range is ignored, so a damaged link degrades to the defaults.
export function applyHash(state, fields, reference) {
  const dims = reference?.dims ?? [1, 1, 1];
  const cam = fields.cam && fields.cam.split(',').map(Number);
  if (cam && cam.length >= 2 && cam.every(Number.isFinite)) {
    state.camera.az = cam[0];
    state.camera.el = Math.max(-90, Math.min(90, cam[1]));
    state.camera.dist = cam[2] > 0 ? cam[2] : null;
  }
  const target = fields.tgt && numbers(fields.tgt, 3);
  if (target) state.camera.target = target;
  const cursor = fields.cur && numbers(fields.cur, 3);
  if (cursor) state.cursor = cursor.map((c, i) => Math.max(0, Math.min(dims[i] - 1, Math.round(c))));
  const tf = fields.tf && tfFromString(fields.tf);
  if (tf) {
    state.tf = tf;
    state.tfPreset = fields.preset ?? '';
  }
  applyRenderFields(state, fields);
  applyLabelFields(state, fields);
  if (LAYOUTS.includes(fields.layout)) state.layout = fields.layout;
  const box = fields.box && parseBox(fields.box, dims);
  if (box && !box.error) state.box = box.box;
  return state;
}

// "x0,y0,z0,x1,y1,z1" (half-open, level-0 voxels inside `dims`) -> {box} or {error}.
export function parseBox(text, dims) {
  const values = text.split(/[\s,;:]+/).filter(Boolean).map(Number);
  if (values.length !== 6 || !values.every(Number.isInteger)) return { error: 'expected six integers x0,y0,z0,x1,y1,z1' };
  for (let i = 0; i < 3; i++) {
    if (values[i] < 0 || values[i + 3] > dims[i] || values[i] >= values[i + 3]) {
      return { error: `box must satisfy 0 <= ${'xyz'[i]}0 < ${'xyz'[i]}1 <= ${dims[i]}` };
    }
  }
  return { box: values };
}

function applyRenderFields(state, fields) {
  const rank = Number(fields.rank);
  if (state.rank > 0 && Number.isInteger(rank) && rank >= 1 && rank <= state.rank) state.rank = rank;
  const lod = Number(fields.lod);
  if (lod > 0 && lod <= 64) state.lod = lod;
  const featureScale = Number(fields.fs);
  if (featureScale > 0 && featureScale <= 1) state.featureScale = featureScale;
  const step = Number(fields.step);
  if (step >= 0.05 && step <= 4) state.step = step;
  if (fields.sh === '0' || fields.sh === '1') state.shading = fields.sh === '1';
  const window = fields.win && numbers(fields.win, 2);
  if (window && window[0] < window[1]) state.window = window;
  if (fields.smap === 'window' || fields.smap === 'tf') state.sliceMap = fields.smap;
  if ((fields.src === 'scalar' && state.scalar !== null) || (fields.src === 'labels' && state.labels !== null)) {
    state.source3d = fields.src;
  }
}

function applyLabelFields(state, fields) {
  const vis = fields.vis && fields.vis.split(',');
  if (vis && vis.length === 2) {
    state.scalarVisible = vis[0] !== '0';
    state.labelsVisible = vis[1] !== '0';
  }
  const opacity = Number(fields.lop);
  if (fields.lop !== undefined && opacity >= 0 && opacity <= 1) state.labelOpacity = opacity;
  if (fields.ldef === 'hash') state.labelDefault = 'hash';
  else if (fields.ldef && isHexColor(`#${fields.ldef}`)) state.labelDefault = `#${fields.ldef}`;
  state.labelColors = {};
  for (const entry of (fields.lc ?? '').split(',')) {
    const [id, color] = entry.split(':');
    if (/^-?\d+$/.test(id ?? '') && isHexColor(`#${color}`)) state.labelColors[id] = `#${color.toLowerCase()}`;
  }
  state.hiddenLabels = (fields.lh ?? '').split(',').filter((id) => /^-?\d+$/.test(id)).map(Number);
  state.selectedLabels = (fields.ls ?? '').split(',').filter((id) => /^-?\d+$/.test(id)).map(Number);
  state.labelsOnly = fields.lonly === '1';
}
