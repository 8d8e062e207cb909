#!/usr/bin/env bash
# Online embodiment at the policy's rate (issue 26): the long bimanual episodes of
# `omcbsa bench-online --family bimanual` at 50 Hz, 20 episodes of each task per arm count,
# chunked three ways, each against the same episodes planned in whole windows; each chunking
# also with --axis-weight 0 (chunks planned greedily, IK tracking first: the Embodier before
# transfer 013's dead end was fixed), the peer of the same run.
#   scripts/online_rate.sh [OUT.md]   (default docs/bench/online_rate.md)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/bench/online_rate.md}
cargo build --release -p omcbsa >/dev/null
bin=target/release/omcbsa
{
    echo "# Online embodiment at 50 Hz on the long bimanual family"
    echo
    echo "Made by \`scripts/online_rate.sh\` on $(date -u +%Y-%m-%d) ($(nproc) cores)."
    for chunking in "--chunk-len 16 --stride 16" "--chunk-len 16 --stride 16 --axis-weight 0" \
                    "--chunk-len 16 --stride 16 --lead 8" \
                    "--chunk-len 16 --stride 16 --lead 8 --axis-weight 0" \
                    "--chunk-len 64 --stride 16" "--chunk-len 64 --stride 16 --axis-weight 0"; do
        echo
        echo "## \`$bin bench-online --family bimanual --hz 50 --episodes 20 $chunking\`"
        echo
        "$bin" bench-online --family bimanual --hz 50 --episodes 20 $chunking 2>/tmp/online_rate.err
        echo
        echo "Episodes not embodied:"
        echo
        grep -v " arms: " /tmp/online_rate.err | sed 's/^/    /' || echo "    (none)"
    done
} > "$out"
echo "written: $out"
