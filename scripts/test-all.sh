#!/usr/bin/env bash
# Runs every test on a fresh machine, installing what the tests need first:
#   - the bare-metal target, to prove the core builds with no std and no alloc;
#   - the Python venv of the mock arms (hardware-in-the-loop tests);
#   - the Python package (python/), built from source by maturin into that venv, and its
#     ray extra (the sweep tests).
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== docs: relative links resolve, no issue numbers in README.md and docs/, docs/README.md indexes every page,"
echo "   docs/ARCHITECTURE.md's tree names every source file and every omcbsa subcommand"
python3 scripts/test_check_docs.py
python3 scripts/check_docs.py

echo "== house checks: no import circles between a crate's modules, no function over 100 lines (and the checkers' own tests)"
python3 scripts/test_module_cycles.py
python3 scripts/module_cycles.py
python3 scripts/test_long_functions.py
python3 scripts/long_functions.py

echo "== clippy, warnings denied (the workspace, and python/, a workspace of its own)"
rustup component add clippy >/dev/null
cargo clippy --workspace --all-targets -- -D warnings
(cd python && cargo clippy --all-targets -- -D warnings)

echo "== bare-metal build of the core (thumbv7em-none-eabihf: no std, no alloc)"
rustup target add thumbv7em-none-eabihf >/dev/null
cargo build -p omcbsa-core --release --target thumbv7em-none-eabihf

echo "== Python venv for the mock arms (pinned python-can, canopen; protobuf, grpcio-tools for the Kortex mock)"
bash hw-adapter/mock/setup_venv.sh

echo "== headless Chromium for the plan viewer's browser test (host/tests/view_browser.rs)"
if ! command -v chromium >/dev/null; then
    apt-get update && apt-get install -y chromium
fi

echo "== tests"
cargo test --workspace

echo "== Python package: wheel built by maturin into .venv (pinned), with its ray extra (pinned), pytest against the CLI"
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r python/requirements.txt
cargo build --release -p omcbsa
# One release build of the host crate serves the CLI above and the wheel (same target dir).
PATH="$PWD/.venv/bin:$PATH" CARGO_TARGET_DIR="$PWD/target" .venv/bin/python -m pip install --quiet --disable-pip-version-check \
    --no-build-isolation --no-deps --force-reinstall ./python
# The ray extra's pins (omcbsa.sweep and its tests), from the package's own metadata.
.venv/bin/python -m pip install --quiet --disable-pip-version-check \
    $(.venv/bin/python -c 'from importlib.metadata import requires; print(" ".join(r.split(";")[0].strip() for r in requires("omcbsa") if ";" in r and "ray" in r.split(";")[1]))')
.venv/bin/python -m pytest python/tests -q

echo "== scripts/bench-docs.sh on a small subset (the published run: the script with its defaults)"
trial="$(mktemp -d)"
bash scripts/bench-docs.sh --per-family 1 --planners omcbsa,pp --timeout 1 --out "$trial/docs" --work "$trial/work"
for f in summary.md results.csv.gz run.txt success_by_family.svg success_by_robots.png; do
    test -s "$trial/docs/$f" || { echo "bench-docs.sh wrote no $f" >&2; exit 1; }
done
grep -q "## Success rate by family" "$trial/docs/summary.md"
rm -rf "$trial"
