#!/usr/bin/env bash
# Creates the Python venv used by the hardware-in-the-loop tests at <repo root>/.venv
# (ignored by git) with the pinned versions of hw-adapter/mock/requirements.txt, and generates
# the Kortex mock's message code from hw-adapter/proto into <venv>/kortex-proto.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
venv="$root/.venv"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$here/requirements.txt"
proto="$root/hw-adapter/proto"
out="$venv/kortex-proto"
rm -rf "$out.tmp" && mkdir -p "$out.tmp"
"$venv/bin/python" -m grpc_tools.protoc -I "$proto" --python_out="$out.tmp" "$proto"/*.proto
rm -rf "$out" && mv "$out.tmp" "$out"
echo "mock-arm venv ready: $venv/bin/python"
