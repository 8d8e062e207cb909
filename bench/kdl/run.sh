#!/bin/bash
# Orocos KDL's FK on omcbsa's FK configurations, as a peer in the same run (see
# docs/bench/collision.md). Debian packages only; not part of CI.
#
#   bash bench/kdl/run.sh [PASSES] [PASS_MS]
#
# Installs KDL, kdl_parser and nlohmann-json from Debian when missing, builds kdl_fk.cc into
# target/kdl/, writes the configurations with `peer_scene fk-configs`, prints KDL's rows.
# FK_CONFIGS=FILE uses configurations already written (the side-by-side script does).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
passes=${1:-21} pass_ms=${2:-5}
if ! dpkg -s liborocos-kdl-dev libkdl-parser-dev nlohmann-json3-dev >/dev/null 2>&1; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq liborocos-kdl-dev libkdl-parser-dev nlohmann-json3-dev g++ >/dev/null
fi
mkdir -p "$root/target/kdl"
bin=$root/target/kdl/kdl_fk
if [[ ! -x $bin || $root/bench/kdl/kdl_fk.cc -nt $bin ]]; then
  g++ -std=c++17 -O3 -march=native -I/usr/include/eigen3 "$root/bench/kdl/kdl_fk.cc" -o "$bin" \
    -lkdl_parser -lorocos-kdl
fi
configs=${FK_CONFIGS:-}
if [[ -z $configs ]]; then
  configs=$root/target/kdl/fk_configs.json
  (cd "$root" && cargo run --release -q -p omcbsa --example peer_scene -- fk-configs "$configs")
fi
# kdl_parser's ROS logger warns that KDL ignores the root links' inertia: not about FK.
"$bin" "$configs" "$passes" "$pass_ms" "$root/robots" 2> >(grep -v "has an inertia specified" >&2)
