// The 3D view: server-rendered frames of the chosen layer, an orbit camera driven by the mouse,
// and a client-drawn overlay (volume outline, the three slice planes at the cursor, the query
// box, an axis triad) that follows the camera at once while frames catch up.
import { LatestChannel, apiUrl, fetchImage } from './api.js';
import { boxEdges, pannedTarget, project, resolveCamera, worldSize } from './camera.js';
import { AXIS_COLORS } from './colors.js';
import { tidy } from './transfer-function.js';
import { axisLetters } from './orientation.js';

const ORBIT_DEG_PER_PIXEL = 0.4;
const ZOOM_PER_WHEEL_UNIT = 0.0015;
// After the last camera change, wait this long before asking for the exact frame, so a drag
// or a wheel spin produces a stream of coarse frames and only one exact frame.
const EXACT_DELAY_MS = 250;
// At rest, scalar frames are refined: passes 1..REFINE_PASSES-1 of the same view, each with its
// own ray jitter pattern, are averaged with the exact frame (pass 0), which removes the
// sampling noise of the step (docs/viewer.md).
const REFINE_PASSES = 8;

export class View3D {
  constructor(viewer, section) {
    this.viewer = viewer;
    this.section = section;
    this.body = section.querySelector('.view-body');
    this.canvas = section.querySelector('#canvas-3d');
    this.overlay = section.querySelector('#overlay-3d');
    this.message = section.querySelector('.view-message');
    this.channel = new LatestChannel((error) => viewer.reportError(error));
    this.clientId = `c${Math.random().toString(36).slice(2, 10)}`;
    this.seq = 0;
    this.shownSeq = 0;
    this.frames = 0;
    this.lastExact = null; // {key, blob}: the screenshot reuses it when the view has not changed
    this.refined = null; // {key, sum, passes, width, height}: the mean of the view's passes so far
    this.exactTimer = null;
    this.size = { width: 1, height: 1 };
    this.showOverlay = true;
    this.bindPointer();
    this.bindWheel();
    new ResizeObserver(() => this.resize()).observe(this.body);
  }

  get state() {
    return this.viewer.state;
  }

  // --- camera interaction -------------------------------------------------------------------

  bindPointer() {
    this.body.addEventListener('contextmenu', (event) => event.preventDefault());
    this.body.addEventListener('pointerdown', (event) => {
      if (!this.viewer.dataset3d()) return;
      if (event.button === 0 && event.altKey) {
        // Alt-click picks what the pixel shows (the server walks the pixel's ray).
        event.preventDefault();
        const rect = this.body.getBoundingClientRect();
        const at = (v, size) => Math.min(Math.max(v - 0.5, -0.5), size - 0.5 - 1e-3);
        this.viewer.pick3d(at(event.clientX - rect.left, this.size.width), at(event.clientY - rect.top, this.size.height));
        return;
      }
      const pan = event.button === 2 || event.button === 1 || event.shiftKey;
      if (event.button !== 0 && !pan) return;
      event.preventDefault();
      this.body.setPointerCapture(event.pointerId);
      this.drag = { pan, x: event.clientX, y: event.clientY };
      this.body.classList.add(pan ? 'panning' : 'orbiting');
    });
    this.body.addEventListener('pointermove', (event) => {
      if (!this.drag) return;
      const dx = event.clientX - this.drag.x;
      const dy = event.clientY - this.drag.y;
      if (dx === 0 && dy === 0) return;
      this.drag.x = event.clientX;
      this.drag.y = event.clientY;
      if (this.drag.pan) this.pan(dx, dy);
      else this.orbit(dx, dy);
    });
    const end = () => {
      if (!this.drag) return;
      this.drag = null;
      this.body.classList.remove('panning', 'orbiting');
      this.requestFrame(false); // the camera stopped: the exact frame now
    };
    this.body.addEventListener('pointerup', end);
    this.body.addEventListener('pointercancel', end);
  }

  bindWheel() {
    this.body.addEventListener(
      'wheel',
      (event) => {
        if (!this.viewer.dataset3d()) return;
        event.preventDefault();
        const delta = event.deltaMode === 1 ? event.deltaY * 20 : event.deltaY;
        this.zoom(Math.exp(delta * ZOOM_PER_WHEEL_UNIT));
      },
      { passive: false },
    );
  }

  orbit(dx, dy) {
    const camera = this.state.camera;
    // Grab-and-turn: dragging right turns the volume right, dragging down tips its top forward.
    camera.az = round((((camera.az - dx * ORBIT_DEG_PER_PIXEL) % 360) + 360) % 360, 2);
    camera.el = round(Math.max(-90, Math.min(90, camera.el + dy * ORBIT_DEG_PER_PIXEL)), 2);
    this.viewer.changed({ camera: true, interactive: true });
  }

  pan(dx, dy) {
    this.state.camera.target = pannedTarget(this.resolved(), dx, dy, this.size.height).map(tidy);
    this.viewer.changed({ camera: true, interactive: true });
  }

  zoom(factor) {
    const dist = this.resolved().dist * factor;
    const size = Math.hypot(...worldSize(this.viewer.dataset3d()));
    this.state.camera.dist = tidy(Math.min(Math.max(dist, size * 0.05), size * 20));
    this.viewer.changed({ camera: true, interactive: true });
  }

  resetCamera() {
    Object.assign(this.state.camera, { az: 30, el: 20, dist: null, target: null });
    this.viewer.changed({ camera: true });
  }

  // Turns the camera to look along a world axis ('x', 'y', 'z') or back to the default view.
  alignTo(axis) {
    const views = { x: [90, 0], y: [0, 0], z: [0, 90] };
    [this.state.camera.az, this.state.camera.el] = views[axis];
    this.viewer.changed({ camera: true });
  }

  resolved() {
    return resolveCamera(this.state.camera, this.viewer.dataset3d(), this.size.width, this.size.height);
  }

  // --- frames -------------------------------------------------------------------------------

  resize() {
    const rect = this.body.getBoundingClientRect();
    const width = Math.round(rect.width);
    const height = Math.round(rect.height);
    if (width < 2 || height < 2) {
      this.hidden = true; // by the layout: no frames until it shows again
      return;
    }
    const shown = this.hidden;
    this.hidden = false;
    if (!shown && width === this.size.width && height === this.size.height) return;
    this.size = { width, height };
    this.measured = true;
    const ratio = window.devicePixelRatio || 1;
    for (const canvas of [this.canvas, this.overlay]) {
      canvas.width = Math.round(width * ratio);
      canvas.height = Math.round(height * ratio);
    }
    this.redrawFrame();
    this.drawOverlay();
    this.requestFrame(false);
  }

  // Coarse frames while the user interacts, then one exact frame once things are still.
  requestFrame(interactive) {
    clearTimeout(this.exactTimer);
    if (!this.viewer.ready || !this.measured || this.hidden) return; // resize() asks later
    const dataset = this.viewer.dataset3d();
    if (!dataset || !this.layerVisible()) {
      this.clear(dataset ? 'layer hidden' : 'no volume');
      return;
    }
    if (interactive) {
      this.send('coarse');
      this.exactTimer = setTimeout(() => this.send('exact'), EXACT_DELAY_MS);
    } else if (!this.bitmap) {
      // Nothing shown yet (the page or the dataset just opened): a coarse frame first, drawn
      // from the top-level bricks within a few hundred ms, while the exact one waits its turn.
      this.send('coarse');
      this.send('exact');
    } else {
      this.send('exact');
    }
  }

  layerVisible() {
    return this.state.source3d === 'labels' ? this.state.labelsVisible : this.state.scalarVisible;
  }

  // Everything that determines the picture (not the quality or the request's identity).
  frameParams() {
    const state = this.state;
    const { camera } = state;
    const params = {
      w: this.size.width,
      h: this.size.height,
      az: round(camera.az, 3),
      el: round(camera.el, 3),
      dist: camera.dist === null ? null : round(camera.dist, 4),
      target: camera.target ? camera.target.map((t) => round(t, 4)) : null,
      lod: state.lod,
      step: state.step,
      shading: state.shading ? 1 : 0,
    };
    if (state.source3d === 'scalar') {
      params.tf = this.viewer.tfString();
      if (state.rank > 0) params.rank = state.rank;
      if (state.featureScale > 0) params.fs = state.featureScale;
    }
    return params;
  }

  // The pick endpoint's parameters for pixel (x, y) of the current frame: its camera, and for a
  // scalar layer the transfer function and rank, so the pick stops where the picture turns solid.
  pickParams(x, y) {
    const { w, h, az, el, dist, target, tf, rank } = this.frameParams();
    return { w, h, az, el, dist, target, tf, rank, x: round(x, 2), y: round(y, 2) };
  }

  send(quality, pass = 0) {
    const dataset = this.viewer.dataset3d();
    const params = this.frameParams();
    const key = apiUrl(dataset.id, 'render', params);
    const seq = ++this.seq;
    const extra = pass > 0 ? { pass } : {};
    const url = apiUrl(dataset.id, 'render', { ...params, ...extra, quality, client: this.clientId, seq });
    const started = performance.now();
    this.channel.submit({
      // An exact frame in flight is worthless once the camera moves again.
      abortable: quality === 'exact',
      run: async (signal, channel) => {
        const frame = await fetchImage(url, signal, channel);
        if (!frame || seq < this.shownSeq) return;
        if (pass > 0) await this.refine(frame, { seq, key, pass });
        else this.show(frame, { seq, quality, key, elapsed: performance.now() - started });
      },
    });
  }

  show(frame, { seq, quality, key, elapsed }) {
    this.shownSeq = seq;
    this.bitmap?.close?.();
    this.bitmap = frame.bitmap;
    this.refined = null;
    if (quality === 'exact') this.lastExact = { key, blob: frame.blob };
    this.message.hidden = true;
    this.redrawFrame();
    this.frames += 1;
    // Milliseconds from the page's first request to its first picture (bench/viewer/first_frame.mjs).
    if (this.frames === 1) this.canvas.dataset.firstFrameMs = Math.round(performance.now());
    Object.assign(this.canvas.dataset, { frames: this.frames, quality, seq, passes: quality === 'exact' ? 1 : 0 });
    this.viewer.status.frameShown(parseStats(frame.headers), quality, elapsed);
    if (quality === 'exact' && this.state.source3d === 'scalar') {
      this.refined = { key, sum: null, passes: 0 };
      this.accumulate(frame.bitmap);
      this.send('exact', 1);
    }
  }

  // Adds a frame's pixels to the running sum of the view's passes.
  accumulate(bitmap) {
    const { width, height } = bitmap;
    const scratch = new OffscreenCanvas(width, height).getContext('2d', { willReadFrequently: true });
    scratch.drawImage(bitmap, 0, 0);
    const pixels = scratch.getImageData(0, 0, width, height).data;
    const r = this.refined;
    if (!r.sum || r.width !== width || r.height !== height) Object.assign(r, { sum: new Float32Array(pixels.length), passes: 0, width, height });
    for (let i = 0; i < pixels.length; i += 1) r.sum[i] += pixels[i];
    r.passes += 1;
  }

  // A refinement pass arrived: show the mean of the passes so far and ask for the next one.
  async refine(frame, { seq, key, pass }) {
    const r = this.refined;
    if (!r || r.key !== key || pass !== r.passes) return; // the view changed meanwhile
    this.accumulate(frame.bitmap);
    frame.bitmap.close?.();
    const mean = new ImageData(r.width, r.height);
    const inverse = 1 / r.passes;
    for (let i = 0; i < mean.data.length; i += 1) mean.data[i] = Math.round(r.sum[i] * inverse);
    const bitmap = await createImageBitmap(mean);
    if (this.refined !== r || seq < this.shownSeq) return;
    this.shownSeq = seq;
    this.bitmap?.close?.();
    this.bitmap = bitmap;
    r.image = mean;
    this.redrawFrame();
    this.canvas.dataset.passes = r.passes;
    if (r.passes < REFINE_PASSES) this.send('exact', r.passes);
  }

  redrawFrame() {
    const context = this.canvas.getContext('2d');
    context.fillStyle = '#000';
    context.fillRect(0, 0, this.canvas.width, this.canvas.height);
    if (!this.bitmap) return;
    context.imageSmoothingEnabled = true;
    context.drawImage(this.bitmap, 0, 0, this.canvas.width, this.canvas.height);
  }

  clear(text) {
    this.bitmap?.close?.();
    this.bitmap = null;
    this.redrawFrame();
    this.message.textContent = text;
    this.message.hidden = false;
  }

  // The exact PNG of the current view: the last exact frame when nothing changed since.
  async screenshotBlob() {
    const dataset = this.viewer.dataset3d();
    if (!dataset) return null;
    const params = this.frameParams();
    const key = apiUrl(dataset.id, 'render', params);
    if (this.refined?.key === key && this.refined.image) {
      const canvas = new OffscreenCanvas(this.refined.width, this.refined.height);
      canvas.getContext('2d').putImageData(this.refined.image, 0, 0);
      return canvas.convertToBlob({ type: 'image/png' });
    }
    if (this.lastExact?.key === key) return this.lastExact.blob;
    const frame = await fetchImage(apiUrl(dataset.id, 'render', { ...params, quality: 'exact', format: 'png' }));
    return frame?.blob ?? null;
  }

  // --- overlay ------------------------------------------------------------------------------

  drawOverlay() {
    const context = this.overlay.getContext('2d');
    const ratio = this.overlay.width / this.size.width;
    context.setTransform(ratio, 0, 0, ratio, 0, 0);
    context.clearRect(0, 0, this.size.width, this.size.height);
    const dataset = this.viewer.dataset3d();
    if (!dataset || !this.showOverlay) return;
    const camera = this.resolved();
    const spacing = dataset.spacing ?? [1, 1, 1];
    const size = worldSize(dataset);
    this.strokeBox(context, camera, [0, 0, 0], size, 'rgba(200, 210, 225, 0.35)', []);
    this.drawSlicePlanes(context, camera, size, spacing);
    const box = this.state.box;
    if (box) {
      const lo = box.slice(0, 3).map((v, i) => v * spacing[i]);
      const hi = box.slice(3).map((v, i) => v * spacing[i]);
      this.strokeBox(context, camera, lo, hi, 'rgba(255, 214, 64, 0.9)', [4, 3]);
    }
    this.drawTriad(context, camera);
  }

  drawSlicePlanes(context, camera, size, spacing) {
    const cursor = this.state.cursor.map((c, i) => (c + 0.5) * spacing[i]);
    ['x', 'y', 'z'].forEach((axis, i) => {
      const lo = [0, 0, 0];
      const hi = [...size];
      lo[i] = hi[i] = cursor[i];
      this.strokeBox(context, camera, lo, hi, hexAlpha(AXIS_COLORS[axis], 0.8), []);
    });
  }

  strokeBox(context, camera, lo, hi, color, dash) {
    context.strokeStyle = color;
    context.lineWidth = 1;
    context.setLineDash(dash);
    context.beginPath();
    for (const [a, b] of boxEdges(lo, hi)) {
      const pa = project(camera, a, this.size.width, this.size.height);
      const pb = project(camera, b, this.size.width, this.size.height);
      if (!pa || !pb) continue;
      context.moveTo(pa[0], pa[1]);
      context.lineTo(pb[0], pb[1]);
    }
    context.stroke();
    context.setLineDash([]);
  }

  // Orientation triad in the lower-left corner: the volume's axes as the camera sees them,
  // named by the anatomical direction they point to when the file says (R, A, S ...).
  drawTriad(context, camera) {
    const origin = [34, this.size.height - 34];
    const length = 22;
    const letters = axisLetters(this.viewer.dataset3d());
    context.font = '10px system-ui, sans-serif';
    context.lineWidth = 2;
    this.overlay.dataset.triad = letters ? letters.map((l) => l.plus).join(',') : 'x,y,z';
    ['x', 'y', 'z'].forEach((axis, i) => {
      const unit = [0, 0, 0];
      unit[i] = 1;
      const sx = unit[0] * camera.right[0] + unit[1] * camera.right[1] + unit[2] * camera.right[2];
      const sy = unit[0] * camera.up[0] + unit[1] * camera.up[1] + unit[2] * camera.up[2];
      const end = [origin[0] + sx * length, origin[1] - sy * length];
      context.strokeStyle = AXIS_COLORS[axis];
      context.fillStyle = AXIS_COLORS[axis];
      context.beginPath();
      context.moveTo(...origin);
      context.lineTo(...end);
      context.stroke();
      context.fillText(letters ? letters[i].plus : axis, end[0] + sx * 6 - 3, end[1] - sy * 6 + 3);
    });
  }
}

function round(value, digits) {
  return Number(value.toFixed(digits));
}

function hexAlpha(hex, alpha) {
  const [r, g, b] = [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16));
  return `rgba(${r}, ${g}, ${b}, ${alpha})`;
}

function parseStats(headers) {
  try {
    return JSON.parse(headers.get('X-Strata-Stats') ?? 'null');
  } catch {
    return null;
  }
}
