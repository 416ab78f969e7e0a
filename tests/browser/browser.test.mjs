// Real-browser check of citylod tilesets (DESIGN.md §8): every tileset in CITYLOD_TILESETS (comma-separated
// directories; default target/e2e/delft, target/e2e/nyc and target/e2e/delft-lod22 (3D models, --lod 2.2), built by the
// Rust end-to-end tests) is served by
// tools/serve.mjs and opened in CesiumJS and in 3d-tiles-renderer in Debian's Chromium (SwiftShader WebGL).
// For the views far, mid and street: loading finishes within the time-out, no tile fails, no page error,
// at least one tile is selected, showing the tileset changes at least MIN_DIFF_PIXELS pixels, and those
// pixels are shaded (at least MIN_SHADE_LEVELS luminance levels: lit walls and roofs, not a flat silhouette).
// Screenshots: target/browser/<tileset>/<client>-<view>.png. One JSON line per view on stdout. A missing
// tileset is skipped with a message, or fails when CITYLOD_REQUIRE_TILESETS=1. CITYLOD_CLIENTS=cesium|3dtr
// limits the run to one client; CITYLOD_IDLE_TIMEOUT_MS changes the per-view load time-out (60 s).
import { after, before, describe, test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { CLIENTS, REPO, launchBrowser, runClient, startServer, tilesetDirs } from '../../tools/browser.mjs';

// CITYLOD_CLIENTS=cesium or =3dtr runs one client only (default: both).
const clients = (process.env.CITYLOD_CLIENTS ?? Object.keys(CLIENTS).join(',')).split(',').filter((c) => c in CLIENTS);
const dirs = tilesetDirs().map((dir) => ({ dir, name: path.basename(dir), present: fs.existsSync(path.join(dir, 'tileset.json')) }));
let browser = null;
before(async () => { if (dirs.some((d) => d.present)) browser = await launchBrowser(); });
after(async () => { if (browser) await browser.close(); });

for (const { dir, name, present } of dirs) {
  const missing = `no tileset at ${dir}: run the Rust end-to-end test first (make test-rust keeps its tilesets in ` +
    'target/e2e/) or set CITYLOD_TILESETS=dir1,dir2';
  if (!present && process.env.CITYLOD_REQUIRE_TILESETS === '1') {
    test(`tileset ${name} is present`, () => assert.fail(missing));
    continue;
  }
  describe(`tileset ${name}`, { skip: present ? false : missing }, () => {
    let server = null;
    before(async () => { server = await startServer(dir); });
    after(async () => { if (server) await server.close(); });
    for (const client of clients) {
      test(`${name} loads and draws in ${client}`, { timeout: 240000 }, async () => {
        const result = await runClient({
          browser,
          baseUrl: server.url,
          client,
          outDir: path.join(REPO, 'target', 'browser', name),
          log: (rec) => {
            const { selectedTileUris, requestedUris, ...rest } = rec.stats ?? {};
            process.stdout.write(JSON.stringify({
              tileset: name, client, view: rec.view, idleMs: rec.idleMs, diffPixels: rec.diffPixels, shadeLevels: rec.shadeLevels, ...rest,
              selectedTileUris: (selectedTileUris ?? []).slice(0, 20), selectedTileUrisTotal: (selectedTileUris ?? []).length,
              camera: rec.camera, pickCentre: rec.pickCentre, problems: rec.problems, shadingProblem: rec.shadingProblem, consoleErrors: rec.consoleErrors,
            }) + '\n');
          },
        });
        process.stdout.write(JSON.stringify({ tileset: name, client, totalMs: result.ms }) + '\n');
        const problems = result.records.flatMap((r) =>
          [...r.problems, ...(r.shadingProblem ? [r.shadingProblem] : [])].map((p) => `${r.view}: ${p}`));
        assert.deepEqual(problems, [], `${name} in ${client}:\n  ${problems.join('\n  ')}`);
      });
    }
  });
}
