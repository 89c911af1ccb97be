#!/usr/bin/env bash
# The Python package's tests, on the package as a user installs it: a new
# virtual environment in a temporary directory, `pip install ./python`
# (maturin builds the extension; pytest and numpy from PyPI), then pytest
# on python/tests, which compares with the parcal binary (built here).
#
# PARCAL_PROFILE=dev builds the extension with the workspace's dev profile
# in target/, reusing what `cargo test --workspace` compiled (CI does);
# the default is pip's, the release profile.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
venv="$(mktemp -d)"
trap 'rm -rf "$venv"' EXIT
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check pytest numpy
if [[ "${PARCAL_PROFILE:-release}" == dev ]]; then
    export MATURIN_PEP517_ARGS="--profile dev"
    # The binary of the test build: nothing to do after `cargo test
    # --workspace`, where `cargo build -p parcal-cli` would compile every
    # crate again without the dev-dependencies' features.
    build_cli=(cargo test --quiet --workspace --no-run)
else
    build_cli=(cargo build --quiet -p parcal-cli)
fi
CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}" \
    "$venv/bin/pip" install --quiet --disable-pip-version-check "$root/python"
"${build_cli[@]}"
cd "$root"
PARCAL_CLI="$root/target/debug/parcal" "$venv/bin/python" -m pytest -q python/tests
