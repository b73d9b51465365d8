// One axis-aligned slice view (xy, xz or yz): the scalar slice in grey (window) or TF colours,
// the label slice over it with the layer's opacity, the shared cursor as a crosshair, the query
// box, and the mouse: click/drag moves the cursor, wheel moves the slice, Shift-drag draws a
// query box, Alt-click lists the label under the mouse, right-drag sets window/level,
// Ctrl-wheel zooms, middle-drag pans.
import { LatestChannel, apiUrl, fetchImage } from './api.js';
import { AXIS_COLORS } from './colors.js';
import { formatNumber, tidy } from './transfer-function.js';
import { axisLetters, scaleBar } from './orientation.js';

const AXIS_NAMES = ['x', 'y', 'z'];
// For a slice across `axis`: which volume axes run along the image's columns (u) and rows (v).
// Views whose rows run along z are shown with z up, as the 3D view shows it.
const PLANES = {
  z: { normal: 2, u: 0, v: 1, name: 'xy' },
  y: { normal: 1, u: 0, v: 2, name: 'xz' },
  x: { normal: 0, u: 1, v: 2, name: 'yz' },
};
const FIT_MARGIN = 0.94;
const CROSSHAIR_GAP = 7;
const WHEEL_NOTCH = 40; // pixel delta that counts as one step (mouse notches send 100 or more)
const SCALE_BAR_PIXELS = 80; // about this long; the length is a round number of world units

export class SliceView {
  constructor(viewer, section, axis) {
    this.viewer = viewer;
    this.section = section;
    this.axis = axis;
    this.plane = PLANES[axis];
    this.body = section.querySelector('.view-body');
    this.canvas = section.querySelector('canvas');
    this.title = section.querySelector('.view-index');
    this.readout = section.querySelector('.view-readout');
    const report = (error) => viewer.reportError(error);
    this.channels = { scalar: new LatestChannel(report), labels: new LatestChannel(report) };
    this.images = { scalar: null, labels: null };
    this.requested = { scalar: null, labels: null };
    this.zoom = 1;
    this.pan = [0, 0];
    this.size = { width: 1, height: 1 };
    this.frames = 0;
    this.wheelRemainder = 0;
    this.bindEvents();
    new ResizeObserver(() => this.resize()).observe(this.body);
  }

  get state() {
    return this.viewer.state;
  }

  get index() {
    return this.state.cursor[this.plane.normal];
  }

  // --- geometry: screen (CSS pixels in the view) <-> level-0 voxel coordinates (u, v) --------

  geometry() {
    const dataset = this.viewer.referenceDataset();
    const spacing = dataset.spacing ?? [1, 1, 1];
    const { u, v } = this.plane;
    const extentU = dataset.dims[u] * spacing[u];
    const extentV = dataset.dims[v] * spacing[v];
    const scale = Math.min(this.size.width / extentU, this.size.height / extentV) * FIT_MARGIN * this.zoom;
    return {
      flip: v === 2,
      dims: [dataset.dims[u], dataset.dims[v]],
      perVoxel: [scale * spacing[u], scale * spacing[v]],
      origin: [
        this.size.width / 2 - (extentU * scale) / 2 + this.pan[0],
        this.size.height / 2 - (extentV * scale) / 2 + this.pan[1],
      ],
    };
  }

  // Continuous voxel coordinates: voxel k spans [k, k + 1).
  toVoxel(x, y, geometry = this.geometry()) {
    const v = (y - geometry.origin[1]) / geometry.perVoxel[1];
    return [(x - geometry.origin[0]) / geometry.perVoxel[0], geometry.flip ? geometry.dims[1] - v : v];
  }

  toScreen(u, v, geometry = this.geometry()) {
    const row = geometry.flip ? geometry.dims[1] - v : v;
    return [geometry.origin[0] + u * geometry.perVoxel[0], geometry.origin[1] + row * geometry.perVoxel[1]];
  }

  // The volume voxel [x, y, z] under a screen point, or null outside the volume.
  voxelAt(x, y) {
    const geometry = this.geometry();
    const [u, v] = this.toVoxel(x, y, geometry).map(Math.floor);
    if (u < 0 || v < 0 || u >= geometry.dims[0] || v >= geometry.dims[1]) return null;
    const voxel = [...this.state.cursor];
    voxel[this.plane.u] = u;
    voxel[this.plane.v] = v;
    return voxel;
  }

  // --- images ----------------------------------------------------------------------------------

  resize() {
    const rect = this.body.getBoundingClientRect();
    this.hidden = rect.width < 2 || rect.height < 2; // by the layout: no requests meanwhile
    if (this.hidden) return;
    this.size = { width: Math.round(rect.width), height: Math.round(rect.height) };
    this.measured = true;
    const ratio = window.devicePixelRatio || 1;
    this.canvas.width = Math.round(this.size.width * ratio);
    this.canvas.height = Math.round(this.size.height * ratio);
    this.draw();
    this.refresh();
  }

  // Requests the slices whose parameters changed (force: also unchanged ones, e.g. after a
  // palette change that the URL does not show).
  refresh({ force = false } = {}) {
    if (!this.viewer.ready || !this.measured || this.hidden || !this.viewer.referenceDataset()) return;
    this.title.textContent = `${AXIS_NAMES[this.plane.normal]} ${this.index}`;
    this.request('scalar', this.viewer.scalarDataset(), this.state.scalarVisible, force);
    this.request('labels', this.viewer.labelDataset(), this.state.labelsVisible, force);
  }

  request(layer, dataset, visible, force) {
    if (!dataset || !visible) {
      this.requested[layer] = null;
      if (this.images[layer]) {
        this.images[layer] = null;
        this.draw();
      }
      return;
    }
    const url = apiUrl(dataset.id, 'slice', this.sliceParams(layer));
    if (url === this.requested[layer] && !force) return;
    this.requested[layer] = url;
    this.channels[layer].submit({
      run: async (signal, channel) => {
        const image = await fetchImage(url, signal, channel);
        if (!image) return;
        const bitmap = image.bitmap;  // label slices carry their coverage as alpha
        this.images[layer]?.bitmap.close?.();
        this.images[layer] = { bitmap, level: Number(image.headers.get('X-Strata-Level') ?? 0) };
        this.frames += 1;
        this.canvas.dataset.frames = this.frames;
        this.draw();
      },
    });
  }

  sliceParams(layer) {
    const ratio = window.devicePixelRatio || 1;
    const { perVoxel } = this.geometry();
    const params = { axis: this.axis, index: this.index, zoom: formatNumber(Math.min(...perVoxel) * ratio, 3) };
    if (layer === 'labels') return params;
    if (this.state.rank > 0) params.rank = this.state.rank;
    if (this.state.sliceMap === 'tf') params.tf = this.viewer.tfString();
    else params.window = this.state.window.map((w) => formatNumber(w, 6));
    return params;
  }

  // --- drawing ---------------------------------------------------------------------------------

  draw() {
    const context = this.canvas.getContext('2d');
    const ratio = this.canvas.width / this.size.width;
    context.setTransform(1, 0, 0, 1, 0, 0);
    context.fillStyle = '#000';
    context.fillRect(0, 0, this.canvas.width, this.canvas.height);
    if (!this.viewer.referenceDataset()) return;
    context.setTransform(ratio, 0, 0, ratio, 0, 0);
    const geometry = this.geometry();
    const [x0, y0] = geometry.origin;
    const width = geometry.dims[0] * geometry.perVoxel[0];
    const height = geometry.dims[1] * geometry.perVoxel[1];
    context.save();
    context.beginPath();
    context.rect(x0, y0, width, height);
    context.clip();
    context.fillStyle = '#07090c';
    context.fillRect(x0, y0, width, height);
    context.imageSmoothingEnabled = false; // voxels stay voxels
    this.drawImage(context, this.images.scalar, geometry, 1);
    this.drawImage(context, this.images.labels, geometry, this.viewer.labelOverlayAlpha());
    context.restore();
    context.strokeStyle = 'rgba(160, 170, 185, 0.35)';
    context.lineWidth = 1;
    context.strokeRect(x0 - 0.5, y0 - 0.5, width + 1, height + 1);
    this.drawBox(context, geometry);
    this.drawCrosshair(context, geometry);
    this.drawOrientation(context, geometry);
    this.drawScaleBar(context, geometry);
  }

  // Anatomical letters at the middle of each edge (R on the right of a radiological xy slice
  // is L: the letters say which way the data runs, as the file's world space defines it).
  drawOrientation(context, geometry) {
    const letters = axisLetters(this.viewer.referenceDataset());
    if (!letters) {
      delete this.canvas.dataset.orientation;
      return;
    }
    const { u, v } = this.plane;
    // Screen up is +v for the flipped (z up) views, -v otherwise.
    const top = geometry.flip ? letters[v].plus : letters[v].minus;
    const bottom = geometry.flip ? letters[v].minus : letters[v].plus;
    const marks = { left: letters[u].minus, right: letters[u].plus, top, bottom };
    const { width, height } = this.size;
    context.font = 'bold 12px system-ui, sans-serif';
    context.fillStyle = 'rgba(255, 220, 120, 0.9)';
    context.textAlign = 'center';
    context.textBaseline = 'middle';
    context.fillText(marks.left, 9, height / 2);
    context.fillText(marks.right, width - 9, height / 2);
    context.fillText(marks.top, width / 2, 10);
    context.fillText(marks.bottom, width / 2, height - 10);
    context.textAlign = 'start';
    context.textBaseline = 'alphabetic';
    this.canvas.dataset.orientation = [marks.left, marks.right, marks.top, marks.bottom].join(',');
  }

  // A bar of a round length in the file's unit, lower right.
  drawScaleBar(context, geometry) {
    const dataset = this.viewer.referenceDataset();
    const spacing = (dataset.spacing ?? [1, 1, 1])[this.plane.u];
    const bar = scaleBar(geometry.perVoxel[0] / spacing, SCALE_BAR_PIXELS, dataset.geometry?.unit);
    const x1 = this.size.width - 12;
    const y = this.size.height - 24;
    context.strokeStyle = 'rgba(235, 238, 245, 0.9)';
    context.lineWidth = 2;
    context.beginPath();
    context.moveTo(x1 - bar.pixels, y);
    context.lineTo(x1, y);
    context.stroke();
    context.font = '10px system-ui, sans-serif';
    context.fillStyle = 'rgba(235, 238, 245, 0.9)';
    context.textAlign = 'right';
    context.fillText(bar.label, x1, y - 4);
    context.textAlign = 'start';
    this.canvas.dataset.scaleBar = bar.label;
  }

  // A slice of level l has one pixel per 2^l level-0 voxels; the clip trims a partial last one.
  drawImage(context, image, geometry, alpha) {
    if (!image || alpha <= 0) return;
    const factor = 2 ** image.level;
    const width = image.bitmap.width * factor * geometry.perVoxel[0];
    const height = image.bitmap.height * factor * geometry.perVoxel[1];
    context.save();
    context.globalAlpha = alpha;
    if (geometry.flip) {
      // Row 0 (v = 0) goes to the bottom edge of the volume.
      context.translate(0, geometry.origin[1] + geometry.dims[1] * geometry.perVoxel[1]);
      context.scale(1, -1);
      context.drawImage(image.bitmap, geometry.origin[0], 0, width, height);
    } else {
      context.drawImage(image.bitmap, geometry.origin[0], geometry.origin[1], width, height);
    }
    context.restore();
  }

  drawCrosshair(context, geometry) {
    const cursor = this.state.cursor;
    const [cx, cy] = this.toScreen(cursor[this.plane.u] + 0.5, cursor[this.plane.v] + 0.5, geometry);
    context.lineWidth = 1;
    // The vertical line is where the plane across u cuts this one, so it takes u's colour.
    context.strokeStyle = AXIS_COLORS[AXIS_NAMES[this.plane.u]];
    context.beginPath();
    context.moveTo(cx, 0);
    context.lineTo(cx, cy - CROSSHAIR_GAP);
    context.moveTo(cx, cy + CROSSHAIR_GAP);
    context.lineTo(cx, this.size.height);
    context.stroke();
    context.strokeStyle = AXIS_COLORS[AXIS_NAMES[this.plane.v]];
    context.beginPath();
    context.moveTo(0, cy);
    context.lineTo(cx - CROSSHAIR_GAP, cy);
    context.moveTo(cx + CROSSHAIR_GAP, cy);
    context.lineTo(this.size.width, cy);
    context.stroke();
  }

  // The query box (solid where this slice cuts it, faint and dashed elsewhere), or the box being
  // drawn.
  drawBox(context, geometry) {
    const box = this.dragBox ?? this.state.box;
    if (!box) return;
    const { u, v, normal } = this.plane;
    const inside = this.index >= box[normal] && this.index < box[normal + 3];
    const [x0, y0] = this.toScreen(box[u], box[v], geometry);
    const [x1, y1] = this.toScreen(box[u + 3], box[v + 3], geometry);
    context.strokeStyle = inside ? 'rgba(255, 214, 64, 0.95)' : 'rgba(255, 214, 64, 0.4)';
    context.fillStyle = inside ? 'rgba(255, 214, 64, 0.08)' : 'transparent';
    context.setLineDash(inside ? [] : [4, 3]);
    context.fillRect(x0, y0, x1 - x0, y1 - y0);
    context.strokeRect(x0, y0, x1 - x0, y1 - y0);
    context.setLineDash([]);
  }

  // --- mouse -------------------------------------------------------------------------------------

  bindEvents() {
    const body = this.body;
    body.addEventListener('contextmenu', (event) => event.preventDefault());
    body.addEventListener('pointerdown', (event) => this.pointerDown(event));
    body.addEventListener('pointermove', (event) => this.pointerMove(event));
    body.addEventListener('pointerup', (event) => this.pointerUp(event));
    body.addEventListener('pointercancel', () => this.endDrag());
    body.addEventListener('pointerleave', () => this.viewer.hover(null));
    body.addEventListener('dblclick', () => this.resetZoom());
    body.addEventListener('wheel', (event) => this.wheel(event), { passive: false });
  }

  local(event) {
    const rect = this.body.getBoundingClientRect();
    return [event.clientX - rect.left, event.clientY - rect.top];
  }

  pointerDown(event) {
    if (!this.viewer.referenceDataset()) return;
    event.preventDefault();
    this.body.focus({ preventScroll: true });
    const [x, y] = this.local(event);
    if (event.button === 0 && event.altKey) {
      const voxel = this.voxelAt(x, y);
      if (voxel) this.viewer.pickLabel(voxel);
      return;
    }
    let mode = null;
    if (event.button === 0 && event.shiftKey) mode = 'box';
    else if (event.button === 1 || (event.button === 0 && event.ctrlKey)) mode = 'pan';
    else if (event.button === 2) mode = this.viewer.scalarDataset() ? 'window' : null;
    else if (event.button === 0) mode = 'cursor';
    if (!mode) return;
    this.body.setPointerCapture(event.pointerId);
    this.drag = { mode, start: [x, y], last: [x, y], window: [...this.state.window] };
    if (mode === 'cursor') this.moveCursorTo(x, y, true);
  }

  pointerMove(event) {
    const [x, y] = this.local(event);
    this.viewer.hover(this.voxelAt(x, y), this);
    if (!this.drag) return;
    const drag = this.drag;
    if (drag.mode === 'cursor') this.moveCursorTo(x, y, true);
    else if (drag.mode === 'pan') this.panBy(x - drag.last[0], y - drag.last[1]);
    else if (drag.mode === 'window') this.windowLevel(x - drag.start[0], y - drag.start[1], drag.window);
    else if (drag.mode === 'box') this.updateDragBox(drag.start, [x, y]);
    drag.last = [x, y];
  }

  pointerUp(event) {
    if (!this.drag) return;
    const [x, y] = this.local(event);
    const drag = this.drag;
    if (drag.mode === 'cursor') this.moveCursorTo(x, y, false);
    if (drag.mode === 'window') this.viewer.changed({ window: true });
    if (drag.mode === 'box' && this.dragBox) this.viewer.setBox(this.dragBox, { run: true });
    this.endDrag();
  }

  endDrag() {
    this.drag = null;
    this.dragBox = null;
    this.draw();
  }

  moveCursorTo(x, y, interactive) {
    const geometry = this.geometry();
    const [u, v] = this.toVoxel(x, y, geometry).map(Math.floor);
    const cursor = [...this.state.cursor];
    cursor[this.plane.u] = Math.max(0, Math.min(geometry.dims[0] - 1, u));
    cursor[this.plane.v] = Math.max(0, Math.min(geometry.dims[1] - 1, v));
    this.viewer.setCursor(cursor, { interactive });
  }

  // Drag right widens the window, drag up raises the level (as in radiology viewers).
  windowLevel(dx, dy, start) {
    const range = this.viewer.scalarDataset().value_range;
    const span = Math.max(range[1] - range[0], 1e-12);
    const width = Math.max((start[1] - start[0]) * Math.exp(dx * 0.01), span * 1e-4);
    const center = (start[0] + start[1]) / 2 - dy * span * 0.003;
    this.state.window = [tidy(center - width / 2), tidy(center + width / 2)];
    this.viewer.changed({ window: true, interactive: true });
  }

  // The rectangle spans the two in-plane axes; across the slice the box gets the thickness of
  // its smaller side, centred on the slice, so a drag makes a roughly cubic box.
  updateDragBox(start, end) {
    const geometry = this.geometry();
    const a = this.toVoxel(...start, geometry);
    const b = this.toVoxel(...end, geometry);
    const clampU = (t) => Math.max(0, Math.min(geometry.dims[0], Math.round(t)));
    const clampV = (t) => Math.max(0, Math.min(geometry.dims[1], Math.round(t)));
    const [u0, u1] = [clampU(Math.min(a[0], b[0])), clampU(Math.max(a[0], b[0]))];
    const [v0, v1] = [clampV(Math.min(a[1], b[1])), clampV(Math.max(a[1], b[1]))];
    if (u1 <= u0 || v1 <= v0) {
      this.dragBox = null;
      this.draw();
      return;
    }
    const { u, v, normal } = this.plane;
    const depth = this.viewer.referenceDataset().dims[normal];
    const thickness = Math.min(Math.min(u1 - u0, v1 - v0), depth);
    const n0 = Math.max(0, Math.min(depth - thickness, this.index - Math.floor(thickness / 2)));
    const box = [0, 0, 0, 0, 0, 0];
    [box[u], box[u + 3], box[v], box[v + 3], box[normal], box[normal + 3]] = [u0, u1, v0, v1, n0, n0 + thickness];
    this.dragBox = box;
    this.draw();
  }

  panBy(dx, dy) {
    this.pan = [this.pan[0] + dx, this.pan[1] + dy];
    this.draw();
    this.refresh();
  }

  resetZoom() {
    this.zoom = 1;
    this.pan = [0, 0];
    this.draw();
    this.refresh();
  }

  wheel(event) {
    if (!this.viewer.referenceDataset()) return;
    event.preventDefault();
    if (event.ctrlKey) {
      this.zoomAt(this.local(event), Math.exp(-event.deltaY * 0.002));
      return;
    }
    const delta = event.deltaMode === 1 ? event.deltaY * WHEEL_NOTCH : event.deltaY;
    this.wheelRemainder += delta;
    if (Math.abs(this.wheelRemainder) < WHEEL_NOTCH) return;
    const steps = Math.sign(this.wheelRemainder) * (event.shiftKey ? 10 : 1);
    this.wheelRemainder = 0;
    this.step(steps);
  }

  // Moves the slice by `steps` voxels along its normal.
  step(steps) {
    const cursor = [...this.state.cursor];
    const depth = this.viewer.referenceDataset().dims[this.plane.normal];
    cursor[this.plane.normal] = Math.max(0, Math.min(depth - 1, cursor[this.plane.normal] + steps));
    this.viewer.setCursor(cursor, { interactive: false });
  }

  // Zooms about a screen point, keeping the voxel under it in place.
  zoomAt([x, y], factor) {
    const before = this.toVoxel(x, y);
    this.zoom = Math.max(0.25, Math.min(64, this.zoom * factor));
    const after = this.toScreen(...before);
    this.pan = [this.pan[0] + x - after[0], this.pan[1] + y - after[1]];
    this.draw();
    this.refresh();
  }
}

