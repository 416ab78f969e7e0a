#!/usr/bin/env node
// Screenshot of a tileset in a browser client (Debian's Chromium, SwiftShader WebGL), used by `make demo`:
//   node tools/screenshot.mjs --tileset DIR --out FILE.png [--client cesium|3dtr] [--view far|mid|street]
// Serves DIR with tools/serve.mjs, waits until every tile of the view is loaded, writes the PNG and prints one
// JSON line of statistics. Exit 0 on success, 1 when a tile failed, the page errored or nothing was drawn,
// 2 on usage errors. Unlit-looking buildings are only a warning here (the browser test fails on them).
import fs from 'node:fs';
import path from 'node:path';
import { CLIENTS, VIEWS, launchBrowser, runClient, startServer } from './browser.mjs';

function usage(problem) {
  if (problem) process.stderr.write(`screenshot: ${problem}\n`);
  process.stderr.write('usage: node tools/screenshot.mjs --tileset DIR --out FILE.png [--client cesium|3dtr] [--view far|mid|street]\n');
  process.exit(2);
}

const opts = { tileset: null, out: null, client: 'cesium', view: 'far' };
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i++) {
  const key = argv[i].replace(/^--/, '');
  if (!(key in opts) || i + 1 >= argv.length) usage(`bad argument ${argv[i]}`);
  opts[key] = argv[++i];
}
if (!opts.tileset || !opts.out) usage('--tileset and --out are required');
if (!(opts.client in CLIENTS)) usage(`unknown client ${opts.client}`);
if (!VIEWS.includes(opts.view)) usage(`unknown view ${opts.view}`);
if (!fs.existsSync(path.join(opts.tileset, 'tileset.json'))) usage(`no tileset.json in ${opts.tileset}`);

const server = await startServer(opts.tileset);
const browser = await launchBrowser();
let result;
try {
  const tmpDir = fs.mkdtempSync(path.join(path.dirname(path.resolve(opts.out)), '.screenshot-'));
  try {
    result = await runClient({ browser, baseUrl: server.url, client: opts.client, outDir: tmpDir, views: [opts.view] });
    const shot = result.records[0]?.screenshot;
    if (shot) fs.renameSync(shot, opts.out);
  } finally {
    fs.rmSync(tmpDir, { recursive: true, force: true });
  }
} finally {
  await browser.close();
  await server.close();
}
const rec = result.records[0];
const { selectedTileUris, ...stats } = rec.stats ?? {};
process.stdout.write(JSON.stringify({ client: opts.client, view: opts.view, out: opts.out, ms: result.ms, diffPixels: rec.diffPixels, shadeLevels: rec.shadeLevels, ...stats, problems: rec.problems }) + '\n');
if (rec.shadingProblem) process.stderr.write(`screenshot: warning: ${rec.shadingProblem}\n`);
if (rec.problems.length) {
  process.stderr.write(`screenshot: ${rec.problems.join('\n  ')}\n`);
  process.exitCode = 1;
}
