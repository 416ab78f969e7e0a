// Browser harness shared by tests/browser/ and tools/screenshot.mjs: starts tools/serve.mjs for a tileset,
// drives Debian's Chromium with playwright-core (never a downloaded browser; WebGL on SwiftShader) and checks
// one client page per view: idle within a time-out, no failed tile, no page error, tiles selected, pixels drawn
// and shaded (lit, not one flat colour).
import { spawn, spawnSync } from 'node:child_process';
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
  return { diffPixels: n, shadeLevels, changed, width, height };
}

const frames = (page, n) => page.evaluate((count) => new Promise((resolve) => {
  const step = (k) => (k === 0 ? resolve() : requestAnimationFrame(() => step(k - 1)));
  step(count);
}), n);

/**
 * Opens one client page on the served tileset and goes through the views (names, or {name, distance}: a
 * camera `distance` metres from the tileset's centre at pitch -45). onView(page, rec, {changed, width,
 * height}) runs after the screenshots with the tileset shown (changed: 1 per pixel the tileset draws); what
 * it returns is kept as rec.extra. Returns one record per view:
 * {view, camera, idleMs, stats, pickCentre, diffPixels, shadeLevels, screenshot, problems: [..],
 * shadingProblem: string|null} (problems empty when the view loaded and drew), plus page-level problems.
 * Never throws for a client-side failure: failures are reported as problems.
 */
export async function runClient({ browser, baseUrl, client, outDir, views = VIEWS, onView = null, log = () => {} }) {
  const context = await browser.newContext({ viewport: VIEWPORT, deviceScaleFactor: 1 });
  const page = await context.newPage();
  const pageErrors = [], consoleErrors = [], badResponses = [];
  page.on('pageerror', (e) => pageErrors.push(String(e.stack ?? e)));
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('response', (r) => { if (r.status() >= 400) badResponses.push(`${r.status()} ${r.url()}`); });
  page.on('requestfailed', (r) => badResponses.push(`failed ${r.url()}: ${r.failure()?.errorText}`));
  // The page starts at the first view (a {distance} view as the number of metres), so that nothing a
  // default view would request is counted in the first view's requests and bytes.
  const first = views[0];
  const initial = typeof first === 'string' ? first : String(first.distance);
  const url = `${baseUrl}viewer/${CLIENTS[client]}${CLIENTS[client].includes('?') ? '&' : '?'}` +
    `tileset=/tileset/tileset.json&view=${encodeURIComponent(initial)}`;
  const started = Date.now();
  const records = [];
  try {
    await page.goto(url, { waitUntil: 'load', timeout: 30000 });
    await page.waitForFunction(() => window.__citylod && window.__citylod.ready, null, { timeout: 30000 });
    const loadErrors = await page.evaluate(() => window.__citylod.errors.slice());
    if (loadErrors.length) throw new Error(`page failed to load the tileset: ${loadErrors.join('; ')}`);
    for (const view of views) {
      const rec = { view: typeof view === 'string' ? view : view.name, problems: [] };
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
      const { changed, width, height, ...pixels } = comparePixels(visible, hidden);
      Object.assign(rec, pixels);
      if (onView) rec.extra = await onView(page, rec, { changed, width, height });
      if (outDir) {
        fs.mkdirSync(outDir, { recursive: true });
        rec.screenshot = path.join(outDir, `${client}-${rec.view}.png`);
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
    : ['target/e2e/delft', 'target/e2e/nyc', 'target/e2e/delft-lod22'].map((d) => path.join(REPO, d));
  return dirs.map((d) => path.resolve(REPO, d));
}

/** The debug binary the Makefile's `cargo nextest` run leaves behind (CITYLOD_BIN overrides). */
export const CITYLOD_BIN = path.resolve(REPO, process.env.CITYLOD_BIN ?? 'target/debug/citylod');

/**
 * Builds a tileset with `citylod build INPUT --out OUT ...args` (paths relative to the repository). Throws a
 * message naming the missing binary and how to build it when CITYLOD_BIN does not exist.
 */
export function buildTileset(input, out, args = []) {
  if (!fs.existsSync(CITYLOD_BIN)) {
    throw new Error(`${CITYLOD_BIN} not found: run \`cargo build -p citylod\` (make test builds it in its ` +
      'cargo nextest step) or set CITYLOD_BIN');
  }
  const r = spawnSync(CITYLOD_BIN, ['build', path.resolve(REPO, input), '--out', path.resolve(REPO, out), '--quiet', ...args],
    { encoding: 'utf8' });
  if (r.status !== 0) throw new Error(`citylod build ${input} ${args.join(' ')} failed (${r.status}): ${r.stderr}`);
  return path.resolve(REPO, out);
}

/** The glTF JSON chunk of a glb file. */
export function glbJson(file) {
  const b = fs.readFileSync(file);
  if (b.readUInt32LE(0) !== 0x46546c67) throw new Error(`${file} is not a glb`);
  const len = b.readUInt32LE(12);
  return JSON.parse(b.subarray(20, 20 + len).toString('utf8'));
}

/** Feature counts per metadata class of a glb ({building: 26, cluster: 1}), from its property tables. */
export function glbClasses(file) {
  const tables = glbJson(file).extensions?.EXT_structural_metadata?.propertyTables ?? [];
  const counts = {};
  for (const t of tables) if (t.count > 0) counts[t.class] = (counts[t.class] ?? 0) + t.count;
  return counts;
}

/** Vertical field of view (radians) both viewer pages use: 60 degrees across the wider side. */
export const FOVY_RAD = 2 * Math.atan(Math.tan(Math.PI / 6) / (VIEWPORT.width / VIEWPORT.height));
/** Screen-space error both viewer pages refine to (maximumScreenSpaceError / errorTarget), pixels. */
export const MAX_SSE_PX = 16;

/**
 * The tiles a standard REPLACE traversal (no skipping) draws for a camera distanceM metres from the root
 * box's centre looking north at pitchDeg, in the tileset's root frame (assumes an ENU root transform and no
 * child transforms, as citylod writes): a tile is drawn when its screen-space error geometricError·H /
 * (d·2·tan(fovy/2)) is at most MAX_SSE_PX or it has no children, d = distance to its box. Returns
 * [{uri, depth, geometricError, distanceM, ssePx}]. Frustum culling is ignored (the whole tileset is in view).
 */
export function predictSelection(tilesetJson, distanceM, pitchDeg = -45) {
  const root = tilesetJson.root;
  const c = root.boundingVolume.box.slice(0, 3);
  const p = pitchDeg * Math.PI / 180;
  const eye = [c[0], c[1] - distanceM * Math.cos(p), c[2] - distanceM * Math.sin(p)];
  const boxDistance = (box) => {
    const d = [0, 1, 2].map((i) => eye[i] - box[i]);
    let sq = 0;
    for (let k = 0; k < 3; k++) {
      const u = box.slice(3 + 3 * k, 6 + 3 * k), len = Math.hypot(...u);
      if (len === 0) continue;
      const t = Math.abs((d[0] * u[0] + d[1] * u[1] + d[2] * u[2]) / len);
      sq += Math.max(0, t - len) ** 2;
    }
    return Math.sqrt(sq);
  };
  const out = [];
  const walk = (tile, depth) => {
    if (depth > 0 && tile.transform) throw new Error('predictSelection: child transforms are not supported');
    const distM = Math.max(boxDistance(tile.boundingVolume.box), 1e-6);
    const ssePx = (tile.geometricError * VIEWPORT.height) / (distM * 2 * Math.tan(FOVY_RAD / 2));
    const children = tile.children ?? [];
    if (children.length && ssePx > MAX_SSE_PX) { for (const ch of children) walk(ch, depth + 1); return; }
    if (tile.content?.uri) out.push({ uri: tile.content.uri, depth, geometricError: tile.geometricError, distanceM: distM, ssePx });
  };
  walk(root, 0);
  return out;
}

/**
 * A camera distance (m from the root centre, pitch -45) at which predictSelection draws tiles holding
 * feature class `cls` (classesOf(uri) -> counts): the geometric middle of the nearest range of distances
 * (scanned from minM outwards in 2 % steps up to 200·minM) whose selection stays the same over at least a
 * factor `minSpan`. null when there is none.
 */
export function distanceShowing(tilesetJson, classesOf, cls, minM, minSpan = 1.5) {
  let runStart = null, runKey = null;
  for (let d = minM; d <= minM * 200; d *= 1.02) {
    const sel = predictSelection(tilesetJson, d);
    const key = sel.some((t) => classesOf(t.uri)[cls]) ? sel.map((t) => t.uri).join(',') : null;
    if (key !== runKey) { runStart = d; runKey = key; }
    if (key && d / runStart >= minSpan) {
      // Extend the run to its end, then take the middle.
      let end = d;
      while (end * 1.02 <= minM * 200 && predictSelection(tilesetJson, end * 1.02).map((t) => t.uri).join(',') === key) end *= 1.02;
      return Math.sqrt(runStart * end);
    }
  }
  return null;
}

/** Pixels [x, y] on a stepPx grid where the tileset draws (changed mask from runClient's onView). */
export function drawnPoints({ changed, width, height }, stepPx = 3) {
  const pts = [];
  for (let y = 0; y < height; y += stepPx) for (let x = 0; x < width; x += stepPx) if (changed[y * width + x]) pts.push([x, y]);
  return pts;
}

/** window.__citylod.pick at each screen point [x, y]: {x, y, tile, featureId, properties} or null per point. */
export async function pickPoints(page, points) {
  return page.evaluate((pts) => pts.map(([x, y]) => {
    const f = window.__citylod.pick(x, y);
    return f ? { x, y, ...f } : null;
  }), points);
}
