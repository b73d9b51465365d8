// Transfer-function model: piecewise-linear points {v (data units), color '#rrggbb', a}, the
// presets of the server (src/render/transfer_function.cpp, x over the value range) and the
// TF string of docs/viewer.md ("v:r:g:b:a;...").
import { hexToRgb, mixHex, rgbToHex } from './colors.js';

const PRESETS = {
  grayscale: [
    [0.0, [0, 0, 0], 0],
    [0.1, [0.1, 0.1, 0.1], 0],
    [1.0, [1, 1, 1], 0.25],
  ],
  ct: [
    [0.0, [0, 0, 0], 0],
    [0.25, [0.55, 0.25, 0.15], 0],
    [0.35, [0.8, 0.45, 0.3], 0.015],
    [0.45, [0.9, 0.6, 0.45], 0.02],
    [0.55, [0.95, 0.9, 0.8], 0.5],
    [1.0, [1, 1, 1], 0.9],
  ],
  mri: [
    [0.0, [0, 0, 0], 0],
    [0.15, [0.2, 0.1, 0.1], 0],
    [0.4, [0.7, 0.5, 0.4], 0.02],
    [0.7, [0.95, 0.85, 0.75], 0.15],
    [1.0, [1, 1, 1], 0.4],
  ],
  fire: [
    [0.0, [0, 0, 0], 0],
    [0.2, [0.3, 0, 0], 0],
    [0.45, [0.9, 0.1, 0], 0.03],
    [0.7, [1, 0.6, 0], 0.12],
    [1.0, [1, 1, 0.8], 0.5],
  ],
};

export const PRESET_NAMES = Object.keys(PRESETS);

export function presetPoints(name, range) {
  const [lo, hi] = range;
  return PRESETS[name].map(([x, rgb, a]) => ({ v: tidy(lo + x * (hi - lo)), color: rgbToHex(rgb), a }));
}

// Short decimal text: enough digits for the value range at hand, no trailing noise.
export function formatNumber(value, digits = 6) {
  if (!Number.isFinite(value)) return String(value);
  return String(Number(value.toPrecision(digits)));
}

// Rounds to six significant digits: finer than any control, and short in the URL.
export function tidy(value) {
  return Number(value.toPrecision(6));
}

export function tfToString(points) {
  return points
    .map((p) => [String(p.v), ...hexToRgb(p.color).map((c) => formatNumber(c, 4)), String(p.a)].join(':'))
    .join(';');
}

// Parses a TF string; returns null when it is malformed (so a hand-edited URL falls back).
export function tfFromString(text) {
  const points = [];
  for (const part of text.split(';')) {
    const numbers = part.split(':').map(Number);
    if (numbers.length !== 5 || numbers.some((n) => !Number.isFinite(n))) return null;
    const [v, r, g, b, a] = numbers;
    points.push({ v, color: rgbToHex([r, g, b]), a: Math.min(1, Math.max(0, a)) });
  }
  if (points.length < 2) return null;
  for (let i = 1; i < points.length; i++) if (points[i].v < points[i - 1].v) return null;
  if (!(points[0].v < points.at(-1).v)) return null;  // the server needs a range to map
  return points;
}

// Colour and opacity of the TF at value v (used for a new point between two others).
export function evaluate(points, v) {
  if (v <= points[0].v) return { color: points[0].color, a: points[0].a };
  const last = points[points.length - 1];
  if (v >= last.v) return { color: last.color, a: last.a };
  const i = points.findIndex((p) => p.v > v);
  const a = points[i - 1];
  const b = points[i];
  const t = (v - a.v) / (b.v - a.v);
  return { color: mixHex(a.color, b.color, t), a: a.a + (b.a - a.a) * t };
}
