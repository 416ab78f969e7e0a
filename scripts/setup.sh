#!/usr/bin/env bash
# Installs what `make test` and `make demo` need, idempotently:
#   - Debian packages chromium (browser tests), mesa-vulkan-drivers and libvulkan1 (lavapipe for the wgpu
#     renderer) and libsqlite3-dev (the SQLite library GeoPackage input is read with) with apt-get, as root, only when one is missing (apt-get update only then);
#   - the JavaScript tools with `npm ci`, only when node_modules is missing or older than package-lock.json.
# Exits non-zero with a message saying what could not be installed.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"

die() {
  echo "setup: $*" >&2
  exit 1
}

# --- Debian packages ---------------------------------------------------------------------------------
apt_packages=(chromium mesa-vulkan-drivers libvulkan1 libsqlite3-dev)
missing=()
for pkg in "${apt_packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$pkg")
  fi
done
if ((${#missing[@]} > 0)); then
  command -v apt-get >/dev/null 2>&1 ||
    die "missing packages ${missing[*]} and no apt-get here: install them with your package manager"
  if [[ $(id -u) -ne 0 ]]; then
    die "missing packages ${missing[*]}: run as root (or: sudo apt-get install -y ${missing[*]})"
  fi
  echo "setup: installing ${missing[*]} with apt-get"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q || die "apt-get update failed"
  apt-get install -y -q --no-install-recommends "${missing[@]}" || die "apt-get install ${missing[*]} failed"
fi
[[ -x /usr/bin/chromium ]] || die "/usr/bin/chromium is missing after installing the chromium package"

# --- Node.js tools -----------------------------------------------------------------------------------
command -v node >/dev/null 2>&1 || die "node is not installed (Node.js >= 20.19 is needed for the browser tests)"
command -v npm >/dev/null 2>&1 || die "npm is not installed (it comes with Node.js)"
node_major="$(node -p 'process.versions.node.split(".")[0]')"
((node_major >= 20)) || die "Node.js $(node --version) is too old: version 20.19 or newer is needed"

stamp="node_modules/.citylod-npm-ci.stamp"
if [[ ! -f "$stamp" || package-lock.json -nt "$stamp" || package.json -nt "$stamp" ]]; then
  echo "setup: npm ci"
  npm ci --no-audit --no-fund || die "npm ci failed (is the npm registry reachable?)"
  touch "$stamp"
fi
for mod in cesium 3d-tiles-renderer three playwright-core gltf-validator pngjs; do
  [[ -d "node_modules/$mod" ]] || die "node_modules/$mod is missing after npm ci"
done
