// Label layer controls: default colouring (hash colours or one colour), per-label colour and
// visibility, opacity, and the selection: labels found by id, Alt-clicked in a slice or listed
// by a query, which 3D and the slices can show alone ("only selected") or hide. Every change is
// sent to the server as the whole palette (POST palette: the Mixture Graph re-colours every mip
// level, so even a selection out of tens of thousands of segments shows at once) and the label
// slices and 3D frames follow.
import { LatestChannel, apiUrl, postJson } from './api.js';
import { hashLabelColor } from './colors.js';
import { formatNumber } from './transfer-function.js';

// A name search selects at most this many labels (a word common to thousands of segment names
// would otherwise flood the list).
const MAX_NAME_MATCHES = 200;

export class LabelLayer {
  constructor(viewer, elements) {
    this.viewer = viewer;
    // {opacity, opacityOut, defaultMode, defaultColor, search, searchButton, list, paletteStatus,
    //  reset, only, hideSelected, clearSelection}
    this.el = elements;
    this.channel = new LatestChannel((error) => viewer.reportError(error));
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

  isSelected(label) {
    return this.state.selectedLabels.includes(Number(label));
  }

  // Adds a label to the selection (listed, for a colour or visibility change) without changing
  // its colour; with "only selected" on, it shows at once.
  select(label) {
    const id = Number(label);
    if (!this.isSelected(id)) {
      this.state.selectedLabels = [...this.state.selectedLabels, id];
      if (this.state.labelsOnly) this.changed();
      else this.viewer.scheduleHash();
    }
    this.render();
    this.el.list.querySelector(`[data-label="${label}"]`)?.scrollIntoView({ block: 'nearest' });
  }

  // Labels whose name (the file's label table) contains `text`, ignoring case.
  labelsNamed(text) {
    const names = this.viewer.labelDataset()?.label_names ?? {};
    const wanted = text.toLowerCase();
    return Object.entries(names)
      .filter(([, name]) => name.toLowerCase().includes(wanted))
      .map(([id]) => Number(id));
  }

  nameOf(label) {
    return this.viewer.labelDataset()?.label_names?.[label] ?? '';
  }

  selectAll(labels) {
    this.state.selectedLabels = [...new Set([...this.state.selectedLabels, ...labels])];
    if (this.state.labelsOnly) this.changed();
    else this.viewer.scheduleHash();
    this.render();
  }

  deselect(label) {
    this.state.selectedLabels = this.state.selectedLabels.filter((l) => l !== Number(label));
  }

  setColor(label, color, { interactive = false } = {}) {
    this.state.labelColors[label] = color;
    if (!this.isSelected(label)) this.state.selectedLabels = [...this.state.selectedLabels, Number(label)];
    this.changed({ interactive });
  }

  setHidden(label, hidden) {
    const id = Number(label);
    const others = this.state.hiddenLabels.filter((l) => l !== id);
    this.state.hiddenLabels = hidden ? [...others, id] : others;
    if (!this.isSelected(id)) this.state.selectedLabels = [...this.state.selectedLabels, id];
    this.changed();
  }

  setOnly(only) {
    this.state.labelsOnly = only;
    this.changed();
  }

  hideSelected() {
    this.state.hiddenLabels = [...new Set([...this.state.hiddenLabels, ...this.state.selectedLabels])];
    this.changed();
  }

  clearSelection() {
    this.state.selectedLabels = [];
    this.changed();
  }

  resetLabel(label) {
    delete this.state.labelColors[label];
    this.state.hiddenLabels = this.state.hiddenLabels.filter((l) => l !== Number(label));
    this.deselect(label);
    this.changed();
  }

  resetAll() {
    Object.assign(this.state, { labelColors: {}, hiddenLabels: [], selectedLabels: [], labelsOnly: false });
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
      const text = el.search.value.trim();
      if (text === '') return;
      if (/^-?\d+$/.test(text)) {
        this.select(Number(text));
        el.list.querySelector(`[data-label="${text}"] input[type=color]`)?.focus();
        return;
      }
      const found = this.labelsNamed(text);
      this.selectAll(found.slice(0, MAX_NAME_MATCHES));
      const more = found.length > MAX_NAME_MATCHES ? ` (the first ${MAX_NAME_MATCHES} selected)` : '';
      this.viewer.status.message(`${found.length} labels named like "${text}"${more}`);
    };
    el.searchButton.addEventListener('click', find);
    el.search.addEventListener('keydown', (event) => event.key === 'Enter' && find());
    el.reset.addEventListener('click', () => this.resetAll());
    el.only.addEventListener('change', () => this.setOnly(el.only.checked));
    el.hideSelected.addEventListener('click', () => this.hideSelected());
    el.clearSelection.addEventListener('click', () => this.clearSelection());
  }

  // Reflects the state in the controls (after a load from the URL or a dataset change).
  sync() {
    const el = this.el;
    el.opacity.value = this.state.labelOpacity;
    el.opacityOut.textContent = formatNumber(this.state.labelOpacity, 2);
    el.defaultMode.value = this.state.labelDefault === 'hash' ? 'hash' : 'single';
    if (this.state.labelDefault !== 'hash') el.defaultColor.value = this.state.labelDefault;
    el.only.checked = this.state.labelsOnly;
    this.render();
  }

  listedLabels() {
    const state = this.state;
    const ids = new Set([...Object.keys(state.labelColors).map(Number), ...state.hiddenLabels, ...state.selectedLabels]);
    return [...ids].sort((a, b) => a - b);
  }

  render() {
    const list = this.el.list;
    list.replaceChildren(...this.listedLabels().map((id) => this.row(id)));
    list.classList.toggle('empty', list.children.length === 0);
    this.el.only.checked = this.state.labelsOnly;
  }

  // One label row: colour, id, visibility, reset. Also used by the query table.
  row(id) {
    const row = document.createElement('div');
    row.className = 'label-row';
    row.dataset.label = id;
    row.dataset.testid = 'label-row';
    const name = this.nameOf(id);
    row.append(this.colorInput(id), text('span', 'label-id', `#${id}`));
    if (name) row.append(text('span', 'label-name', name));
    row.append(this.visibilityToggle(id));
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
      ...(state.labelsOnly ? { only: [...state.selectedLabels] } : {}),
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
