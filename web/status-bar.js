// The status bar: figures of the last 3D frame (from the X-Strata-Stats header), the frame rate
// the user sees, the voxel under the mouse, and transient messages.
import { formatNumber } from './transfer-function.js';

const FPS_WINDOW_MS = 2000;
const MESSAGE_MS = 6000;

export class StatusBar {
  constructor(elements) {
    this.el = elements; // {frame, fps, bricks, bytes, decode, hover, message}
    this.shownAt = [];
  }

  frameShown(stats, quality, elapsedMs) {
    const now = performance.now();
    this.shownAt = this.shownAt.filter((t) => now - t < FPS_WINDOW_MS).concat(now);
    const fps = this.shownAt.length > 1 ? ((this.shownAt.length - 1) * 1000) / (now - this.shownAt[0]) : 0;
    const load = stats?.load ?? {};
    this.set('frame', stats?.frame_ms !== undefined ? `${formatNumber(stats.frame_ms, 3)} ms` : '—',
      `${quality} frame; ${formatNumber(elapsedMs, 3)} ms round trip`);
    this.el.frame.dataset.quality = quality;
    this.set('fps', fps ? formatNumber(fps, 2) : '—');
    this.set('bricks', load.bricks_resident !== undefined ? `${load.bricks_resident} / ${load.bricks_loading ?? 0}` : '—',
      cutSummary(stats?.selection));
    this.set('bytes', load.bytes_read !== undefined ? formatBytes(load.bytes_read) : '—');
    this.set('decode', load.decode_ms !== undefined ? `${formatNumber(load.decode_ms, 3)} ms` : '—');
  }

  set(name, text, title = '') {
    this.el[name].textContent = text;
    this.el[name].title = title;
  }

  hover(text) {
    this.el.hover.textContent = text;
  }

  message(text, kind = 'info') {
    clearTimeout(this.messageTimer);
    this.el.message.textContent = text;
    this.el.message.dataset.kind = kind;
    this.messageTimer = setTimeout(() => {
      this.el.message.textContent = '';
    }, MESSAGE_MS);
  }
}

// The LOD cut in words: bricks per level and, with an error target, per rank.
export function cutSummary(selection) {
  if (!selection?.per_level) return '';
  const levels = selection.per_level.map((n, level) => (n > 0 ? `L${level} ${n}` : null)).filter(Boolean);
  const ranks = Object.entries(selection.per_rank ?? {})
    .sort((a, b) => Number(a[0]) - Number(b[0]))
    .map(([rank, n]) => `K${rank} ${n}`);
  return [`bricks per level: ${levels.join(', ')}`, ...(ranks.length ? [`per rank: ${ranks.join(', ')}`] : [])].join('; ');
}

export function formatBytes(bytes) {
  const units = ['B', 'KiB', 'MiB', 'GiB', 'TiB'];
  let value = bytes;
  let unit = 0;
  while (value >= 1024 && unit < units.length - 1) {
    value /= 1024;
    unit += 1;
  }
  return `${unit ? value.toFixed(1) : value} ${units[unit]}`;
}
