// The orbit camera of the server (src/render/camera.cpp), mirrored so the client can zoom and
// pan in world units and draw its overlay (box outline, slice planes) in step with the frames.
// World space: level-0 voxel coordinates times spacing; the volume is [0, dims * spacing].

export const FOV_DEG = 30;

const radians = (deg) => (deg * Math.PI) / 180;
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const normalized = (a) => scale(a, 1 / Math.hypot(...a));

export function worldSize(dataset) {
  return dataset.dims.map((d, i) => d * (dataset.spacing?.[i] ?? 1));
}

// Distance at which the sphere holding the volume's content (the dataset's `frame_radius`,
// else its bounding sphere) fills the narrower field of view: the server's default when a
// request carries no `dist`.
export function framingDistance(dataset, width, height) {
  const bounding = Math.max(0.5 * Math.hypot(...worldSize(dataset)), 1e-9);
  const radius = dataset.frame_radius > 0 ? Math.min(dataset.frame_radius, bounding) : bounding;
  const tanV = Math.tan(radians(FOV_DEG) / 2);
  const tanH = tanV * (width / height);
  return radius / Math.sin(Math.atan(Math.min(tanV, tanH)));
}

// The camera with defaults resolved: {az, el, dist, target, eye, forward, right, up}.
export function resolveCamera(camera, dataset, width, height) {
  const dist = camera.dist ?? framingDistance(dataset, width, height);
  const target = camera.target ?? scale(worldSize(dataset), 0.5);
  const az = radians(camera.az);
  const el = radians(camera.el);
  const toEye = [Math.sin(az) * Math.cos(el), -Math.cos(az) * Math.cos(el), Math.sin(el)];
  const forward = scale(toEye, -1);
  const right = [Math.cos(az), Math.sin(az), 0];
  const up = normalized(cross(right, forward));
  return { az: camera.az, el: camera.el, dist, target, eye: add(target, scale(toEye, dist)), forward, right, up };
}

// Screen position (CSS pixels, y down) of a world point, or null behind the eye.
export function project(resolved, point, width, height) {
  const rel = sub(point, resolved.eye);
  const depth = dot(rel, resolved.forward);
  if (depth <= 1e-6) return null;
  const tanV = Math.tan(radians(FOV_DEG) / 2);
  const u = dot(rel, resolved.right) / (depth * tanV * (width / height));
  const v = dot(rel, resolved.up) / (depth * tanV);
  return [((u + 1) / 2) * width, ((1 - v) / 2) * height];
}

// The target moved so the scene follows a drag of (dx, dy) screen pixels.
export function pannedTarget(resolved, dx, dy, height) {
  const worldPerPixel = (2 * resolved.dist * Math.tan(radians(FOV_DEG) / 2)) / height;
  const shift = add(scale(resolved.right, -dx * worldPerPixel), scale(resolved.up, dy * worldPerPixel));
  return add(resolved.target, shift);
}

// The eight corners and twelve edges of the box [lo, hi].
export function boxEdges(lo, hi) {
  const corner = (i) => [i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]];
  const edges = [];
  for (let i = 0; i < 8; i++) {
    for (const bit of [1, 2, 4]) if (!(i & bit)) edges.push([corner(i), corner(i | bit)]);
  }
  return edges;
}
