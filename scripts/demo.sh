#!/usr/bin/env bash
# The demo on a fresh machine: the mock arms' Python venv, a release build of the `omcbsa`
# binary, then `omcbsa demo` (plan the 3-arm box flip with Ω-CBSA, validate it, stream it to
# three mock arms). Extra arguments go to `omcbsa demo`, e.g. `--out /tmp/demo`.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== Python venv for the mock arms"
bash hw-adapter/mock/setup_venv.sh

echo "== release build of omcbsa"
cargo build --release -p omcbsa --bin omcbsa

echo "== omcbsa demo"
exec target/release/omcbsa demo "$@"
