#!/usr/bin/env bash
# Hash the frames of a short prefix of every shipped scene, so that a
# restructuring of the kernels can be shown to keep whole simulations' bits
# (the kernel-level companion is ek-hash, verify/ek_hash.c).
#
# usage: tools/hash_scenes.sh BUILD_DIR OUT_FILE [STEPS]
#   Runs BUILD_DIR/bin/ek-sim on every scenes/*.json for STEPS steps
#   (default 20, or EK_HASH_STEPS) on 2 threads (EK_HASH_THREADS), writing
#   frames to a temporary directory, and writes one line per HDF5 dataset
#   of each frame file to OUT_FILE:
#     <scene> <dataset> <sha256 of the dataset's raw bytes, first 16 hex>
#   A scene that fails prints "<scene> - rc=<exit status>". Only datasets
#   are hashed (positions, per-element fields, step and simulated time):
#   attributes (creation metadata) are left out. ek-sim writes a frame at
#   every scene output interval and always at the last step, so every scene
#   contributes its state after STEPS steps whatever its interval.
#   Results are the same bits at any thread count except for scenes that
#   pick the atomic scatter (none of the shipped ones does).
# Needs h5ls and h5dump (Debian: hdf5-tools).
set -euo pipefail

if [ $# -lt 2 ] || [ $# -gt 3 ]; then
  echo "usage: $0 BUILD_DIR OUT_FILE [STEPS]" >&2
  exit 2
fi
build=$1
out=$2
steps=${3:-${EK_HASH_STEPS:-20}}
threads=${EK_HASH_THREADS:-2}
sim=$build/bin/ek-sim
root=$(cd "$(dirname "$0")/.." && pwd)

if [ ! -x "$sim" ]; then
  echo "$0: $sim not found (build the ek-sim target)" >&2
  exit 2
fi
for tool in h5ls h5dump sha256sum; do
  if ! command -v "$tool" >/dev/null; then
    echo "$0: $tool not found (apt-get install hdf5-tools)" >&2
    exit 2
  fi
done

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
: >"$tmp/out"

for scene in "$root"/scenes/*.json; do
  name=$(basename "$scene" .json)
  h5=$tmp/$name.h5
  start=$(date +%s.%N)
  rc=0
  "$sim" "$scene" --steps "$steps" --threads "$threads" --out "$h5" --force \
    >"$tmp/$name.log" 2>&1 || rc=$?
  secs=$(echo "$(date +%s.%N) - $start" | bc 2>/dev/null || echo "?")
  if [ "$rc" -ne 0 ] || [ ! -f "$h5" ]; then
    echo "$name - rc=$rc" >>"$tmp/out"
    echo "$name: ek-sim failed (rc=$rc): $(tail -n 3 "$tmp/$name.log")" >&2
    continue
  fi
  # Every dataset, in h5ls's (sorted) order.
  h5ls -r "$h5" | awk '$2 == "Dataset" { print $1 }' >"$tmp/datasets"
  while read -r ds; do
    rm -f "$tmp/ds.bin"
    h5dump -b NATIVE -d "$ds" -o "$tmp/ds.bin" "$h5" >/dev/null
    h=$(sha256sum "$tmp/ds.bin" | cut -c1-16)
    echo "$name $ds $h" >>"$tmp/out"
  done <"$tmp/datasets"
  echo "$name: $(wc -l <"$tmp/datasets") datasets, ${secs}s" >&2
done
cp "$tmp/out" "$out"
echo "$0: $(wc -l <"$out") lines in $out" >&2
