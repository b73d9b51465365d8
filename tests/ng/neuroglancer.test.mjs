// Acceptance test: a real Neuroglancer client (the npm package, bundled with vite into dist/)
// reads `strata serve`'s precomputed volumes in Debian's headless chromium.
//
//   node neuroglancer.test.mjs /path/to/strata        (or STRATA_BINARY=/path/to/strata)
//
// Makes a u8 prisms volume and a Voronoi label volume with the strata CLI, serves them with
// `strata serve --cors <origin of the page>`, serves the bundled Neuroglancer from a node http
// server on another port, opens `precomputed://http://127.0.0.1:PORT/precomputed/<slug>` in a
// single xy cross-section at 5 screen pixels per voxel and compares the pixels at the voxel
// centres with Strata's own slice of the same plane (GET /api/datasets/<slug>/slice).
// Exits 77 (CTest's SKIP_RETURN_CODE) with a message when the npm packages or chromium are
// missing. Screenshots go to STRATA_NG_SHOTS (a folder) when it is set.
import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const HERE = path.dirname(fileURLToPath(import.meta.url));
const DIST = path.join(HERE, 'dist');
const CHROMIUM = process.env.CHROMIUM ?? '/usr/bin/chromium';
// No GPU here: WebGL2 through ANGLE on SwiftShader (software). The rest keeps chromium off the
// network, which is closed on the test machines.
const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--use-gl=angle', '--enable-webgl', '--ignore-gpu-blocklist', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync'];
const ZOOM = 5; // screen pixels per voxel: odd, so a voxel's centre pixel is 2 pixels from its edges
const READY_TIMEOUT_MS = 60000;

function skip(reason) {
  console.log(`skipped: ${reason}`);
  process.exit(77);
}

if (!fs.existsSync(path.join(HERE, 'node_modules', 'neuroglancer'))) {
  skip('tests/ng/node_modules is missing: run `npm ci --prefix tests/ng` (setup.sh does)');
}
if (!fs.existsSync(CHROMIUM)) skip(`chromium not found at ${CHROMIUM}: install Debian's chromium (setup.sh does)`);
const { chromium } = await import('playwright-core');
const { PNG } = await import('pngjs');

// --- the bundle --------------------------------------------------------------------------------

// Builds dist/ with vite when it is missing or older than the lock file or its sources.
function buildBundle() {
  const built = path.join(DIST, 'index.html');
  const inputs = ['package-lock.json', 'node_modules/.package-lock.json', 'vite.config.js', 'index.html', 'src/main.js'];
  const stale = !fs.existsSync(built) ||
    inputs.some((input) => fs.statSync(path.join(HERE, input)).mtimeMs > fs.statSync(built).mtimeMs);
  if (!stale) return;
  console.log('building the Neuroglancer bundle (vite build)');
  execFileSync(process.execPath, [path.join(HERE, 'node_modules/vite/bin/vite.js'), 'build'],
    { cwd: HERE, stdio: ['ignore', 'inherit', 'inherit'] });
}

const MIME = { '.html': 'text/html', '.js': 'text/javascript', '.css': 'text/css', '.wasm': 'application/wasm',
  '.json': 'application/json', '.svg': 'image/svg+xml', '.png': 'image/png' };

function serveStatic(root) {
  const server = http.createServer((request, response) => {
    const name = decodeURIComponent(new URL(request.url, 'http://x').pathname);
    if (name === '/favicon.ico') {
      response.writeHead(204).end(); // the browser asks for one; the page has none
      return;
    }
    const file = path.join(root, name === '/' ? 'index.html' : name);
    if (!file.startsWith(root + path.sep) || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      response.writeHead(404).end();
      return;
    }
    response.writeHead(200, { 'Content-Type': MIME[path.extname(file)] ?? 'application/octet-stream' });
    fs.createReadStream(file).pipe(response);
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

// --- data and strata serve ---------------------------------------------------------------------

function strataBinary() {
  const binary = process.argv[2] ?? process.env.STRATA_BINARY;
  if (!binary) throw new Error('usage: node neuroglancer.test.mjs /path/to/strata (or set STRATA_BINARY)');
  if (!fs.existsSync(binary)) throw new Error(`strata binary not found: ${binary}`);
  return path.resolve(binary);
}

function makeData(strata, dir) {
  const run = (...args) => execFileSync(strata, ['--progress', 'none', ...args], { cwd: dir, stdio: ['ignore', 'ignore', 'pipe'] });
  run('generate', 'prisms', '--size', '96,80,64', '--dtype', 'u8', '-o', 'p.nrrd');
  run('compress', 'p.nrrd', '-o', 'prisms.strata');
  run('generate', 'voronoi', '--size', '64', '-o', 'v.nrrd');
  run('labels', 'encode', 'v.nrrd', '-o', 'cells.strata');
}

// `strata serve --port 0` picks a free port and prints "Serving on http://127.0.0.1:PORT/".
function startStrata(strata, dir, origin) {
  const child = spawn(strata, ['serve', 'prisms.strata', 'cells.strata', '--host', '127.0.0.1', '--port', '0',
    '--cors', origin], { cwd: dir, stdio: ['ignore', 'pipe', 'pipe'] });
  child.output = '';
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`strata serve printed no address: ${child.output}`)), 30000);
    const collect = (chunk) => {
      child.output = (child.output + chunk).slice(-4000);
      const match = /Serving on (http:\/\/127\.0\.0\.1:\d+\/)/.exec(child.output);
      if (match) {
        clearTimeout(timer);
        resolve({ child, url: match[1] });
      }
    };
    child.stdout.on('data', collect);
    child.stderr.on('data', collect);
    child.once('exit', (code) => {
      clearTimeout(timer);
      reject(new Error(`strata serve exited with code ${code}: ${child.output}`));
    });
  });
}

let workDir;
let strata;
let strataUrl;
let pageServer;
let pageUrl;
let browser;
const shotDir = process.env.STRATA_NG_SHOTS;

before(async () => {
  const binary = strataBinary();
  buildBundle();
  workDir = fs.mkdtempSync(path.join(os.tmpdir(), 'strata-ng-'));
  makeData(binary, workDir);
  pageServer = await serveStatic(DIST);
  pageUrl = `http://127.0.0.1:${pageServer.address().port}`;
  ({ child: strata, url: strataUrl } = await startStrata(binary, workDir, pageUrl));
  browser = await chromium.launch({ executablePath: CHROMIUM, args: CHROMIUM_ARGS });
  if (shotDir) fs.mkdirSync(shotDir, { recursive: true });
});

after(async () => {
  await browser?.close();
  pageServer?.close();
  if (strata && strata.exitCode === null) {
    strata.removeAllListeners('exit');
    strata.kill('SIGTERM');
    await new Promise((resolve) => {
      const timer = setTimeout(() => {
        strata.kill('SIGKILL');
        resolve();
      }, 3000);
      strata.once('exit', () => {
        clearTimeout(timer);
        resolve();
      });
    });
  }
  if (workDir) fs.rmSync(workDir, { recursive: true, force: true });
});

// --- Strata's slice and Neuroglancer's picture -------------------------------------------------

// Strata's own level-0 slice across z, raw: float32 samples (scalar) or uint32 labels, row y,
// column x.
async function strataSlice(slug, z) {
  const response = await fetch(`${strataUrl}api/datasets/${slug}/slice?axis=z&index=${z}&level=0&format=raw`);
  assert.equal(response.status, 200, `slice of ${slug}: ${await response.clone().text()}`);
  const [w, h] = response.headers.get('X-Strata-Dims').split(',').map(Number);
  const bytes = await response.arrayBuffer();
  const kind = response.headers.get('Content-Type');
  return { w, h, kind, bytes };
}

// Opens Neuroglancer on one layer, in a single xy panel centred on the volume's middle (x, y)
// at the centre of voxel z, ZOOM screen pixels per voxel; waits until the viewer is ready.
// Returns the decoded screenshot, the panel's rectangle and what happened on the network.
async function showInNeuroglancer(name, layer, dims, z) {
  const state = {
    dimensions: { x: [1e-9, 'm'], y: [1e-9, 'm'], z: [1e-9, 'm'] },
    position: [dims[0] / 2, dims[1] / 2, z + 0.5],
    crossSectionScale: 1 / ZOOM,
    layout: 'xy',
    showAxisLines: false,
    showScaleBar: false,
    showDefaultAnnotations: false,
    crossSectionBackgroundColor: '#000000',
    selectedLayer: { visible: false },
    layers: [{ name, ...layer }],
  };
  const context = await browser.newContext({ viewport: { width: 1024, height: 768 }, deviceScaleFactor: 1 });
  const page = await context.newPage();
  const errors = [];
  const strataResponses = [];
  const failed = [];
  page.on('pageerror', (error) => errors.push(error.message));
  page.on('console', (message) => {
    if (message.type() === 'error') errors.push(`${message.text()} (${message.location().url})`);
  });
  page.on('requestfailed', (request) => failed.push(`${request.url()}: ${request.failure()?.errorText}`));
  page.on('response', (response) => {
    if (response.url().startsWith(strataUrl)) strataResponses.push(response);
  });
  try {
    await page.goto(`${pageUrl}/#!${encodeURIComponent(JSON.stringify(state))}`);
    await page.waitForFunction(() => window.viewer !== undefined, null, { timeout: READY_TIMEOUT_MS });
    try {
      await page.waitForFunction(() => window.viewer.isReady(), null, { timeout: READY_TIMEOUT_MS, polling: 200 });
    } catch (error) {
      const status = await page.evaluate(() => document.body.innerText.slice(0, 2000));
      throw new Error(`Neuroglancer not ready after ${READY_TIMEOUT_MS} ms; errors: ${errors.join(' | ')}; ` +
        `failed requests: ${failed.join(' | ')}; page text: ${status}`);
    }
    // isReady() says the visible chunks are on the GPU; two more frames draw them.
    await page.evaluate(() => new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve))));
    const panel = await page.evaluate(() => {
      const panels = [...document.querySelectorAll('.neuroglancer-rendered-data-panel')]
        .map((element) => element.getBoundingClientRect())
        .filter((rect) => rect.width > 0 && rect.height > 0);
      return panels.map((rect) => ({ left: rect.left, top: rect.top, width: rect.width, height: rect.height }));
    });
    assert.equal(panel.length, 1, `one visible cross-section panel, not ${JSON.stringify(panel)}`);
    const shot = await page.screenshot({ type: 'png' });
    if (shotDir) fs.writeFileSync(path.join(shotDir, `${name}.png`), shot);
    const responses = await Promise.all(strataResponses.map(async (response) => ({
      url: response.url(), status: response.status(), headers: await response.allHeaders() })));
    return { image: PNG.sync.read(shot), panel: panel[0], errors, failed, responses };
  } finally {
    await context.close();
  }
}

// The RGB of the screen pixel whose centre is nearest the centre of voxel (x, y): Neuroglancer
// puts `position` at the panel's centre and voxel i at [i, i + 1), so voxel x's centre lies
// (x + 0.5 - position.x) * ZOOM pixels right of the panel's centre.
function voxelPixel(shown, dims, x, y) {
  const { image, panel } = shown;
  const sx = panel.left + panel.width / 2 + (x + 0.5 - dims[0] / 2) * ZOOM;
  const sy = panel.top + panel.height / 2 + (y + 0.5 - dims[1] / 2) * ZOOM;
  const px = Math.round(sx - 0.5);
  const py = Math.round(sy - 0.5);
  const at = 4 * (py * image.width + px);
  return [image.data[at], image.data[at + 1], image.data[at + 2]];
}

// What every Neuroglancer session must show on the network: every request to strata answered
// 200 with the CORS header naming the page's origin, the info and at least one level-0 chunk.
function checkNetwork(shown, slug) {
  assert.deepEqual(shown.failed, [], 'failed requests');
  const bad = shown.responses.filter((r) => r.status !== 200 || r.headers['access-control-allow-origin'] !== pageUrl);
  assert.deepEqual(bad.map((r) => `${r.url} ${r.status} ${r.headers['access-control-allow-origin']}`), []);
  const urls = shown.responses.map((r) => r.url);
  assert.ok(urls.includes(`${strataUrl}precomputed/${slug}/info`), `info requested: ${urls.join(' ')}`);
  assert.ok(urls.some((url) => url.startsWith(`${strataUrl}precomputed/${slug}/1_1_1/`)),
    `a level-0 chunk requested: ${urls.join(' ')}`);
}

// --- tests -------------------------------------------------------------------------------------

test('Neuroglancer shows the u8 image slice that Strata shows', async () => {
  const dims = [96, 80, 64];
  const z = 37;
  // toNormalized(uint8) is value / 255: grey g = v / 255, written to an 8-bit canvas as
  // round(255 g) = v. The one step of tolerance is the float-to-unorm8 conversion, which OpenGL
  // ES allows to be off by one unit in the last place.
  const shown = await showInNeuroglancer('prisms', {
    type: 'image',
    source: `precomputed://${strataUrl}precomputed/prisms`,
    opacity: 1,
    shader: 'void main() { emitGrayscale(toNormalized(getDataValue())); }',
  }, dims, z);
  assert.deepEqual(shown.errors, [], 'page errors');
  checkNetwork(shown, 'prisms');

  const slice = await strataSlice('prisms', z);
  assert.deepEqual([slice.w, slice.h], [dims[0], dims[1]]);
  const values = new Float32Array(slice.bytes);
  let worst = 0;
  let worstAt = null;
  const greys = new Set();
  for (let y = 0; y < dims[1]; ++y) {
    for (let x = 0; x < dims[0]; ++x) {
      // The precomputed chunk holds the sample rounded and clamped to u8.
      const expected = Math.min(255, Math.max(0, Math.round(values[y * dims[0] + x])));
      const [r, g, b] = voxelPixel(shown, dims, x, y);
      assert.ok(r === g && g === b, `grey at voxel (${x}, ${y}): ${r},${g},${b}`);
      greys.add(r);
      const diff = Math.abs(r - expected);
      if (diff > worst) {
        worst = diff;
        worstAt = { x, y, expected, shown: r };
      }
    }
  }
  // Not blank: the prisms slice spans many grey levels.
  assert.ok(greys.size >= 20, `only ${greys.size} grey levels on screen`);
  console.log(`prisms z=${z}: ${dims[0] * dims[1]} voxel centres, ${greys.size} grey levels, largest difference ${worst}`);
  assert.ok(worst <= 1, `Neuroglancer's grey differs from Strata's slice by ${worst}: ${JSON.stringify(worstAt)}`);
});

test('Neuroglancer partitions the label slice as Strata does', async () => {
  const dims = [64, 64, 64];
  const z = 21;
  const shown = await showInNeuroglancer('cells', {
    type: 'segmentation',
    source: `precomputed://${strataUrl}precomputed/cells`,
    selectedAlpha: 1,
    hoverHighlight: false,
  }, dims, z);
  assert.deepEqual(shown.errors, [], 'page errors');
  checkNetwork(shown, 'cells');

  const slice = await strataSlice('cells', z);
  assert.deepEqual([slice.w, slice.h], [dims[0], dims[1]]);
  const labels = new Uint32Array(slice.bytes);
  // Segment colours are hashes of the ids, drawn opaque (selectedAlpha 1) over black, label 0
  // transparent: the same label must give exactly the same colour everywhere, different labels
  // different colours, and label 0 the background.
  const colourOf = new Map();
  for (let y = 0; y < dims[1]; ++y) {
    for (let x = 0; x < dims[0]; ++x) {
      const label = labels[y * dims[0] + x];
      const colour = voxelPixel(shown, dims, x, y).join(',');
      if (label === 0) {
        assert.equal(colour, '0,0,0', `label 0 at voxel (${x}, ${y}) is not background`);
        continue;
      }
      const seen = colourOf.get(label);
      if (seen === undefined) colourOf.set(label, colour);
      else assert.equal(colour, seen, `label ${label} at voxel (${x}, ${y}): ${colour}, elsewhere ${seen}`);
    }
  }
  console.log(`cells z=${z}: ${dims[0] * dims[1]} voxel centres, ${colourOf.size} labels with distinct colours`);
  assert.ok(colourOf.size >= 5, `only ${colourOf.size} labels in the slice`);
  const byColour = new Map();
  for (const [label, colour] of colourOf) {
    assert.notEqual(colour, '0,0,0', `label ${label} drawn as background`);
    assert.ok(!byColour.has(colour), `labels ${byColour.get(colour)} and ${label} share the colour ${colour}`);
    byColour.set(colour, label);
  }
});
