#!/usr/bin/env node
// Tile budget measurement (issue 4, docs/tile-budget.md): builds Boston and NYC with a range of
// --tile-max-features and --tile-max-triangles (LOD tilesets, and with --modes lod,leaves also --leaves-only) and
// loads each tileset's far, mid and street views in CesiumJS and 3d-tiles-renderer (Debian's Chromium,
// tools/browser.mjs), each view on a fresh page (cold cache). Per view: requests, bytes (encoded body sizes), tiles
// selected, ms until loading settles, and a derived cost of those requests over a network (requestCostMs). A
// tileset byte-identical to one already measured (same tileset.json and glb sizes) reuses its measurements.
// One JSON line per measurement on stdout; a markdown summary in OUT/summary.md.
//   node tools/measure-tile-budget.mjs [--out /tmp/tile-budget] [--datasets boston,nyc] [--modes lod,leaves]
//     [--features 250,500,...] [--triangles FEATURES:TRIANGLES,...] [--clients cesium,3dtr]
//     [--views far,mid,street] [--bin target/release/citylod] [--skip-build]
import { createHash } from 'node:crypto';
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { CLIENTS, REPO, VIEWS, launchBrowser, runClient, startServer } from './browser.mjs';

const DATASETS = {
  boston: { input: path.join(REPO, '..', 'shared', 'data', 'boston', 'boston_buildings.geojson'), args: ['--storey-height', '3.5'] },
  nyc: { input: path.join(REPO, 'examples/nyc-les/les_buildings.geojson'), args: [] },
};
/** The CLI's defaults (citylod build --help). */
const DEFAULT_MAX_TRIANGLES = 200000;
/**
 * Networks assumed for the derived cost (localhost has no latency): round trip, parallel connections (HTTP/1.1,
 * per host), bandwidth. ① a good connection, ② a slow one.
 */
const NETS = [{ name: 'net1', rttMs: 20, parallel: 6, mbitPerS: 50 }, { name: 'net2', rttMs: 80, parallel: 6, mbitPerS: 10 }];

function usage(problem) {
  process.stderr.write(`measure-tile-budget: ${problem}\n`);
  process.exit(2);
}

const opts = {
  out: '/tmp/tile-budget', datasets: 'boston,nyc', modes: 'lod', features: '250,500,1000,2000,5000', triangles: '2000:50000',
  clients: Object.keys(CLIENTS).join(','), views: VIEWS.join(','), bin: 'target/release/citylod', 'skip-build': false,
};
const argv = process.argv.slice(2);
for (let i = 0; i < argv.length; i++) {
  const key = argv[i].replace(/^--/, '');
  if (!(key in opts)) usage(`unknown argument ${argv[i]}`);
  if (typeof opts[key] === 'boolean') opts[key] = true;
  else if (i + 1 < argv.length) opts[key] = argv[++i];
  else usage(`${argv[i]} needs a value`);
}
const list = (s) => s.split(',').map((x) => x.trim()).filter(Boolean);
const bin = path.resolve(REPO, opts.bin);
const outRoot = path.resolve(opts.out);
const clients = list(opts.clients).filter((c) => c in CLIENTS);
const views = list(opts.views).filter((v) => VIEWS.includes(v));
const modes = list(opts.modes);
for (const m of modes) if (!['lod', 'leaves'].includes(m)) usage(`unknown mode ${m} (lod, leaves)`);
for (const d of list(opts.datasets)) if (!(d in DATASETS)) usage(`unknown dataset ${d} (${Object.keys(DATASETS)})`);

/** The budgets: every --features value at the default triangles, plus each --triangles "FEATURES:TRIANGLES". */
const budgets = [
  ...list(opts.features).map((f) => ({ features: Number(f), triangles: DEFAULT_MAX_TRIANGLES })),
  ...list(opts.triangles).map((s) => { const [f, t] = s.split(':').map(Number); return { features: f, triangles: t }; }),
];
const configName = (ds, mode, b) => `${ds}-${mode === 'leaves' ? 'leaves-' : ''}${b.features}${b.triangles === DEFAULT_MAX_TRIANGLES ? '' : `-t${b.triangles}`}`;

const print = (obj) => process.stdout.write(JSON.stringify(obj) + '\n');

/**
 * What requests and bytes would cost over network `net` (ms): requests go out in waves of net.parallel, each wave
 * one round trip (no request waits on another, no HTTP/2 multiplexing), plus the bytes at net.mbitPerS.
 */
function requestCostMs(net, requests, bytes) {
  return Math.round((Math.ceil(requests / net.parallel) * net.rttMs + (bytes * 8) / (net.mbitPerS * 1e6) * 1000) * 10) / 10;
}

/** Totals of a tileset directory: content tiles (glb), tiles in the tree(s), bytes of glb and tileset json. */
function tilesetTotals(dir) {
  let glbs = 0, glbBytes = 0, jsonFiles = 0, jsonBytes = 0, tiles = 0, maxDepth = 0;
  const walkTree = (tile, depth) => {
    tiles += 1;
    maxDepth = Math.max(maxDepth, depth);
    for (const c of tile.children ?? []) walkTree(c, depth + 1);
  };
  const files = fs.readdirSync(dir, { recursive: true }).map(String);
  for (const f of files) {
    const full = path.join(dir, f);
    if (!fs.statSync(full).isFile()) continue;
    if (f.endsWith('.glb')) { glbs += 1; glbBytes += fs.statSync(full).size; }
    if (f.endsWith('.json') && f !== 'build-report.json') {
      jsonFiles += 1;
      jsonBytes += fs.statSync(full).size;
      const j = JSON.parse(fs.readFileSync(full, 'utf8'));
      if (j.root) walkTree(j.root, 0);
    }
  }
  // Same tileset.json files and glb sizes: the same tileset (builds are deterministic).
  const hash = createHash('sha256');
  for (const f of files.filter((x) => x.endsWith('.json') || x.endsWith('.glb')).sort()) {
    const full = path.join(dir, f);
    if (f === 'build-report.json' || !fs.statSync(full).isFile()) continue;
    hash.update(`${f}\0${f.endsWith('.glb') ? fs.statSync(full).size : fs.readFileSync(full, 'utf8')}\0`);
  }
  return { glbs, glbBytes, jsonFiles, jsonBytes, totalBytes: glbBytes + jsonBytes, treeTiles: tiles, maxDepth,
    fingerprint: hash.digest('hex').slice(0, 16) };
}

function build(ds, mode, b, out) {
  fs.rmSync(out, { recursive: true, force: true });
  const args = ['build', DATASETS[ds].input, '--out', out, '--quiet', ...DATASETS[ds].args, ...(mode === 'leaves' ? ['--leaves-only'] : []),
    '--tile-max-features', String(b.features), '--tile-max-triangles', String(b.triangles)];
  const t0 = Date.now();
  const r = spawnSync(bin, args, { encoding: 'utf8' });
  if (r.status !== 0) throw new Error(`${bin} ${args.join(' ')} failed (${r.status}): ${r.stderr}`);
  return Date.now() - t0;
}

const depthOf = (uri) => uri.replace(/\.glb$/, '').split('/').length - 2; // tiles/0.glb is the root: 0

if (!fs.existsSync(bin)) usage(`${bin} not found: cargo build --release -p citylod`);
fs.mkdirSync(outRoot, { recursive: true });
print({ kind: 'setup', bin, out: outRoot, budgets, clients, views, nets: NETS, started: new Date().toISOString() });

const rows = [];
const tilesets = [];
const browser = await launchBrowser();
try {
  for (const ds of list(opts.datasets)) for (const mode of modes) {
    for (const b of budgets) {
      const name = configName(ds, mode, b);
      const dir = path.join(outRoot, name);
      const buildMs = opts['skip-build'] && fs.existsSync(path.join(dir, 'tileset.json')) ? null : build(ds, mode, b, dir);
      const totals = tilesetTotals(dir);
      const same = tilesets.find((t) => t.dataset === ds && t.fingerprint === totals.fingerprint);
      const ts = { kind: 'tileset', name, dataset: ds, mode, maxFeatures: b.features, maxTriangles: b.triangles, buildMs, ...totals,
        sameAs: same ? same.name : null };
      tilesets.push(ts);
      print(ts);
      if (same) {
        // Byte-identical to a tileset already measured: the same requests and bytes; not loaded again.
        for (const r of rows.filter((x) => x.name === same.name)) {
          const row = { ...r, name, mode, maxFeatures: b.features, maxTriangles: b.triangles, sameAs: same.name };
          rows.push(row);
          print(row);
        }
        continue;
      }
      const server = await startServer(dir);
      try {
        for (const client of clients) {
          for (const view of views) {
            // One fresh page (and browser context: empty cache) per view, so each view's requests are its own.
            const result = await runClient({ browser, baseUrl: server.url, client, views: [view], outDir: path.join(outRoot, 'shots', name) });
            for (const rec of result.records) {
              const { selectedTileUris = [], requestedUris = [], ...stats } = rec.stats ?? {};
              const glbRequests = requestedUris.filter((u) => u.endsWith('.glb')).length;
              const row = {
                kind: 'view', name, dataset: ds, mode, maxFeatures: b.features, maxTriangles: b.triangles, client, view: rec.view,
                requests: stats.requests ?? null, glbRequests, bytes: stats.bytes ?? null,
                refetches: requestedUris.length - new Set(requestedUris).size,
                tilesSelected: stats.tilesSelected ?? null, tilesLoaded: stats.tilesLoaded ?? null,
                selectedDepths: [...new Set(selectedTileUris.map(depthOf))].sort((x, y) => x - y),
                idleMs: rec.idleMs ?? null, pageMs: result.ms, diffPixels: rec.diffPixels ?? null,
                ...Object.fromEntries(NETS.map((n) => [`${n.name}Ms`, stats.requests != null ? requestCostMs(n, stats.requests, stats.bytes) : null])),
                problems: rec.problems, shadingProblem: rec.shadingProblem ?? null, consoleErrors: rec.consoleErrors ?? [],
                sameAs: null,
              };
              rows.push(row);
              print(row);
            }
          }
        }
      } finally {
        await server.close();
      }
    }
  }
} finally {
  await browser.close();
}

// Markdown summary (the tables of docs/tile-budget.md): per dataset and mode, one row per budget; requests / MB per
// view of the first client (the others in parentheses where they differ), sums over the views, derived network
// costs of the first client, and settle times summed per client.
const mb = (n) => (n / 1e6).toFixed(2);
const sum = (rs, f) => rs.reduce((a, r) => a + (r[f] ?? 0), 0);
const lines = [`Measured ${new Date().toISOString()} with ${path.relative(REPO, bin) || bin}. Derived network cost, summed over ` +
  `the views: ${NETS.map((n, i) => `${'①②③④'[i]} ${n.rttMs} ms round trip, ${n.parallel} parallel connections, ${n.mbitPerS} Mbit/s`).join('; ')}.`, ''];
for (const ds of list(opts.datasets)) for (const mode of modes) {
  const [first, ...others] = clients;
  lines.push(`### ${ds}${mode === 'leaves' ? ', --leaves-only' : ''}`, '',
    `| features / triangles | glb tiles | tileset MB | ${views.map((v) => `${v}: req / MB`).join(' | ')} | Σ req | Σ MB | ` +
    `${NETS.map((_, i) => `Σ net s ${'①②③④'[i]}`).join(' | ')} | Σ settle s ${clients.join(' / ')} |`,
    '|' + '---|'.repeat(5 + views.length + NETS.length + 1));
  for (const ts of tilesets.filter((t) => t.dataset === ds && t.mode === mode)) {
    const of = (c) => rows.filter((x) => x.name === ts.name && x.client === c);
    const mine = of(first);
    const cells = views.map((v) => {
      const r = mine.find((x) => x.view === v);
      if (!r) return '–';
      let cell = `${r.requests} / ${mb(r.bytes)}${r.problems.length ? ' ⚠' : ''}`;
      for (const c of others) {
        const o = of(c).find((x) => x.view === v);
        if (o && (o.requests !== r.requests || o.bytes !== r.bytes)) cell += ` (${o.requests} / ${mb(o.bytes)})`;
      }
      return cell;
    });
    const same = ts.sameAs ? ` (= ${ts.sameAs.slice(ds.length + 1)})` : '';
    lines.push(`| ${ts.maxFeatures.toLocaleString('en-US')} / ${ts.maxTriangles.toLocaleString('en-US')}${same} | ${ts.glbs} | ` +
      `${mb(ts.totalBytes)} | ${cells.join(' | ')} | ${sum(mine, 'requests')} | ${mb(sum(mine, 'bytes'))} | ` +
      `${NETS.map((n) => (sum(mine, `${n.name}Ms`) / 1000).toFixed(2)).join(' | ')} | ` +
      `${clients.map((c) => (sum(of(c), 'idleMs') / 1000).toFixed(1)).join(' / ')} |`);
  }
  lines.push('');
}
const problems = rows.filter((r) => !r.sameAs && (r.problems.length || r.shadingProblem));
lines.push(problems.length ? `Problems (⚠): ${problems.length} views` : 'No failed tile, page error or time-out in any view.');
for (const r of problems) lines.push(`- ${r.name} ${r.client} ${r.view}: ${[...r.problems, r.shadingProblem].filter(Boolean).join('; ')}`);
fs.writeFileSync(path.join(outRoot, 'summary.md'), lines.join('\n') + '\n');
print({ kind: 'done', summary: path.join(outRoot, 'summary.md'), views: rows.length, problems: problems.length, finished: new Date().toISOString() });
