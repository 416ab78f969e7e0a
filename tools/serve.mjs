#!/usr/bin/env node
// Tiny static HTTP server for viewing and testing a tileset, node's http module only (no dependencies).
// Routes: /tileset/* -> --root DIR (the tileset directory), /viewer/* -> the repo's viewer/ pages,
// /cesium/* -> node_modules/cesium/Build/Cesium/, /modules/{three,3d-tiles-renderer}/* -> node_modules.
// Prints "citylod serve: http://HOST:PORT/" once listening (with --port 0 the OS picks a free port), then the
// viewer addresses. Serves the files as they are: no directory listing, nothing outside the mounted folders.
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const REPO = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');

const TYPES = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.mjs': 'text/javascript; charset=utf-8',
  '.css': 'text/css; charset=utf-8',
  '.json': 'application/json',
  '.map': 'application/json',
  '.glb': 'model/gltf-binary',
  '.gltf': 'model/gltf+json',
  '.b3dm': 'application/octet-stream',
  '.subtree': 'application/octet-stream',
  '.bin': 'application/octet-stream',
  '.wasm': 'application/wasm',
  '.png': 'image/png',
  '.jpg': 'image/jpeg',
  '.jpeg': 'image/jpeg',
  '.svg': 'image/svg+xml',
  '.ktx2': 'image/ktx2',
  '.xml': 'application/xml',
  '.txt': 'text/plain; charset=utf-8',
};

function parseArgs(argv) {
  const opts = { port: 8080, host: '127.0.0.1', root: null };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    const value = () => {
      if (i + 1 >= argv.length) usage(`${a} needs a value`);
      return argv[++i];
    };
    if (a === '--port') opts.port = Number(value());
    else if (a === '--root') opts.root = value();
    else if (a === '--host') opts.host = value();
    else if (a === '-h' || a === '--help') usage();
    else if (!a.startsWith('-') && opts.root === null) opts.root = a;
    else usage(`unknown argument ${a}`);
  }
  if (!Number.isInteger(opts.port) || opts.port < 0 || opts.port > 65535) usage('--port must be 0..65535');
  return opts;
}

function usage(problem) {
  if (problem) process.stderr.write(`serve: ${problem}\n`);
  process.stderr.write('usage: node tools/serve.mjs [--port P] [--host H] [--root TILESET_DIR]\n' +
    '  then open http://H:P/viewer/cesium.html?tileset=/tileset/tileset.json (or viewer/3dtr.html)\n');
  process.exit(problem ? 2 : 0);
}

/** URL prefix -> directory on disk. Longest prefix wins; nothing outside these directories is served. */
function mounts(root) {
  const nm = path.join(REPO, 'node_modules');
  const m = [
    ['/viewer/', path.join(REPO, 'viewer')],
    ['/cesium/', path.join(nm, 'cesium', 'Build', 'Cesium')],
    ['/modules/three/', path.join(nm, 'three')],
    ['/modules/3d-tiles-renderer/', path.join(nm, '3d-tiles-renderer')],
  ];
  if (root) m.push(['/tileset/', path.resolve(root)]);
  return m.sort((a, b) => b[0].length - a[0].length);
}

const INDEX = (hasRoot) => `<!doctype html><meta charset="utf-8"><title>citylod viewer</title>
<h1>citylod</h1>${hasRoot ? `<ul>
<li><a href="/viewer/cesium.html?tileset=/tileset/tileset.json">CesiumJS</a></li>
<li><a href="/viewer/3dtr.html?tileset=/tileset/tileset.json">3d-tiles-renderer (three.js)</a></li></ul>`
  : '<p>No tileset: start with <code>node tools/serve.mjs --root DIR</code>.</p>'}`;

function resolvePath(table, urlPath) {
  for (const [prefix, dir] of table) {
    if (!urlPath.startsWith(prefix)) continue;
    const rel = urlPath.slice(prefix.length);
    const file = path.resolve(dir, '.' + path.posix.normalize('/' + rel));
    if (file !== dir && !file.startsWith(dir + path.sep)) return null;
    return file;
  }
  return null;
}

export function createServer({ root }) {
  const table = mounts(root);
  return http.createServer((req, res) => {
    res.setHeader('Access-Control-Allow-Origin', '*');
    res.setHeader('Cache-Control', 'no-cache');
    if (req.method === 'OPTIONS') {
      res.setHeader('Access-Control-Allow-Methods', 'GET, HEAD, OPTIONS');
      res.setHeader('Access-Control-Allow-Headers', '*');
      res.writeHead(204).end();
      return;
    }
    if (req.method !== 'GET' && req.method !== 'HEAD') {
      res.writeHead(405, { 'Content-Type': 'text/plain' }).end('method not allowed\n');
      return;
    }
    let urlPath;
    try {
      urlPath = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    } catch {
      res.writeHead(400, { 'Content-Type': 'text/plain' }).end('bad url\n');
      return;
    }
    if (urlPath === '/favicon.ico') {
      res.writeHead(204).end();
      return;
    }
    if (urlPath === '/' || urlPath === '/index.html') {
      res.writeHead(200, { 'Content-Type': TYPES['.html'] }).end(req.method === 'HEAD' ? undefined : INDEX(Boolean(root)));
      return;
    }
    let file = resolvePath(table, urlPath);
    if (file && fs.existsSync(file) && fs.statSync(file).isDirectory()) file = path.join(file, 'index.html');
    let stat;
    try {
      stat = file && fs.statSync(file);
    } catch {
      stat = null;
    }
    if (!stat || !stat.isFile()) {
      res.writeHead(404, { 'Content-Type': 'text/plain' }).end(`not found: ${urlPath}\n`);
      return;
    }
    const type = TYPES[path.extname(file).toLowerCase()] ?? 'application/octet-stream';
    res.writeHead(200, { 'Content-Type': type, 'Content-Length': stat.size });
    if (req.method === 'HEAD') {
      res.end();
      return;
    }
    const stream = fs.createReadStream(file);
    stream.on('error', () => res.destroy());
    stream.pipe(res);
  });
}

if (process.argv[1] && path.resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
  const opts = parseArgs(process.argv.slice(2));
  if (opts.root && !fs.existsSync(opts.root)) usage(`tileset directory not found: ${opts.root}`);
  if (!fs.existsSync(path.join(REPO, 'node_modules', 'cesium'))) {
    process.stderr.write('serve: node_modules is missing; run `npm ci` (or scripts/setup.sh) first\n');
  }
  const server = createServer(opts);
  server.on('error', (e) => {
    process.stderr.write(`serve: ${e.message}\n`);
    process.exit(1);
  });
  server.listen(opts.port, opts.host, () => {
    const { port } = server.address();
    const base = `http://${opts.host}:${port}/`;
    process.stdout.write(`citylod serve: ${base}\n`);
    if (opts.root) {
      process.stdout.write(`  CesiumJS:          ${base}viewer/cesium.html?tileset=/tileset/tileset.json\n` +
        `  3d-tiles-renderer: ${base}viewer/3dtr.html?tileset=/tileset/tileset.json\n`);
    }
  });
}
