#!/usr/bin/env bash
# Runs every test on a fresh machine, installing what the tests need first:
#   - the bare-metal target, to prove the core builds with no std and no alloc;
#   - the Python venv of the mock arms (hardware-in-the-loop tests);
#   - the Python package (python/), built from source by maturin into that venv.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== docs: relative links resolve, no issue numbers in README.md and docs/, docs/README.md indexes every page"
python3 scripts/check_docs.py

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

echo "== Python package: wheel built by maturin into .venv (pinned), pytest against the CLI"
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r python/requirements.txt
cargo build --release -p omcbsa
# One release build of the host crate serves the CLI above and the wheel (same target dir).
PATH="$PWD/.venv/bin:$PATH" CARGO_TARGET_DIR="$PWD/target" .venv/bin/python -m pip install --quiet --disable-pip-version-check \
    --no-build-isolation --no-deps --force-reinstall ./python
.venv/bin/python -m pytest python/tests -q
