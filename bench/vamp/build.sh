#!/bin/bash
# Builds VAMP (KavrakiLab/vamp) and the harness vamp_peer, VAMP's side of the comparison in
# docs/bench/collision.md. Not part of CI.
#
#   bash bench/vamp/build.sh                          # sources from GitHub
#   VAMP_MIRRORS=/path/to/mirrors bash bench/vamp/build.sh
#
# Gets VAMP and the dependencies its CMake would download at pinned commits, and builds them
# into target/vamp/ (git-ignored): nothing of VAMP enters the repository. With VAMP_MIRRORS
# set, the sources come from local git mirrors, $VAMP_MIRRORS/<owner>+<name>/repo, instead of
# GitHub. Installs cmake, libeigen3-dev (VAMP's Eigen) and nlohmann-json3-dev (the harness)
# from Debian when missing. Prints the path of vamp_peer.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=$root/target/vamp
src=$out/src
build=$out/build

VAMP=f6de6a72e0725ba08e0829f0a34261a3f465aed7
# The commits VAMP's cmake/Dependencies.cmake and cmake/Python.cmake pin.
NIGH=97130999440647c204e0265d05a997dbd8da4e70
PDQSORT=b1ef26a55cdb60d236a5cb199c4234c704f46726
SIMDXORSHIFT=857c1a01df53cf1ee1ae8db3238f0ef42ef8e490
NANOBIND=9a25aed8a7edfe60ef9ad1c911e57667bc4916c4
ROBIN_MAP=4ec1bf19c6a96125ea22062f38c2cf5b958e448e # nanobind's ext/robin_map at that commit
# CPM.cmake v0.40.1, the release VAMP's cmake/FetchInitCPM.cmake downloads, and its SHA-256.
CPM=8b67fe23447a564d0cff45e94547a23c114109b5
CPM_SHA256=117cbf2711572f113bab262933eb5187b08cfc06dce0714a1ee94f2183ddc3ec

if ! dpkg -s cmake libeigen3-dev nlohmann-json3-dev >/dev/null 2>&1; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq cmake libeigen3-dev nlohmann-json3-dev g++ git >/dev/null
fi

# get OWNER/NAME COMMIT DEST: the repository's tree at COMMIT into DEST, once per commit.
get() {
  local repo=$1 rev=$2 dest=$3
  local stamp=$dest.commit
  [[ -f $stamp && $(cat "$stamp") == "$rev" ]] && return
  rm -rf "$dest" "$stamp"
  mkdir -p "$dest"
  if [[ -n ${VAMP_MIRRORS:-} ]]; then
    local g=$VAMP_MIRRORS/${repo/\//+}/repo
    [[ -d $g ]] || { echo "build.sh: no mirror of $repo at $g" >&2; exit 1; }
    git -C "$g" cat-file -e "$rev^{commit}" 2>/dev/null ||
      { echo "build.sh: mirror $g does not hold commit $rev" >&2; exit 1; }
    # A mirror may leave out large blobs (meshes, test data): check out every file it holds,
    # through an index of our own (the mirror is only read).
    local index oid path
    index=$(mktemp)
    local git=(env GIT_INDEX_FILE="$index" git --git-dir="$g" --work-tree="$dest")
    "${git[@]}" read-tree "$rev"
    while read -r oid path; do
      if ! git -C "$g" cat-file -e "$oid" 2>/dev/null; then
        echo "  left out (absent in mirror): $repo:$path" >&2
        "${git[@]}" update-index --force-remove -- "$path"
      fi
    done < <(git -C "$g" ls-tree -r --format='%(objecttype) %(objectname) %(path)' "$rev" |
      sed -n 's/^blob //p')
    "${git[@]}" checkout-index -a
    rm -f "$index"
  else
    git -C "$dest" init -q
    git -C "$dest" fetch -q --depth 1 "https://github.com/$repo" "$rev"
    git -C "$dest" -c advice.detachedHead=false checkout -q FETCH_HEAD
  fi
  echo "$rev" >"$stamp"
}

get KavrakiLab/vamp $VAMP "$src/vamp"
get KavrakiLab/nigh $NIGH "$src/nigh"
get orlp/pdqsort $PDQSORT "$src/pdqsort"
get lemire/SIMDxorshift $SIMDXORSHIFT "$src/SIMDxorshift"
get wjakob/nanobind $NANOBIND "$src/nanobind"
get Tessil/robin-map $ROBIN_MAP "$src/nanobind/ext/robin_map"
get cpm-cmake/CPM.cmake $CPM "$src/CPM.cmake"

# The released CPM.cmake is the tagged source with its version filled in. VAMP's
# file(DOWNLOAD ... EXPECTED_HASH) finds it in place with the expected hash and downloads
# nothing; no file of VAMP is changed.
mkdir -p "$build/vamp/cmake"
cpm=$build/vamp/cmake/CPM.cmake
sed 's/^set(CURRENT_CPM_VERSION .*)/set(CURRENT_CPM_VERSION 0.40.1)/' \
  "$src/CPM.cmake/cmake/CPM.cmake" >"$cpm"
echo "$CPM_SHA256  $cpm" | sha256sum -c --quiet

# CPM_<name>_SOURCE points CPM at the local sources (nanobind's only for VAMP's Python
# bindings, which the harness leaves off). The harness includes VAMP's own
# CompilerSettings.cmake, so it is compiled as VAMP compiles its demos.
cmake --no-warn-unused-cli -S "$root/bench/vamp" -B "$build" -DCMAKE_BUILD_TYPE=Release -DVAMP_SOURCE="$src/vamp" \
  -DCPM_nigh_SOURCE="$src/nigh" -DCPM_pdqsort_SOURCE="$src/pdqsort" \
  -DCPM_SIMDxorshift_SOURCE="$src/SIMDxorshift" -DCPM_nanobind_SOURCE="$src/nanobind" >/dev/null
cmake --build "$build" -j"$(nproc)" --target vamp_peer >&2
echo "$build/vamp_peer"
