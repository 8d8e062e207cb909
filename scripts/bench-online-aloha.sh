#!/usr/bin/env bash
# Online embodiment of the recorded ALOHA episodes (data/aloha_sim: ACT's scripted transfer-cube
# and insertion policies in gym-aloha's MuJoCo simulation, 50 episodes each at 50 Hz), as a
# policy sends chunks: 16 every 16 steps (just in time), 64 every 16, 100 every 100 (ACT's
# default) and 100 every step (ACT's temporal ensembling), at the policy's rate and with time
# scaling (64- and 100-step first chunks started where the joints' reserve is largest:
# --rank-starts); the same episodes planned whole in windows as the reference; on 2, 3, 4 and 6 Gen3s
# at the table's corners, and on the other layout and the mixed Gen3/Panda fleet.
#
#   bash scripts/bench-online-aloha.sh OUT_DIR [OMCBSA_BINARY]
#
# Writes one Markdown table per run into OUT_DIR (and the runs' notes: every episode not
# embodied, with its first error, in *.log). Needs a release build (cargo build --release).
set -euo pipefail
out="$1"
bin="${2:-target/release/omcbsa}"
mkdir -p "$out"
run() {
    local name="$1"
    shift
    echo "== $name: omcbsa bench-online --family aloha-sim $*" >&2
    "$bin" bench-online --family aloha-sim "$@" > "$out/$name.md" 2> "$out/$name.log"
    grep '^| [0-9]' "$out/$name.md" >&2 || true
}
gen3=(--layouts corners --fleets gen3 --arms 2,3,4,6)
# At the policy's rate; the first run also plans every episode whole (the reference).
run rate_16_16 "${gen3[@]}" --chunk-len 16 --stride 16
run rate_64_16 "${gen3[@]}" --rank-starts --chunk-len 64 --stride 16 --no-reference
run rate_100_100 "${gen3[@]}" --rank-starts --chunk-len 100 --stride 100 --no-reference
run rate_100_1 "${gen3[@]}" --rank-starts --chunk-len 100 --stride 1 --no-reference
# With time scaling: a chunk the arms cannot follow is slowed, not failed.
for scheme in "16 16" "64 16" "100 100" "100 1"; do
    set -- $scheme
    rank=()
    [ "$1" -ge 64 ] && rank=(--rank-starts)
    run "scaled_$1_$2" "${gen3[@]}" "${rank[@]}" --chunk-len "$1" --stride "$2" --no-reference --time-scaling
done
# The other layout and the mixed fleet, with their references.
other=(--arms 2,3,4)
run rows_gen3_16_16 --layouts rows --fleets gen3 "${other[@]}" --chunk-len 16 --stride 16
run corners_mixed_16_16 --layouts corners --fleets mixed "${other[@]}" --chunk-len 16 --stride 16
run rows_gen3_64_16 --layouts rows --fleets gen3 "${other[@]}" --chunk-len 64 --stride 16 --no-reference
run corners_mixed_64_16 --layouts corners --fleets mixed "${other[@]}" --chunk-len 64 --stride 16 --no-reference
