#!/usr/bin/env node
// Runs the Khronos glTF-Validator on every .glb/.gltf under the given directories (or on the given files).
// Prints one JSON summary to stdout: {files, errors, warnings, infos, messages: [{file, code, severity,
// pointer, message}]} (messages lists errors and warnings only). Exit 0 when no file has an error, 1 when one
// has, 2 on usage errors. A file the validator cannot read counts as an error; the run never stops early.
// The validator (2.0.0-dev.3.10) cannot look inside EXT_meshopt_compression: such a glb is validated twice,
// as it is (structure) and once more decoded to plain buffer views (contents; messages say "meshopt-decoded").
import fs from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';
import { MeshoptDecoder } from 'meshoptimizer';

const SEVERITY = ['error', 'warning', 'info', 'hint'];

async function collect(target, out) {
  const st = await fs.stat(target);
  if (st.isDirectory()) {
    const entries = (await fs.readdir(target)).sort();
    for (const name of entries) await collect(path.join(target, name), out);
  } else if (/\.(glb|gltf)$/i.test(target)) {
    out.push(target);
  }
}

const GLB_MAGIC = 0x46546c67, CHUNK_JSON = 0x4e4f534a, CHUNK_BIN = 0x004e4942;

function parseGlb(bytes) {
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (bytes.length < 20 || view.getUint32(0, true) !== GLB_MAGIC) return null;
  let offset = 12, json = null, bin = null;
  while (offset + 8 <= bytes.length) {
    const len = view.getUint32(offset, true), type = view.getUint32(offset + 4, true);
    const chunk = bytes.subarray(offset + 8, offset + 8 + len);
    if (type === CHUNK_JSON && json === null) json = JSON.parse(new TextDecoder().decode(chunk));
    else if (type === CHUNK_BIN && bin === null) bin = chunk;
    offset += 8 + len;
  }
  return json ? { json, bin } : null;
}

function writeGlb(json, bin) {
  const pad = (b, fill) => (b.length % 4 ? Buffer.concat([b, Buffer.alloc(4 - (b.length % 4), fill)]) : b);
  const js = pad(Buffer.from(JSON.stringify(json)), 0x20), bn = pad(Buffer.from(bin), 0);
  const head = Buffer.alloc(12);
  head.writeUInt32LE(GLB_MAGIC, 0);
  head.writeUInt32LE(2, 4);
  head.writeUInt32LE(12 + 8 + js.length + 8 + bn.length, 8);
  const chunk = (len, type) => {
    const b = Buffer.alloc(8);
    b.writeUInt32LE(len, 0);
    b.writeUInt32LE(type, 4);
    return b;
  };
  return new Uint8Array(Buffer.concat([head, chunk(js.length, CHUNK_JSON), js, chunk(bn.length, CHUNK_BIN), bn]));
}

/**
 * The glb with every EXT_meshopt_compression buffer view decoded into one plain BIN buffer and the extension
 * removed, or null when the file does not use it. Throws when a view cannot be decoded.
 */
async function decodeMeshopt(bytes, dir) {
  const glb = parseGlb(bytes);
  if (!glb || !(glb.json.extensionsUsed ?? []).includes('EXT_meshopt_compression')) return null;
  await MeshoptDecoder.ready;
  const json = structuredClone(glb.json);
  const buffers = [];
  for (const [i, b] of (json.buffers ?? []).entries()) {
    if (b.uri) buffers.push(new Uint8Array(await fs.readFile(path.join(dir, decodeURIComponent(b.uri)))));
    else if (i === 0 && glb.bin) buffers.push(glb.bin);
    else buffers.push(null); // a fallback buffer without data
  }
  const parts = [];
  let offset = 0;
  for (const [i, bv] of (json.bufferViews ?? []).entries()) {
    const ext = bv.extensions?.EXT_meshopt_compression;
    let data;
    if (ext) {
      const src = buffers[ext.buffer];
      if (!src) throw new Error(`bufferViews[${i}]: compressed data in buffer ${ext.buffer} is missing`);
      const source = src.subarray(ext.byteOffset ?? 0, (ext.byteOffset ?? 0) + ext.byteLength);
      data = new Uint8Array(ext.count * ext.byteStride);
      MeshoptDecoder.decodeGltfBuffer(data, ext.count, ext.byteStride, source, ext.mode, ext.filter ?? 'NONE');
      delete bv.extensions.EXT_meshopt_compression;
      if (Object.keys(bv.extensions).length === 0) delete bv.extensions;
    } else {
      const src = buffers[bv.buffer];
      if (!src) throw new Error(`bufferViews[${i}] points into buffer ${bv.buffer}, which has no data`);
      data = src.subarray(bv.byteOffset ?? 0, (bv.byteOffset ?? 0) + bv.byteLength);
    }
    if (data.length !== bv.byteLength) {
      throw new Error(`bufferViews[${i}]: decoded ${data.length} bytes, byteLength says ${bv.byteLength}`);
    }
    bv.buffer = 0;
    bv.byteOffset = offset;
    parts.push(data, new Uint8Array((4 - (data.length % 4)) % 4));
    offset += data.length + ((4 - (data.length % 4)) % 4);
  }
  json.buffers = [{ byteLength: offset }];
  const strip = (list) => list?.filter((e) => e !== 'EXT_meshopt_compression');
  json.extensionsUsed = strip(json.extensionsUsed);
  if (json.extensionsRequired) json.extensionsRequired = strip(json.extensionsRequired);
  if (json.extensionsRequired?.length === 0) delete json.extensionsRequired;
  return writeGlb(json, Buffer.concat(parts));
}

function validate(bytes, file) {
  const dir = path.dirname(file);
  return validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 200,
    // Relative URIs (external buffers or images) resolve next to the file; anything else is refused.
    externalResourceFunction: async (uri) => {
      if (/^[a-z][a-z0-9+.-]*:/i.test(uri)) throw new Error(`non-relative URI refused: ${uri}`);
      return new Uint8Array(await fs.readFile(path.join(dir, decodeURIComponent(uri))));
    },
  });
}

/** Validation messages of one file (and of its meshopt-decoded form), with counts. */
async function validateFile(file) {
  const bytes = new Uint8Array(await fs.readFile(file));
  const reports = [{ label: file, report: await validate(bytes, file) }];
  let decoded = null;
  try {
    decoded = await decodeMeshopt(bytes, path.dirname(file));
  } catch (e) {
    reports.push({ label: `${file} (meshopt-decoded)`, failure: `cannot decode EXT_meshopt_compression: ${e.message}` });
  }
  if (decoded) reports.push({ label: `${file} (meshopt-decoded)`, report: await validate(decoded, file) });
  return reports;
}

async function main(args) {
  if (args.length === 0 || args.includes('-h') || args.includes('--help')) {
    process.stderr.write('usage: node tools/validate-gltf.mjs <tileset-dir | file.glb>...\n');
    return 2;
  }
  const files = [];
  for (const a of args) {
    try {
      await collect(a, files);
    } catch (e) {
      process.stderr.write(`validate-gltf: cannot read ${a}: ${e.message}\n`);
      return 2;
    }
  }
  const summary = { files: files.length, errors: 0, warnings: 0, infos: 0, messages: [] };
  for (const file of files) {
    let reports;
    try {
      reports = await validateFile(file);
    } catch (e) {
      reports = [{ label: file, failure: String((e && e.message) || e) }];
    }
    for (const { label, report, failure } of reports) {
      if (failure) {
        summary.errors += 1;
        summary.messages.push({ file: label, code: 'VALIDATOR_FAILED', severity: 'error', pointer: '', message: failure });
        continue;
      }
      const issues = report.issues;
      summary.errors += issues.numErrors;
      summary.warnings += issues.numWarnings;
      summary.infos += issues.numInfos;
      for (const m of issues.messages) {
        if (m.severity > 1) continue;
        summary.messages.push({ file: label, code: m.code, severity: SEVERITY[m.severity], pointer: m.pointer ?? '', message: m.message });
      }
    }
  }
  process.stdout.write(JSON.stringify(summary, null, 2) + '\n');
  if (files.length === 0) process.stderr.write('validate-gltf: no .glb or .gltf file found\n');
  return summary.errors > 0 ? 1 : 0;
}

process.exitCode = await main(process.argv.slice(2));
