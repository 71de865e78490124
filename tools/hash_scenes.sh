#!/usr/bin/env bash
# Hash the frames of a short prefix of every shipped scene, so that a
# restructuring of the kernels can be shown to keep whole simulations' bits
# (the kernel-level companion is ek-hash, verify/ek_hash.c).
#
# usage: tools/hash_scenes.sh BUILD_DIR OUT_FILE [STEPS]
#   Runs BUILD_DIR/bin/ek-sim on every scenes/*.json for STEPS steps
#   (default 30, or EK_HASH_STEPS; fewer for the costly scenes, below) on 2 threads (EK_HASH_THREADS), writing
#   frames to a temporary directory, and writes one line per HDF5 dataset
#   of each frame file to OUT_FILE:
#     <scene> <dataset> <sha256 of the dataset's dump, first 16 hex>
#   A scene that fails prints "<scene> - rc=<exit status>"; one that ran but
#   failed ek-sim's state check (rc 3, 4) is hashed and said on stderr. Only datasets
#   are hashed (positions, per-element fields, step and simulated time):
#   attributes (creation metadata) are left out. ek-sim writes a frame at
#   every scene output interval and always at the last step, so every scene
#   contributes its state after STEPS steps whatever its interval.
#   Results are the same bits at any thread count except for scenes that
#   pick the atomic scatter (none of the shipped ones does).
#   The costly scenes run fewer steps (steps_for below; measured on the
#   2-core Zen 4 machine while other builds ran: bracket's implicit step,
#   120k tets, took 330 s, cantilever_implicit's 13 s, cantilever_xpbd's
#   1 s, the others 0.01-0.25 s): bracket is skipped ("<scene> - skipped")
#   unless EK_HASH_ALL=1 (then 1 step), so the script takes a few minutes.
# Needs h5dump (Debian: hdf5-tools) and python3 (standard library only).
set -euo pipefail

if [ $# -lt 2 ] || [ $# -gt 3 ]; then
  echo "usage: $0 BUILD_DIR OUT_FILE [STEPS]" >&2
  exit 2
fi
build=$1
out=$2
steps=${3:-${EK_HASH_STEPS:-30}}
threads=${EK_HASH_THREADS:-2}
sim=$build/bin/ek-sim
root=$(cd "$(dirname "$0")/.." && pwd)

if [ ! -x "$sim" ]; then
  echo "$0: $sim not found (build the ek-sim target)" >&2
  exit 2
fi
for tool in h5dump python3; do
  if ! command -v "$tool" >/dev/null; then
    echo "$0: $tool not found (apt-get install hdf5-tools)" >&2
    exit 2
  fi
done

# Steps for a scene: 0 = skipped.
steps_for() {
  case $1 in
  bracket) if [ "${EK_HASH_ALL:-0}" = 1 ]; then echo 1; else echo 0; fi ;;
  cantilever_implicit) echo 2 ;;
  cantilever_xpbd | stiff_bar_implicit) echo $((steps < 5 ? steps : 5)) ;;
  *_implicit) echo $((steps < 10 ? steps : 10)) ;;
  *) echo "$steps" ;;
  esac
}

# Reads h5dump's text on stdin; prints "<scene> <dataset path> <hash>" per
# DATASET block (its type, shape and data lines), in the dump's order.
split_py='
import hashlib, re, sys
scene = sys.argv[1]
stack, cur, depth = [], None, 0
for line in sys.stdin:
    s = line.strip()
    m = re.match(r"(GROUP|DATASET) \"(.*)\" \{$", s)
    if cur is None and m:
        stack.append(m.group(2))
        if m.group(1) == "DATASET":
            cur, depth = hashlib.sha256(), 0
        continue
    if cur is not None:
        depth += s.count("{") - s.count("}")
        if depth < 0:
            path = "/" + "/".join(x for x in stack if x != "/")
            print(scene, path, cur.hexdigest()[:16])
            stack.pop()
            cur = None
        else:
            cur.update(s.encode() + b"\n")
    elif s == "}" and stack:
        stack.pop()
'

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
: >"$tmp/out"

for scene in "$root"/scenes/*.json; do
  name=$(basename "$scene" .json)
  h5=$tmp/$name.h5
  n=$(steps_for "$name")
  if [ "$n" -eq 0 ]; then
    echo "$name - skipped" >>"$tmp/out"
    echo "$name: skipped" >&2
    continue
  fi
  start=$(date +%s.%N)
  rc=0
  "$sim" "$scene" --steps "$n" --threads "$threads" --out "$h5" --force \
    >"$tmp/$name.log" 2>&1 || rc=$?
  secs=$(echo "$(date +%s.%N) - $start" | bc 2>/dev/null || echo "?")
  # rc 3 and 4 (sim/cli.h): the run finished and wrote every frame, but
  # its state check failed (NaN/inf or a blow-up; inverted elements at the
  # end). The frames are hashed as any others; the verdict goes to stderr.
  check=""
  if [ "$rc" -eq 3 ] || [ "$rc" -eq 4 ]; then
    check=" (state check failed, rc=$rc)"
    rc=0
  fi
  if [ "$rc" -ne 0 ] || [ ! -f "$h5" ]; then
    echo "$name - rc=$rc" >>"$tmp/out"
    echo "$name: ek-sim failed (rc=$rc): $(tail -n 3 "$tmp/$name.log")" >&2
    continue
  fi
  # One h5dump per file (one per dataset took two minutes for the 1700
  # datasets): the data as text, floats as C99 hex floats (%a: exact, every
  # bit of the value; a NaN prints as nan or -nan, its payload not kept),
  # attributes left out (-A 0); each DATASET block is hashed on its own.
  h5dump -A 0 -m '%a' -w 0 "$h5" | python3 -c "$split_py" "$name" >"$tmp/lines"
  cat "$tmp/lines" >>"$tmp/out"
  echo "$name: $n steps, $(wc -l <"$tmp/lines") datasets, ${secs}s$check" >&2
done
cp "$tmp/out" "$out"
echo "$0: $(wc -l <"$out") lines in $out" >&2
