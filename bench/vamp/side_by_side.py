#!/usr/bin/env python3
"""omcbsa, VAMP and KDL side by side in one run, one table (docs/bench/collision.md).

    python3 bench/vamp/side_by_side.py [--runs 9] [--passes 21] [--pass-ms 5] [--no-build]

Builds VAMP's harness (bench/vamp/build.sh, into target/vamp/) and omcbsa's `peer_scene`
example (release profile), writes the FK configurations once, then runs the three programs
--runs times, interleaved (the order rotates each run), on core/benches/scenes/panda_vamp.json. Each program
prints per case the median time per item over its passes; the table gives, per cell, the
median over the runs of those medians and their spread (least-most), in ns.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from collections import defaultdict

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = "core/benches/scenes/panda_vamp.json"
VAMP_PEER = "target/vamp/build/vamp_peer"
VAMP_COMMIT = "target/vamp/src/vamp.commit"  # written by build.sh

# (row label, omcbsa case, omcbsa batched case, VAMP single case, VAMP batched case, KDL case)
ROWS = [
    ("check, random configurations", "check_random", "check_random_batched", "check_random",
     "batch8_random", None),
    ("check, free configurations", "check_free", "check_free_batched", "check_free",
     "batch8_free", None),
    ("any of 8 random collides? (per configuration)", "any8_random", "any8_random_batched", None,
     "batch8_random", None),
    ("valid motion, 0.1 rad (per motion)", "motion_0.1", "motion_0.1_batched", None,
     "motion_0.1", None),
    ("valid motion, 1 rad (per motion)", "motion_1", "motion_1_batched", None, "motion_1", None),
    ("valid motion, 5 rad (per motion)", "motion_5", "motion_5_batched", None, "motion_5", None),
    ("FK Panda, tool pose", "fk_franka_panda", "fk_franka_panda_batched", "fk_franka_panda", None,
     "fk_franka_panda"),
    ("FK Panda, all collision spheres (VAMP, per configuration)", None, None, None,
     "spherefk8_franka_panda", None),
    ("FK Gen3, tool pose", "fk_kinova_gen3", "fk_kinova_gen3_batched", None, None,
     "fk_kinova_gen3"),
]


def sh(cmd, **kw):
    return subprocess.run(cmd, check=True, text=True, stdout=subprocess.PIPE, **kw).stdout


def rows_of(text):
    """{(system, case): (items, hits, median_ns, min_ns)} from a program's tab-separated rows."""
    out = {}
    for line in text.splitlines():
        f = line.split("\t")
        if len(f) == 7 and f[0] != "system":
            out[(f[0], f[1])] = (int(f[2]), int(f[3]), float(f[4]), float(f[5]))
    return out


def machine():
    lscpu = sh(["lscpu"])
    model = next(l.split(":", 1)[1].strip() for l in lscpu.splitlines() if l.startswith("Model name"))
    flags = next(l for l in lscpu.splitlines() if l.startswith("Flags")).split()
    simd = [f for f in ("avx2", "fma", "avx512f") if f in flags]
    load = open("/proc/loadavg").read().split()[:3]
    return f"{model}, {os.cpu_count()} CPUs, {' '.join(simd)}; load average at start {' '.join(load)}"


def cell(values):
    if not values:
        return "-"
    m = statistics.median(values)
    fmt = (lambda v: f"{v:.0f}") if m >= 100 else (lambda v: f"{v:.1f}")
    return f"{fmt(m)} ({fmt(min(values))}-{fmt(max(values))})"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=9)
    ap.add_argument("--passes", type=int, default=21)
    ap.add_argument("--pass-ms", type=float, default=5.0)
    ap.add_argument("--no-build", action="store_true")
    a = ap.parse_args()
    os.chdir(ROOT)
    if not a.no_build:
        subprocess.run(["bash", "bench/vamp/build.sh"], check=True, stdout=sys.stderr)
        subprocess.run(["cargo", "build", "--release", "-q", "-p", "omcbsa", "--example", "peer_scene"],
                       check=True)
    target = os.environ.get("CARGO_TARGET_DIR", "target")
    ours = os.path.join(target, "release/examples/peer_scene")
    vamp = VAMP_PEER
    for program in (ours, vamp):
        if not os.access(program, os.X_OK):
            sys.exit(f"side_by_side.py: {program} is not built (run without --no-build)")
    fk = os.path.join(tempfile.mkdtemp(), "fk_configs.json")
    sh([ours, "fk-configs", fk])
    passes, pass_ms = str(a.passes), str(a.pass_ms)
    programs = [
        ("omcbsa", [ours, "run", SCENE, "--passes", passes, "--pass-ms", pass_ms], {}),
        ("vamp", [vamp, SCENE, fk, passes, pass_ms], {}),
        ("kdl", ["bash", "bench/kdl/run.sh", passes, pass_ms],
         {"env": dict(os.environ, FK_CONFIGS=fk)}),
    ]
    at_start = machine()
    runs = defaultdict(list)  # (system, case) -> medians, one per run
    least = defaultdict(list)  # (system, case) -> least pass, one per run
    info = {}
    for r in range(a.runs):
        for name, cmd, kw in programs[r % 3:] + programs[:r % 3]:
            print(f"run {r + 1}/{a.runs}: {name}", file=sys.stderr)
            for key, (items, hits, ns, ns_min) in rows_of(sh(cmd, **kw)).items():
                runs[key].append(ns)
                least[key].append(ns_min)
                info[key] = (items, hits)
    commit = open(VAMP_COMMIT).read().strip()
    head = sh(["git", "rev-parse", "--short", "HEAD"]).strip()
    print(f"machine: {at_start}; at end {' '.join(open('/proc/loadavg').read().split()[:3])}")
    print(f"omcbsa {head}; VAMP {commit}; {a.runs} runs x {a.passes} passes of ~{a.pass_ms} ms per case")
    table("ns per item: median over runs of each run's median pass (least-most of the runs' medians)",
          runs, info, cell)
    print()
    table("ns per item: least pass of all runs (load only adds time)", least, info,
          lambda v: cell([min(v)]).split(" ")[0] if v else "-")


def table(title, values, info, fmt):
    print(title + "\n")
    print("| case | omcbsa scalar | omcbsa batched | VAMP single | VAMP batched-8 | KDL | items/hits per column |")
    print("|---|---|---|---|---|---|---|")
    for label, o, ob, vs, vb, k in ROWS:
        cols = (("omcbsa", o), ("omcbsa", ob), ("vamp", vs), ("vamp", vb), ("kdl", k))
        cells = [fmt(values.get((s, c), [])) if c else "-" for s, c in cols]
        counts = " · ".join("{}/{}".format(*info[(s, c)]) if (s, c) in info else "-" for s, c in cols)
        print(f"| {label} | " + " | ".join(cells) + f" | {counts} |")

if __name__ == "__main__":
    main()
