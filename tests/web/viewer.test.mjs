// Browser tests of the viewer (web/) against a real `strata serve`.
//
//   node viewer.test.mjs /path/to/strata        (or STRATA_BINARY=/path/to/strata node viewer.test.mjs)
//
// Makes a small scalar volume and a label volume with the strata CLI in a temporary folder,
// serves them on a free loopback port, and drives Debian's chromium through playwright-core.
// STRATA_VIEWER_URL=http://127.0.0.1:PORT/ skips the data and server and tests a running server
// (which must serve the same two datasets: scalar first, labels second).
import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { freePort } from './free-port.mjs';

const CHROMIUM = process.env.CHROMIUM ?? '/usr/bin/chromium';
const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];
const SIZE = 64;
const FRAME_TIMEOUT_MS = 20000;

let server;
let workDir;
let browser;
let page;
let baseUrl;
const pageErrors = [];

// --- setup -------------------------------------------------------------------------------------

async function loadPlaywright() {
  try {
    return await import('playwright-core');
  } catch {
    throw new Error('playwright-core is missing: run `npm ci --prefix tests/web` (setup.sh does)');
  }
}

function strataBinary() {
  const binary = process.argv[2] ?? process.env.STRATA_BINARY;
  if (!binary) throw new Error('usage: node viewer.test.mjs /path/to/strata (or set STRATA_BINARY)');
  if (!fs.existsSync(binary)) throw new Error(`strata binary not found: ${binary}`);
  return path.resolve(binary);
}

function makeData(strata, dir) {
  const run = (...args) => execFileSync(strata, ['--progress', 'none', ...args], { cwd: dir, stdio: ['ignore', 'ignore', 'pipe'] });
  run('generate', 'marschner-lobb', '--size', String(SIZE), '-o', 'x.nrrd');
  // Placed in RAS space in millimetres, as a scanner's file would be: the views mark directions.
  const file = fs.readFileSync(path.join(dir, 'x.nrrd'));
  const end = file.indexOf('\n\n') + 1;
  const header = file.subarray(0, end).toString().replace(/spacings: .*\n/,
    'space: right-anterior-superior\nspace directions: (1,0,0) (0,1,0) (0,0,1)\nspace units: "mm" "mm" "mm"\n');
  fs.writeFileSync(path.join(dir, 'x.nrrd'), Buffer.concat([Buffer.from(header), file.subarray(end)]));
  run('compress', 'x.nrrd', '-o', 'x.strata', '--rank', '8');
  run('generate', 'voronoi', '--size', String(SIZE), '-o', 'l.nrrd');
  // Segment names, as an atlas's table gives them: label 1 is the only hippocampus.
  fs.writeFileSync(path.join(dir, 'names.csv'), 'label,name\n1,Hippocampus_L\n2,Precentral_L\n3,Precentral_R\n');
  run('labels', 'encode', 'l.nrrd', '-o', 'l.strata', '--names', 'names.csv');
  run('compress', 'x.nrrd', '-o', 'g.strata', '--rank', '8', '--codec', 'ta-global');
}

async function waitForServer(url, child, timeoutMs = 30000) {
  const deadline = Date.now() + timeoutMs;
  while (Date.now() < deadline) {
    if (child.exitCode !== null) throw new Error(`strata serve exited with code ${child.exitCode}: ${child.output}`);
    try {
      const response = await fetch(`${url}api/datasets`);
      if (response.ok) return;
    } catch {
      // not listening yet
    }
    await new Promise((resolve) => setTimeout(resolve, 100));
  }
  throw new Error(`strata serve did not answer at ${url} within ${timeoutMs} ms: ${child.output}`);
}

async function startServer() {
  const strata = strataBinary();
  workDir = fs.mkdtempSync(path.join(os.tmpdir(), 'strata-web-'));
  makeData(strata, workDir);
  const port = await freePort();
  const child = spawn(strata, ['serve', 'x.strata', 'l.strata', 'g.strata', '--host', '127.0.0.1', '--port', String(port)], {
    cwd: workDir,
    stdio: ['ignore', 'pipe', 'pipe'],
  });
  child.output = '';
  const collect = (chunk) => {
    child.output = (child.output + chunk).slice(-4000);
  };
  child.stdout.on('data', collect);
  child.stderr.on('data', collect);
  const url = `http://127.0.0.1:${port}/`;
  await waitForServer(url, child);
  return { child, url };
}

before(async () => {
  if (!fs.existsSync(CHROMIUM)) throw new Error(`chromium not found at ${CHROMIUM}: install Debian's chromium (setup.sh does)`);
  const { chromium } = await loadPlaywright();
  if (process.env.STRATA_VIEWER_URL) {
    baseUrl = process.env.STRATA_VIEWER_URL.replace(/\/?$/, '/');
  } else {
    const started = await startServer();
    server = started.child;
    baseUrl = started.url;
  }
  browser = await chromium.launch({ executablePath: CHROMIUM, args: CHROMIUM_ARGS });
  const context = await browser.newContext({ viewport: { width: 1280, height: 800 }, acceptDownloads: true });
  page = await context.newPage();
  page.on('pageerror', (error) => pageErrors.push(error.message));
});

after(async () => {
  await browser?.close();
  if (server && server.exitCode === null) {
    server.kill('SIGTERM');
    await new Promise((resolve) => {
      const timer = setTimeout(() => {
        server.kill('SIGKILL');
        resolve();
      }, 3000);
      server.once('exit', () => {
        clearTimeout(timer);
        resolve();
      });
    });
  }
  if (workDir) fs.rmSync(workDir, { recursive: true, force: true });
});

// --- page helpers ------------------------------------------------------------------------------

// A small copy of a canvas (64 x 48 RGBA), enough to tell pictures apart; with `url`, of the
// image the page fetches from there instead.
async function thumbnail(testId, url = null) {
  return page.evaluate(async ([id, address]) => {
    const source = address
      ? await createImageBitmap(await (await fetch(address)).blob())
      : document.querySelector(`[data-testid="${id}"]`);
    const small = document.createElement('canvas');
    small.width = 64;
    small.height = 48;
    const context = small.getContext('2d');
    context.drawImage(source, 0, 0, small.width, small.height);
    return Array.from(context.getImageData(0, 0, small.width, small.height).data);
  }, [testId, url]);
}

function meanAbsDifference(a, b) {
  let sum = 0;
  for (let i = 0; i < a.length; i++) if (i % 4 !== 3) sum += Math.abs(a[i] - b[i]);
  return sum / ((a.length * 3) / 4);
}

function luminanceStdDev(pixels) {
  const values = [];
  for (let i = 0; i < pixels.length; i += 4) values.push(0.299 * pixels[i] + 0.587 * pixels[i + 1] + 0.114 * pixels[i + 2]);
  const mean = values.reduce((s, v) => s + v, 0) / values.length;
  return Math.sqrt(values.reduce((s, v) => s + (v - mean) ** 2, 0) / values.length);
}

const frameCount = (testId) =>
  page.evaluate((id) => Number(document.querySelector(`[data-testid="${id}"]`).dataset.frames ?? 0), testId);

// Waits until the 3D view has shown a frame after `count` and the newest one is exact.
async function waitForExactFrame(count) {
  await page.waitForFunction(
    (n) => {
      const canvas = document.querySelector('[data-testid="canvas-3d"]');
      return Number(canvas.dataset.frames ?? 0) > n && canvas.dataset.quality === 'exact'
        && !window.strataViewer.view3d.channel.busy;
    },
    count,
    { timeout: FRAME_TIMEOUT_MS },
  );
}

async function waitForSliceFrame(testId, count) {
  await page.waitForFunction(
    ([id, n]) => Number(document.querySelector(`[data-testid="${id}"]`).dataset.frames ?? 0) > n,
    [testId, count],
    { timeout: FRAME_TIMEOUT_MS },
  );
}

async function centreOf(testId) {
  const box = await page.getByTestId(testId).boundingBox();
  return [box.x + box.width / 2, box.y + box.height / 2];
}

// Hovers near the middle of the xy view until the readout shows a label other than the
// background (0); returns that label id.
async function hoverLabelNearCentre() {
  const [x, y] = await centreOf('canvas-xy');
  for (const [dx, dy] of [[0, 0], [12, 0], [0, 12], [-12, 0], [0, -12], [24, 24], [-24, -24]]) {
    const voxelBefore = await page.getByTestId('status-hover').getAttribute('data-voxel');
    await page.mouse.move(x + dx, y + dy);
    await page.waitForFunction(
      (previous) => {
        const readout = document.querySelector('[data-testid="status-hover"]').dataset;
        return readout.label !== undefined && readout.voxel !== previous;
      },
      voxelBefore,
    );
    const label = await page.getByTestId('status-hover').getAttribute('data-label');
    if (label !== '0') return label;
  }
  throw new Error('no labelled voxel near the middle of the xy slice');
}

// RGB of the xy view's label slice (as the server sent it) at level-0 voxel (x, y).
async function labelSlicePixel(x, y) {
  return page.evaluate(([vx, vy]) => {
    const { bitmap, level } = window.strataViewer.slices[0].images.labels;
    const canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
    const context = canvas.getContext('2d');
    context.drawImage(bitmap, 0, 0);
    const pixel = context.getImageData(vx >> level, vy >> level, 1, 1).data;
    return [pixel[0], pixel[1], pixel[2]];
  }, [x, y]);
}

// The xy label slice's pixels: how many are opaque, and how many of those are not `rgb`.
async function labelSliceCoverage(rgb) {
  return page.evaluate((colour) => {
    const { bitmap } = window.strataViewer.slices[0].images.labels;
    const canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
    const context = canvas.getContext('2d');
    context.drawImage(bitmap, 0, 0);
    const data = context.getImageData(0, 0, bitmap.width, bitmap.height).data;
    let opaque = 0;
    let other = 0;
    for (let i = 0; i < data.length; i += 4) {
      if (data[i + 3] < 128) continue;
      opaque += 1;
      if (Math.abs(data[i] - colour[0]) + Math.abs(data[i + 1] - colour[1]) + Math.abs(data[i + 2] - colour[2]) > 6) other += 1;
    }
    return { opaque, other };
  }, rgb);
}

// Runs `act` (a change of the label palette) and waits until the page's palette reached the
// server and the xy slice followed.
async function paletteChange(act) {
  const posts = Number((await page.getByTestId('palette-status').getAttribute('data-posts')) ?? 0);
  const frames = await frameCount('canvas-xy');
  await act();
  await page.waitForFunction(
    (n) => Number(document.querySelector('[data-testid="palette-status"]').dataset.posts ?? 0) > n,
    posts,
    { timeout: FRAME_TIMEOUT_MS },
  );
  await waitForSliceFrame('canvas-xy', frames);
  await page.waitForTimeout(300); // let the last slice of the palette settle
}

const viewState = () => page.evaluate(() => JSON.parse(JSON.stringify(window.strataViewer.state)));

// --- tests -------------------------------------------------------------------------------------

test('the page loads, lists the datasets and shows a non-blank 3D view', async () => {
  await page.goto(baseUrl);
  await waitForExactFrame(0);
  const info = await page.getByTestId('dataset-info').textContent();
  assert.match(info, /x\.strata/);
  assert.match(info, /l\.strata/);
  assert.match(info, new RegExp(`${SIZE} × ${SIZE} × ${SIZE}`));
  const pixels = await thumbnail('canvas-3d');
  assert.ok(luminanceStdDev(pixels) > 4, '3D view looks blank');
  await waitForSliceFrame('canvas-xy', 0);
  assert.ok(luminanceStdDev(await thumbnail('canvas-xy')) > 4, 'xy slice looks blank');
  assert.match(await page.getByTestId('status-frame').textContent(), /ms/);
});

test('the views mark anatomical directions and a scale bar from the file\'s geometry', async () => {
  const xy = await page.getByTestId('canvas-xy').getAttribute('data-orientation');
  const xz = await page.getByTestId('canvas-xz').getAttribute('data-orientation');
  // left, right, top, bottom: the xy slice has +y down (A at the bottom), the xz slice z up.
  assert.equal(xy, 'L,R,P,A');
  assert.equal(xz, 'L,R,S,I');
  assert.match(await page.getByTestId('canvas-xy').getAttribute('data-scale-bar'), /^\d+ mm$/);
  assert.equal(await page.locator('#overlay-3d').getAttribute('data-triad'), 'R,A,S');
});

test('at rest the 3D view refines its frame from 8 jittered passes', async () => {
  const passes = [];
  const seen = (request) => {
    const pass = new URL(request.url()).searchParams.get('pass');
    if (request.url().includes('/render') && pass) passes.push(Number(pass));
  };
  page.on('request', seen);
  const frames = await frameCount('canvas-3d');
  await page.evaluate(() => {
    window.strataViewer.state.camera.az += 10;
    window.strataViewer.changed({ camera: true });
  });
  await page.waitForFunction(
    (n) => {
      const canvas = document.getElementById('canvas-3d');
      return Number(canvas.dataset.frames) > n && canvas.dataset.passes === '8';
    },
    frames,
    { timeout: FRAME_TIMEOUT_MS },
  );
  page.off('request', seen);
  assert.deepEqual([...new Set(passes)].sort((a, b) => a - b), [1, 2, 3, 4, 5, 6, 7]);
  // The mean of the passes stays close to one pass: the jitter moves samples within a step.
  const refined = await thumbnail('canvas-3d');
  const single = await thumbnail(null, await page.evaluate(() => window.strataViewer.view3d.refined.key));
  const change = meanAbsDifference(single, refined);
  assert.ok(change < 4, `the mean of the passes differs from one pass by ${change} levels on average`);
});

test('dragging in the 3D view orbits the camera and produces new frames', async () => {
  const before = await thumbnail('canvas-3d');
  const camera = (await viewState()).camera;
  const frames = await frameCount('canvas-3d');
  const [x, y] = await centreOf('canvas-3d');
  await page.mouse.move(x, y);
  await page.mouse.down();
  for (let i = 1; i <= 10; i++) await page.mouse.move(x + i * 12, y + i * 3);
  await page.mouse.up();
  await waitForExactFrame(frames);
  const after = (await viewState()).camera;
  assert.notEqual(after.az, camera.az);
  assert.notEqual(after.el, camera.el);
  assert.ok(meanAbsDifference(before, await thumbnail('canvas-3d')) > 1, 'the frame did not change');
});

test('the rank slider changes the image', async () => {
  const before = await thumbnail('canvas-3d');
  const frames = await frameCount('canvas-3d');
  await page.getByTestId('rank-slider').focus();
  await page.keyboard.press('Home'); // rank 1
  await waitForExactFrame(frames);
  assert.equal((await viewState()).rank, 1);
  assert.ok(meanAbsDifference(before, await thumbnail('canvas-3d')) > 1, 'rank 1 looks like rank 8');
});

test('the error control is off for a file without a feature-scale table', async () => {
  // The served scalar file uses the per-brick codec: only ta-global files carry the table.
  assert.equal(await page.getByTestId('fs-slider').isDisabled(), true);
  assert.equal(await page.getByTestId('fs-out').textContent(), '—');
});

test('moving a transfer-function point changes the image', async () => {
  // x.strata opens with the mri preset (it lies in RAS space); start from the ct preset.
  assert.equal((await viewState()).tfPreset, 'mri');
  let frames = await frameCount('canvas-3d');
  await page.getByTestId('tf-preset').selectOption('ct');
  await waitForExactFrame(frames);
  const before = await thumbnail('canvas-3d');
  frames = await frameCount('canvas-3d');
  const tfBefore = (await viewState()).tf;
  const canvas = await page.getByTestId('tf-canvas').boundingBox();
  const handles = JSON.parse(await page.getByTestId('tf-canvas').getAttribute('data-handles'));
  // The ct preset's opaque shoulder (value 0.55 of the range, opacity 0.5): pull it down and left.
  const top = 4;
  const [hx, hy] = handles[top];
  await page.mouse.move(canvas.x + hx, canvas.y + hy);
  await page.mouse.down();
  for (let i = 1; i <= 6; i++) await page.mouse.move(canvas.x + hx - i * 4, canvas.y + hy + i * 8);
  await page.mouse.up();
  await waitForExactFrame(frames);
  const tfAfter = (await viewState()).tf;
  assert.equal((await viewState()).tfPreset, '');  // edited: no longer the preset
  assert.ok(tfAfter[top].a < tfBefore[top].a, 'the point did not move down');
  assert.ok(meanAbsDifference(before, await thumbnail('canvas-3d')) > 1, 'the frame did not change');
});

test('a label colour change re-colours the label slices', async () => {
  const label = await hoverLabelNearCentre();
  const before = await thumbnail('canvas-xy');
  await page.getByTestId('label-search').fill(label);
  await page.getByTestId('label-search-button').click();
  const row = page.locator(`#label-list [data-label="${label}"]`);
  // The swatch (the client's copy of the hash colour) matches the server's label slice.
  const voxel = (await page.getByTestId('status-hover').getAttribute('data-voxel')).split(',').map(Number);
  const served = await labelSlicePixel(voxel[0], voxel[1]);
  const swatch = await row.getByTestId('label-color').inputValue();
  const expected = [1, 3, 5].map((i) => parseInt(swatch.slice(i, i + 2), 16));
  served.forEach((c, i) => assert.ok(Math.abs(c - expected[i]) <= 2, `swatch ${swatch} but the slice shows ${served}`));
  await paletteChange(() => row.getByTestId('label-color').fill('#ff0000'));
  assert.equal((await viewState()).labelColors[label], '#ff0000');
  assert.match(await page.getByTestId('palette-status').textContent(), /palette .* ms/);
  assert.ok(meanAbsDifference(before, await thumbnail('canvas-xy')) > 0.5, 'the xy slice did not change colour');
});

test('"only selected" shows the selection alone, and "hide selected" hides it', async () => {
  // The previous test selected the label under the cursor and coloured it red.
  const [label] = (await viewState()).selectedLabels;
  assert.equal((await viewState()).labelColors[label], '#ff0000');
  const before = await labelSliceCoverage([255, 0, 0]);
  assert.ok(before.other > 0, 'other labels show before');
  await paletteChange(() => page.getByTestId('label-only').click());
  assert.equal((await viewState()).labelsOnly, true);
  const only = await labelSliceCoverage([255, 0, 0]);
  assert.ok(only.opaque > 0, 'the selected label still shows');
  assert.equal(only.other, 0, 'only the selected (red) label shows');
  await paletteChange(() => page.getByTestId('label-hide-selected').click());
  assert.deepEqual((await viewState()).hiddenLabels, [Number(label)]);
  assert.equal((await labelSliceCoverage([255, 0, 0])).opaque, 0, 'the hidden selection leaves nothing');
  await paletteChange(() => page.getByTestId('label-only').click()); // off again: every label but the hidden one
  const after = await labelSliceCoverage([255, 0, 0]);
  assert.ok(after.opaque > 0 && after.other === after.opaque, 'every other label shows, the hidden one not');
});

test('a name search selects the labels whose name matches, and their rows show the names', async () => {
  const labels = (await page.evaluate(() => window.strataViewer.labelDataset())).label_names;
  assert.deepEqual(labels, { 1: 'Hippocampus_L', 2: 'Precentral_L', 3: 'Precentral_R' });
  const before = (await viewState()).selectedLabels;
  await page.getByTestId('label-search').fill('precentral');
  await page.getByTestId('label-search-button').click();
  const selected = (await viewState()).selectedLabels;
  assert.deepEqual(selected.filter((l) => !before.includes(l)).sort(), [2, 3]);
  assert.equal(await page.locator('#label-list [data-label="3"] .label-name').textContent(), 'Precentral_R');
  await page.getByTestId('label-search').fill('HIPPO');
  await page.getByTestId('label-search-button').click();
  assert.ok((await viewState()).selectedLabels.includes(1));
});

// Alt-clicks the middle of the 3D view and waits for the pick's answer; returns the voxel.
async function altClick3d() {
  const [x, y] = await centreOf('canvas-3d');
  const before = await page.locator('#canvas-3d').evaluate((c) => c.parentElement.dataset.picked ?? '');
  await page.keyboard.down('Alt');
  await page.mouse.click(x, y);
  await page.keyboard.up('Alt');
  await page.waitForFunction((previous) => {
    const picked = document.querySelector('#canvas-3d').parentElement.dataset.picked;
    return picked !== undefined && picked !== previous;
  }, before);
  const picked = await page.locator('#canvas-3d').evaluate((c) => c.parentElement.dataset.picked);
  assert.notEqual(picked, 'none', 'the middle of the 3D view shows the volume');
  return picked.split(',').map(Number);
}

test('Alt-click in 3D moves the slices to the picked voxel and selects its label', async () => {
  const voxel = await altClick3d();
  assert.deepEqual((await viewState()).cursor, voxel, 'the cursor moved to the picked voxel');
  assert.match(await page.getByTestId('status-message').textContent(), /voxel .*: value/);
  await page.getByTestId('source-3d').selectOption('labels');
  await waitForExactFrame(1);
  const labelVoxel = await altClick3d();
  const labels = await page.evaluate(() => window.strataViewer.labelDataset().id);
  const { label } = await page.evaluate(
    async ([id, [x, y, z]]) => (await fetch(`/api/datasets/${id}/value?x=${x}&y=${y}&z=${z}`)).json(),
    [labels, labelVoxel],
  );
  assert.ok((await viewState()).selectedLabels.includes(label), `label ${label} under the pointer was not selected`);
  assert.deepEqual((await viewState()).cursor, labelVoxel);
  await page.getByTestId('source-3d').selectOption('scalar');
});

test('a box query lists labels whose exact counts sum to the box volume', async () => {
  const box = [8, 8, 8, 40, 36, 30];
  const volume = (box[3] - box[0]) * (box[4] - box[1]) * (box[5] - box[2]);
  await page.getByTestId('query-box').fill(box.join(','));
  await page.getByTestId('query-run').click();
  await page.waitForFunction(() => /hybrid/.test(document.querySelector('[data-testid="query-summary"]').dataset.methods ?? ''));
  await page.getByTestId('query-exact').click();
  await page.waitForFunction(() => /naive/.test(document.querySelector('[data-testid="query-summary"]').dataset.methods ?? ''));
  const rows = page.locator('[data-testid="query-row"]');
  assert.ok((await rows.count()) > 1, 'expected several labels in the box');
  const exact = await rows.evaluateAll((trs) => trs.map((tr) => Number(tr.dataset.exact)));
  assert.equal(exact.reduce((s, c) => s + c, 0), volume);
  const estimates = await rows.evaluateAll((trs) => trs.map((tr) => Number(tr.dataset.estimate ?? 0)));
  assert.ok(Math.abs(estimates.reduce((s, c) => s + c, 0) - volume) < volume * 0.05, 'estimates far from the volume');
  assert.match(await page.getByTestId('query-summary').textContent(), /naive: [\d.]+ ms/);
  assert.match(await page.getByTestId('query-table').textContent(), /±/);
  // Per-segment statistics: shares of the exact counts add up to the whole box, names show.
  const shares = await rows.evaluateAll((trs) => trs.map((tr) => Number(tr.dataset.share)));
  assert.ok(Math.abs(shares.reduce((s, c) => s + c, 0) - 100) < 1e-6, `shares sum to ${shares.reduce((s, c) => s + c, 0)}`);
  if (exact.length > 0 && (await rows.evaluateAll((trs) => trs.some((tr) => tr.dataset.label === '2'))))
    assert.match(await page.locator('[data-testid="query-row"][data-label="2"] .label-id').textContent(), /#2 Precentral_L/);
  // A click on a label selects it.
  const label = await rows.nth(0).getAttribute('data-label');
  const target = label === '0' ? rows.nth(1) : rows.nth(0);
  const id = Number(await target.getAttribute('data-label'));
  await target.locator('.label-id').click();
  assert.ok((await viewState()).selectedLabels.includes(id));
});

test('the help overlay opens with ? and closes with Escape', async () => {
  await page.locator('body').click({ position: { x: 5, y: 5 } });
  await page.keyboard.press('?');
  assert.ok(await page.getByTestId('help').isVisible());
  await page.keyboard.press('Escape');
  assert.ok(!(await page.getByTestId('help').isVisible()));
});

test('the screenshot button downloads the 3D view as PNG', async () => {
  const [download] = await Promise.all([page.waitForEvent('download'), page.getByTestId('screenshot').click()]);
  const file = await download.path();
  const signature = fs.readFileSync(file).subarray(0, 8);
  assert.deepEqual([...signature], [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]);
  assert.match(download.suggestedFilename(), /^strata-x-az\d+-el-?\d+\.png$/);
});

test('reloading the URL restores the view', async () => {
  // Move the cursor and the camera distance too, so more fields differ from the defaults.
  const [x, y] = await centreOf('canvas-xz');
  await page.mouse.click(x - 30, y + 20);
  const frames = await frameCount('canvas-3d');
  await page.mouse.move(...(await centreOf('canvas-3d')));
  await page.mouse.wheel(0, -240);
  await waitForExactFrame(frames);
  await page.waitForTimeout(300); // the hash is written shortly after the last change
  const before = await viewState();
  const url = page.url();
  await page.reload();
  await waitForExactFrame(0);
  const after = await viewState();
  assert.equal(page.url(), url);
  const fields = ['scalar', 'labels', 'camera', 'cursor', 'tf', 'rank', 'lod', 'step', 'shading', 'window',
    'source3d', 'labelColors', 'hiddenLabels', 'selectedLabels', 'labelsOnly', 'labelOpacity', 'box', 'layout'];
  for (const field of fields) assert.deepEqual(after[field], before[field], `${field} not restored`);
  assert.equal(after.rank, 1);
  assert.ok(after.camera.dist > 0);
  assert.ok(luminanceStdDev(await thumbnail('canvas-3d')) > 4, '3D view blank after reload');
});

test('on a ta-global file the error control picks ranks per brick and coarsens the cut', async () => {
  const ids = await page.evaluate(() => [...document.querySelectorAll('#scalar-select option')].map((o) => o.textContent));
  const global = ids.findIndex((text) => text.startsWith('g.strata'));
  assert.ok(global > 0, `g.strata not offered: ${ids}`);
  let frames = await frameCount('canvas-3d');
  await page.getByTestId('scalar-select').selectOption({ index: global });
  await waitForExactFrame(frames);
  assert.equal(await page.getByTestId('fs-slider').isDisabled(), false);
  assert.equal(await page.getByTestId('fs-out').textContent(), 'off');
  const bricksOff = Number((await page.getByTestId('status-bricks').textContent()).split(' / ')[0]);
  const before = await thumbnail('canvas-3d');
  frames = await frameCount('canvas-3d');
  await page.getByTestId('fs-slider').focus();
  await page.keyboard.press('End'); // the largest target, 20 % of the value range
  await waitForExactFrame(frames);
  assert.equal((await viewState()).featureScale, 0.2);
  assert.equal(await page.getByTestId('fs-out').textContent(), '20 %');
  const title = await page.getByTestId('status-bricks').getAttribute('title');
  assert.match(title, /per rank: K\d+ \d+/, `no per-rank figures in "${title}"`);
  const bricksLoose = Number((await page.getByTestId('status-bricks').textContent()).split(' / ')[0]);
  assert.ok(bricksLoose < bricksOff, `a loose target should draw fewer bricks (${bricksLoose} vs ${bricksOff})`);
  assert.ok(meanAbsDifference(before, await thumbnail('canvas-3d')) > 1, 'the coarse cut looks like the fine one');
  // The view state reaches the URL a moment after the last change (web/app.js, URL_DELAY_MS).
  await page.waitForURL(/fs=0\.2/, { timeout: 5000 });
});

test('a link to a dataset the server does not have says so and opens nothing', async () => {
  const url = new URL(page.url());
  // A fresh load (not a hash change, which the page would answer by rewriting the hash).
  await page.goto('about:blank');
  await page.goto(`${url.origin}${url.pathname}#v=no-such-volume&l=none`);
  await page.waitForFunction(() => document.getElementById('status-message')?.textContent.includes('not served here'),
    null, { timeout: 10000 });
  assert.match(await page.locator('#status-message').textContent(), /"no-such-volume" is not served here/);
  assert.equal(await page.locator('#scalar-select').inputValue(), 'none');
});

test('the page raised no errors', () => {
  assert.deepEqual(pageErrors, []);
});
