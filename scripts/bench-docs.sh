#!/usr/bin/env bash
# Regenerates docs/bench from a clean checkout: the suite (`omcbsa gen-bench`, checked against
# docs/bench/suite.sha256 when it is the default one), every planner on it (`omcbsa bench`),
# and what the runs gave: summary.md (success and time per planner, per arm count and per
# family; path quality), the plots, results.csv.gz (every run, one row each) and run.txt (the
# command, commit and machine).
#
#   bash scripts/bench-docs.sh               # the published run: 608 problems, six planners, 5 s, 2 jobs
#   bash scripts/bench-docs.sh --per-family 2 --planners omcbsa,pp --timeout 1 --out /tmp/trial
#
# Options: --per-family N (76), --planners A,B (all six), --timeout S (5), --jobs N (2),
# --out DIR (docs/bench), --work DIR (a new temporary directory; holds the suite and the
# bench directory with its 3D views). Exit code: the bench's (1 when a reported success
# failed validation: the files are still written), 2 on bad options.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"

per_family=76 planners="" timeout=5 jobs=2 out=docs/bench work=""
while [ $# -gt 0 ]; do
    case "$1" in
        --per-family) per_family="$2"; shift 2 ;;
        --planners) planners="$2"; shift 2 ;;
        --timeout) timeout="$2"; shift 2 ;;
        --jobs) jobs="$2"; shift 2 ;;
        --out) out="$2"; shift 2 ;;
        --work) work="$2"; shift 2 ;;
        *) echo "bench-docs.sh: unknown option $1 (see the comment at the top)" >&2; exit 2 ;;
    esac
done
work="${work:-$(mktemp -d)}"
mkdir -p "$work" "$out"
work="$(cd "$work" && pwd)" out="$(cd "$out" && pwd)"

echo "== build"
cargo build --release -p omcbsa
bin="$root/target/release/omcbsa"

echo "== suite: $work/suite"
rm -rf "$work/suite" "$work/bench"
started=$(date +%s) load_start="$(cut -d' ' -f1-3 /proc/loadavg)"
# The commit the runs are of, taken before the results are copied into docs/bench.
commit="$(git rev-parse HEAD)$(git diff --quiet HEAD -- . 2>/dev/null || echo ' (with uncommitted changes)')"
"$bin" gen-bench "$work/suite" --per-family "$per_family"
if [ "$per_family" = 76 ]; then
    (cd "$work/suite" && sha256sum --quiet --check "$root/docs/bench/suite.sha256")
    echo "the suite's files match docs/bench/suite.sha256"
fi

echo "== runs"
# From the work directory, so that summary.md names the suite `suite`, not a temporary path.
status=0
(cd "$work" && "$bin" bench suite --timeout "$timeout" --jobs "$jobs" --out bench \
    ${planners:+--planners "$planners"}) || status=$?
[ "$status" -le 1 ] || exit "$status"

echo "== results into $out"
cp "$work/bench/summary.md" "$work"/bench/*.svg "$work"/bench/*.png "$out/"
# -n: no name or time in the header, so the same rows give the same bytes.
gzip -9 -n -c "$work/bench/results.csv" > "$out/results.csv.gz"
{
    echo "bash scripts/bench-docs.sh --per-family $per_family --planners ${planners:-all} --timeout $timeout --jobs $jobs"
    echo "commit $commit"
    echo "finished $(date -u +%Y-%m-%dT%H:%M:%SZ), $(( $(date +%s) - started )) s"
    echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
    # Other work on the machine slows the runs: a run's timeout is wall-clock time.
    echo "load average (1, 5, 15 min): $load_start at the start, $(cut -d' ' -f1-3 /proc/loadavg) at the end"
} > "$out/run.txt"
cat "$out/run.txt"
echo "3D views of every problem: $work/bench/index.html"
exit "$status"
