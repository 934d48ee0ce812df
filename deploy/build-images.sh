#!/usr/bin/env bash
# Builds the release binaries and the FROM-scratch images
#   buridan/learner:$TAG, buridan/actor:$TAG and buridan/fleet-control:$TAG
#   (TAG defaults to "dev").
#
# No base image is pulled: the binaries and the shared libraries that `ldd`
# lists for them (libc, libm, libgcc_s, the loader at its own path, ...) are
# copied into a root filesystem staged under deploy/.build/, which is the
# docker build context of deploy/Dockerfile. Safe to run again: the staging
# directory is rebuilt from scratch each time and the tags are overwritten.
#
# Environment:
#   TAG=dev              image tag
#   IMAGE_PREFIX=buridan image names are $IMAGE_PREFIX/learner, …/actor and …/fleet-control
#   SKIP_CARGO=1         reuse the binaries already in the target directory
#   CARGO_TARGET_DIR     where cargo puts them (default: <repo>/target)
#   STRIP_DEBUG=0        keep the debug info in the image binaries (default: strip it)
#   CUDA=1               build buridan/learner:cuda instead (TAG defaults to "cuda"):
#                        the `cuda` learner of scripts/build-cuda.sh (target/cuda)
#                        and NVIDIA's CUDA 13 libraries from its toolchain; the
#                        driver (libcuda.so.1) comes from the NVIDIA container runtime
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEPLOY="$ROOT/deploy"
STAGE="$DEPLOY/.build"
CUDA="${CUDA:-0}"
IMAGE_PREFIX="${IMAGE_PREFIX:-buridan}"
if [[ "$CUDA" == 1 ]]; then
    TAG="${TAG:-cuda}"
    TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target/cuda}"
    BINS=(learner)
    # The toolchain of scripts/build-cuda.sh: the CUDA 13 libraries and the
    # driver stub (for the smoke test only; never in the image).
    CUDA_TOOLCHAIN="${BURIDAN_CUDA_TOOLCHAIN:-$ROOT/target/cuda-toolchain}"
else
    TAG="${TAG:-dev}"
    TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target}"
    BINS=(learner actor fleet-control)
fi

say() { printf '==> %s\n' "$*" >&2; }
die() { printf 'build-images: error: %s\n' "$*" >&2; exit 1; }

for tool in docker ldd; do
    command -v "$tool" >/dev/null || die "'$tool' not found on PATH"
done
docker info >/dev/null 2>&1 || die "cannot reach the Docker daemon (is it running? are you in the docker group?)"

# 1. Release binaries.
if [[ "${SKIP_CARGO:-0}" != 1 && "$CUDA" == 1 ]]; then
    say "scripts/build-cuda.sh (about 13 minutes on a cold tree with 2 cores)"
    "$ROOT/scripts/build-cuda.sh"
elif [[ "${SKIP_CARGO:-0}" != 1 ]]; then
    command -v cargo >/dev/null || die "'cargo' not found on PATH (or set SKIP_CARGO=1)"
    say "cargo build --release -p buridan-cli -p buridan-actor -p buridan-control (several minutes on a cold tree)"
    (cd "$ROOT" && cargo build --release -p buridan-cli -p buridan-actor -p buridan-control)
fi
for b in "${BINS[@]}"; do
    [[ -x "$TARGET_DIR/release/$b" ]] || die "$TARGET_DIR/release/$b is missing; build it (or unset SKIP_CARGO)"
done

# 2. Staging context: bin/, rootfs/, data/, models/.
say "staging the root filesystem in ${STAGE#"$ROOT"/}"
rm -rf "$STAGE"
# cuda/ holds the CUDA libraries of a CUDA=1 build (empty otherwise: the
# classic builder reads every stage before its target).
mkdir -p "$STAGE/bin" "$STAGE/rootfs/tmp" "$STAGE/rootfs/etc" "$STAGE/data" "$STAGE/cuda"
chmod 1777 "$STAGE/rootfs/tmp"
chmod 0755 "$STAGE/data"
# The pretrained models the fleet controller serves (checkpoint:model:NAME).
cp -r "$ROOT/models" "$STAGE/models"
# No /etc/passwd or /etc/group (the images run as a numeric uid). glibc reads
# nsswitch.conf for name lookups; Docker/Kubernetes mount /etc/hosts and
# /etc/resolv.conf at run time.
printf 'hosts: files dns\n' > "$STAGE/rootfs/etc/nsswitch.conf"

for b in "${BINS[@]}"; do
    src="$TARGET_DIR/release/$b"
    cp "$src" "$STAGE/bin/$b"
    if [[ "${STRIP_DEBUG:-1}" == 1 ]] && command -v strip >/dev/null; then
        strip --strip-debug "$STAGE/bin/$b"
    fi
    # ldd prints "libx.so => /path (0x..)" and "/lib64/ld-linux-x86-64.so.2 (0x..)".
    # A cuda binary finds its CUDA libraries in the toolchain's wheels; the
    # driver's libcuda.so.1 is the NVIDIA runtime's at run time, so its
    # absence here is expected.
    cuda_lib=""
    if [[ "$CUDA" == 1 ]]; then
        cuda_lib="$("$ROOT/scripts/build-cuda.sh" --print-libs)"
    fi
    if ! ldd_out="$(LD_LIBRARY_PATH="$cuda_lib" ldd "$src" 2>&1 | grep -v '^\s*libcuda\.so\.1 => not found')"; then
        if grep -q 'not a dynamic executable\|statically linked' <<<"$ldd_out"; then
            say "$b is static: no libraries to copy"
            continue
        fi
        die "ldd $src failed: $ldd_out"
    fi
    if grep -q 'not found' <<<"$ldd_out"; then
        die "ldd $src: missing libraries:"$'\n'"$ldd_out"
    fi
    while read -r lib; do
        if [[ -n "$cuda_lib" && "$lib" == "$cuda_lib"/* ]]; then
            # CUDA's libraries go to /usr/local/cuda/lib64 (LD_LIBRARY_PATH).
            cp -L "$lib" "$STAGE/cuda/"
            continue
        fi
        # Same path in the image as on the build host (the loader path is
        # baked into the binary's PT_INTERP); -L copies the file, not a symlink.
        cp -L --parents "$lib" "$STAGE/rootfs/"
    done < <(awk '{ for (i = 1; i <= NF; i++) if ($i ~ /^\//) print $i }' <<<"$ldd_out" | sort -u)
done
interp="$(readelf -l "$TARGET_DIR/release/learner" 2>/dev/null | sed -n 's/.*Requesting program interpreter: \(.*\)]/\1/p' || true)"
if [[ -n "$interp" && ! -e "$STAGE/rootfs$interp" ]]; then
    die "the loader $interp is not in the staged rootfs"
fi
say "libraries in the image:"
(cd "$STAGE/rootfs" && find . -type f -name '*.so*' | sed 's/^\./    /' | sort) >&2

# 3. Images. BuildKit needs the buildx plugin; without it use the classic builder.
if docker buildx version >/dev/null 2>&1; then
    export DOCKER_BUILDKIT="${DOCKER_BUILDKIT:-1}"
else
    export DOCKER_BUILDKIT=0
fi
revision="$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)"
for b in "${BINS[@]}"; do
    image="$IMAGE_PREFIX/$b:$TAG"
    target="$b"
    smoke=()
    if [[ "$CUDA" == 1 ]]; then
        target="$b-cuda"
        # Without a GPU here the smoke test lends the binary the driver stub.
        smoke=(-v "$CUDA_TOOLCHAIN/lib/libcuda.so:/usr/local/cuda/stub/libcuda.so.1:ro"
               -e LD_LIBRARY_PATH=/usr/local/cuda/lib64:/usr/local/cuda/stub)
    fi
    say "docker build --target $target -t $image"
    docker build -q \
        -f "$DEPLOY/Dockerfile" \
        --target "$target" \
        --label "org.opencontainers.image.title=buridan-$b" \
        --label "org.opencontainers.image.revision=$revision" \
        -t "$image" \
        "$STAGE" >/dev/null
    # Smoke test: the loader finds every library and the binary starts.
    version="$(docker run --rm "${smoke[@]}" "$image" --version 2>&1)" || die "$image does not start: $version"
    say "$image OK ($version)"
done

docker image ls "$IMAGE_PREFIX/*:$TAG" >&2
say "done: ${BINS[*]/#/$IMAGE_PREFIX/} (tag $TAG)"
