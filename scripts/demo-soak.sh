#!/usr/bin/env bash
# The demos hold on this machine: runs `omcbsa demo` (CAN mocks), `omcbsa demo --transport
# kortex` and `omcbsa online --demo`, each RUNS times in a row with the defaults (default 20),
# then LOADED times each (default 5) with two CPU-bound processes (`yes > /dev/null`) beside
# them. Prints one line per run and a table of exit codes; a failed run's output is kept in
# OUT/NAME-K.txt (default OUT: /tmp/omcbsa-demo-soak). Exit code 0 if every run exited 0.
# OMCBSA_BIN: the binary to run (default: target/release/omcbsa, built first).
#
#   bash scripts/demo-soak.sh [RUNS] [LOADED]
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-20}"
loaded="${2:-5}"
out="${OMCBSA_SOAK_OUT:-/tmp/omcbsa-demo-soak}"

bash hw-adapter/mock/setup_venv.sh >/dev/null
bin="${OMCBSA_BIN:-target/release/omcbsa}"
[ -n "${OMCBSA_BIN:-}" ] || cargo build --release -p omcbsa --bin omcbsa 2>/dev/null
rm -rf "$out"
mkdir -p "$out"
echo "commit $(git rev-parse --short HEAD)$(git diff --quiet || echo '+changes'), $(nproc) cores"
"$bin" doctor || true

declare -A failed total
names=("demo" "demo-kortex" "online")
cmd() {
    case "$1" in
        demo) echo "demo --out $2" ;;
        demo-kortex) echo "demo --transport kortex --out $2" ;;
        online) echo "online --demo --out $2" ;;
    esac
}

run_all() {  # $1: runs per command, $2: label
    for name in "${names[@]}"; do
        for k in $(seq 1 "$1"); do
            key="$name/$2"
            dir="$out/$name-$2-$k"
            rc=0
            start=$(date +%s)
            # shellcheck disable=SC2046
            "$bin" $(cmd "$name" "$dir") >"$dir.txt" 2>&1 || rc=$?
            total[$key]=$(( ${total[$key]:-0} + 1 ))
            if [ "$rc" -eq 0 ]; then
                rm -rf "$dir" "$dir.txt"
                echo "$key run $k: exit 0 ($(( $(date +%s) - start )) s)"
            else
                failed[$key]=$(( ${failed[$key]:-0} + 1 ))
                echo "$key run $k: EXIT $rc, see $dir.txt:"
                grep -m3 '^error\|fault' "$dir.txt" | sed 's/^/    /' || true
            fi
        done
    done
}

run_all "$runs" idle
if [ "$loaded" -gt 0 ]; then
    yes >/dev/null & y1=$!
    yes >/dev/null & y2=$!
    trap 'kill $y1 $y2 2>/dev/null || true' EXIT
    run_all "$loaded" "2xyes"
    kill $y1 $y2 2>/dev/null || true
fi

echo
echo "| command | beside it | runs | exit 0 |"
echo "|---|---|---:|---:|"
bad=0
for label in idle 2xyes; do
    for name in "${names[@]}"; do
        key="$name/$label"
        [ -n "${total[$key]:-}" ] || continue
        f=${failed[$key]:-0}
        bad=$((bad + f))
        what="nothing"; [ "$label" = idle ] || what='two `yes > /dev/null`'
        echo "| \`omcbsa $(cmd "$name" DIR | sed 's/ --out DIR//')\` | $what | ${total[$key]} | $(( ${total[$key]} - f )) |"
    done
done
echo "(load average at the end: $(cut -d' ' -f1-3 /proc/loadavg))"
[ "$bad" -eq 0 ]
