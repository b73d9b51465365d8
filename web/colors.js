// Colour helpers. hashLabelColor mirrors the server's hash_label_color (src/render/
// label_color_map.cpp) so the swatches in the panel match what the slices and the 3D view show.

const MASK64 = 0xffffffffffffffffn;

function splitmix64(value) {
  let x = (BigInt.asUintN(64, BigInt(value)) + 0x9e3779b97f4a7c15n) & MASK64;
  x = ((x ^ (x >> 30n)) * 0xbf58476d1ce4e5b9n) & MASK64;
  x = ((x ^ (x >> 27n)) * 0x94d049bb133111ebn) & MASK64;
  return x ^ (x >> 31n);
}

const unit = (bits) => Number(bits & 0xffffffn) / 0x1000000;

function hsvToRgb(h, s, v) {
  const h6 = h * 6;
  const sector = Math.floor(h6) % 6;
  const f = h6 - Math.floor(h6);
  const p = v * (1 - s);
  const q = v * (1 - s * f);
  const t = v * (1 - s * (1 - f));
  return [[v, t, p], [q, v, p], [p, v, t], [p, q, v], [t, p, v], [v, p, q]][sector];
}

const hashCache = new Map();

// '#rrggbb' of a label value's default (hash) colour.
export function hashLabelColor(label) {
  let color = hashCache.get(label);
  if (!color) {
    const h = splitmix64(label);
    const rgb = hsvToRgb(unit(h), 0.55 + 0.4 * unit(h >> 24n), 0.75 + 0.25 * unit(h >> 48n));
    color = rgbToHex(rgb);
    hashCache.set(label, color);
  }
  return color;
}

// [r, g, b] in [0, 1] -> '#rrggbb'
export function rgbToHex(rgb) {
  return `#${rgb.map((c) => Math.round(Math.min(1, Math.max(0, c)) * 255).toString(16).padStart(2, '0')).join('')}`;
}

// '#rrggbb' -> [r, g, b] in [0, 1]
export function hexToRgb(hex) {
  return [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16) / 255);
}

export function isHexColor(text) {
  return /^#[0-9a-fA-F]{6}$/.test(text);
}

// Component-wise linear mix of two '#rrggbb' colours.
export function mixHex(a, b, t) {
  const ca = hexToRgb(a);
  const cb = hexToRgb(b);
  return rgbToHex(ca.map((c, i) => c + (cb[i] - c) * t));
}

// Colours of the three axes (and of the slice views whose normal they are), as in most
// scientific viewers: x red, y green, z blue.
export const AXIS_COLORS = { x: '#e8575a', y: '#5cc46a', z: '#4f8fe8' };
