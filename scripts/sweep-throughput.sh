#!/usr/bin/env bash
# What Ray costs and gives: a sample of a suite (every 15th problem, as `omcbsa bench --quick`
# picks them) run by `omcbsa bench --jobs N` and by `python -m omcbsa.sweep --num-cpus N`, for
# N = 1 and 2, one after the other; Ray's overhead per run with the fastest planner alone, on
# the whole suite; and from these an estimate of the whole suite with every planner on a
# 64-core node. Prints a markdown table and the estimate (docs/bench/sweep.md).
#
#   bash scripts/sweep-throughput.sh SUITE WORK [PLANNERS] [TIMEOUT]
#
# SUITE: a suite directory (omcbsa gen-bench); WORK: a new directory for the runs. PLANNERS
# (default: all six) and TIMEOUT (default 5 s) as omcbsa bench takes them. Needs
# target/release/omcbsa and the package with its ray extra in .venv (scripts/test-all.sh).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
suite="$(cd "$1" && pwd)" work="$2" planners="${3:-omcbsa,pp,pp-single,ik-tracking,descartes,composite-astar}" timeout="${4:-5}"
bin="$root/target/release/omcbsa" py="$root/.venv/bin/python"
mkdir -p "$work" && work="$(cd "$work" && pwd)"
load_start="$(cut -d' ' -f1-3 /proc/loadavg)"

# The sample: a suite of its own whose files are the suite's.
mkdir -p "$work/sample"
"$py" - "$suite" "$work/sample" <<'EOF'
import json, os, sys
suite, sample = sys.argv[1:]
index = json.load(open(os.path.join(suite, "suite.json")))
index["problems"] = index["problems"][::15]
for e in index["problems"]:
    link = os.path.join(sample, e["file"])
    if not os.path.exists(link):
        os.symlink(os.path.join(suite, e["file"]), link)
json.dump(index, open(os.path.join(sample, "suite.json"), "w"), indent=2)
EOF

# The wall time of a command, its output in LOG; a command that fails stops the script.
seconds() {
    local log="$1" t0
    shift
    t0=$(date +%s.%N)
    "$@" >"$log" 2>&1 || { echo "failed: $* (see $log)" >&2; return 1; }
    awk "BEGIN { print $(date +%s.%N) - $t0 }"
}
rm -f "$work/walls.txt"
for n in 1 2; do
    rm -rf "$work/bench-$n" "$work/sweep-$n"
    b=$(seconds "$work/bench-$n.log" "$bin" bench "$work/sample" --planners "$planners" --timeout "$timeout" --jobs "$n" --out "$work/bench-$n")
    s=$(seconds "$work/sweep-$n.log" "$py" -m omcbsa.sweep "$work/sample" --planners "$planners" --param "timeout=$timeout" --num-cpus "$n" --out "$work/sweep-$n" --no-progress)
    echo "$n $b $s" >> "$work/walls.txt"
done
rm -rf "$work/overhead"
seconds "$work/overhead.log" "$py" -m omcbsa.sweep "$suite" --planners ik-tracking --param "timeout=$timeout" --num-cpus 2 --out "$work/overhead" --no-progress >/dev/null
echo "load average (1, 5, 15 min): $load_start at the start, $(cut -d' ' -f1-3 /proc/loadavg) at the end"

"$py" - "$work" "$suite" "$timeout" <<'EOF'
import csv, json, os, sys
work, suite, timeout = sys.argv[1], sys.argv[2], float(sys.argv[3])
setting = f"timeout={sys.argv[3]}_approach=on"
print("| workers | omcbsa bench (s) | sweep (s) | sweep runs only (s) | runs | runs/s (sweep, runs only) | mean CPU in a run (s) | Ray overhead per run (ms) |")
print("|---:|---:|---:|---:|---:|---:|---:|---:|")
for line in open(os.path.join(work, "walls.txt")):
    n, b, s = line.split()
    st = json.load(open(os.path.join(work, f"sweep-{n}", "sweep.json")))
    print(f"| {n} | {float(b):.1f} | {float(s):.1f} | {st['wall_s']:.1f} | {st['runs']} | "
          f"{st['runs_per_s']:.2f} | {st['task_cpu_s_mean']:.3f} | {1000 * st['overhead_per_run_s']:.1f} |")
ov = json.load(open(os.path.join(work, "overhead", "sweep.json")))
print(f"\nik-tracking alone on the whole suite, 2 workers: {ov['runs']} runs, {1000 * ov['task_s_mean']:.1f} ms in a "
      f"run, Ray's overhead {1000 * ov['overhead_per_run_s']:.1f} ms per run")

# The whole suite with these planners on 64 cores: what each run of the sample costs a
# dedicated core (its CPU time; a run that stopped at its deadline, the whole timeout, as it
# would take on an idle core), scaled from the sample to the suite, plus Ray's overhead per
# run, over 64 cores; plus the longest run, which may be the last to start.
rows = {(r["problem"], r["planner"]): r for r in csv.DictReader(open(os.path.join(work, "sweep-2", setting, "results.csv")))}
cost, longest = 0.0, 0.0
for t in csv.DictReader(open(os.path.join(work, "sweep-2", "tasks.csv"))):
    r = rows[(t["problem"], t["planner"])]
    c = timeout if r["status"] == "timeout" else float(t["task_cpu_s"])
    cost, longest = cost + c, max(longest, c)
full = len(json.load(open(os.path.join(suite, "suite.json")))["problems"])
sample = len(json.load(open(os.path.join(work, "sample", "suite.json")))["problems"])
planners = len({p for _, p in rows})
runs = full * planners
per_run = ov["overhead_per_run_s"]
total = cost * full / sample + runs * per_run
print(f"\nsample: {len(rows)} runs costing {cost:.0f} s of one core ({sum(r['status'] == 'timeout' for r in rows.values())} at the {timeout:g} s deadline)")
print(f"suite: {full} problems x {planners} planners = {runs} runs, about {total / 3600:.2f} core-hours "
      f"({cost * full / sample:.0f} s of runs + {runs * per_run:.0f} s of Ray)")
print(f"64 cores: {total / 64:.0f} s + the longest run ({longest:.1f} s) = about {(total / 64 + longest) / 60:.1f} min")
EOF
