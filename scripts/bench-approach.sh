#!/usr/bin/env bash
# Planning time of two `omcbsa` binaries on one family of a suite, measured in the same run:
# the binaries alternate over ROUNDS rounds of `omcbsa bench SUBSET --planners P --jobs 1`
# (which one goes first alternates too), so that load on a shared machine falls on both. Per
# problem the least planning time (`time_s` of results.csv) of each binary's runs; printed:
# the median of those over the problems, the ratio NEW/OLD of the medians, and the median of
# the per-problem ratios. Only problems solved by both binaries in every round are compared;
# any other is listed.
#
#   bash scripts/bench-approach.sh OLD_BIN NEW_BIN SUITE ROUNDS [--family approach]
#       [--planners omcbsa] [--timeout 5] [--work DIR]
#
# SUITE is a directory written by `omcbsa gen-bench`. The family's problems are copied with a
# suite.json listing only them into WORK/suite (WORK: a new temporary directory unless given);
# each run's bench directory is WORK/runs/<round>-<old|new>. Exit code 2 on bad arguments or a
# failed run, 1 when some run reported a success that failed validation.
set -euo pipefail

usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[ $# -ge 4 ] || usage
old="$1" new="$2" suite="$3" rounds="$4"
shift 4
family=approach planners=omcbsa timeout=5 work=""
while [ $# -gt 0 ]; do
    case "$1" in
        --family) family="$2"; shift 2 ;;
        --planners) planners="$2"; shift 2 ;;
        --timeout) timeout="$2"; shift 2 ;;
        --work) work="$2"; shift 2 ;;
        *) echo "bench-approach.sh: unknown option $1" >&2; usage ;;
    esac
done
for bin in "$old" "$new"; do
    [ -x "$bin" ] || { echo "bench-approach.sh: $bin is not an executable" >&2; exit 2; }
done
[ -f "$suite/suite.json" ] || { echo "bench-approach.sh: $suite/suite.json not found" >&2; exit 2; }
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "bench-approach.sh: ROUNDS must be a positive integer, got $rounds" >&2; exit 2; }
work="${work:-$(mktemp -d)}"
mkdir -p "$work"
work="$(cd "$work" && pwd)"
old="$(cd "$(dirname "$old")" && pwd)/$(basename "$old")"
new="$(cd "$(dirname "$new")" && pwd)/$(basename "$new")"

# The subset: the family's entries of the index, their problem files and witnesses.
rm -rf "$work/suite" "$work/runs"
mkdir -p "$work/suite" "$work/runs"
python3 - "$suite" "$work/suite" "$family" <<'EOF'
import json, shutil, sys
from pathlib import Path
src, dst, family = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
index = json.loads((src / "suite.json").read_text())
index["problems"] = [p for p in index["problems"] if p.get("family") == family]
if not index["problems"]:
    sys.exit(f"bench-approach.sh: no problem of family {family!r} in {src / 'suite.json'}")
for p in index["problems"]:
    for key in ("file", "witness"):
        if p.get(key):
            (dst / p[key]).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src / p[key], dst / p[key])
(dst / "suite.json").write_text(json.dumps(index, indent=1) + "\n")
print(f"{len(index['problems'])} problems of family {family!r} in {dst}")
EOF

status=0
run() {  # run ROUND NAME BIN
    local code=0
    "$3" bench "$work/suite" --planners "$planners" --timeout "$timeout" --jobs 1 \
        --out "$work/runs/$1-$2" > "$work/runs/$1-$2.log" 2>&1 || code=$?
    [ "$code" -le 1 ] || { echo "bench-approach.sh: $3 failed (exit $code), see $work/runs/$1-$2.log" >&2; exit 2; }
    [ "$code" -eq 0 ] || status=1
}
for r in $(seq 1 "$rounds"); do
    echo "round $r/$rounds (load $(cut -d' ' -f1-3 /proc/loadavg))"
    if [ $((r % 2)) -eq 1 ]; then run "$r" old "$old"; run "$r" new "$new"
    else run "$r" new "$new"; run "$r" old "$old"; fi
done

python3 - "$work/runs" "$rounds" <<'EOF'
import csv, statistics, sys
from pathlib import Path
runs, rounds = Path(sys.argv[1]), int(sys.argv[2])
best, solved = {"old": {}, "new": {}}, {"old": {}, "new": {}}
for side in best:
    for r in range(1, rounds + 1):
        with open(runs / f"{r}-{side}" / "results.csv", newline="") as f:
            for row in csv.DictReader(f):
                key = (row["problem"], row["planner"])
                ok = row["success"] == "true"
                solved[side][key] = solved[side].get(key, 0) + ok
                if ok:
                    t = float(row["time_s"])
                    best[side][key] = min(best[side].get(key, t), t)
keys = sorted(set(solved["old"]) | set(solved["new"]))
both = [k for k in keys if solved["old"].get(k, 0) == rounds and solved["new"].get(k, 0) == rounds]
for k in keys:
    if k not in both:
        print(f"not solved in every round: {k[0]} ({k[1]}): old {solved['old'].get(k, 0)}, "
              f"new {solved['new'].get(k, 0)} of {rounds}")
for planner in sorted({k[1] for k in both}):
    ks = [k for k in both if k[1] == planner]
    mo = statistics.median(best["old"][k] for k in ks) * 1e3
    mn = statistics.median(best["new"][k] for k in ks) * 1e3
    per = statistics.median(best["new"][k] / best["old"][k] for k in ks)
    print(f"{planner}: {len(ks)} problems solved by both in all {rounds} rounds; "
          f"median of the least time per problem: old {mo:.3f} ms, new {mn:.3f} ms, "
          f"ratio new/old {mn / mo:.3f}; median of the per-problem ratios {per:.3f}")
EOF
exit "$status"
