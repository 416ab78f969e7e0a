// Levels of detail in real clients (DESIGN.md §8): the bundled Lower East Side data is built three times with
// target/debug/citylod (LOD, --leaves-only, --compression draco into target/e2e/browser-nyc-*) and opened in
// CesiumJS and 3d-tiles-renderer. Measured per client: requests and bytes of the far view, LOD against
// leaves-only; which tiles, depths and feature classes each view draws; that the `clusters` view (camera
// distance at which tileset.json's geometric errors select a tile holding clusters, predictSelection in
// tools/browser.mjs) draws cluster tiles; picks on a cluster and on a landmark there; the Draco tileset loads
// and draws. CITYLOD_BIN overrides the binary (default target/debug/citylod). One JSON line per measurement on stdout; screenshots in target/browser/browser-nyc-*/. Known
// shortfalls of the current tilesets are `todo` tests: they run, print their figures and are reported as TODO.
import { after, before, describe, test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import {
  CLIENTS, FOVY_RAD, REPO, VIEWPORT, buildTileset, distanceShowing, drawnPoints, glbClasses, glbJson, launchBrowser, pickPoints, predictSelection,
  runClient, startServer,
} from '../../tools/browser.mjs';

const INPUT = 'examples/nyc-les/les_buildings.geojson';
const TILESETS = {
  lod: { out: 'target/e2e/browser-nyc-lod', args: [] },
  leaves: { out: 'target/e2e/browser-nyc-leaves', args: ['--leaves-only'] },
  draco: { out: 'target/e2e/browser-nyc-draco', args: ['--compression', 'draco'] },
};
/** The target: the LOD far view loads at most this share of the leaves-only far view's bytes. */
const FAR_BYTES_TARGET = 0.2;
const clients = (process.env.CITYLOD_CLIENTS ?? Object.keys(CLIENTS).join(',')).split(',').filter((c) => c in CLIENTS);
const print = (obj) => process.stdout.write(JSON.stringify(obj) + '\n');

let browser = null;
const servers = {};
const tilesetJson = {};
const classCache = new Map();
/** Feature classes of a tile of tileset `name` ({building: n, cluster: m}). */
const classesOf = (name, uri) => {
  const key = `${name}/${uri}`;
  if (!classCache.has(key)) classCache.set(key, glbClasses(path.join(REPO, TILESETS[name].out, uri)));
  return classCache.get(key);
};
const depthOf = (uri) => uri.replace(/\.glb$/, '').split('/').length - 2; // tiles/0.glb is the root: 0
/** Measurements shared between tests: results[client][key]. */
const results = Object.fromEntries(clients.map((c) => [c, {}]));
let clusterDistanceM = null;

before(async () => {
  for (const [name, { out, args }] of Object.entries(TILESETS)) {
    const t0 = Date.now();
    buildTileset(INPUT, out, args);
    tilesetJson[name] = JSON.parse(fs.readFileSync(path.join(REPO, out, 'tileset.json'), 'utf8'));
    print({ build: name, out, args, ms: Date.now() - t0 });
  }
  const lod = tilesetJson.lod;
  const radiusM = Math.hypot(...[3, 6, 9].map((k) => Math.hypot(...lod.root.boundingVolume.box.slice(k, k + 3))));
  clusterDistanceM = distanceShowing(lod, (uri) => classesOf('lod', uri), 'cluster', radiusM);
  print({ clusterView: { distanceM: clusterDistanceM, predicted: clusterDistanceM && predictSelection(lod, clusterDistanceM) } });
  browser = await launchBrowser();
  for (const name of Object.keys(TILESETS)) servers[name] = await startServer(path.join(REPO, TILESETS[name].out));
});
after(async () => {
  for (const s of Object.values(servers)) await s.close();
  if (browser) await browser.close();
});

/** What a view drew: selected tiles with their depth and classes, and the requested paths. */
function drawn(name, rec) {
  const tiles = (rec.stats?.selectedTileUris ?? []).map((uri) => ({ uri, depth: depthOf(uri), classes: classesOf(name, uri) }));
  return {
    tiles,
    depths: [...new Set(tiles.map((t) => t.depth))].sort((a, b) => a - b),
    classes: [...new Set(tiles.flatMap((t) => Object.keys(t.classes)))].sort(),
  };
}

function logView(name, client, rec, extra = {}) {
  const { selectedTileUris, requestedUris, ...stats } = rec.stats ?? {};
  const d = drawn(name, rec);
  print({
    tileset: `browser-nyc-${name}`, client, view: rec.view, idleMs: rec.idleMs, diffPixels: rec.diffPixels, shadeLevels: rec.shadeLevels,
    ...stats, requestedUris, selected: d.tiles, drawnDepths: d.depths, drawnClasses: d.classes,
    camera: rec.camera, problems: rec.problems,
    shadingProblem: rec.shadingProblem, ...extra,
  });
}

/** predictSelection for the far and mid views (the distances of namedView in viewer/citylod-common.js). */
function namedPrediction(view) {
  const box = tilesetJson.lod.root.boundingVolume.box;
  const radiusM = Math.hypot(...[3, 6, 9].map((k) => Math.hypot(...box.slice(k, k + 3))));
  const farM = (radiusM / Math.sin(Math.min(FOVY_RAD, 2 * Math.atan(Math.tan(FOVY_RAD / 2) * VIEWPORT.width / VIEWPORT.height)) / 2)) * 1.05;
  if (view === 'far') return predictSelection(tilesetJson.lod, farM, -45).map((t) => t.uri);
  if (view === 'mid') return predictSelection(tilesetJson.lod, farM / 2, -40).map((t) => t.uri);
  return undefined;
}

const problemsOf = (result) => result.records.flatMap((r) =>
  [...r.problems, ...(r.shadingProblem ? [r.shadingProblem] : [])].map((p) => `${r.view}: ${p}`));

/** Picks are taken on a grid of this step over the pixels the tileset draws in the clusters view. */
const PICK_STEP_PX = 4;
// Blocks and their landmarks share the `cluster` class (one property table per glb, which CesiumJS needs for
// picking); a landmark has `landmark: true` and the building's source_id and height.
const isLandmark = (f) => f && f.properties.landmark === true;
const isCluster = (f) => f && 'member_count' in f.properties && !isLandmark(f);
const isBuilding = (f) => f && 'height_m' in f.properties && !('member_count' in f.properties);
const pickKey = (f) => `${f.tile}#${f.featureId}#${isCluster(f) ? 'cluster' : isLandmark(f) ? 'landmark' : isBuilding(f) ? 'building' : '?'}`;

describe('NYC Lower East Side, LOD in the browser', () => {
  for (const client of clients) {
    test(`${client}: LOD tileset far, mid and street views load and draw`, { timeout: 180000 }, async () => {
      const name = 'lod';
      const result = await runClient({
        browser, baseUrl: servers[name].url, client, outDir: path.join(REPO, 'target', 'browser', 'browser-nyc-lod'),
        log: (rec) => logView(name, client, rec, { predicted: namedPrediction(rec.view) }),
      });
      print({ tileset: 'browser-nyc-lod', client, totalMs: result.ms });
      results[client].lodViews = result.records;
      assert.deepEqual(problemsOf(result), [], `browser-nyc-lod in ${client}:\n  ${problemsOf(result).join('\n  ')}`);
      for (const rec of result.records) assert.ok(drawn(name, rec).tiles.length > 0, `${rec.view}: no tile selected`);
    });

    test(`${client}: LOD tileset, a view chosen from the geometric errors draws cluster tiles`, { timeout: 180000 }, async () => {
      assert.ok(clusterDistanceM, 'no camera distance draws cluster tiles by the geometric errors in tileset.json');
      const picks = {};
      const result = await runClient({
        browser, baseUrl: servers.lod.url, client, outDir: path.join(REPO, 'target', 'browser', 'browser-nyc-lod'),
        views: [{ name: 'clusters', distance: clusterDistanceM }],
        onView: async (page, _rec, mask) => {
          const t0 = Date.now();
          picks.all = (await pickPoints(page, drawnPoints(mask, PICK_STEP_PX))).filter(Boolean);
          picks.ms = Date.now() - t0;
          return { pickMs: picks.ms };
        },
        log: (rec) => logView('lod', client, rec, { distanceM: clusterDistanceM, predicted: predictSelection(tilesetJson.lod, clusterDistanceM), pickMs: rec.extra?.pickMs }),
      });
      results[client].clusterView = result.records[0];
      results[client].picks = picks.all ?? null;
      assert.deepEqual(problemsOf(result), [], `clusters view in ${client}:\n  ${problemsOf(result).join('\n  ')}`);
      const d = drawn('lod', result.records[0]);
      assert.ok(d.classes.includes('cluster'), `no selected tile holds clusters: ${JSON.stringify(d.tiles)}`);
    });

    test(`${client}: leaves-only tileset far view loads and draws`, { timeout: 120000 }, async () => {
      const result = await runClient({
        browser, baseUrl: servers.leaves.url, client, views: ['far'], outDir: path.join(REPO, 'target', 'browser', 'browser-nyc-leaves'),
        log: (rec) => logView('leaves', client, rec),
      });
      results[client].leavesFar = result.records[0];
      assert.deepEqual(problemsOf(result), [], `browser-nyc-leaves in ${client}:\n  ${problemsOf(result).join('\n  ')}`);
    });

    test(`${client}: Draco tileset loads and draws shaded in every view`, { timeout: 180000 }, async () => {
      const glbs = fs.readdirSync(path.join(REPO, TILESETS.draco.out), { recursive: true }).filter((f) => String(f).endsWith('.glb'));
      for (const f of glbs) {
        const used = glbJson(path.join(REPO, TILESETS.draco.out, String(f))).extensionsUsed ?? [];
        assert.ok(used.includes('KHR_draco_mesh_compression'), `${f} does not use KHR_draco_mesh_compression: ${used}`);
      }
      const result = await runClient({
        browser, baseUrl: servers.draco.url, client, outDir: path.join(REPO, 'target', 'browser', 'browser-nyc-draco'),
        log: (rec) => logView('draco', client, rec),
      });
      print({ tileset: 'browser-nyc-draco', client, totalMs: result.ms, glbs: glbs.length });
      assert.deepEqual(problemsOf(result), [], `browser-nyc-draco in ${client}:\n  ${problemsOf(result).join('\n  ')}`);
    });
  }

  /** Far-view bytes and requests, LOD against leaves-only, per client (null when a run is missing). */
  const farComparison = (client) => {
    const lod = results[client].lodViews?.find((r) => r.view === 'far');
    const leaves = results[client].leavesFar;
    if (!lod?.stats || !leaves?.stats) return null;
    return {
      client,
      lodBytes: lod.stats.bytes, leavesBytes: leaves.stats.bytes, bytesRatio: lod.stats.bytes / leaves.stats.bytes,
      lodRequests: lod.stats.requests, leavesRequests: leaves.stats.requests,
      lodRequested: lod.stats.requestedUris, leavesRequested: leaves.stats.requestedUris,
      lodDrawnDepths: drawn('lod', lod).depths, lodDrawnClasses: drawn('lod', lod).classes,
    };
  };

  test('far view: requests and bytes, LOD against leaves-only (printed)', () => {
    for (const client of clients) {
      const c = farComparison(client);
      assert.ok(c, `${client}: the far views did not run`);
      print({ measurement: 'far-bytes-ratio', ...c, bytesRatio: Number(c.bytesRatio.toFixed(4)) });
    }
  });

  // The LOD far view loads fewer bytes than the leaves-only one: measured 2026-11-28, both clients, 136,004 B in 9
  // requests against 468,856 B in 3, ratio 0.29, since 13 outlines are drawn by their building:parts (before: 143,480
  // B against 477,252 B, 0.30, with landmarks from 20 m above their block; 237,336 B, 0.50, from
  // 30 m, with blocks on a grid of up to e/16; 246,268 B, 0.52, on e/64;
  // 258,916 B, 0.54, before landmarks were put on their block's grid; 0.55
  // before triangles in vertex-cache order; 0.54 before narrower property tables and the buildings of rough blocks
  // re-outlined; 0.55 before interleaved vertex views; 0.69 in 15 requests
  // before the top of the tree was condensed and levels that remove little were left out, --level-ratio 0.8). (Before rough blocks were drawn as their buildings in their level-1
  // tile (hlod::DEMOTE_ERROR_RATIO), one block of a 10 m and a 57 m building set a whole level-1 tile's error to 47 m
  // and the far view refined it to the leaves: ratio 1.17, before that 1.36, 1.77 and 2.03.)
  // Held at a third, so that a regression from today's 0.29 shows while the 20 % target below stays a todo.
  const FAR_BYTES_REGRESSION_BOUND = 1 / 3;
  test('far view: LOD loads at most a third of the leaves-only bytes', () => {
    for (const client of clients) {
      const c = farComparison(client);
      assert.ok(c && c.bytesRatio <= FAR_BYTES_REGRESSION_BOUND, `${client}: LOD far ${c?.lodBytes} B against leaves-only far ${c?.leavesBytes} B (ratio ${c?.bytesRatio.toFixed(3)} > ${FAR_BYTES_REGRESSION_BOUND.toFixed(3)})`);
    }
  });
  // Known shortfall: at 800×600 this 1 km district's far camera allows ~36 m of error near it; one level-2 tile keeps
  // 43.4 m (44.5 m before outlines were drawn by their parts; a block whose Δa of 988 m² is ground its merge filled; drawing it as its level-1 blocks would add more than
  // hlod::DEMOTE_MAX_ADDED_SHARE) and refines to its level-1 tiles (~44 kB), and every ancestor on the way is loaded.
  // Nothing reaches the leaves any more. The issue's ≤ 20 % does not hold here (it does on Boston,
  // far-city.test.mjs: 0.07). With that block demoted (ratio 2, share 0.25 on levels ≥ 2) the far view loads
  // ~70 kB (0.15), but Delft's far view 13 % more and NYC's at 400×300 9.3× instead of 10.8× fewer triangles than
  // full detail (docs/coarse-bytes.md, session 12).
  const SHORTFALL = 'known shortfall: one level-2 tile keeps 43.4 m and refines, and the far view loads every ancestor ' +
    '(measured ratio 0.29 in both clients: 136,004 B vs 468,856 B)';
  test(`far view: LOD loads at most ${FAR_BYTES_TARGET * 100} % of the leaves-only bytes`, { todo: SHORTFALL }, () => {
    for (const client of clients) {
      const c = farComparison(client);
      assert.ok(c && c.bytesRatio <= FAR_BYTES_TARGET, `${client}: ratio ${c?.bytesRatio.toFixed(3)} > ${FAR_BYTES_TARGET}`);
    }
  });
  test('far view: at least one selected tile holds clusters', () => {
    for (const client of clients) {
      const far = results[client].lodViews?.find((r) => r.view === 'far');
      assert.ok(far, `${client}: the far view did not run`);
      const d = drawn('lod', far);
      assert.ok(d.classes.includes('cluster'), `${client}: far view draws depths ${d.depths} with classes ${d.classes}`);
    }
  });

  test('clusters view: fewer bytes than the leaves-only far view (printed)', () => {
    for (const client of clients) {
      const v = results[client].clusterView, leaves = results[client].leavesFar;
      assert.ok(v?.stats && leaves?.stats, `${client}: the clusters or leaves-only view did not run`);
      const ratio = v.stats.bytes / leaves.stats.bytes;
      print({ measurement: 'clusters-view-bytes-ratio', client, distanceM: clusterDistanceM, lodBytes: v.stats.bytes, leavesFarBytes: leaves.stats.bytes,
        bytesRatio: Number(ratio.toFixed(4)), lodRequested: v.stats.requestedUris, drawnDepths: drawn('lod', v).depths });
      assert.ok(v.stats.bytes < leaves.stats.bytes, `${client}: clusters view ${v.stats.bytes} B >= leaves-only far ${leaves.stats.bytes} B`);
    }
  });

  /** The clusters-view picks of a client as a map 'x,y' -> pick (null when that view did not run). */
  const picksAt = (client) => (results[client]?.picks ? new Map(results[client].picks.map((f) => [`${f.x},${f.y}`, f])) : null);
  const clusterTilesOf = (client) =>
    new Set((results[client].clusterView?.stats?.selectedTileUris ?? []).filter((u) => classesOf('lod', u).cluster));

  function assertCluster(client) {
    const picks = results[client].picks;
    assert.ok(picks, `${client}: the clusters view did not run`);
    // A block: a cluster of several buildings (a level may also hold single buildings as one-member clusters).
    const cluster = picks.find((f) => isCluster(f) && Number(f.properties.member_count) > 1);
    print({ measurement: 'pick-cluster', client, distanceM: clusterDistanceM, picked: picks.length,
      clusters: new Set(picks.filter(isCluster).map(pickKey)).size, buildings: new Set(picks.filter(isBuilding).map(pickKey)).size, cluster: cluster ?? null });
    assert.ok(cluster, `${client}: no cluster feature among ${picks.length} picks`);
    assert.ok(Number(cluster.properties.member_count) > 1, `member_count ${cluster.properties.member_count}`);
    // A block is no building: its building_index (noData) reads as missing, not as building 0.
    assert.ok(cluster.properties.building_index == null, `block building_index = ${JSON.stringify(cluster.properties.building_index)}`);
    for (const k of ['dh_m', 'da_m2', 'area_m2']) {
      assert.equal(typeof cluster.properties[k], 'number', `cluster ${k} = ${JSON.stringify(cluster.properties[k])}`);
      assert.ok(Number.isFinite(cluster.properties[k]), `cluster ${k} = ${cluster.properties[k]}`);
    }
  }

  // CesiumJS 1.140 picks, styles and shows features through one property table per glb content (the first
  // primitive's), so citylod writes one class per tile: blocks and their landmarks are both `cluster` features.
  for (const client of clients) {
    test(`${client}: a click on a cluster at the clusters view returns its properties`, () => assertCluster(client));

    test(`${client}: a click on a landmark at the clusters view returns its building properties`, () => {
      const picks = results[client].picks;
      assert.ok(picks, `${client}: the clusters view did not run`);
      const clusterTiles = clusterTilesOf(client);
      const candidates = picks.filter((f) => isLandmark(f) && clusterTiles.has(f.tile));
      const landmark = candidates[0];
      print({ measurement: 'pick-landmark', client, distanceM: clusterDistanceM, landmarkPicks: candidates.length, landmark: landmark ?? null });
      assert.ok(landmark, `${client}: no landmark picked in a tile holding clusters (${[...clusterTiles]})`);
      assert.equal(typeof landmark.properties.source_id, 'string');
      assert.ok(landmark.properties.source_id.length > 0, 'landmark source_id is empty');
      assert.equal(typeof landmark.properties.height_m, 'number');
      assert.ok(landmark.properties.height_m > 0, `landmark height_m ${landmark.properties.height_m}`);
    });
  }

  test('the two clients return the same properties for the same cluster', () => {
    const a = picksAt('cesium'), b = picksAt('3dtr');
    assert.ok(a && b, 'both clients must have run the clusters view');
    // Pixels where both picked the same feature of the same tile (a block: several members).
    const same = [...a.entries()].filter(([key, f]) => {
      const g = b.get(key);
      return g && isCluster(f) && isCluster(g) && f.tile === g.tile && f.featureId === g.featureId && Number(f.properties.member_count) > 1;
    });
    assert.ok(same.length >= 10, `only ${same.length} pixels where both clients picked the same block`);
    for (const [key, f] of same) {
      // A missing value (noData) may come back undefined or null; JSON drops both alike.
      const plain = (props) => JSON.parse(JSON.stringify(props, (k, v) => (v === null ? undefined : v)));
      assert.deepEqual(plain(b.get(key).properties), plain(f.properties), `${f.tile} feature ${f.featureId} at ${key}`);
    }
  });

  test('the two clients pick the same feature class at the same pixel, away from edges', () => {
    const a = picksAt('cesium'), b = picksAt('3dtr');
    assert.ok(a && b, 'both clients must have run the clusters view');
    const kind = (f) => (f ? (isCluster(f) ? 'cluster' : isLandmark(f) ? 'landmark' : 'building') : 'none');
    // Two rasterizers may differ on silhouette pixels (a landmark standing on its block, a block's outline), so
    // only interior pixels count: those whose four grid neighbours 3d-tiles-renderer picks as the same kind.
    const interior = (key) => {
      const [x, y] = key.split(',').map(Number);
      const k = kind(b.get(key));
      return [[PICK_STEP_PX, 0], [-PICK_STEP_PX, 0], [0, PICK_STEP_PX], [0, -PICK_STEP_PX]]
        .every(([dx, dy]) => kind(b.get(`${x + dx},${y + dy}`)) === k);
    };
    const tally = {};
    let interiorClusters = 0;
    for (const key of new Set([...a.keys(), ...b.keys()])) {
      const k = `3dtr:${kind(b.get(key))}/cesium:${kind(a.get(key))}`;
      tally[k] = (tally[k] ?? 0) + 1;
      if (kind(b.get(key)) === 'cluster' && interior(key)) interiorClusters += 1;
    }
    const disagree = [...b.keys()].filter((key) => kind(b.get(key)) === 'cluster' && interior(key) && kind(a.get(key)) !== 'cluster');
    print({ measurement: 'pick-agreement', stepPx: PICK_STEP_PX, tally, interiorClusters, interiorDisagreements: disagree.length });
    assert.ok(interiorClusters >= 10, `only ${interiorClusters} interior cluster pixels to compare`);
    assert.deepEqual(disagree, [], 'interior pixels where 3d-tiles-renderer picks a cluster and CesiumJS does not');
  });
});
