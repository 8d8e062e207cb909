#!/usr/bin/env bash
# The collision benchmark of this checkout against an older core, measured in the same run:
# builds this checkout's core/benches/collision.rs against the core of OLD_REV (so both time the
# same cases, the same configurations and motions) and against this checkout's, then runs the
# two binaries alternately ROUNDS times on the criterion filter FILTER. Prints one line per
# case and run: which build (old/new), the case, criterion's estimate.
#
#   bash scripts/bench-collision-ab.sh OLD_REV FILTER [ROUNDS]
#
# e.g. `bash scripts/bench-collision-ab.sh 227b2b4 'motion/gen3' 2`. OLD_REV's core must have
# the API the bench uses. Both builds go to this checkout's target directory (the old one
# through a temporary worktree), so the next build here recompiles the core.
set -euo pipefail

usage() { sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[ $# -ge 2 ] || usage
old_rev="$1" filter="$2" rounds="${3:-2}"
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "bench-collision-ab.sh: ROUNDS must be a positive integer, got $rounds" >&2; exit 2; }
root="$(cd "$(dirname "$0")/.." && pwd)"
git -C "$root" rev-parse --verify -q "$old_rev^{commit}" >/dev/null \
    || { echo "bench-collision-ab.sh: $old_rev is not a commit" >&2; exit 2; }
work="$(mktemp -d)"
trap 'git -C "$root" worktree remove --force "$work/old-tree" 2>/dev/null || true; rm -rf "$work"' EXIT

# The bench executable cargo builds, for the manifest in directory $1.
build() {
    (cd "$1" && CARGO_TARGET_DIR="$root/target" cargo bench -p omcbsa-core --bench collision \
        --no-run --message-format=json 2>/dev/null) \
        | python3 -c 'import json,sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "collision" and m.get("executable"):
        print(m["executable"])'
}

git -C "$root" worktree add -q --detach "$work/old-tree" "$old_rev"
cp "$root/core/benches/collision.rs" "$work/old-tree/core/benches/collision.rs"
cp "$(build "$work/old-tree")" "$work/old"
cp "$(build "$root")" "$work/new"

for round in $(seq "$rounds"); do
    for side in old new; do
        "$work/$side" --bench "$filter" --warm-up-time 0.5 --measurement-time 3 2>/dev/null \
            | awk -v side="$side" '
                /^[a-z0-9_]+\// { case = $1 }
                /time:/ { s = $0; sub(/.*\[/, "", s); sub(/\].*/, "", s); split(s, f, " "); if (f[4] !~ /%/) print side, case, f[3], f[4] }'
    done
done
