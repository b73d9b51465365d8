// Where a dataset lies in the world, for people: anatomical direction letters (R/L, A/P, S/I)
// along each voxel axis when the file says its world space is RAS or LPS, and a scale bar of a
// round length in the file's unit.

// Letters of the world axes' positive and negative directions, per world space.
const LETTERS = {
  RAS: { plus: ['R', 'A', 'S'], minus: ['L', 'P', 'I'] },
  LPS: { plus: ['L', 'P', 'S'], minus: ['R', 'A', 'I'] },
};

// For each voxel axis (0, 1, 2) the letters its positive and negative directions point to
// ({plus, minus}), or null when the file names no anatomical space. An oblique axis takes the
// letter of the world axis it runs most along.
export function axisLetters(dataset) {
  const geometry = dataset?.geometry;
  const letters = LETTERS[geometry?.space];
  if (!letters || geometry.direction?.length !== 9) return null;
  return [0, 1, 2].map((axis) => {
    const column = [0, 1, 2].map((row) => geometry.direction[row * 3 + axis]);
    const world = column.reduce((best, value, i) => (Math.abs(value) > Math.abs(column[best]) ? i : best), 0);
    const positive = column[world] > 0;
    return {
      plus: positive ? letters.plus[world] : letters.minus[world],
      minus: positive ? letters.minus[world] : letters.plus[world],
    };
  });
}

const UNIT_NAMES = { um: 'µm', micron: 'µm', angstrom: 'Å' };

// A scale bar about `targetPixels` long: a length of 1, 2 or 5 times a power of ten world units
// at `pixelsPerUnit`, its length in pixels and its label ("20 mm"; "20 units" when the file
// gives no unit).
export function scaleBar(pixelsPerUnit, targetPixels, unit) {
  const ideal = targetPixels / pixelsPerUnit;
  const power = 10 ** Math.floor(Math.log10(ideal));
  const length = [5, 2, 1].map((m) => m * power).find((l) => l <= ideal) ?? power;
  const name = unit ? UNIT_NAMES[unit] ?? unit : 'units';
  return { pixels: length * pixelsPerUnit, label: `${Number(length.toPrecision(6))} ${name}` };
}
