#!/usr/bin/env bash
# Builds the `buridan` Python package (python/) from this checkout and runs
# its tests. Needs only the Rust toolchain (with rustfmt) and python3 with
# venv: CPython 3.11 for the pinned test requirements (the package itself
# supports CPython >= 3.9):
#
#   1. a virtual environment in target/python-venv (BURIDAN_PY_VENV to move it),
#   2. the pinned test requirements (python/requirements-test.txt),
#   3. `pip install ./python` (maturin, release profile, --locked against
#      python/Cargo.lock, build artifacts in python/target),
#   4. pytest python/tests.
#
# It checks the crate's formatting first (cheap); its lints, which need a
# build of their own: cargo clippy --manifest-path python/Cargo.toml --release --locked --all-targets -- -D warnings
#
# Extra arguments go to pytest (e.g. `scripts/test-python.sh -k trace`).
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
venv=${BURIDAN_PY_VENV:-$root/target/python-venv}
python=${PYTHON:-python3}
started=$(date +%s)

# The crate is outside the top-level workspace, so `cargo fmt --all` there
# does not see it.
cargo fmt --manifest-path python/Cargo.toml --check

if [ ! -x "$venv/bin/python" ]; then
    echo "test-python: creating $venv with $("$python" --version 2>&1)"
    if ! "$python" -m venv "$venv"; then
        echo "test-python: '$python -m venv' failed (on Debian/Ubuntu: apt-get install python3-venv)" >&2
        exit 1
    fi
fi
# The venv's tools first (maturin's build backend runs the `maturin` binary).
export PATH="$venv/bin:$PATH"
pip=("$venv/bin/python" -m pip --disable-pip-version-check)
"${pip[@]}" install --quiet --upgrade pip
"${pip[@]}" install --quiet -r python/requirements-test.txt

echo "test-python: building and installing python/ (release, --locked)"
# The pinned maturin from the requirements builds the wheel; --locked keeps
# python/Cargo.lock as committed.
MATURIN_PEP517_ARGS="--locked" \
    "${pip[@]}" install --quiet --no-build-isolation --no-deps --force-reinstall ./python

echo "test-python: installed in $(( $(date +%s) - started )) s; running pytest"
# From the repository root: the tests import the installed package, not python/buridan.
"$venv/bin/python" -m pytest python/tests -q -p no:cacheprovider "$@"
echo "test-python: done in $(( $(date +%s) - started )) s"
