#!/usr/bin/env python3
"""What the approach adds to planning time, per family and planner.

Usage: scripts/approach_cost.py WITH/results.csv WITHOUT/results.csv [-o approach_cost.md]

WITH is an `omcbsa bench` run (the approach planned from `initial`), WITHOUT the same suite
and planners with `--no-approach`, run at the same time on the same machine. For each family
and planner, over the problems both runs solved, it prints the median planning time of each and
their ratio, and how each approach was found (straight together, one at a time, RRT-Connect).
"""

import argparse
import csv
import statistics
import sys
from collections import Counter, defaultdict


def rows(path):
    with open(path, newline="") as f:
        return {(r["problem"], r["planner"]): r for r in csv.DictReader(f)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("with_approach")
    ap.add_argument("without_approach")
    ap.add_argument("-o", "--out")
    args = ap.parse_args()
    on, off = rows(args.with_approach), rows(args.without_approach)
    times = defaultdict(lambda: ([], []))
    methods = defaultdict(Counter)
    for key, r in on.items():
        other = off.get(key)
        group = (r["family"], r["planner"])
        if r["success"] == "true":
            methods[group][r["approach_method"] or "none"] += 1
        if other and r["success"] == "true" and other["success"] == "true":
            times[group][0].append(float(r["time_s"]))
            times[group][1].append(float(other["time_s"]))
    lines = [
        "| family | planner | both solved | median with approach (ms) | median without (ms) "
        "| ratio | approaches: together / ordered / ordered-rrt / rrt-connect / none |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    for group in sorted(times):
        w, wo = times[group]
        mw, mwo = statistics.median(w) * 1e3, statistics.median(wo) * 1e3
        m = methods[group]
        lines.append(
            f"| {group[0]} | {group[1]} | {len(w)} | {mw:.2f} | {mwo:.2f} | {mw / mwo:.2f} "
            f"| {m['together']} / {m['ordered']} / {m['ordered-rrt']} / {m['rrt-connect']} / {m['none']} |"
        )
    text = "\n".join(lines) + "\n"
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
