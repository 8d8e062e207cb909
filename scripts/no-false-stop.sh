#!/usr/bin/env bash
# No false stop: runs `omcbsa demo` (fault-free, the command line's default watchdog settings)
# N times (default 10) and counts the runs a fault stopped. A stopped run's output and bus logs
# are kept in OUT/run-K (default OUT: /tmp/omcbsa-no-false-stop). Exit code 0 if no run was
# stopped, 1 otherwise. Extra arguments go to `omcbsa demo` (e.g. --missed-cycles 3).
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-10}"
shift || true
out="${OMCBSA_NO_FALSE_STOP_OUT:-/tmp/omcbsa-no-false-stop}"

bash hw-adapter/mock/setup_venv.sh >/dev/null
cargo build --release -p omcbsa --bin omcbsa 2>/dev/null
rm -rf "$out"
mkdir -p "$out"
stopped=0
for k in $(seq 1 "$runs"); do
    dir="$out/run-$k"
    rc=0
    target/release/omcbsa demo --out "$dir" "$@" >"$dir.txt" 2>&1 || rc=$?
    if [ "$rc" -eq 0 ]; then
        rm -rf "$dir" "$dir.txt"
        echo "run $k: completed"
    else
        stopped=$((stopped + 1))
        echo "run $k: STOPPED (exit $rc), see $dir.txt and $dir/mock-*.log:"
        grep -A1 '^fault on\|^error' "$dir.txt" | sed 's/^/    /'
    fi
done
echo "$((runs - stopped)) of $runs fault-free demo runs completed, $stopped stopped" \
     "(load average: $(cut -d' ' -f1-3 /proc/loadavg))"
[ "$stopped" -eq 0 ]
