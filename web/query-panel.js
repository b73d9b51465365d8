// Box query: the expected voxel count ± σ of every label in a box (the Mixture Graph's fast
// estimate), and beside it the exact count (method=naive) for comparison.
import { apiUrl, getJson } from './api.js';
import { formatNumber } from './transfer-function.js';
import { parseBox } from './state.js';

const MAX_ROWS = 500;

export class QueryPanel {
  constructor(viewer, elements) {
    this.viewer = viewer;
    this.el = elements; // {box, method, run, exact, summary, table, body}
    this.results = { estimate: null, exact: null };
    this.el.run.addEventListener('click', () => this.runFromInput(this.el.method.value));
    this.el.exact.addEventListener('click', () => this.runFromInput('naive'));
    this.el.box.addEventListener('keydown', (event) => {
      if (event.key === 'Enter') this.runFromInput(this.el.method.value);
    });
  }

  // Shows the state's box in the text field; a new box drops the results of the old one.
  sync() {
    const box = this.viewer.state.box;
    this.el.box.value = box ? box.join(',') : '';
    const enabled = Boolean(this.viewer.labelDataset());
    for (const control of [this.el.run, this.el.exact, this.el.box, this.el.method]) control.disabled = !enabled;
    if (!box || this.results.box?.join() !== box.join()) {
      this.results = { estimate: null, exact: null, box };
      this.render();
    }
  }

  // "x0,y0,z0,x1,y1,z1" (half-open, level-0 voxels) -> box, or an error message.
  parse(text) {
    return parseBox(text, this.viewer.labelDataset()?.dims ?? [0, 0, 0]);
  }

  runFromInput(method) {
    const parsed = this.parse(this.el.box.value);
    if (parsed.error) {
      this.el.summary.textContent = parsed.error;
      this.el.summary.classList.add('error');
      return;
    }
    this.viewer.setBox(parsed.box, { run: false });
    this.run(method);
  }

  async run(method = this.el.method.value) {
    const dataset = this.viewer.labelDataset();
    const box = this.viewer.state.box;
    if (!dataset || !box) return;
    this.el.summary.classList.remove('error');
    this.el.summary.textContent = `querying (${method})…`;
    try {
      const result = await getJson(apiUrl(dataset.id, 'query', { box, method }));
      if (this.viewer.state.box?.join() !== box.join()) return; // a newer box was drawn meanwhile
      this.results[method === 'naive' ? 'exact' : 'estimate'] = result;
      this.results.box = box;
      this.render();
    } catch (error) {
      this.el.summary.textContent = `query failed: ${error.message}`;
      this.el.summary.classList.add('error');
    }
  }

  render() {
    const { estimate, exact } = this.results;
    this.el.table.hidden = !estimate && !exact;
    this.el.summary.classList.remove('error');
    this.el.summary.textContent = [estimate, exact]
      .filter(Boolean)
      .map((r) => `${r.method}: ${formatNumber(r.ms, 3)} ms`)
      .concat(estimate || exact ? [`${(estimate ?? exact).voxels} voxels`] : [])
      .join(' · ');
    this.el.summary.dataset.methods = [estimate?.method, exact?.method].filter(Boolean).join(',');
    this.el.body.replaceChildren(...this.rows());
  }

  // Rows in the estimate's order (descending count), exact-only labels appended.
  rows() {
    const { estimate, exact } = this.results;
    const exactCounts = new Map((exact?.labels ?? []).map((l) => [l.label, l.count]));
    const order = (estimate ?? exact)?.labels ?? [];
    const seen = new Set(order.map((l) => l.label));
    const extra = (exact?.labels ?? []).filter((l) => !seen.has(l.label));
    const entries = [...order, ...extra.map((l) => ({ label: l.label, count: null, sigma: null }))];
    const exactOf = (label) => (exact ? (exactCounts.get(label) ?? 0) : undefined);
    const rows = entries.slice(0, MAX_ROWS).map((entry) => this.row(entry, estimate ? entry : null, exactOf(entry.label)));
    if (entries.length > MAX_ROWS) {
      const more = document.createElement('tr');
      more.innerHTML = `<td colspan="6" class="muted">… ${entries.length - MAX_ROWS} more labels</td>`;
      rows.push(more);
    }
    return rows;
  }

  row(entry, estimate, exactCount) {
    const tr = document.createElement('tr');
    tr.dataset.testid = 'query-row';
    tr.dataset.label = entry.label;
    if (exactCount !== undefined) tr.dataset.exact = exactCount;
    if (estimate) tr.dataset.estimate = estimate.count;
    const layer = this.viewer.labelLayer;
    const colorCell = document.createElement('td');
    // Label 0 is the background: transparent unless coloured, so it gets no swatch.
    if (entry.label !== 0) colorCell.append(layer.colorInput(entry.label));
    const segment = layer.nameOf(entry.label);
    const name = entry.label === 0 ? '0 background' : `#${entry.label}${segment ? ` ${segment}` : ''}`;
    const estimateText = estimate ? `${estimate.count.toFixed(1)} ± ${estimate.sigma.toFixed(1)}` : '—';
    const exactText = exactCount === undefined ? '—' : String(exactCount);
    // Per-segment statistics from the best count at hand (exact when scanned): its share of the
    // box and its volume in the file's unit.
    const count = exactCount ?? estimate?.count ?? 0;
    const voxels = (this.results.estimate ?? this.results.exact)?.voxels ?? 1;
    const share = (100 * count) / voxels;
    tr.dataset.share = share;
    const idCell = cell(name, 'label-id');
    if (entry.label !== 0) {
      idCell.title = 'Click to select this label';
      idCell.classList.add('clickable');
      idCell.addEventListener('click', () => layer.select(entry.label));
    }
    tr.append(colorCell, idCell, cell(estimateText, 'num'), cell(exactText, 'num'),
      cell(`${share.toFixed(1)} %`, 'num'), cell(this.physicalVolume(count), 'num'));
    return tr;
  }

  // `count` level-0 voxels as a volume in the file's unit ("1.2e+03 mm³"; "vox" without a unit).
  physicalVolume(count) {
    const dataset = this.viewer.labelDataset();
    const unit = dataset?.geometry?.unit;
    if (!unit) return `${formatNumber(count, 4)} vox`;
    const [sx, sy, sz] = dataset.spacing ?? [1, 1, 1];
    return `${formatNumber(count * sx * sy * sz, 4)} ${unit === 'um' ? 'µm' : unit}³`;
  }
}

function cell(content, className) {
  const td = document.createElement('td');
  td.className = className;
  td.textContent = content;
  return td;
}
