#!/usr/bin/env bash
# Builds the `cuda` binaries (learner, actor, …: `--device cuda`) on a
# machine without a GPU and without a system CUDA install. NVIDIA's
# compiler and libraries come from the package registry (PyPI wheels, one
# consistent CUDA 13.0 set, pinned below) into a virtual environment; the
# driver library, which no wheel ships, is replaced at link time by a stub
# (one function per driver symbol cudarc binds, each returning
# CUDA_ERROR_STUB_LIBRARY); at run time the GPU machine's own driver
# (`libcuda.so.1`) is used.
#
#   scripts/build-cuda.sh            # binaries in target/cuda/release/
#   CUDA_COMPUTE_CAP=80 scripts/build-cuda.sh   # another GPU generation
#
# Environment: CUDA_COMPUTE_CAP (default 90: Hopper, H100/H200),
# BURIDAN_CUDA_TOOLCHAIN (default target/cuda-toolchain: the venv, the
# link folder, the stub), CARGO_BUILD_JOBS as cargo reads it.
#
# To run a binary on a GPU machine: its driver provides libcuda.so.1; the
# CUDA 13 libraries (libcublas.so.13, libcublasLt.so.13, libcurand.so.10,
# libcudart.so.13, libnvrtc.so.13) must be on LD_LIBRARY_PATH, e.g. from the
# same wheels (`$BURIDAN_CUDA_TOOLCHAIN/venv/.../nvidia/cu13/lib`, which
# `scripts/build-cuda.sh --print-libs` prints). The book's chapter
# "A GPU learner" has the rest.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
toolchain="${BURIDAN_CUDA_TOOLCHAIN:-$root/target/cuda-toolchain}"
venv="$toolchain/venv"
links="$toolchain/lib"

# The CUDA 13.0 set: nvcc 13.0 emits PTX that driver 580 (the lent
# machine's) accepts; nvvm pinned, or nvcc pulls a newer one.
wheels=(
  nvidia-cuda-nvcc==13.0.88
  nvidia-nvvm==13.0.88
  nvidia-cuda-crt==13.0.88
  nvidia-cuda-cccl==13.0.85
  nvidia-cuda-runtime==13.0.96
  nvidia-cuda-nvrtc==13.0.88
  nvidia-cublas==13.0.2.14
  nvidia-curand==10.4.0.35
)

cu13() {
  "$venv/bin/python" -c 'import nvidia, os; print(os.path.join(list(nvidia.__path__)[0], "cu13"))'
}

if [[ "${1:-}" == "--print-libs" ]]; then
  echo "$(cu13)/lib"
  exit 0
fi

step() { printf '\n== %s\n' "$*" >&2; }

step "CUDA 13.0 toolchain from the package registry into $venv"
if [[ ! -x "$venv/bin/python" ]]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "${wheels[@]}"
cuda="$(cu13)"
for need in bin/nvcc include/cuda_runtime.h lib/libcudart.so.13; do
  [[ -e "$cuda/$need" ]] || { echo "build-cuda: the wheels lack $cuda/$need" >&2; exit 1; }
done

step "unversioned library links and the driver stub in $links"
mkdir -p "$links"
# The wheels ship only versioned files (libcublas.so.13); the linker asks
# for libcublas.so.
for lib in "$cuda"/lib/lib*.so.*; do
  base="$(basename "$lib")"
  ln -sf "$lib" "$links/${base%%.so.*}.so"
done
# The driver: every cu* function cudarc's bindings declare, as a stub.
cargo fetch --manifest-path "$root/Cargo.toml" --quiet
cudarc="$(cargo metadata --manifest-path "$root/Cargo.toml" --format-version 1 --features buridan-cli/cuda 2>/dev/null \
  | "$venv/bin/python" -c 'import json, sys, os
meta = json.load(sys.stdin)
print(next(os.path.dirname(p["manifest_path"]) for p in meta["packages"] if p["name"] == "cudarc"))')"
symbols="$(grep -ohE '^pub unsafe fn cu[A-Za-z0-9_]+' "$cudarc/src/driver/sys/mod.rs" | sed 's/^pub unsafe fn //' | sort -u)"
[[ -n "$symbols" ]] || { echo "build-cuda: no driver symbols found under $cudarc" >&2; exit 1; }
{
  echo '/* Link-time stand-in for libcuda.so.1: the GPU machine loads its driver instead. */'
  echo '#define CUDA_ERROR_STUB_LIBRARY 34'
  for s in $symbols; do echo "int $s(void) { return CUDA_ERROR_STUB_LIBRARY; }"; done
} > "$toolchain/libcuda-stub.c"
cc -shared -fPIC -O0 -Wl,-soname,libcuda.so.1 -o "$links/libcuda.so" "$toolchain/libcuda-stub.c"
echo "stub: $(wc -l <<<"$symbols") driver symbols" >&2

step "cargo build --release --features cuda (candle's kernels compile with nvcc: ~13 min cold on 2 cores)"
export PATH="$cuda/bin:$PATH"
export CUDA_HOME="$cuda" CUDA_PATH="$cuda" CUDA_ROOT="$links"
export LIBRARY_PATH="$links${LIBRARY_PATH:+:$LIBRARY_PATH}"
export CUDA_COMPUTE_CAP="${CUDA_COMPUTE_CAP:-90}"
export CUDAFORGE_THREADS="${CUDAFORGE_THREADS:-$(nproc)}"
cargo build --manifest-path "$root/Cargo.toml" --release --features buridan-cli/cuda \
  -p buridan-cli --bins --target-dir "$root/target/cuda"
# The parity tests (learner/tests/device.rs) and the update bench, built to
# be carried to a GPU machine (scripts/gpu-check.sh): cargo prints their paths.
cargo test --manifest-path "$root/Cargo.toml" --release --features cuda \
  -p buridan-learner --test device --no-run --target-dir "$root/target/cuda"
cargo bench --manifest-path "$root/Cargo.toml" --features cuda \
  -p buridan-learner --bench update --no-run --target-dir "$root/target/cuda"

step "done"
echo "binary: $root/target/cuda/release/learner (actors need no GPU: the default build's actor joins it)"
echo "run them with LD_LIBRARY_PATH=<the GPU machine's CUDA 13 libraries>, or $cuda/lib"
