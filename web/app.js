// The Strata viewer: wires the views and panels to one view state, which lives in the URL hash.
import { apiUrl, getJson, LatestChannel } from './api.js';
import { LabelLayer } from './label-layer.js';
import { QueryPanel } from './query-panel.js';
import { SliceView } from './slice-view.js';
import { StatusBar } from './status-bar.js';
import { TfEditor } from './tf-editor.js';
import { PRESET_NAMES, formatNumber, presetPoints, tfToString } from './transfer-function.js';
import {
  FEATURE_SCALE_STEPS,
  LAYOUTS,
  applyHash,
  datasetsFromHash,
  defaultState,
  encodeState,
  nearestStep,
  parseHash,
} from './state.js';
import { View3D } from './view3d.js';
import { bindKeyboard } from './keyboard.js';

const LOD_STEPS = [0.25, 0.5, 1, 2, 4, 8, 16];
const URL_DELAY_MS = 150;
const $ = (id) => document.getElementById(id);

class Viewer {
  constructor() {
    this.ready = false;
    this.datasets = [];
    this.state = defaultState(null, null);
    this.status = new StatusBar({
      frame: $('status-frame'), fps: $('status-fps'), bricks: $('status-bricks'), bytes: $('status-bytes'),
      decode: $('status-decode'), hover: $('status-hover'), message: $('status-message'),
    });
    this.view3d = new View3D(this, $('view-3d'));
    this.slices = [['view-xy', 'z'], ['view-xz', 'y'], ['view-yz', 'x']].map(([id, axis]) => new SliceView(this, $(id), axis));
    this.tfEditor = new TfEditor($('tf-canvas'), {
      value: $('tf-value'), opacity: $('tf-opacity'), color: $('tf-color'), remove: $('tf-remove'),
    });
    this.labelLayer = new LabelLayer(this, {
      opacity: $('label-opacity'), opacityOut: $('label-opacity-out'), defaultMode: $('label-default'),
      defaultColor: $('label-default-color'), search: $('label-search'), searchButton: $('label-search-button'),
      list: $('label-list'), paletteStatus: $('palette-status'), reset: $('label-reset'),
      only: $('label-only'), hideSelected: $('label-hide-selected'), clearSelection: $('label-clear-selection'),
    });
    this.query = new QueryPanel(this, {
      box: $('query-box'), method: $('query-method'), run: $('query-run'), exact: $('query-exact'),
      summary: $('query-summary'), table: $('query-table'), body: $('query-body'),
    });
    this.hoverChannel = new LatestChannel(() => {});
    this.bindControls();
    bindKeyboard(this);
  }

  async start() {
    try {
      this.datasets = await getJson('/api/datasets');
    } catch (error) {
      this.status.message(`cannot list datasets: ${error.message}`, 'error');
      return;
    }
    this.loadHash();
    window.addEventListener('hashchange', () => {
      if (location.hash.slice(1) !== this.writtenHash) this.loadHash();
    });
  }

  // --- datasets ----------------------------------------------------------------------------------

  dataset(slug) {
    return slug === null || slug === undefined ? null : this.datasets.find((d) => d.slug === slug) ?? null;
  }

  scalarDataset() {
    return this.dataset(this.state.scalar);
  }

  labelDataset() {
    return this.dataset(this.state.labels);
  }

  // The dataset whose grid the slices and the cursor use.
  referenceDataset() {
    return this.scalarDataset() ?? this.labelDataset();
  }

  dataset3d() {
    return this.state.source3d === 'labels' ? this.labelDataset() : this.scalarDataset();
  }

  scalarChoices() {
    return this.datasets.filter((d) => d.kind === 'scalar' || d.kind === 'plain');
  }

  // The scalar choices in the order a first visit picks from: compressed files before plain
  // volumes, and among them those a label dataset can overlay first (a scan with its atlas or
  // segmentation is the view people open the viewer for).
  preferredScalarChoices() {
    const rank = (d) => (d.kind === 'scalar' ? 0 : 2) + (this.labelChoices(d).length > 0 ? 0 : 1);
    return [...this.scalarChoices()].sort((a, b) => rank(a) - rank(b) || a.id - b.id);
  }

  // Label datasets that can overlay the scalar one: the same level-0 grid.
  labelChoices(scalar = this.scalarDataset()) {
    return this.datasets.filter((d) => d.kind === 'labels' && (!scalar || d.dims.join() === scalar.dims.join()));
  }

  // A hash's choice when it names a suitable dataset (by slug); undefined (not in the hash) means
  // the first suitable one, null means none. A slug the server does not have (a link from another
  // server, or a file since removed) opens nothing and says so: the first dataset would be a
  // different volume under the same view.
  pickDatasets(wanted) {
    const pick = (slug, choices) => {
      if (slug === null) return null;
      if (slug === undefined) return choices[0] ?? null;
      const found = choices.find((d) => d.slug === slug);
      if (!found && !this.dataset(slug)) this.status.message(`the link's dataset "${slug}" is not served here`, 'error');
      return found ?? null;
    };
    const scalar = pick(wanted.scalar, this.preferredScalarChoices());
    const labels = pick(wanted.labels, this.labelChoices(scalar));
    return { scalar, labels };
  }

  fillDatasetSelects() {
    const option = (value, text) => Object.assign(document.createElement('option'), { value, textContent: text });
    const describe = (d) => `${d.name}  (${d.dims.join('×')})`;
    $('scalar-select').replaceChildren(option('none', '— none —'), ...this.scalarChoices().map((d) => option(d.slug, describe(d))));
    const labels = this.labelChoices();
    $('labels-select').replaceChildren(option('none', '— none —'), ...labels.map((d) => option(d.slug, describe(d))));
  }

  // Switches datasets: everything tied to the old data (camera, TF, cursor, label colours) resets.
  chooseDatasets(scalarId, labelsId) {
    const { scalar, labels } = this.pickDatasets({ scalar: scalarId, labels: labelsId });
    const layout = this.state.layout;
    this.state = { ...defaultState(scalar, labels), layout };
    this.applyState({ postPalette: true });
  }

  // --- state -------------------------------------------------------------------------------------

  loadHash() {
    const fields = parseHash(location.hash);
    const { scalar, labels } = this.pickDatasets(datasetsFromHash(fields));
    this.state = applyHash(defaultState(scalar, labels), fields, scalar ?? labels);
    this.applyState({ postPalette: true });
  }

  // Pushes the whole state into every control and view (after a load or a dataset switch).
  applyState({ postPalette }) {
    this.ready = true;
    this.syncControls();
    this.labelLayer.sync();
    this.query.sync();
    this.view3d.lastExact = null;
    this.view3d.drawOverlay();
    this.view3d.requestFrame(false);
    for (const slice of this.slices) {
      slice.images = { scalar: null, labels: null };
      slice.requested = { scalar: null, labels: null };
      slice.draw();
      slice.refresh();
    }
    if (postPalette) this.labelLayer.post();
    this.updateReadouts();
    this.writeHash();
  }

  // Something changed; `what` says which parts: camera, cursor, render (TF, rank, LOD, step,
  // shading), window, labelsStyle, layers; `interactive` asks for coarse frames.
  changed(what) {
    const interactive = Boolean(what.interactive);
    if (what.camera || what.render || what.layers) this.view3d.requestFrame(interactive);
    if (what.camera || what.cursor || what.layers) this.view3d.drawOverlay();
    if (!what.camera || what.render) {
      for (const slice of this.slices) {
        slice.refresh();
        slice.draw();
      }
    }
    if (what.window) this.syncWindowInputs();
    this.updateReadouts();
    this.scheduleHash();
  }

  setCursor(cursor, { interactive = false } = {}) {
    if (cursor.join() === this.state.cursor.join()) return;
    this.state.cursor = cursor;
    this.changed({ cursor: true, interactive });
  }

  setBox(box, { run }) {
    this.state.box = box;
    this.query.sync();
    for (const slice of this.slices) slice.draw();
    this.view3d.drawOverlay();
    this.scheduleHash();
    if (run) this.query.run();
  }

  // The palette reached the server: label slices (and label frames) must be fetched again.
  paletteApplied() {
    for (const slice of this.slices) slice.refresh({ force: true });
    if (this.state.source3d === 'labels') this.view3d.requestFrame(false);
  }

  tfString() {
    return tfToString(this.state.tf);
  }

  // Opacity of the label slices over the scalar ones. The server draws label slices opaque (the
  // palette's opacity is for the 3D view), so the layer opacity is applied here; with no scalar
  // slice beneath, the labels are drawn in full.
  labelOverlayAlpha() {
    return this.scalarDataset() && this.state.scalarVisible ? this.state.labelOpacity : 1;
  }

  scheduleHash() {
    clearTimeout(this.hashTimer);
    this.hashTimer = setTimeout(() => this.writeHash(), URL_DELAY_MS);
  }

  writeHash() {
    clearTimeout(this.hashTimer);
    this.writtenHash = encodeState(this.state);
    history.replaceState(null, '', `#${this.writtenHash}`);
  }

  // --- hover readout -------------------------------------------------------------------------

  // Shows the value and label under the mouse (voxel null: the mouse left the volume).
  hover(voxel, view) {
    if (view) this.activeSlice = view;
    if (!voxel) {
      this.status.hover('');
      for (const slice of this.slices) slice.readout.textContent = '';
      return;
    }
    const where = `x ${voxel[0]}  y ${voxel[1]}  z ${voxel[2]}`;
    this.hoverChannel.submit({ run: (signal) => this.readVoxel(voxel, where, view, signal) });
  }

  async readVoxel(voxel, where, view, signal) {
    const [x, y, z] = voxel;
    const scalar = this.scalarDataset();
    const labels = this.labelDataset();
    const rank = this.state.rank > 0 ? this.state.rank : null;
    const [value, label] = await Promise.all([
      scalar ? getJson(apiUrl(scalar.id, 'value', { x, y, z, rank }), { signal }) : null,
      labels ? getJson(apiUrl(labels.id, 'value', { x, y, z }), { signal }) : null,
    ]);
    const parts = [where];
    if (value) parts.push(`value ${formatNumber(value.value, 5)}`);
    if (label) parts.push(`label ${label.label}`);
    const text = parts.join('  ·  ');
    this.status.hover(text);
    const hoverElement = $('status-hover');
    hoverElement.dataset.voxel = voxel.join(',');
    if (label) hoverElement.dataset.label = label.label;
    if (value) hoverElement.dataset.value = value.value;
    for (const slice of this.slices) slice.readout.textContent = slice === view ? parts.slice(1).join('  ') : '';
  }

  // Lists the label at a voxel in the label panel, ready for a colour (Alt-click in a slice).
  async pickLabel(voxel) {
    const labels = this.labelDataset();
    if (!labels) return;
    try {
      const [x, y, z] = voxel;
      const { label } = await getJson(apiUrl(labels.id, 'value', { x, y, z }));
      this.labelLayer.select(label);
      this.status.message(`label ${label} selected in the label layer`);
    } catch (error) {
      this.reportError(error);
    }
  }

  // Alt-click in the 3D view: the first voxel the pixel shows solid (a visible label, or where
  // the rendered opacity reaches one half) becomes the cursor, so the slices move to it; on the
  // label layer its label is also selected, as an Alt-click in a slice selects it.
  async pick3d(x, y) {
    const dataset = this.dataset3d();
    if (!dataset) return;
    try {
      const pick = await getJson(apiUrl(dataset.id, 'pick', this.view3d.pickParams(x, y)));
      this.view3d.body.dataset.picked = pick.hit ? pick.voxel.join(',') : 'none';
      if (!pick.hit) {
        this.status.message('nothing visible under the pointer');
        return;
      }
      // The cursor lives in the reference grid: the picked voxel's centre, through world space.
      const reference = this.referenceDataset();
      this.setCursor(pick.voxel.map((v, i) => {
        const world = (v + 0.5) * dataset.spacing[i];
        return Math.min(Math.max(Math.floor(world / reference.spacing[i]), 0), reference.dims[i] - 1);
      }));
      if (pick.label !== undefined) {
        this.labelLayer.select(pick.label);
        this.status.message(`label ${pick.label} at voxel ${pick.voxel.join(', ')} selected in the label layer`);
      } else {
        this.status.message(`voxel ${pick.voxel.join(', ')}: value ${formatNumber(pick.value, 5)}`);
      }
    } catch (error) {
      this.reportError(error);
    }
  }

  updateReadouts() {
    const { az, el, dist } = this.state.camera;
    const resolvedDist = this.dataset3d() ? this.view3d.resolved().dist : dist;
    $('camera-readout').textContent = `az ${az.toFixed(1)}°  el ${el.toFixed(1)}°  dist ${resolvedDist ? formatNumber(resolvedDist, 4) : '—'}`;
    for (const slice of this.slices) slice.title.textContent = `${'xyz'[slice.plane.normal]} ${slice.index}`;
  }

  reportError(error) {
    console.warn(error);
    this.status.message(error.message, 'error');
  }

  // --- panel controls ------------------------------------------------------------------------

  bindControls() {
    this.bindDatasetControls();
    this.bindTfControls();
    this.bindRenderControls();
    this.bindSliceControls();
    $('screenshot-button').addEventListener('click', () => this.screenshot());
    $('copy-link-button').addEventListener('click', () => this.copyLink());
    $('help-button').addEventListener('click', () => this.toggleHelp());
    $('help-close').addEventListener('click', () => this.toggleHelp(false));
    $('help').addEventListener('click', (event) => event.target === $('help') && this.toggleHelp(false));
    for (const button of document.querySelectorAll('#layout-buttons button')) {
      button.addEventListener('click', () => this.setLayout(button.dataset.layout));
    }
  }

  bindDatasetControls() {
    const id = (value) => (value === 'none' ? null : value);
    $('scalar-select').addEventListener('change', (e) => this.chooseDatasets(id(e.target.value), undefined));
    $('labels-select').addEventListener('change', (e) => this.chooseLabels(id(e.target.value)));
    $('source-3d').addEventListener('change', (e) => this.setSource3d(e.target.value));
  }

  // Changing only the label layer keeps the camera, cursor and TF.
  chooseLabels(labelsId) {
    this.state.labels = this.labelChoices().some((d) => d.slug === labelsId) ? labelsId : null;
    Object.assign(this.state, { labelColors: {}, hiddenLabels: [], selectedLabels: [], labelsOnly: false, box: null });
    if (!this.state.labels && this.state.source3d === 'labels') this.state.source3d = 'scalar';
    this.applyState({ postPalette: true });
  }

  setSource3d(source) {
    if (source === 'labels' ? !this.labelDataset() : !this.scalarDataset()) return;
    this.state.source3d = source;
    this.view3d.lastExact = null;
    this.syncControls();
    this.changed({ layers: true });
  }

  bindTfControls() {
    const select = $('tf-preset');
    select.replaceChildren(
      Object.assign(document.createElement('option'), { value: '', textContent: 'custom' }),
      ...PRESET_NAMES.map((name) => Object.assign(document.createElement('option'), { value: name, textContent: name })),
    );
    select.addEventListener('change', () => {
      if (!select.value) return;
      this.state.tf = presetPoints(select.value, this.scalarDataset()?.value_range ?? [0, 1]);
      this.state.tfPreset = select.value;
      this.tfEditor.setPoints(this.state.tf);
      this.changed({ render: true });
    });
    const edited = (interactive) => (event) => {
      this.state.tf = event.detail.points;
      this.state.tfPreset = '';
      select.value = '';
      this.changed({ render: true, interactive });
    };
    this.tfEditor.addEventListener('input', edited(true));
    this.tfEditor.addEventListener('change', edited(false));
  }

  bindRenderControls() {
    const slider = (id, apply) => {
      $(id).addEventListener('input', () => apply(true));
      $(id).addEventListener('change', () => apply(false));
    };
    slider('rank-slider', (interactive) => this.setRender({ rank: Number($('rank-slider').value) }, interactive));
    slider('lod-slider', (interactive) => this.setRender({ lod: LOD_STEPS[Number($('lod-slider').value)] }, interactive));
    slider('fs-slider', (interactive) =>
      this.setRender({ featureScale: FEATURE_SCALE_STEPS[Number($('fs-slider').value)] }, interactive));
    slider('step-slider', (interactive) => this.setRender({ step: Number($('step-slider').value) }, interactive));
    $('shading-toggle').addEventListener('change', (e) => this.setRender({ shading: e.target.checked }, false));
    $('scalar-visible').addEventListener('change', (e) => this.setLayerVisible('scalar', e.target.checked));
    $('labels-visible').addEventListener('change', (e) => this.setLayerVisible('labels', e.target.checked));
  }

  setRender(patch, interactive) {
    Object.assign(this.state, patch);
    this.syncRenderOutputs();
    this.changed({ render: true, interactive });
  }

  setLayerVisible(layer, visible) {
    this.state[layer === 'scalar' ? 'scalarVisible' : 'labelsVisible'] = visible;
    $(layer === 'scalar' ? 'scalar-visible' : 'labels-visible').checked = visible;
    this.changed({ layers: true });
  }

  bindSliceControls() {
    $('slice-map').addEventListener('change', (e) => {
      this.state.sliceMap = e.target.value;
      this.changed({ window: true });
    });
    const setWindow = () => {
      const lo = Number($('window-lo').value);
      const hi = Number($('window-hi').value);
      if (Number.isFinite(lo) && Number.isFinite(hi) && lo < hi) this.state.window = [lo, hi];
      this.changed({ window: true });
    };
    $('window-lo').addEventListener('change', setWindow);
    $('window-hi').addEventListener('change', setWindow);
    $('window-auto').addEventListener('click', () => {
      this.state.window = [...(this.scalarDataset()?.value_range ?? [0, 1])];
      this.changed({ window: true });
    });
    $('window-percentile').addEventListener('click', () => {
      const scalar = this.scalarDataset();
      this.state.window = [...(scalar?.defaults?.window ?? scalar?.value_range ?? [0, 1])];
      this.changed({ window: true });
    });
  }

  setLayout(layout) {
    if (!LAYOUTS.includes(layout)) return;
    this.state.layout = layout;
    this.syncLayout();
    this.scheduleHash();
  }

  // --- controls <- state ---------------------------------------------------------------------

  syncControls() {
    const state = this.state;
    const scalar = this.scalarDataset();
    this.fillDatasetSelects();
    $('scalar-select').value = state.scalar ?? 'none';
    $('labels-select').value = state.labels ?? 'none';
    $('source-3d').value = state.source3d;
    $('source-3d').querySelector('[value=labels]').disabled = !this.labelDataset();
    $('source-3d').querySelector('[value=scalar]').disabled = !scalar;
    this.tfEditor.setData(scalar?.value_range ?? [0, 1], scalar?.histogram ?? []);
    this.tfEditor.setPoints(state.tf);
    $('tf-preset').value = PRESET_NAMES.includes(state.tfPreset) ? state.tfPreset : '';
    $('tf-lo').textContent = scalar ? formatNumber(scalar.value_range[0], 4) : '';
    $('tf-hi').textContent = scalar ? formatNumber(scalar.value_range[1], 4) : '';
    $('scalar-visible').checked = state.scalarVisible;
    $('labels-visible').checked = state.labelsVisible;
    $('slice-map').value = state.sliceMap;
    $('section-volume').classList.toggle('disabled', !scalar);
    $('section-labels').classList.toggle('disabled', !this.labelDataset());
    this.syncRenderOutputs();
    this.syncWindowInputs();
    this.syncDatasetInfo();
    this.syncLayout();
  }

  syncRenderOutputs() {
    const state = this.state;
    const rank = $('rank-slider');
    rank.max = Math.max(1, this.scalarDataset()?.rank ?? 1);
    rank.value = Math.max(1, state.rank);
    rank.disabled = !(state.rank > 0);
    $('rank-out').textContent = state.rank > 0 ? `${state.rank}/${rank.max}` : '—';
    $('lod-slider').value = nearestStep(LOD_STEPS, state.lod);
    $('lod-out').textContent = `${formatNumber(state.lod, 3)} px`;
    // Only ta-global files carry the feature-scale table the error control needs.
    const hasTable = (this.scalarDataset()?.feature_scale_ladder ?? []).length > 0;
    $('fs-slider').value = nearestStep(FEATURE_SCALE_STEPS, state.featureScale);
    $('fs-slider').disabled = !hasTable;
    $('fs-out').textContent = !hasTable ? '—' : state.featureScale > 0 ? `${formatNumber(100 * state.featureScale, 3)} %` : 'off';
    $('step-slider').value = state.step;
    $('step-out').textContent = formatNumber(state.step, 3);
    $('shading-toggle').checked = state.shading;
  }

  syncWindowInputs() {
    $('window-lo').value = formatNumber(this.state.window[0], 4);
    $('window-hi').value = formatNumber(this.state.window[1], 4);
  }

  syncDatasetInfo() {
    const rows = [];
    const add = (term, value) => rows.push(`<dt>${term}</dt><dd title="${escapeHtml(value)}">${escapeHtml(value)}</dd>`);
    const spacing = (d) => (d.spacing ?? [1, 1, 1]).map((s) => formatNumber(s, 4)).join(' × ');
    const scalar = this.scalarDataset();
    const labels = this.labelDataset();
    if (scalar) {
      add('volume', scalar.name);
      add('dims', `${scalar.dims.join(' × ')}  ${scalar.dtype}`);
      add('spacing', spacing(scalar));
      add('levels', `${scalar.levels}  ·  rank ${scalar.rank || '— (uncompressed)'}`);
      add('value range', scalar.value_range.map((v) => formatNumber(v, 5)).join(' … '));
    }
    if (labels) {
      add('labels', labels.name);
      add('', `${labels.dims.join(' × ')}  ${labels.dtype}  ·  ${labels.levels} levels`);
      add('', `${labels.label_count} distinct labels`);
    }
    $('dataset-info').innerHTML = rows.length ? rows.join('') : '<dd class="muted">no dataset</dd>';
  }

  syncLayout() {
    $('views').dataset.layout = this.state.layout;
    for (const button of document.querySelectorAll('#layout-buttons button')) {
      button.classList.toggle('active', button.dataset.layout === this.state.layout);
    }
  }

  // --- actions -------------------------------------------------------------------------------

  async screenshot() {
    try {
      const blob = await this.view3d.screenshotBlob();
      if (!blob) return;
      const { az, el } = this.state.camera;
      const link = document.createElement('a');
      link.href = URL.createObjectURL(blob);
      link.download = `strata-${this.dataset3d().name.replace(/\.[^.]*$/, '')}-az${Math.round(az)}-el${Math.round(el)}.png`;
      link.click();
      setTimeout(() => URL.revokeObjectURL(link.href), 10000);
    } catch (error) {
      this.reportError(error);
    }
  }

  async copyLink() {
    this.writeHash();
    try {
      await navigator.clipboard.writeText(location.href);
      this.status.message('link copied');
    } catch {
      this.status.message('copy the address bar to share this view');
    }
  }

  toggleHelp(show = $('help').hidden) {
    $('help').hidden = !show;
  }
}

function escapeHtml(text) {
  return String(text).replace(/[&<>"']/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' })[c]);
}

const viewer = new Viewer();
// A handle for debugging from the console and for the browser tests.
window.strataViewer = viewer;
viewer.start();
