// Browser harness shared by tests/browser/ and tools/screenshot.mjs: starts tools/serve.mjs for a tileset,
// drives Debian's Chromium with playwright-core (never a downloaded browser; WebGL on SwiftShader) and checks
// one client page per view: idle within a time-out, no failed tile, no page error, tiles selected, pixels drawn
// and shaded (lit, not one flat colour).
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';
import { PNG } from 'pngjs';

export const REPO = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
export const CHROMIUM = process.env.CITYLOD_CHROMIUM ?? '/usr/bin/chromium';
export const CHROMIUM_ARGS = [
  '--headless=new', '--no-sandbox', '--disable-background-networking', '--disable-component-update',
  '--disable-sync', '--no-first-run', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
];
export const VIEWPORT = { width: 800, height: 600 };
export const VIEWS = ['far', 'mid', 'street'];
export const CLIENTS = { cesium: 'cesium.html', '3dtr': '3dtr.html?controls=0' };
/** A view must load completely within this time (SwiftShader is slow; a broken glb can hang a client). */
export const IDLE_TIMEOUT_MS = Number(process.env.CITYLOD_IDLE_TIMEOUT_MS ?? 60000);
/** Per-channel difference (0..255) above which a pixel counts as changed by showing the tileset. */
export const PIXEL_TOLERANCE = 8;
/** Pixels (of 800x600 = 480,000) that must change when the tileset is shown: 0.2 % of the view. */
export const MIN_DIFF_PIXELS = 1000;

/** Starts `node tools/serve.mjs --port 0 --root DIR`; resolves {url, close()} once it listens. */
export function startServer(root) {
  return new Promise((resolve, reject) => {
    const child = spawn(process.execPath, [path.join(REPO, 'tools', 'serve.mjs'), '--port', '0', '--root', root], {
      stdio: ['ignore', 'pipe', 'pipe'],
    });
    let out = '', err = '';
    const timer = setTimeout(() => { child.kill(); reject(new Error(`serve.mjs did not start: ${err}`)); }, 10000);
    child.stderr.on('data', (d) => { err += d; });
    child.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/citylod serve: (http:\/\/\S+\/)/);
      if (m) {
        clearTimeout(timer);
        resolve({
          url: m[1],
          close: () => new Promise((r) => { child.once('exit', r); child.kill(); }),
        });
      }
    });
    child.once('exit', (code) => { clearTimeout(timer); reject(new Error(`serve.mjs exited with ${code}: ${err}`)); });
  });
}

export function launchBrowser() {
  if (!fs.existsSync(CHROMIUM)) {
    throw new Error(`${CHROMIUM} not found: run scripts/setup.sh (installs Debian's chromium)`);
  }
  return chromium.launch({ executablePath: CHROMIUM, args: CHROMIUM_ARGS });
}

/** Luminance bins (of 32) that must each hold at least SHADE_BIN_SHARE of the building's interior pixels. */
export const MIN_SHADE_LEVELS = 2;
export const SHADE_BIN_SHARE = 0.02;
/** Below this many interior building pixels the shading is not judged (shadeLevels is null). */
export const MIN_INTERIOR_PIXELS = 500;

/**
 * Compares the screenshot with the tileset shown (a) and hidden (b): diffPixels = pixels whose RGB differs by
 * more than PIXEL_TOLERANCE in some channel; shadeLevels = luminance levels (32 bins, each counted when it
 * holds SHADE_BIN_SHARE) among the changed pixels whose 8 neighbours changed too (edges blend with the
 * background and are left out). Lit walls and roofs give several levels; an unlit mesh (CesiumJS draws glTF
 * without NORMAL unlit) is one flat colour: 1 level. null when there are too few interior pixels to judge.
 */
export function comparePixels(pngA, pngB) {
  const a = PNG.sync.read(pngA), b = PNG.sync.read(pngB);
  if (a.width !== b.width || a.height !== b.height) throw new Error('screenshots differ in size');
  const { width, height } = a;
  const changed = new Uint8Array(width * height);
  let n = 0;
  for (let p = 0, i = 0; p < changed.length; p += 1, i += 4) {
    if (Math.abs(a.data[i] - b.data[i]) > PIXEL_TOLERANCE || Math.abs(a.data[i + 1] - b.data[i + 1]) > PIXEL_TOLERANCE ||
      Math.abs(a.data[i + 2] - b.data[i + 2]) > PIXEL_TOLERANCE) {
      changed[p] = 1;
      n += 1;
    }
  }
  const bins = new Array(32).fill(0);
  let interior = 0;
  for (let y = 1; y < height - 1; y++) {
    for (let x = 1; x < width - 1; x++) {
      const p = y * width + x;
      if (!changed[p]) continue;
      let all = true;
      for (let dy = -1; dy <= 1 && all; dy++) for (let dx = -1; dx <= 1; dx++) if (!changed[p + dy * width + dx]) { all = false; break; }
      if (!all) continue;
      const i = p * 4;
      const lum = 0.2126 * a.data[i] + 0.7152 * a.data[i + 1] + 0.0722 * a.data[i + 2];
      bins[Math.min(31, Math.floor(lum / 8))] += 1;
      interior += 1;
    }
  }
  const shadeLevels = interior < MIN_INTERIOR_PIXELS ? null : bins.filter((c) => c >= SHADE_BIN_SHARE * interior).length;
  return { diffPixels: n, shadeLevels };
}

const frames = (page, n) => page.evaluate((count) => new Promise((resolve) => {
  const step = (k) => (k === 0 ? resolve() : requestAnimationFrame(() => step(k - 1)));
  step(count);
}), n);

/**
 * Opens one client page on the served tileset and goes through the views. Returns one record per view:
 * {view, camera, idleMs, stats, pickCentre, diffPixels, shadeLevels, screenshot, problems: [..],
 * shadingProblem: string|null} (problems empty when the view loaded and drew), plus page-level problems.
 * Never throws for a client-side failure: failures are reported as problems.
 */
export async function runClient({ browser, baseUrl, client, outDir, views = VIEWS, log = () => {} }) {
  const context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  const page = await context.newPage();
  const pageErrors = [], consoleErrors = [], badResponses = [];
  page.on('pageerror', (e) => pageErrors.push(String(e.stack ?? e)));
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('response', (r) => { if (r.status() >= 400) badResponses.push(`${r.status()} ${r.url()}`); });
  page.on('requestfailed', (r) => badResponses.push(`failed ${r.url()}: ${r.failure()?.errorText}`));
  const url = `${baseUrl}viewer/${CLIENTS[client]}${CLIENTS[client].includes('?') ? '&' : '?'}tileset=/tileset/tileset.json`;
  const started = Date.now();
  const records = [];
  try {
    await page.goto(url, { waitUntil: 'load', timeout: 30000 });
    await page.waitForFunction(() => window.__citylod && window.__citylod.ready, null, { timeout: 30000 });
    const loadErrors = await page.evaluate(() => window.__citylod.errors.slice());
    if (loadErrors.length) throw new Error(`page failed to load the tileset: ${loadErrors.join('; ')}`);
    for (const view of views) {
      const rec = { view, problems: [] };
      const t0 = Date.now();
      const camera = await page.evaluate((v) => window.__citylod.setView(v), view);
      rec.camera = { lon: camera.lon, lat: camera.lat, height: camera.height, heading: camera.heading, pitch: camera.pitch };
      try {
        await page.evaluate((ms) => window.__citylod.waitIdle(ms), IDLE_TIMEOUT_MS);
      } catch (e) {
        rec.problems.push(`time-out: ${e.message.split('\n')[0]}`);
      }
      rec.idleMs = Date.now() - t0;
      rec.stats = await page.evaluate(() => window.__citylod.stats());
      // What a click in the middle of the view would show (informational: feature id and properties).
      rec.pickCentre = await page.evaluate(([x, y]) => window.__citylod.pick(x, y), [VIEWPORT.width / 2, VIEWPORT.height / 2]);
      const visible = await page.screenshot({ type: 'png' });
      await page.evaluate(() => window.__citylod.setTilesetVisible(false));
      await frames(page, 3);
      const hidden = await page.screenshot({ type: 'png' });
      await page.evaluate(() => window.__citylod.setTilesetVisible(true));
      await frames(page, 2);
      Object.assign(rec, comparePixels(visible, hidden));
      if (outDir) {
        fs.mkdirSync(outDir, { recursive: true });
        rec.screenshot = path.join(outDir, `${client}-${view}.png`);
        fs.writeFileSync(rec.screenshot, visible);
      }
      const errs = await page.evaluate(() => window.__citylod.errors.slice());
      if (rec.stats.failedTiles.length) rec.problems.push(`failed tiles: ${JSON.stringify(rec.stats.failedTiles)}`);
      if (errs.length) rec.problems.push(`page errors: ${errs.join('; ')}`);
      if (pageErrors.length) rec.problems.push(`uncaught page errors: ${pageErrors.join('; ')}`);
      if (badResponses.length) rec.problems.push(`failed requests: ${badResponses.join('; ')}`);
      if (rec.stats.tilesSelected < 1) rec.problems.push('no tile selected');
      if (rec.diffPixels < MIN_DIFF_PIXELS) {
        rec.problems.push(`only ${rec.diffPixels} pixels change when the tileset is shown (minimum ${MIN_DIFF_PIXELS})`);
      }
      rec.shadingProblem = rec.shadeLevels !== null && rec.shadeLevels < MIN_SHADE_LEVELS
        ? `buildings look unlit: ${rec.shadeLevels} shade level(s) among interior building pixels (minimum ` +
          `${MIN_SHADE_LEVELS}); CesiumJS draws glTF primitives without NORMAL unlit`
        : null;
      rec.consoleErrors = consoleErrors.splice(0);
      log(rec);
      records.push(rec);
    }
  } catch (e) {
    records.push({ view: '(page)', problems: [String(e.message ?? e), ...pageErrors, ...badResponses] });
  } finally {
    await context.close();
  }
  return { client, ms: Date.now() - started, records };
}

/** The tileset directories to test: CITYLOD_TILESETS (comma-separated) or the Makefile's e2e outputs. */
export function tilesetDirs() {
  const env = process.env.CITYLOD_TILESETS;
  const dirs = env ? env.split(',').map((s) => s.trim()).filter(Boolean)
    : ['target/e2e/delft', 'target/e2e/nyc'].map((d) => path.join(REPO, d));
  return dirs.map((d) => path.resolve(REPO, d));
}
