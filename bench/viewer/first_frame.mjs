// Time from a page's first request to its first 3D picture, on a freshly started server each
// run (nothing decoded, no table built): what a user waits for after opening a link.
//   node bench/viewer/first_frame.mjs --strata build/release/strata --runs 5 DATA.strata [MORE...]
// Needs Debian's chromium and playwright-core (npm ci --prefix tests/web). Prints JSON: per run
// the milliseconds from navigation start to the first frame shown (performance.now() when the
// 3D canvas first draws) and that frame's quality, then the median and maximum.
import { spawn } from 'node:child_process';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

import { freePort } from '../../tests/web/free-port.mjs';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.join(here, '../../tests/web/package.json'));
const { chromium } = require('playwright-core');

function parseArgs(argv) {
  const args = { strata: 'build/release/strata', runs: 5, files: [] };
  for (let i = 0; i < argv.length; ++i) {
    if (argv[i] === '--strata') args.strata = argv[++i];
    else if (argv[i] === '--runs') args.runs = Number(argv[++i]);
    else args.files.push(argv[i]);
  }
  if (args.files.length === 0 || !(args.runs >= 1)) throw new Error('usage: first_frame.mjs [--strata BIN] [--runs N] FILE...');
  return args;
}

async function waitForServer(url, child) {
  for (let waited = 0; waited < 30000; waited += 50) {
    if (child.exitCode !== null) throw new Error(`strata serve exited with ${child.exitCode}`);
    try {
      if ((await fetch(`${url}api/datasets`)).ok) return;
    } catch {
      // not listening yet
    }
    await new Promise((resolve) => setTimeout(resolve, 50));
  }
  throw new Error('strata serve did not answer within 30 s');
}

async function oneRun(args, browser) {
  const port = await freePort();
  const child = spawn(path.resolve(args.strata), ['serve', ...args.files, '--host', '127.0.0.1', '--port', String(port)], {
    stdio: 'ignore',
  });
  try {
    const url = `http://127.0.0.1:${port}/`;
    await waitForServer(url, child);
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    await page.goto(url);
    await page.waitForFunction(() => Number(document.querySelector('#canvas-3d').dataset.frames ?? 0) >= 1, null, {
      timeout: 60000,
    });
    const result = await page.evaluate(() => {
      const d = document.querySelector('#canvas-3d').dataset;
      return { first_frame_ms: Number(d.firstFrameMs), quality: d.quality };
    });
    await page.close();
    return result;
  } finally {
    child.kill('SIGTERM');
  }
}

const args = parseArgs(process.argv.slice(2));
const browser = await chromium.launch({ executablePath: '/usr/bin/chromium', args: ['--headless', '--no-sandbox'] });
const runs = [];
for (let i = 0; i < args.runs; ++i) runs.push(await oneRun(args, browser));
await browser.close();
const times = runs.map((r) => r.first_frame_ms).sort((a, b) => a - b);
console.log(JSON.stringify({ runs, median_ms: times[Math.floor(times.length / 2)], max_ms: times[times.length - 1] }, null, 2));
