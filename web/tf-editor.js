// Transfer-function editor: the dataset's 64-bin histogram (log counts) behind a piecewise-linear
// opacity curve whose control points carry colours. Drag a point to move it, double-click to add
// one, right-click (or Delete) to remove one; the inputs below edit the selected point exactly.
// Opacity is drawn on a square-root axis: the useful per-voxel opacities are small (0.01-0.05)
// and would hug the bottom of a linear axis.
//
// Events: 'input' while a point is dragged or a colour is being picked (preview frames), 'change'
// when an edit is complete.
import { evaluate, formatNumber, tidy } from './transfer-function.js';

const PAD = { left: 6, right: 6, top: 6, bottom: 16 };
const COLOR_BAR = 9;
const HANDLE_RADIUS = 4.5;
const HIT_RADIUS = 9;
const MIN_POINTS = 2;

export class TfEditor extends EventTarget {
  constructor(canvas, controls) {
    super();
    this.canvas = canvas;
    this.controls = controls; // {value, opacity, color, remove}
    this.points = [];
    this.range = [0, 1];
    this.histogram = [];
    this.selected = -1;
    this.bindPointer();
    this.bindControls();
    new ResizeObserver(() => this.resize()).observe(canvas);
  }

  setData(range, histogram) {
    this.range = range[1] > range[0] ? range : [range[0], range[0] + 1];
    this.histogram = histogram ?? [];
    this.draw();
  }

  setPoints(points) {
    this.points = points.map((p) => ({ ...p }));
    if (this.selected >= this.points.length) this.selected = -1;
    this.syncControls();
    this.draw();
  }

  emit(type) {
    this.dispatchEvent(new CustomEvent(type, { detail: { points: this.points.map((p) => ({ ...p })) } }));
  }

  // --- coordinates -----------------------------------------------------------------------------

  plot() {
    const width = this.canvas.clientWidth;
    const height = this.canvas.clientHeight;
    return {
      x0: PAD.left,
      y0: PAD.top,
      width: Math.max(1, width - PAD.left - PAD.right),
      height: Math.max(1, height - PAD.top - PAD.bottom),
    };
  }

  toScreen(point, plot = this.plot()) {
    const [lo, hi] = this.range;
    const t = Math.min(1, Math.max(0, (point.v - lo) / (hi - lo)));
    return [plot.x0 + t * plot.width, plot.y0 + (1 - Math.sqrt(point.a)) * plot.height];
  }

  fromScreen(x, y, plot = this.plot()) {
    const [lo, hi] = this.range;
    const t = Math.min(1, Math.max(0, (x - plot.x0) / plot.width));
    const s = Math.min(1, Math.max(0, 1 - (y - plot.y0) / plot.height));
    return { v: lo + t * (hi - lo), a: s * s };
  }

  hit(x, y) {
    const plot = this.plot();
    let best = -1;
    let bestDistance = HIT_RADIUS;
    this.points.forEach((point, i) => {
      const [px, py] = this.toScreen(point, plot);
      const distance = Math.hypot(px - x, py - y);
      if (distance <= bestDistance) {
        best = i;
        bestDistance = distance;
      }
    });
    return best;
  }

  // --- drawing ---------------------------------------------------------------------------------

  resize() {
    const ratio = window.devicePixelRatio || 1;
    this.canvas.width = Math.round(this.canvas.clientWidth * ratio);
    this.canvas.height = Math.round(this.canvas.clientHeight * ratio);
    this.draw();
  }

  draw() {
    const context = this.canvas.getContext('2d');
    const ratio = this.canvas.width / Math.max(1, this.canvas.clientWidth);
    context.setTransform(ratio, 0, 0, ratio, 0, 0);
    context.clearRect(0, 0, this.canvas.clientWidth, this.canvas.clientHeight);
    const plot = this.plot();
    if (!this.points.length) return;
    this.drawGrid(context, plot);
    this.drawHistogram(context, plot);
    this.drawCurve(context, plot);
    this.drawColorBar(context, plot);
    this.drawHandles(context, plot);
  }

  drawGrid(context, plot) {
    context.strokeStyle = 'rgba(255, 255, 255, 0.06)';
    context.lineWidth = 1;
    context.beginPath();
    for (const a of [0.01, 0.05, 0.25, 1]) {
      const y = Math.round(plot.y0 + (1 - Math.sqrt(a)) * plot.height) + 0.5;
      context.moveTo(plot.x0, y);
      context.lineTo(plot.x0 + plot.width, y);
    }
    context.stroke();
    context.fillStyle = 'rgba(200, 210, 225, 0.35)';
    context.font = '9px system-ui, sans-serif';
    for (const a of [0.01, 0.05, 0.25]) {
      context.fillText(String(a), plot.x0 + 2, plot.y0 + (1 - Math.sqrt(a)) * plot.height - 2);
    }
  }

  drawHistogram(context, plot) {
    const counts = this.histogram;
    if (!counts.length) return;
    const peak = Math.log1p(Math.max(...counts));
    if (peak <= 0) return;
    const barWidth = plot.width / counts.length;
    context.fillStyle = 'rgba(130, 145, 170, 0.35)';
    counts.forEach((count, i) => {
      const h = (Math.log1p(count) / peak) * plot.height;
      context.fillRect(plot.x0 + i * barWidth, plot.y0 + plot.height - h, Math.max(1, barWidth - 0.5), h);
    });
  }

  gradient(context, plot, alpha) {
    const [lo, hi] = this.range;
    const gradient = context.createLinearGradient(plot.x0, 0, plot.x0 + plot.width, 0);
    for (const p of this.points) {
      const t = Math.min(1, Math.max(0, (p.v - lo) / (hi - lo)));
      gradient.addColorStop(t, alpha < 1 ? `${p.color}${Math.round(alpha * 255).toString(16).padStart(2, '0')}` : p.color);
    }
    return gradient;
  }

  drawCurve(context, plot) {
    const screen = this.points.map((p) => this.toScreen(p, plot));
    const first = [plot.x0, screen[0][1]];
    const last = [plot.x0 + plot.width, screen[screen.length - 1][1]];
    const path = [first, ...screen, last];
    context.beginPath();
    context.moveTo(first[0], plot.y0 + plot.height);
    for (const [x, y] of path) context.lineTo(x, y);
    context.lineTo(last[0], plot.y0 + plot.height);
    context.closePath();
    context.fillStyle = this.gradient(context, plot, 0.4);
    context.fill();
    context.beginPath();
    path.forEach(([x, y], i) => (i ? context.lineTo(x, y) : context.moveTo(x, y)));
    context.strokeStyle = 'rgba(235, 240, 248, 0.9)';
    context.lineWidth = 1.25;
    context.stroke();
  }

  drawColorBar(context, plot) {
    context.fillStyle = this.gradient(context, plot, 1);
    context.fillRect(plot.x0, plot.y0 + plot.height + PAD.bottom - COLOR_BAR - 2, plot.width, COLOR_BAR);
  }

  drawHandles(context, plot) {
    const handles = [];
    this.points.forEach((point, i) => {
      const [x, y] = this.toScreen(point, plot);
      handles.push([Math.round(x * 10) / 10, Math.round(y * 10) / 10]);
      context.beginPath();
      context.arc(x, y, HANDLE_RADIUS, 0, Math.PI * 2);
      context.fillStyle = point.color;
      context.fill();
      context.lineWidth = i === this.selected ? 2 : 1.25;
      context.strokeStyle = i === this.selected ? '#4ea1ff' : '#e8edf4';
      context.stroke();
    });
    // Handle positions (CSS pixels in the canvas) for tests and tooling.
    this.canvas.dataset.handles = JSON.stringify(handles);
  }

  // --- mouse and keys ----------------------------------------------------------------------------

  local(event) {
    const rect = this.canvas.getBoundingClientRect();
    return [event.clientX - rect.left, event.clientY - rect.top];
  }

  bindPointer() {
    const canvas = this.canvas;
    canvas.addEventListener('contextmenu', (event) => event.preventDefault());
    canvas.addEventListener('pointerdown', (event) => {
      const [x, y] = this.local(event);
      const index = this.hit(x, y);
      if (event.button === 2) {
        if (index >= 0) this.remove(index);
        return;
      }
      if (event.button !== 0) return;
      this.select(index);
      if (index < 0) return;
      canvas.setPointerCapture(event.pointerId);
      this.dragging = index;
    });
    canvas.addEventListener('pointermove', (event) => {
      const [x, y] = this.local(event);
      canvas.style.cursor = this.dragging !== undefined || this.hit(x, y) >= 0 ? 'grab' : 'crosshair';
      if (this.dragging === undefined) return;
      this.move(this.dragging, this.fromScreen(x, y));
      this.emit('input');
    });
    const end = () => {
      if (this.dragging === undefined) return;
      this.dragging = undefined;
      this.emit('change');
    };
    canvas.addEventListener('pointerup', end);
    canvas.addEventListener('pointercancel', end);
    canvas.addEventListener('dblclick', (event) => {
      const [x, y] = this.local(event);
      if (this.hit(x, y) < 0) this.add(this.fromScreen(x, y));
    });
    canvas.addEventListener('keydown', (event) => {
      if ((event.key === 'Delete' || event.key === 'Backspace') && this.selected >= 0) {
        event.preventDefault();
        event.stopPropagation();
        this.remove(this.selected);
      }
    });
  }

  bindControls() {
    const { value, opacity, color, remove } = this.controls;
    value.addEventListener('change', () => this.editSelected({ v: Number(value.value) }));
    opacity.addEventListener('change', () => this.editSelected({ a: Math.min(1, Math.max(0, Number(opacity.value))) }));
    color.addEventListener('input', () => this.editSelected({ color: color.value }, 'input'));
    color.addEventListener('change', () => this.editSelected({ color: color.value }));
    remove.addEventListener('click', () => this.selected >= 0 && this.remove(this.selected));
  }

  // --- edits -------------------------------------------------------------------------------------

  select(index) {
    this.selected = index;
    this.syncControls();
    this.draw();
  }

  // Keeps the points ordered: a point moves only between its neighbours (touching one makes a
  // step in the TF).
  move(index, { v, a }) {
    const lower = index > 0 ? this.points[index - 1].v : this.range[0];
    const upper = index < this.points.length - 1 ? this.points[index + 1].v : this.range[1];
    this.points[index].v = tidy(Math.min(upper, Math.max(lower, v)));
    this.points[index].a = Number(a.toPrecision(3));
    this.syncControls();
    this.draw();
  }

  add({ v, a }) {
    const at = this.points.findIndex((p) => p.v > v);
    const index = at < 0 ? this.points.length : at;
    const { color } = evaluate(this.points, v);
    this.points.splice(index, 0, { v: tidy(v), a: Number(a.toPrecision(3)), color });
    this.select(index);
    this.emit('change');
  }

  remove(index) {
    if (this.points.length <= MIN_POINTS) return;
    this.points.splice(index, 1);
    this.select(-1);
    this.emit('change');
  }

  editSelected(patch, type = 'change') {
    if (this.selected < 0) return;
    if ('v' in patch && Number.isFinite(patch.v)) this.move(this.selected, { v: patch.v, a: this.points[this.selected].a });
    if ('a' in patch && Number.isFinite(patch.a)) this.points[this.selected].a = patch.a;
    if ('color' in patch) this.points[this.selected].color = patch.color;
    this.syncControls();
    this.draw();
    this.emit(type);
  }

  syncControls() {
    const { value, opacity, color, remove } = this.controls;
    const point = this.points[this.selected];
    for (const input of [value, opacity, color, remove]) input.disabled = !point;
    if (!point) {
      value.value = '';
      opacity.value = '';
      return;
    }
    value.value = formatNumber(point.v, 5);
    opacity.value = formatNumber(point.a, 3);
    color.value = point.color;
  }
}
