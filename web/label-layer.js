// Label layer controls: default colouring (hash colours or one colour), per-label colour and
// visibility, opacity. Every change is sent to the server as the whole palette (POST palette:
// the Mixture Graph re-colours every mip level) and the label slices and 3D frames follow.
import { LatestChannel, apiUrl, postJson } from './api.js';
import { hashLabelColor } from './colors.js';
import { formatNumber } from './transfer-function.js';

export class LabelLayer {
  constructor(viewer, elements) {
    this.viewer = viewer;
    this.el = elements; // {opacity, opacityOut, defaultMode, defaultColor, search, searchButton, list, paletteStatus, reset}
    this.channel = new LatestChannel((error) => viewer.reportError(error));
    this.pinned = new Set(); // ids listed because the user looked them up
    this.posts = 0;
    this.bind();
  }

  get state() {
    return this.viewer.state;
  }

  // Colour a label shows now: its own, else the default (hash or single colour).
  colorOf(label) {
    const own = this.state.labelColors[label];
    if (own) return own;
    return this.state.labelDefault === 'hash' ? hashLabelColor(label) : this.state.labelDefault;
  }

  isHidden(label) {
    return this.state.hiddenLabels.includes(Number(label));
  }

  // Lists a label (for a colour or visibility change) without changing it.
  pin(label) {
    this.pinned.add(Number(label));
    this.render();
    this.el.list.querySelector(`[data-label="${label}"]`)?.scrollIntoView({ block: 'nearest' });
  }

  setColor(label, color, { interactive = false } = {}) {
    this.state.labelColors[label] = color;
    this.pinned.add(Number(label));
    this.changed({ interactive });
  }

  setHidden(label, hidden) {
    const id = Number(label);
    const others = this.state.hiddenLabels.filter((l) => l !== id);
    this.state.hiddenLabels = hidden ? [...others, id] : others;
    this.pinned.add(id);
    this.changed();
  }

  resetLabel(label) {
    delete this.state.labelColors[label];
    this.state.hiddenLabels = this.state.hiddenLabels.filter((l) => l !== Number(label));
    this.pinned.delete(Number(label));
    this.changed();
  }

  resetAll() {
    this.state.labelColors = {};
    this.state.hiddenLabels = [];
    this.pinned.clear();
    this.changed();
  }

  // --- DOM ---------------------------------------------------------------------------------------

  bind() {
    const el = this.el;
    el.opacity.addEventListener('input', () => {
      this.state.labelOpacity = Number(el.opacity.value);
      this.changed({ interactive: true });
    });
    el.opacity.addEventListener('change', () => this.changed());
    el.defaultMode.addEventListener('change', () => {
      this.state.labelDefault = el.defaultMode.value === 'hash' ? 'hash' : el.defaultColor.value;
      this.changed();
    });
    el.defaultColor.addEventListener('change', () => {
      if (el.defaultMode.value !== 'single') el.defaultMode.value = 'single';
      this.state.labelDefault = el.defaultColor.value;
      this.changed();
    });
    const find = () => {
      const id = Number(el.search.value);
      if (!Number.isInteger(id) || el.search.value === '') return;
      this.pin(id);
      el.list.querySelector(`[data-label="${id}"] input[type=color]`)?.focus();
    };
    el.searchButton.addEventListener('click', find);
    el.search.addEventListener('keydown', (event) => event.key === 'Enter' && find());
    el.reset.addEventListener('click', () => this.resetAll());
  }

  // Reflects the state in the controls (after a load from the URL or a dataset change).
  sync() {
    const el = this.el;
    el.opacity.value = this.state.labelOpacity;
    el.opacityOut.textContent = formatNumber(this.state.labelOpacity, 2);
    el.defaultMode.value = this.state.labelDefault === 'hash' ? 'hash' : 'single';
    if (this.state.labelDefault !== 'hash') el.defaultColor.value = this.state.labelDefault;
    this.render();
  }

  listedLabels() {
    const ids = new Set([...Object.keys(this.state.labelColors).map(Number), ...this.state.hiddenLabels, ...this.pinned]);
    return [...ids].sort((a, b) => a - b);
  }

  render() {
    const list = this.el.list;
    list.replaceChildren(...this.listedLabels().map((id) => this.row(id)));
    list.classList.toggle('empty', list.children.length === 0);
  }

  // One label row: colour, id, visibility, reset. Also used by the query table.
  row(id) {
    const row = document.createElement('div');
    row.className = 'label-row';
    row.dataset.label = id;
    row.dataset.testid = 'label-row';
    row.append(this.colorInput(id), text('span', 'label-id', `#${id}`), this.visibilityToggle(id));
    const reset = text('button', 'icon-button', '×');
    reset.title = 'Back to the default colour';
    reset.addEventListener('click', () => this.resetLabel(id));
    row.append(reset);
    return row;
  }

  colorInput(id) {
    const input = document.createElement('input');
    input.type = 'color';
    input.value = this.colorOf(id);
    input.title = `Colour of label ${id}`;
    input.dataset.testid = 'label-color';
    input.addEventListener('input', () => this.setColor(id, input.value, { interactive: true }));
    input.addEventListener('change', () => this.setColor(id, input.value));
    return input;
  }

  visibilityToggle(id) {
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.checked = !this.isHidden(id);
    box.title = `Show label ${id}`;
    box.dataset.testid = 'label-visible';
    box.addEventListener('change', () => this.setHidden(id, !box.checked));
    return box;
  }

  // --- server ------------------------------------------------------------------------------------

  changed({ interactive = false } = {}) {
    this.el.opacityOut.textContent = formatNumber(this.state.labelOpacity, 2);
    if (!interactive) this.render();
    this.viewer.changed({ labelsStyle: true, interactive });
    this.post();
  }

  palette() {
    const state = this.state;
    return {
      colors: { ...state.labelColors },
      hidden: [...state.hiddenLabels],
      default: state.labelDefault,
      opacity: state.labelOpacity,
    };
  }

  // Sends the palette; the newest one wins when edits come faster than the server answers.
  post() {
    const dataset = this.viewer.labelDataset();
    if (!dataset || !this.viewer.ready) return;
    const body = this.palette();
    this.channel.submit({
      run: async (signal) => {
        const result = await postJson(apiUrl(dataset.id, 'palette'), body, { signal });
        this.posts += 1;
        this.el.paletteStatus.textContent = `palette ${formatNumber(result.palette_ms, 2)} ms`;
        this.el.paletteStatus.title = `The server re-coloured ${result.labels} labels through every mip level`;
        this.el.paletteStatus.dataset.posts = this.posts;
        this.viewer.paletteApplied(result);
      },
    });
  }
}

function text(tag, className, content) {
  const element = document.createElement(tag);
  element.className = className;
  element.textContent = content;
  return element;
}
