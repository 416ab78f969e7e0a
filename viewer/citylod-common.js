// Shared by viewer/cesium.html and viewer/3dtr.html: camera views computed from a tileset's root bounding
// volume, WGS84 geodetic <-> ECEF helpers, request/byte accounting and error recording for window.__citylod.
// Frames: positions are ECEF metres; a view is {position, direction, up} (unit vectors) in ECEF plus the
// geodetic description {lon, lat, height (ellipsoidal m), heading, pitch (degrees, Cesium's conventions)}.

const WGS84_A = 6378137.0;
const WGS84_F = 1 / 298.257223563;
const WGS84_E2 = WGS84_F * (2 - WGS84_F);
const WGS84_B = WGS84_A * (1 - WGS84_F);
const DEG = Math.PI / 180;

/** The street view's camera height above the tileset's lowest point, metres. */
export const STREET_HEIGHT_M = 50;

const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => scale(a, 1 / Math.hypot(a[0], a[1], a[2]));

/** Geodetic (degrees, ellipsoidal metres) to ECEF metres. */
export function geodeticToEcef(lonDeg, latDeg, height) {
  const lon = lonDeg * DEG, lat = latDeg * DEG;
  const n = WGS84_A / Math.sqrt(1 - WGS84_E2 * Math.sin(lat) ** 2);
  return [
    (n + height) * Math.cos(lat) * Math.cos(lon),
    (n + height) * Math.cos(lat) * Math.sin(lon),
    (n * (1 - WGS84_E2) + height) * Math.sin(lat),
  ];
}

/** ECEF metres to geodetic {lon, lat (degrees), height (m)} (Bowring, sub-millimetre near the surface). */
export function ecefToGeodetic([x, y, z]) {
  const p = Math.hypot(x, y);
  const ep2 = (WGS84_A ** 2 - WGS84_B ** 2) / WGS84_B ** 2;
  const th = Math.atan2(z * WGS84_A, p * WGS84_B);
  const lat = Math.atan2(z + ep2 * WGS84_B * Math.sin(th) ** 3, p - WGS84_E2 * WGS84_A * Math.cos(th) ** 3);
  const n = WGS84_A / Math.sqrt(1 - WGS84_E2 * Math.sin(lat) ** 2);
  return { lon: Math.atan2(y, x) / DEG, lat: lat / DEG, height: p / Math.cos(lat) - n };
}

/** East, north, up unit vectors (ECEF) at a geodetic position given in degrees. */
export function enuAxes(lonDeg, latDeg) {
  const lon = lonDeg * DEG, lat = latDeg * DEG;
  return {
    east: [-Math.sin(lon), Math.cos(lon), 0],
    north: [-Math.sin(lat) * Math.cos(lon), -Math.sin(lat) * Math.sin(lon), Math.cos(lat)],
    up: [Math.cos(lat) * Math.cos(lon), Math.cos(lat) * Math.sin(lon), Math.sin(lat)],
  };
}

function applyPoint(m, p) {
  return [0, 1, 2].map((r) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
}
function applyVector(m, v) {
  return [0, 1, 2].map((r) => m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2]);
}

/**
 * The root bounding volume as an ECEF centre with local east/north/up axes and half extents along them (m).
 * Supports box and sphere (in the root transform's frame) and region (radians, metres). Throws on none.
 */
export function rootExtent(tilesetJson) {
  const root = tilesetJson.root;
  const m = root.transform ?? [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
  const bv = root.boundingVolume ?? {};
  let center, axes;
  if (bv.box) {
    const b = bv.box;
    center = applyPoint(m, [b[0], b[1], b[2]]);
    axes = [applyVector(m, b.slice(3, 6)), applyVector(m, b.slice(6, 9)), applyVector(m, b.slice(9, 12))];
  } else if (bv.sphere) {
    const s = bv.sphere;
    center = applyPoint(m, s.slice(0, 3));
    const r = Math.hypot(...applyVector(m, [s[3], 0, 0]));
    axes = [[r, 0, 0], [0, r, 0], [0, 0, r]];
  } else if (bv.region) {
    const [w, s, e, n, h0, h1] = bv.region;
    const lon = (w + e) / 2 / DEG, lat = (s + n) / 2 / DEG;
    center = geodeticToEcef(lon, lat, (h0 + h1) / 2);
    const ax = enuAxes(lon, lat);
    const ex = ((e - w) / 2) * WGS84_A * Math.cos(lat * DEG);
    const ey = ((n - s) / 2) * WGS84_A;
    axes = [scale(ax.east, ex), scale(ax.north, ey), scale(ax.up, (h1 - h0) / 2)];
  } else {
    throw new Error('root has no box, sphere or region bounding volume');
  }
  const geo = ecefToGeodetic(center);
  const { east, north, up } = enuAxes(geo.lon, geo.lat);
  const extent = (dir) => axes.reduce((acc, a) => acc + Math.abs(dot(a, dir)), 0);
  return { center, east, north, up, ex: extent(east), ey: extent(north), ez: extent(up) };
}

/** A camera at an ECEF position looking along heading/pitch (degrees; heading clockwise from north). */
export function orientedView(position, headingDeg, pitchDeg) {
  const geo = ecefToGeodetic(position);
  const { east, north, up } = enuAxes(geo.lon, geo.lat);
  const h = headingDeg * DEG, p = pitchDeg * DEG;
  const horiz = add(scale(east, Math.sin(h)), scale(north, Math.cos(h)));
  const direction = norm(add(scale(horiz, Math.cos(p)), scale(up, Math.sin(p))));
  const camUp = norm(add(scale(horiz, -Math.sin(p)), scale(up, Math.cos(p))));
  return { position, direction, up: camUp, lon: geo.lon, lat: geo.lat, height: geo.height, heading: headingDeg, pitch: pitchDeg };
}

/** {lon, lat, height, heading, pitch} (degrees, ellipsoidal metres) to a view. */
export function geodeticView({ lon, lat, height, heading = 0, pitch = -45 }) {
  return orientedView(geodeticToEcef(lon, lat, height), heading, pitch);
}

/** A camera distanceM metres from the root extent's centre, looking north at it at pitchDeg (degrees). */
export function centredView(extent, distanceM, pitchDeg = -45) {
  const probe = orientedView(extent.center, 0, pitchDeg);
  return orientedView(add(extent.center, scale(probe.direction, -distanceM)), 0, pitchDeg);
}

/**
 * Named views from the root extent, for a perspective camera with vertical field of view fovyRad and the
 * given aspect (width / height):
 *   far:    the whole bounding sphere fits the narrower field of view, looking north at pitch -45 degrees;
 *   mid:    half that distance at pitch -40 degrees (about a quarter of the tileset's area in view);
 *   street: STREET_HEIGHT_M above the lowest point, a quarter of the north-south extent (at most 250 m)
 *           south of the centre, looking north at pitch -12 degrees.
 */
export function namedView(extent, name, fovyRad, aspect) {
  const { center, north, up, ex, ey, ez } = extent;
  const fovx = 2 * Math.atan(Math.tan(fovyRad / 2) * aspect);
  const half = Math.min(fovyRad, fovx) / 2;
  const radius = Math.max(Math.hypot(ex, ey, ez), 1);
  const farDistance = (radius / Math.sin(half)) * 1.05;
  if (name === 'far') return { name, ...centredView(extent, farDistance, -45) };
  if (name === 'mid') return { name, ...centredView(extent, farDistance / 2, -40) };
  if (name === 'street') {
    const ground = add(center, scale(up, -ez));
    const back = Math.min(ey / 2, 250);
    return { name, ...orientedView(add(add(ground, scale(north, -back)), scale(up, STREET_HEIGHT_M)), 0, -12) };
  }
  throw new Error(`unknown view ${name} (far, mid, street)`);
}


/**
 * Query parameters of the page: tileset URL (required), optional initial view: a name (far, mid, street;
 * default far) or a number, the camera's distance in metres from the tileset's centre at pitch -45 degrees.
 */
export function pageParams() {
  const q = new URLSearchParams(location.search);
  const view = q.get('view') ?? 'far';
  return { tileset: q.get('tileset'), view: /^\d+(\.\d+)?$/.test(view) ? { distance: Number(view), pitch: -45 } : view };
}

/** Records page errors (window error / unhandled rejection) into the returned array. */
export function recordPageErrors() {
  const errors = [];
  window.addEventListener('error', (e) => errors.push(String(e.message ?? e.error ?? e)));
  window.addEventListener('unhandledrejection', (e) => errors.push(`unhandled rejection: ${e.reason?.stack ?? e.reason}`));
  return errors;
}

// Keep every resource timing entry (the default buffer holds 250): they are the request and byte counts.
performance.setResourceTimingBufferSize(1000000);

/**
 * Requests and bytes (encoded body sizes) fetched so far from below the tileset's directory, and the
 * requested paths (relative to that directory, sorted, one entry per request: repeats show re-fetches).
 */
export function resourceStats(tilesetUrl) {
  const base = new URL('.', new URL(tilesetUrl, location.href)).href;
  let requests = 0, bytes = 0;
  const requestedUris = [];
  for (const e of performance.getEntriesByType('resource')) {
    if (!e.name.startsWith(base)) continue;
    requests += 1;
    bytes += e.encodedBodySize || e.transferSize || 0;
    requestedUris.push(decodeURIComponent(e.name.slice(base.length).split(/[?#]/)[0]));
  }
  return { requests, bytes, requestedUris: requestedUris.sort() };
}

/** A tile URI relative to the tileset's directory (absolute URLs elsewhere are kept). */
export function relativeUri(tilesetUrl, uri) {
  const base = new URL('.', new URL(tilesetUrl, location.href)).href;
  const abs = new URL(uri, base).href;
  return abs.startsWith(base) ? decodeURIComponent(abs.slice(base.length)) : abs;
}

/** Loads tileset.json (for the views), with a clear error when it is missing. */
export async function fetchTilesetJson(url) {
  const res = await fetch(url);
  if (!res.ok) throw new Error(`cannot load ${url}: HTTP ${res.status}`);
  return res.json();
}

/** Shows a fatal message on the page (and keeps it for the test). */
export function showStatus(text, isError = false) {
  let el = document.getElementById('citylod-status');
  if (!el) {
    el = document.createElement('div');
    el.id = 'citylod-status';
    el.style.cssText = 'position:absolute;left:8px;bottom:8px;font:12px monospace;color:#fff;background:#0008;padding:4px 6px;z-index:10;pointer-events:none;white-space:pre';
    document.body.appendChild(el);
  }
  el.textContent = text;
  el.style.color = isError ? '#f88' : '#fff';
}

/** Property values made JSON-friendly: bigint -> number (or string when unsafe), typed arrays -> arrays. */
export function plainValue(v) {
  if (typeof v === 'bigint') return Number.isSafeInteger(Number(v)) ? Number(v) : String(v);
  if (ArrayBuffer.isView(v) || Array.isArray(v)) return Array.from(v, plainValue);
  if (v && typeof v === 'object') return Object.fromEntries(Object.entries(v).map(([k, x]) => [k, plainValue(x)]));
  return v;
}

/** Shows picked feature properties (or hides the box when nothing was picked). */
export function showPicked(picked) {
  if (!picked) {
    document.getElementById('citylod-status')?.remove();
    return;
  }
  const lines = Object.entries(picked.properties ?? {}).map(([k, v]) => `${k}: ${JSON.stringify(v)}`);
  showStatus([`${picked.tile ?? ''} feature ${picked.featureId ?? '?'}`, ...lines].join('\n'));
}
