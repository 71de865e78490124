#!/usr/bin/env bash
# Every ek program and test binary behaves alike on its command line
# (sim/cli.h): --help and -h print help naming the environment variables and
# exit 0, --version exits 0, a bad option or EK_ISA value exits 2 with one
# error line, errors are printed once; and the faults of issue 28 that a
# command line reaches (outputs that are not files or are the input, options
# that overflow, a run that goes NaN, a full disk).
#   cli.sh BIN_DIR SCENES_DIR TEST_BINARY...
set -u
bin=$1 scenes=$2
shift 2
failures=0
out=$(mktemp) err=$(mktemp)
trap 'rm -f "$out" "$err"' EXIT

# expect WHAT STATUS COMMAND...: the exit status is STATUS.
expect() {
  local what=$1 want=$2
  shift 2
  "$@" >"$out" 2>"$err" </dev/null
  local got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL $what: exit $got, expected $want"
    sed 's/^/  | /' "$err" | head -5
    failures=$((failures + 1))
    return 1
  fi
  return 0
}
# fail WHAT: a failed check, said.
fail() {
  echo "FAIL $1"
  failures=$((failures + 1))
}
# one_error WHAT: stderr is exactly one line (the error, printed once).
one_error() {
  local n
  n=$(wc -l <"$err")
  if [ "$n" -ne 1 ]; then
    echo "FAIL $1: $n lines on stderr, expected 1"
    sed 's/^/  | /' "$err" | head -5
    failures=$((failures + 1))
  fi
}

for prog in ek-bench ek-sim ek-verify ek-hash "$@"; do
  exe=$bin/$prog
  for h in --help -h; do
    if expect "$prog $h" 0 "$exe" "$h"; then
      for word in usage EK_ISA EK_VERBOSE OMP_NUM_THREADS "Exit status"; do
        grep -q "$word" "$out" || {
          echo "FAIL $prog $h: the help does not mention '$word'"
          failures=$((failures + 1))
        }
      done
      [ -s "$err" ] && {
        echo "FAIL $prog $h: wrote to stderr"
        failures=$((failures + 1))
      }
    fi
  done
  expect "$prog --version" 0 "$exe" --version && grep -q "(ek [0-9]" "$out" || {
    echo "FAIL $prog --version: no '(ek X.Y.Z)' in: $(head -1 "$out")"
    failures=$((failures + 1))
  }
  expect "$prog --no-such-option" 2 "$exe" --no-such-option && one_error "$prog --no-such-option"
done

# Values and environment.
expect "ek-verify --n 0" 2 "$bin/ek-verify" --n 0 && one_error "ek-verify --n 0"
expect "ek-verify --seed x" 2 "$bin/ek-verify" --seed x && one_error "ek-verify --seed x"
expect "ek-bench --threads 0" 2 "$bin/ek-bench" --threads 0 && one_error "ek-bench --threads 0"
expect "ek-bench --suite bogus" 2 "$bin/ek-bench" --suite bogus && one_error "ek-bench --suite bogus"
expect "ek-bench --quick (default suite)" 2 "$bin/ek-bench" --quick &&
  one_error "ek-bench --quick (default suite)"
expect "ek-sim --steps -1" 2 "$bin/ek-sim" "$scenes/cantilever.json" --steps -1 &&
  one_error "ek-sim --steps -1"
expect "ek-sim without a scene" 2 "$bin/ek-sim" && one_error "ek-sim without a scene"
for prog in ek-bench ek-verify; do
  expect "EK_ISA=bogus $prog" 2 env EK_ISA=bogus "$bin/$prog" --filter nothing &&
    one_error "EK_ISA=bogus $prog"
done
# OMP_NUM_THREADS past --threads' limit: a usage error naming the variable,
# not libgomp's "out of memory" at the first parallel region.
for prog in ek-bench ek-verify; do
  expect "OMP_NUM_THREADS=99999999999 $prog" 2 env OMP_NUM_THREADS=99999999999 \
    "$bin/$prog" --filter nothing && one_error "OMP_NUM_THREADS=99999999999 $prog"
done
expect "OMP_NUM_THREADS=4,5000 ek-sim" 2 env OMP_NUM_THREADS=4,5000 "$bin/ek-sim" \
  "$scenes/cantilever.json" --no-output --steps 1 && one_error "OMP_NUM_THREADS=4,5000 ek-sim"
# A nested level's threads (libgomp takes "2,3" as 3 threads per nested
# region): ek opens none, so they would go unused; "2,1" is what ek does.
expect "OMP_NUM_THREADS=2,3 ek-sim" 2 env OMP_NUM_THREADS=2,3 "$bin/ek-sim" \
  "$scenes/cantilever.json" --no-output --steps 1 && one_error "OMP_NUM_THREADS=2,3 ek-sim" &&
  { grep -qF "OMP_NUM_THREADS='2,3': item 2 (3 threads) is for nested parallel regions" "$err" ||
    fail "OMP_NUM_THREADS=2,3 ek-sim: $(cat "$err")"; }
expect "OMP_NUM_THREADS=2,1 ek-sim" 0 env OMP_NUM_THREADS=2,1 "$bin/ek-sim" \
  "$scenes/cantilever.json" --no-output --steps 1
expect "EK_ISA=bogus ek-sim" 2 env EK_ISA=bogus "$bin/ek-sim" "$scenes/cantilever.json" \
  --no-output --steps 1 && one_error "EK_ISA=bogus ek-sim"
# Every EK_* variable as EK_ISA (kernels/env.c): a value not among its words
# is bad usage naming the variable and the value (EK_FVM_PREFETCH=yes was
# read by atoi: silently off).
for e in EK_FVM_PREFETCH=yes EK_SVD3_CHAINS=3 EK_VERBOSE=2; do
  for cmd in "ek-bench --filter nothing" "ek-verify --filter nothing" "ek-hash --threads 1" \
    "ek-sim $scenes/cantilever.json --no-output --steps 1"; do
    # shellcheck disable=SC2086
    expect "$e $cmd" 2 env "$e" "$bin"/$cmd && one_error "$e $cmd" &&
      { grep -qF "${e%%=*}='${e#*=}' is not one of" "$err" || fail "$e $cmd: $(cat "$err")"; }
  done
done
expect "EK_FVM_PREFETCH=1 EK_SVD3_CHAINS=4 EK_VERBOSE=0 ek-sim" 0 env EK_FVM_PREFETCH=1 \
  EK_SVD3_CHAINS=4 EK_VERBOSE=0 "$bin/ek-sim" "$scenes/cantilever.json" --no-output --steps 1
# A scene that cannot be read is a failed run (1), not a usage error.
expect "ek-sim on a missing scene" 1 "$bin/ek-sim" "$scenes/no-such-scene.json" --no-output &&
  one_error "ek-sim on a missing scene"
# ek-sim --advise: bad --tol / --time values and options that do not go with it.
for args in "--tol -0.1" "--tol 1" "--tol nan" "--tol x" "--time 0" "--time -1" "--time inf" "--time"; do
  # shellcheck disable=SC2086
  expect "ek-sim --advise $args" 2 "$bin/ek-sim" "$scenes/small_strain.json" --advise $args &&
    one_error "ek-sim --advise $args"
done
expect "ek-sim --tol without --advise" 2 "$bin/ek-sim" "$scenes/small_strain.json" --tol 0.1 &&
  one_error "ek-sim --tol without --advise"
expect "ek-sim --advise --steps" 2 "$bin/ek-sim" "$scenes/small_strain.json" --advise --steps 5 &&
  one_error "ek-sim --advise --steps"

# Issue 28: faults and hostile input.
work=$(mktemp -d)
trap 'rm -f "$out" "$err"; rm -rf "$work"' EXIT
# Output paths that are not regular files: refused, even with --force, and
# left as they were (the commit renames over the path).
mkfifo "$work/fifo.h5"
mkdir "$work/dir.h5"
expect "ek-sim --out FIFO --force" 1 "$bin/ek-sim" "$scenes/cantilever.json" --steps 1 \
  --out "$work/fifo.h5" --force && one_error "ek-sim --out FIFO --force"
[ -p "$work/fifo.h5" ] || fail "ek-sim --out FIFO --force: the FIFO was replaced"
expect "ek-sim --out DIR --force" 1 "$bin/ek-sim" "$scenes/cantilever.json" --steps 1 \
  --out "$work/dir.h5" --force && one_error "ek-sim --out DIR --force"
[ -d "$work/dir.h5" ] || fail "ek-sim --out DIR --force: the directory was replaced"
expect "ek-bench --out FIFO --force" 1 "$bin/ek-bench" --filter nothing --out "$work/fifo.h5" \
  --json "$work/b.json" --force && one_error "ek-bench --out FIFO --force"
[ -p "$work/fifo.h5" ] || fail "ek-bench --out FIFO --force: the FIFO was replaced"
# A filter of 10 000 characters: the run's metadata holds the whole command
# line (it was once cut at 511 characters, and before that overran a
# 512-byte buffer into the output's name).
long=$(head -c 10000 /dev/zero | tr '\0' x)
filter="^svd3/aosoa/scalar/f32/sweeps:2/rsqrt:approx/threads:1\$|$long"
if expect "ek-bench --filter (10 000 characters)" 0 "$bin/ek-bench" --threads 1 --min-time 0.1 \
  --filter "$filter" --out "$work/long.h5" --json "$work/long.json"; then
  [ -s "$work/long.h5" ] && [ -s "$work/long.json" ] ||
    fail "ek-bench --filter (10 000 characters): $work/long.h5 or long.json not written"
  grep -qF "\"--threads 1 --min-time 0.1 --filter $filter --out $work/long.h5 --json $work/long.json \"" \
    "$work/long.json" ||
    fail "ek-bench --filter (10 000 characters): the JSON's arguments are not the whole command line"
fi
# Run outside its tree, without the shipped scenes (EK_SCENES_DIR naming an
# empty folder): a filter that selects no row of a scene needs none, listed
# or timed; one that selects a sim row, or a polar row of a scene's input,
# fails (1) before anything is timed, naming the scene and the path tried.
mkdir "$work/noscenes"
if expect "ek-bench --list, no scenes, filter svd3/aosoa/scalar" 0 \
  env EK_SCENES_DIR="$work/noscenes" "$bin/ek-bench" --filter svd3/aosoa/scalar --list; then
  grep -q '^svd3/aosoa/scalar/' "$out" || fail "ek-bench --list, no scenes: no svd3 row listed"
  grep -q FAILED "$err" && fail "ek-bench --list, no scenes: $(grep FAILED "$err" | head -1)"
fi
expect "ek-bench, no scenes, one svd3 row timed" 0 env EK_SCENES_DIR="$work/noscenes" \
  "$bin/ek-bench" --threads 1 --min-time 0.1 \
  --filter '^svd3/aosoa/scalar/f32/sweeps:2/rsqrt:approx/threads:1$' \
  --out "$work/noscenes.h5" --json "$work/noscenes.json"
for args in "--list --filter ^sim/cantilever/" "--list --filter solver:matrix_free" \
  "--filter input:twist --out $work/twist.h5"; do
  # shellcheck disable=SC2086
  expect "ek-bench $args, no scenes" 1 env EK_SCENES_DIR="$work/noscenes" "$bin/ek-bench" $args &&
    { grep -q "scene \"[a-z_]*\" not found; tried $work/noscenes/" "$err" ||
      fail "ek-bench $args, no scenes: no 'scene not found' in: $(head -2 "$err")"; }
done
[ -e "$work/twist.h5" ] && fail "ek-bench --filter input:twist, no scenes: wrote results"
# The input scene as the output.
cp "$scenes/cantilever.json" "$work/scene.json"
expect "ek-sim --out SCENE --force" 2 "$bin/ek-sim" "$work/scene.json" --steps 1 \
  --out "$work/scene.json" --force && one_error "ek-sim --out SCENE --force"
cmp -s "$scenes/cantilever.json" "$work/scene.json" || fail "ek-sim --out SCENE: scene changed"
# --advise --time out of range (the step count overflowed a long).
for t in 1e300 1e-300; do
  expect "ek-sim --advise --time $t" 2 "$bin/ek-sim" "$scenes/small_strain.json" --advise \
    --time "$t" && one_error "ek-sim --advise --time $t"
done
# ek-verify --json: checked before the first row, never overwritten without
# --force, never a directory.
echo keep >"$work/v.json"
expect "ek-verify --json EXISTING" 1 "$bin/ek-verify" --filter nothing --json "$work/v.json" &&
  one_error "ek-verify --json EXISTING"
[ "$(cat "$work/v.json")" = keep ] || fail "ek-verify --json EXISTING: overwritten"
grep -q "ek-verify:.*rows" "$out" && fail "ek-verify --json EXISTING: ran the rows first"
expect "ek-verify --json EXISTING --force" 0 "$bin/ek-verify" --quick --n 100 \
  --filter '^svd3 scalar f32 sweeps=def rsqrt=exact random$' --json "$work/v.json" --force
grep -q '"tool"' "$work/v.json" || fail "ek-verify --json --force: not written"
expect "ek-verify --json DIR" 1 "$bin/ek-verify" --filter nothing --json "$work/dir.h5" &&
  one_error "ek-verify --json DIR"
expect "ek-verify --json NO/FOLDER" 1 "$bin/ek-verify" --filter nothing \
  --json "$work/none/v.json" && one_error "ek-verify --json NO/FOLDER"
# A filter that selects no row verified nothing: bad usage, not a PASS.
expect "ek-verify --filter (no row)" 2 "$bin/ek-verify" --filter nothing &&
  one_error "ek-verify --filter (no row)"
grep -q "PASS" "$out" && fail "ek-verify --filter (no row): said PASS"
expect "ek-verify --extremes --filter (no row)" 2 "$bin/ek-verify" --extremes --filter nothing &&
  one_error "ek-verify --extremes --filter (no row)"
# ek-bench: a listing of no row is the mistake a run of none is (exit 2).
expect "ek-bench --list --filter (no row)" 2 "$bin/ek-bench" --list --filter nothing &&
  one_error "ek-bench --list --filter (no row)"
# Output folders that are regular files (root's access(W_OK) passes on a
# file): refused before the first row, not after the run (the audit of
# round 11); an empty output name is bad usage.
echo file >"$work/plain"
expect "ek-verify --json FILE/v.json" 1 "$bin/ek-verify" --filter 'svd3' \
  --json "$work/plain/v.json" && one_error "ek-verify --json FILE/v.json"
grep -q "rows" "$out" && fail "ek-verify --json FILE/v.json: ran the rows first"
expect "ek-verify --json ''" 2 "$bin/ek-verify" --filter nothing --json "" &&
  one_error "ek-verify --json ''"
one_row='^svd3/aosoa/scalar/f32/sweeps:2/rsqrt:approx/threads:1$'
for o in --out --json; do
  h5=$work/b.h5 json=$work/b.json
  [ $o = --out ] && h5=$work/plain/b.h5 || json=$work/plain/b.json
  expect "ek-bench $o FILE/b" 1 "$bin/ek-bench" --threads 1 --min-time 0.1 \
    --filter "$one_row" --out "$h5" --json "$json" && one_error "ek-bench $o FILE/b"
  grep -q "Not a directory" "$err" || fail "ek-bench $o FILE/b: not said: $(head -1 "$err")"
  [ -e "$work/b.h5" ] && fail "ek-bench $o FILE/b: $work/b.h5 written"
done
# ek-bench on a full disk (writes fail with EFBIG): exit 1, one line per
# file, nothing left behind; HDF5's error stack (~180 lines) only under
# EK_VERBOSE=1. (stderr through a pipe: the limit would cut a file.)
mkdir "$work/full"
(
  ulimit -f 4
  trap '' XFSZ
  exec "$bin/ek-bench" --threads 1 --min-time 0.1 --filter "$one_row" --out "$work/full/b.h5"
) 2>&1 >/dev/null </dev/null | cat >"$err"
rc=${PIPESTATUS[0]}
[ "$rc" -eq 1 ] || fail "ek-bench on a full disk: exit $rc, expected 1"
grep -q "HDF5-DIAG" "$err" && fail "ek-bench on a full disk: HDF5's error stack printed"
grep -q "writing '$work/full/b.h5' failed; nothing written" "$err" ||
  fail "ek-bench on a full disk: not said: $(tail -1 "$err")"
if [ -n "$(ls -A "$work/full")" ]; then
  fail "ek-bench on a full disk: left $(ls "$work/full")"
fi
expect "ek-sim --out ''" 2 "$bin/ek-sim" "$scenes/cantilever.json" --steps 1 --out "" &&
  one_error "ek-sim --out ''"
# SIGHUP (the terminal closed) stops ek-sim as SIGTERM does: the frames
# closed and named partial, no scratch file left, death by the signal.
"$bin/ek-sim" "$scenes/cantilever.json" --steps 100000 --out "$work/hup.h5" \
  >"$out" 2>"$err" </dev/null &
pid=$!
for _ in $(seq 300); do
  [ -e "$work/hup.h5" ] && break
  sleep 0.1
done
kill -HUP "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 129 ] || fail "ek-sim SIGHUP: exit $rc, expected 129 (the signal)"
grep -q "stopped by SIGHUP" "$err" || fail "ek-sim SIGHUP: not said: $(tail -1 "$err")"
grep -q "partial" "$out" || fail "ek-sim SIGHUP: the frames are not named partial"
for f in "$work"/hup.*scratch*; do
  [ -e "$f" ] && fail "ek-sim SIGHUP: left $f"
done
# A run whose state goes NaN fails (exit 1) at the step it happens, even
# the last one, naming a non-finite state.
printf '%s\n' '{"mesh": {"box": [2, 2, 2], "size": [1, 1, 1]},' \
  ' "material": {"model": "fixed_corotated", "E": 1e5, "nu": 0.3, "density": 1000},' \
  ' "boundary": [{"type": "pin", "region": {"min": [0, 0, 0], "max": [1, 1, 0]}}],' \
  ' "gravity": [0, 0, -9.81], "dt": 1e3, "steps": 50}' >"$work/nan.json"
expect "ek-sim: state goes NaN" 1 "$bin/ek-sim" "$work/nan.json" --no-output
grep -q "non-finite" "$err" || fail "ek-sim: state goes NaN: no 'non-finite' in: $(tail -1 "$err")"
grep -q "invertible" "$err" && fail "ek-sim: state goes NaN: blamed on the model"
# The state check (issue 25, sim/cli.h): a run that ends inverted exits 4
# and says so, unless the scene's allow.inverted; NaN/inf in a frame or a
# blow-up exits 3 (even without frames for the blow-up), unless
# allow.nonfinite. The summary counts both at the last and the worst frame.
data=$(cd "$(dirname "$0")/data" && pwd)
expect "ek-sim: run ends inverted" 4 "$bin/ek-sim" "$data/inverts.json" --out "$work/inv.h5"
grep -q "24 of 24 tets INVERTED" "$err" || fail "ek-sim: run ends inverted: not said in: $(tail -1 "$err")"
# ... naming the last frame (the scene's steps and dt) and its first
# inverted tet: every tet ends mirrored, J = -1 (the scene's description).
inv_steps=$(grep -o '"steps": [0-9]*' "$data/inverts.json" | grep -o '[0-9]*$')
inv_dt=$(grep -o '"dt": [0-9.e-]*' "$data/inverts.json" | grep -o '[0-9.e-]*$')
inv_at=$(awk -v n="$inv_steps" -v dt="$inv_dt" 'BEGIN { printf "step %d (t = %g s), the first is element 0 with J = -1;", n, n * dt }')
grep -qF "$inv_at" "$err" || fail "ek-sim: run ends inverted: no '$inv_at' in: $(tail -1 "$err")"
grep -q "^check .*last frame.*24 of 24 tets inverted (J <= 0), 0 non-finite" "$out" ||
  fail "ek-sim: run ends inverted: no check line in the summary"
grep -q "worst frame.*24 inverted, 0 non-finite" "$out" ||
  fail "ek-sim: run ends inverted: no worst-frame line in the summary"
expect "ek-sim: run ends inverted, no frames" 4 "$bin/ek-sim" "$data/inverts.json" --no-output
sed 's/^{/{"allow": {"inverted": true},/' "$data/inverts.json" >"$work/inv_allowed.json"
expect "ek-sim: inversion allowed" 0 "$bin/ek-sim" "$work/inv_allowed.json" --no-output
grep -q "allowed: the scene studies inversion" "$out" ||
  fail "ek-sim: inversion allowed: the summary does not say so"
expect "ek-sim --advise on a scene that inverts" 0 "$bin/ek-sim" "$data/inverts.json" --advise --time 2
grep -q "FAILURE .*ends with 24 of 24 tets inverted" "$out" ||
  fail "ek-sim --advise: the inverted reference is not flagged"
grep -q "^pick .*none" "$out" || fail "ek-sim --advise: picked a setting that inverts"
expect "ek-sim: frames hold NaN" 3 "$bin/ek-sim" "$data/flattens.json" --out "$work/flat.h5"
grep -q "FAILED: frames hold NaN/inf" "$err" || fail "ek-sim: frames hold NaN: not said"
grep -q "warning: .*holds [0-9]* NaN/inf values" "$err" ||
  fail "ek-sim: frames hold NaN: no warning at the first such frame"
# ... naming the first: every tet flat (J = 0, finite), so the first
# per-element field that is not finite is element 0's velocity gradient D.
grep -qF "NaN/inf values (first: D of element 0 = " "$err" ||
  fail "ek-sim: frames hold NaN: the first value not named: $(grep warning "$err")"
sed 's/^{/{"allow": {"nonfinite": true, "inverted": true},/' "$data/flattens.json" >"$work/flat_ok.json"
expect "ek-sim: NaN allowed" 0 "$bin/ek-sim" "$work/flat_ok.json" --out "$work/flat_ok.h5"
grep -q "NaN/inf in the frames allowed" "$out" || fail "ek-sim: NaN allowed: the summary does not say so"
printf '%s\n' '{"mesh": {"box": [1, 1, 1], "size": [1, 1, 1]}, "initial": {"velocity": [1e9, 0, 0]},' \
  ' "material": {"model": "stvk", "E": 1e5, "nu": 0.3, "density": 1000}, "dt": 10, "steps": 2}' \
  >"$work/blowup.json"
expect "ek-sim: positions blow up" 3 "$bin/ek-sim" "$work/blowup.json" --no-output
grep -q "FAILED: the positions blew up" "$err" || fail "ek-sim: positions blow up: not said"
# ... at the last frame (2 steps of 10 s) and the vertex: the first of those
# furthest from the rest centre, x = 1 after moving 2e10 m along x.
grep -qF "blew up: at step 2 (t = 20 s) vertex 1 is at (2e+10, 0, 0)," "$err" ||
  fail "ek-sim: positions blow up: step and vertex not named: $(grep blew "$err")"
printf '%s\n' '{"mesh": {"box": [1, 1, 1], "size": [1, 1, 1]}, "allow": {"inverted": 1},' \
  ' "material": {"model": "stvk", "E": 1e5, "nu": 0.3, "density": 1000}, "dt": 1, "steps": 1}' \
  >"$work/badallow.json"
expect "ek-sim: allow.inverted not a bool" 1 "$bin/ek-sim" "$work/badallow.json" --no-output &&
  one_error "ek-sim: allow.inverted not a bool"
# at FILE MARKER: "FILE:LINE:COL" of the byte after the first MARKER (a
# fixed string) in FILE, as scene errors found after parsing name a value.
at() {
  awk -v m="$2" -v f="$1" 'i = index($0, m) { print f ":" NR ":" i + length(m); exit }' "$1"
}
# A box too large for any machine's memory: refused before allocating,
# with the estimate (--explain still explains it), at the box's place.
sed 's/"box": \[100, 1, 10\]/"box": [4096, 4096, 4096]/' "$scenes/cantilever.json" >"$work/huge.json"
expect "ek-sim on a 4096^3 box" 1 "$bin/ek-sim" "$work/huge.json" --no-output &&
  one_error "ek-sim on a 4096^3 box"
grep -q "needs at least" "$err" || fail "ek-sim on a 4096^3 box: no estimate in: $(cat "$err")"
grep -qF "ek-sim: $(at "$work/huge.json" '"box": '): mesh.box 4096 x" "$err" ||
  fail "ek-sim on a 4096^3 box: not at the box's place: $(cat "$err")"
# The scene's output.file naming the scene itself: refused at its place.
sed "s|\"file\": \"cantilever.h5\"|\"file\": \"$work/self.json\"|" "$scenes/cantilever.json" \
  >"$work/self.json"
expect "ek-sim, output.file names the scene" 1 "$bin/ek-sim" "$work/self.json" --steps 1 &&
  one_error "ek-sim, output.file names the scene"
grep -qF "ek-sim: $(at "$work/self.json" '"output": {"file": '): output.file" "$err" ||
  fail "ek-sim, output.file names the scene: not at its place: $(cat "$err")"
expect "ek-sim --explain on a 4096^3 box" 0 "$bin/ek-sim" "$work/huge.json" --explain
# A scene's isa and an EK_ISA that disagree.
sed 's/^{/{"isa": "scalar",/' "$scenes/cantilever.json" >"$work/isa.json"
expect "scene isa scalar under EK_ISA=avx2" 2 env EK_ISA=avx2 "$bin/ek-sim" "$work/isa.json" \
  --no-output --steps 1 && one_error "scene isa scalar under EK_ISA=avx2"
grep -qF "but $(at "$work/isa.json" '"isa": ') names isa" "$err" ||
  fail "scene isa scalar under EK_ISA=avx2: not at the isa's place: $(cat "$err")"
# A full disk (a file size limit: writes fail with EFBIG) after some frames
# (a cantilever frame with every field is about 1.4 MB; 5 MB hold 3): a
# message and exit 1, no crash at exit (rc 139 was HDF5's atexit close), the
# frames written before it kept and named partial.
(
  ulimit -f 5000
  trap '' XFSZ
  exec "$bin/ek-sim" "$scenes/cantilever.json" --steps 3000 --out "$work/full.h5"
) >"$out" 2>"$err" </dev/null
rc=$?
if [ "$rc" -ne 1 ]; then
  fail "ek-sim on a full disk: exit $rc, expected 1"
  sed 's/^/  | /' "$err" | head -5
fi
grep -q "partial" "$out" || fail "ek-sim on a full disk: the frames are not named partial"
grep -Eq "^frames +[1-9][0-9]* written" "$out" ||
  fail "ek-sim on a full disk: no frame kept before the disk filled: $(grep frames "$out")"
# The failed write names its frame's step and time: the frame after the
# K kept, at step K * output.every (500), t = that * dt (1.7e-5).
kept=$(awk '/^frames/ { print $2 }' "$out")
full_at=$(awk -v k="$kept" 'BEGIN { printf "the frame after step %d (t = %g s): ", k * 500, k * 500 * 1.7e-5 }')
grep -qF "$full_at" "$err" || fail "ek-sim on a full disk: no '$full_at' in: $(tail -1 "$err")"
grep -q '"every": 500' "$scenes/cantilever.json" && grep -q '"dt": 1.7e-5' "$scenes/cantilever.json" ||
  fail "ek-sim on a full disk: cantilever.json's output.every or dt changed: update the check"

# Numbers on the command line are strict (sim/cli.h): the whole text is the
# number, no white space ("--steps ' 5'" ran 5 steps), not empty, no
# overflow, decimal; a usage error naming the option and the value.
for v in " 5" "5 " "" "5x" "99999999999999999999"; do
  expect "ek-sim --steps '$v'" 2 "$bin/ek-sim" "$scenes/cantilever.json" --no-output --steps "$v" &&
    one_error "ek-sim --steps '$v'" &&
    { grep -qF -- "--steps '$v'" "$err" || fail "ek-sim --steps '$v': value not named: $(cat "$err")"; }
done
# ek-hash --threads as strict (it was atoi: "2x" ran 2 threads, "x" 0).
for v in "x" " 2" "2x" "0" "4097" "99999999999999999999" ""; do
  expect "ek-hash --threads '$v'" 2 "$bin/ek-hash" --threads "$v" &&
    one_error "ek-hash --threads '$v'" &&
    { grep -qF -- "--threads '$v'" "$err" || fail "ek-hash --threads '$v': value not named: $(cat "$err")"; }
done
expect "ek-hash --threads (no value)" 2 "$bin/ek-hash" --threads &&
  one_error "ek-hash --threads (no value)"
expect "ek-sim --threads ' 1'" 2 "$bin/ek-sim" "$scenes/cantilever.json" --no-output --steps 1 \
  --threads " 1" && one_error "ek-sim --threads ' 1'"
for args in "--tol|0.1 " "--time| 0.01" "--time|0x1p-7"; do
  expect "ek-sim --advise ${args/|/ \'}'" 2 "$bin/ek-sim" "$scenes/small_strain.json" --advise \
    "${args%%|*}" "${args#*|}" && one_error "ek-sim --advise ${args/|/ \'}'"
done
# ek-bench on one row listed: only the bad value can make it exit 2.
for args in "--threads| 1" "--threads|1 " "--seed| -1" "--seed|99999999999999999999" \
  "--min-time| 1" "--isas|scalar,,avx2" "--isas|,scalar" "--isas|scalar," "--isas|"; do
  o=${args%%|*} v=${args#*|}
  expect "ek-bench $o '$v'" 2 "$bin/ek-bench" --list --filter "$one_row" "$o" "$v" &&
    one_error "ek-bench $o '$v'" &&
    { grep -qF -- "$o '$v'" "$err" || fail "ek-bench $o '$v': value not named: $(cat "$err")"; }
done
expect "ek-bench --isas scalar (one row listed)" 0 "$bin/ek-bench" --list --filter "$one_row" \
  --isas scalar
one_check='^svd3 scalar f32 sweeps=def rsqrt=exact random$'
for args in "--seed| 1" "--seed|1 " "--n| 100" "--seed|99999999999999999999"; do
  o=${args%%|*} v=${args#*|}
  expect "ek-verify $o '$v'" 2 "$bin/ek-verify" --quick --n 100 --filter "$one_check" "$o" "$v" &&
    one_error "ek-verify $o '$v'"
done
# Test binaries take --seed as strictly.
for prog in "$@"; do
  expect "$prog --seed ' 1'" 2 "$bin/$prog" --seed " 1" && one_error "$prog --seed ' 1'"
done

# Scene errors name FILE:LINE:COLUMN: the offending value (after parsing)
# or where the text stops being JSON; a file cut short says so.
sed 's/"E": 1.0e8/"E": -100000/' "$scenes/cantilever.json" >"$work/negE.json"
line=$(grep -n '"E": -100000' "$work/negE.json" | cut -d: -f1)
col=$(($(sed -n "${line}p" "$work/negE.json" | sed 's/"E": -100000.*//' | wc -c) + 5))
expect "ek-sim: material.E = -100000" 1 "$bin/ek-sim" "$work/negE.json" --no-output &&
  one_error "ek-sim: material.E = -100000"
grep -qF "negE.json:$line:$col: material.E = -100000" "$err" ||
  fail "ek-sim: material.E = -100000: not placed at $line:$col: $(cat "$err")"
head -c 200 "$scenes/cantilever.json" >"$work/cut.json"
expect "ek-sim: a scene cut short" 1 "$bin/ek-sim" "$work/cut.json" --no-output &&
  one_error "ek-sim: a scene cut short"
grep -q "cut.json:2:[0-9]*: invalid JSON: unexpected end of file" "$err" ||
  fail "ek-sim: a scene cut short: not said: $(cat "$err")"

# Vertices no element uses: one warning naming the mesh file, the count and
# the first; the run goes on as before (exit 0).
printf '%s\n' 'v 0 0 0' 'v 1 0 0' 'v 9 9 9' 'v 0 1 0' 'v 1 1 0' 'v 8 8 8' 'f 1 2 4' 'f 2 5 4' \
  >"$work/stray.obj"
printf '%s\n' '{"mesh": {"file": "stray.obj"}, "material": {"model": "stvk", "E": 1e5,' \
  ' "nu": 0.3, "density": 100}, "cloth": {"thickness": 0.001}, "dt": 1e-4, "steps": 2}' \
  >"$work/stray.json"
expect "ek-sim: a mesh with unused vertices" 0 "$bin/ek-sim" "$work/stray.json" --no-output
[ "$(grep -c warning "$err")" -eq 1 ] &&
  grep -q "warning: $work/stray.obj: 2 of 6 vertices belong to no triangle (the first: vertex 2," \
    "$err" || fail "ek-sim: a mesh with unused vertices: no warning: $(cat "$err")"
expect "ek-sim: a shipped scene from a mesh file" 0 "$bin/ek-sim" "$scenes/bracket.json" \
  --no-output --steps 1
grep -q warning "$err" && fail "ek-sim: bracket.json warns: $(grep warning "$err")"

# OMP_NUM_THREADS that is not a list of whole numbers in 1..4096: bad usage
# naming the variable (libgomp only warned, twice through the re-exec, and
# ran on every core; "-1" was called "more than 4096").
for v in 0 -1 abc "" "4," "2x"; do
  for prog in ek-sim ek-bench ek-verify ek-hash; do
    expect "OMP_NUM_THREADS='$v' $prog" 2 env OMP_NUM_THREADS="$v" "$bin/$prog" &&
      { grep -qF "$prog: OMP_NUM_THREADS='$v': each comma-separated item" "$err" ||
        fail "OMP_NUM_THREADS='$v' $prog: not said: $(cat "$err")"; }
  done
done
# (Blanks around an item are libgomp's; a nested level is 1: ek opens none.)
expect "OMP_NUM_THREADS=' 2, 1' ek-sim" 0 env OMP_NUM_THREADS=" 2, 1" "$bin/ek-sim" \
  "$scenes/cantilever.json" --no-output --steps 1
# An output named .xmf: the name is the HDF5 file's (its XDMF is written
# beside it); it wrote HDF5 into x.xmf and the XDMF into x.xmf.xmf.
expect "ek-sim --out x.xmf" 2 "$bin/ek-sim" "$scenes/cantilever.json" --steps 1 \
  --out "$work/x.xmf" && one_error "ek-sim --out x.xmf"
[ -e "$work/x.xmf" ] && fail "ek-sim --out x.xmf: wrote $work/x.xmf"
sed "s|\"file\": \"cantilever.h5\"|\"file\": \"$work/y.xmf\"|" "$scenes/cantilever.json" \
  >"$work/xmf.json"
expect "ek-sim, output.file y.xmf" 1 "$bin/ek-sim" "$work/xmf.json" --steps 1 &&
  one_error "ek-sim, output.file y.xmf"
grep -qF "ek-sim: $(at "$work/xmf.json" '"output": {"file": '): output.file" "$err" ||
  fail "ek-sim, output.file y.xmf: not at its place: $(cat "$err")"
[ -e "$work/y.xmf" ] && fail "ek-sim, output.file y.xmf: wrote $work/y.xmf"
# --n sizes the random set, which --extremes has not: it was ignored.
expect "ek-verify --extremes --n 5" 2 "$bin/ek-verify" --extremes --n 5 --filter nothing &&
  one_error "ek-verify --extremes --n 5" &&
  { grep -qF -- "--n: not with --extremes" "$err" || fail "ek-verify --extremes --n 5: $(cat "$err")"; }
# SIGTERM during ek-bench, ek-verify and ek-sim --advise (whose results
# come at the end): the process ends by the signal (143), saying so and
# what was not written; no file left behind. (They died silently.)
# stopped WHAT MARKER COMMAND...: started in the background, sent SIGTERM
# once MARKER is on its stderr (unbuffered; at most 30 s), or after 2 s.
stopped() {
  local what=$1 marker=$2
  shift 2
  "$@" >"$out" 2>"$err" </dev/null &
  local pid=$! rc
  if [ -n "$marker" ]; then
    for _ in $(seq 1500); do
      grep -qF -- "$marker" "$err" && break
      sleep 0.02
    done
  else
    sleep 2
  fi
  kill -TERM "$pid"
  wait "$pid"
  rc=$?
  [ "$rc" -eq 143 ] || fail "$what: exit $rc, expected 143 (SIGTERM)"
  grep -q "stopped by SIGTERM" "$err" || fail "$what: not said: $(tail -1 "$err")"
}
mkdir "$work/stop"
# ek-bench keeps the rows it finished (an 8-minute suite stopped near its
# end lost them all): named and marked partial, never under the whole run's
# names; the reports (perf_md.py, results_md.py) refuse such a file. "[1/"
# on a redirected stderr: row 1 is finished.
stopped "ek-bench SIGTERM" "[1/" "$bin/ek-bench" --threads 1 --min-time 0.5 \
  --filter '^svd3/aosoa/scalar' --out "$work/stop/b.h5"
grep -q "stopped by SIGTERM after [1-9][0-9]* of 18 rows; they are in $work/stop/b.partial.h5 and $work/stop/b.partial.json (marked partial)" "$err" ||
  fail "ek-bench SIGTERM: the partial files not named: $(tail -1 "$err")"
for f in b.h5 b.json; do
  [ -e "$work/stop/$f" ] && fail "ek-bench SIGTERM: wrote $f, the name of a whole run"
done
[ -s "$work/stop/b.partial.h5" ] || fail "ek-bench SIGTERM: no b.partial.h5"
if command -v python3 >/dev/null; then
  python3 -c '
import json, sys
c = json.load(open(sys.argv[1]))["context"]
# (Google Benchmark context values are strings)
assert c["partial"] == "true" and 1 <= int(c["rows_done"]) < 18 and c["rows_total"] == "18", c
assert c["partial_reason"].startswith("stopped by SIGTERM after"), c' "$work/stop/b.partial.json" ||
    fail "ek-bench SIGTERM: b.partial.json not marked partial"
  tools=$(cd "$(dirname "$0")/../tools" && pwd)
  for tool in perf_md.py results_md.py; do
    expect "$tool on a partial run" 1 python3 "$tools/$tool" --bench "$work/stop/b.partial.json" \
      --cpu x --out "$work/stop/r.md" &&
      { grep -q "a partial ek-bench run (stopped by SIGTERM" "$err" || fail "$tool on a partial run: $(cat "$err")"; }
  done
fi
# A stale partial file is not overwritten either (before the run starts).
expect "ek-bench, b.partial.h5 exists" 1 "$bin/ek-bench" --threads 1 --min-time 0.1 \
  --filter "$one_row" --out "$work/stop/b.h5" && one_error "ek-bench, b.partial.h5 exists"
grep -q "b.partial.h5' exists; not overwritten (use --force)" "$err" ||
  fail "ek-bench, b.partial.h5 exists: $(cat "$err")"
rm -f "$work"/stop/b.partial.*
# A row that fails in the middle of a run keeps the rows before it, as a
# signal does: b.partial.{h5,json}, marked partial, partial_reason naming
# the first failure (it gave only a count), never the whole run's names;
# exit 1; the FAILED line names what broke. The shipped scenes are copied
# and drop.json broken in ways that only drop's row meets, after twist's
# row (the listing pass reads every scene's JSON, but no mesh file and no
# step): (a) its mesh.file, read when the row starts, names node tag 9 of a
# 4-node mesh on line 13; (b) its dt is 0.5, 356 times its CFL limit, so a
# step fails while the row is timed (its later calls did nothing: the row
# was recorded at 0.2 ns per step and counted in rows_done; now dropped);
# (c) below. ~2 s each on the 2-core Zen 4 machine.
rf=$work/rowfail
mkdir "$rf"
cp -R "$scenes" "$rf/scenes"
printf '%s\n' '$MeshFormat' '2.2 0 8' '$EndMeshFormat' '$Nodes' 4 '1 0 0 0' '2 0.2 0 0' \
  '3 0 0.2 0' '4 0 0 0.2' '$EndNodes' '$Elements' 1 '1 4 2 0 1 1 2 3 9' '$EndElements' \
  >"$rf/scenes/meshes/broken.msh"
# broken_drop SED: the copy of drop.json edited by SED; 1 if SED changed nothing.
broken_drop() {
  sed -E "$1" "$scenes/drop.json" >"$rf/scenes/drop.json"
  ! cmp -s "$scenes/drop.json" "$rf/scenes/drop.json" || { fail "drop.json not edited by $1"; return 1; }
}
# row_fails WHAT SED FAILED_ERE [ERE...]: twist and the broken drop run;
# FAILED_ERE is the FAILED line after "FAILED: ", each ERE a line of stderr.
row_fails() {
  local what="ek-bench, a failing row ($1)" edit=$2 failed=$3 f
  shift 3
  broken_drop "$edit" || return
  expect "$what" 1 env EK_SCENES_DIR="$rf/scenes" "$bin/ek-bench" --threads 1 --min-time 0.1 \
    --filter '^sim/(twist|drop)/' --out "$rf/b.h5" || return
  grep -q "^\[1/2\] sim/twist/.* ns/item" "$err" || fail "$what: twist's row not timed: $(cat "$err")"
  grep -Eq "^ek-bench: FAILED: $failed" "$err" || fail "$what: the FAILED line: $(grep FAILED "$err")"
  for f in "$@"; do
    grep -Eq "$f" "$err" || fail "$what: not on stderr: $f"
  done
  grep -q "^ek-bench: 1 failure(s); see FAILED lines above; the rows timed are in $rf/b.partial.json (partial)$" "$err" ||
    fail "$what: the partial file not named: $(tail -1 "$err")"
  grep -Eq "^wrote $rf/b.partial.h5 and $rf/b.partial.json \(1 of 2 rows: partial, 1 failure\(s\), 1 of 2 rows timed; the first: $failed" "$out" ||
    fail "$what: $(tail -1 "$out")"
  for f in b.h5 b.json; do
    [ -e "$rf/$f" ] && fail "$what: wrote $f, the name of a whole run"
  done
  [ -s "$rf/b.partial.h5" ] && [ -s "$rf/b.partial.json" ] || fail "$what: no b.partial.h5 or .json"
  if command -v h5dump >/dev/null; then
    for f in partial rows_done; do
      h5dump -a "$f" "$rf/b.partial.h5" | grep -q "(0): 1$" || fail "$what: b.partial.h5: $f is not 1"
    done
  fi
  if command -v python3 >/dev/null; then
    python3 -c '
import json, re, sys
d = json.load(open(sys.argv[1]))
c = d["context"]
c = {k: c.get(k) for k in ("partial", "rows_done", "rows_total", "partial_reason")}
assert c["partial"] == "true" and c["rows_done"] == "1" and c["rows_total"] == "2", c
assert re.match("1 failure\\(s\\), 1 of 2 rows timed; the first: " + sys.argv[2], c["partial_reason"]), c
names = {b["run_name"] for b in d["benchmarks"]}
assert len(names) == 1 and names.pop().startswith("sim/twist/"), d["benchmarks"]' \
      "$rf/b.partial.json" "$failed" || fail "$what: b.partial.json"
    expect "perf_md.py on $what" 1 python3 "$(dirname "$0")/../tools/perf_md.py" --bench \
      "$rf/b.partial.json" --cpu x --out "$rf/r.md" &&
      { grep -q "a partial ek-bench run (1 failure(s), 1 of 2 rows timed; the first: " "$err" ||
        fail "perf_md.py on $what: $(cat "$err")"; }
    [ -e "$rf/r.md" ] && fail "perf_md.py on $what: wrote r.md"
  fi
  rm -f "$rf"/b.*
}
row_fails "mesh file" 's|"mesh": \{[^}]*\}|"mesh": {"file": "meshes/broken.msh"}|' \
  "sim: drop: $rf/scenes/drop.json:3:[0-9]+: mesh.file: $rf/scenes/meshes/broken.msh:13: element 1: node tag 9 out of range"
row_fails "step" 's|"dt": [^,]*,|"dt": 0.5,|' \
  "sim/drop/[^ ]*/threads:1: sim: step failed \(rc -?[0-9]+\): step [0-9]+ \(t = .*dt 0.5 is [0-9]+ times the CFL limit" \
  "^\[2/2\] sim/drop/[^ ]*: not recorded \(failed while timed\)$" \
  "^ek-bench: warning: sim/drop/[^ ]*: $rf/scenes/drop.json:[0-9]+:[0-9]+: dt = 0.5 is above the CFL limit"
# (c) f64 and an initial velocity of 1e7 m/s: a rigid flight, no step fails,
# but the positions end 1e7 body sizes away, which the after-row check
# fails (the row was recorded, then failed).
row_fails "blow-up" 's|"translate": \[0, 0, 0.5\]|"translate": [0, 0, 0.5], "velocity": [1e7, 0, 0]|; s|"f32"|"f64"|' \
  "sim/drop/[^ ]*/f64/[^ ]*/threads:1: the positions blew up after step [0-9]+ \(t = .*\): vertex [0-9]+ [0-9.e+]+ body sizes from the rest centre, 0 non-finite values" \
  "^\[2/2\] sim/drop/[^ ]*: not recorded \(failed its check after the timing\)$"
# A bad value in a scene's JSON is found by the listing pass: no row runs,
# nothing is written.
if broken_drop 's|"damping": [^,]*,|"damping": -0.5,|'; then
  expect "ek-bench, a bad value" 1 env EK_SCENES_DIR="$rf/scenes" "$bin/ek-bench" --threads 1 \
    --min-time 0.1 --filter '^sim/(twist|drop)/' --out "$rf/b.h5" &&
    { grep -q "^ek-bench: FAILED: sim: $rf/scenes/drop.json:[0-9]*:[0-9]*: damping = -0.5: must be >= 0" "$err" ||
      fail "ek-bench, a bad value: $(cat "$err")"; }
fi
rm -rf "$rf/scenes"
[ -z "$(ls -A "$rf")" ] || fail "ek-bench, a failing row: left $(ls "$rf")"
stopped "ek-verify SIGTERM" "" "$bin/ek-verify" --json "$work/stop/v.json"
grep -q "no verdict, and the --json file is not written" "$err" ||
  fail "ek-verify SIGTERM: $(tail -1 "$err")"
stopped "ek-sim --advise SIGTERM" "advise: reference run" "$bin/ek-sim" \
  "$scenes/small_strain.json" --advise
[ -z "$(ls -A "$work/stop")" ] || fail "SIGTERM: left $(ls "$work/stop")"
# ek-verify with its table redirected and stderr a terminal (script(1)
# gives the pty): progress on stderr, each family as it starts; the table
# stays whole. (A redirected run showed nothing for minutes.)
if command -v script >/dev/null; then
  script -qec "'$bin/ek-verify' --quick --n 100 --filter '$one_check' >'$work/vt.txt'" /dev/null \
    >"$out" 2>&1 </dev/null
  grep -q "ek-verify: family polar_warm (7 of 7), 1 rows so far" "$out" ||
    fail "ek-verify redirected, stderr a terminal: no progress: $(head -2 "$out")"
  grep -q "1 rows, 0 failing -> PASS" "$work/vt.txt" ||
    fail "ek-verify redirected: the table is not whole: $(tail -1 "$work/vt.txt")"
  grep -q "ek-verify: family" "$work/vt.txt" && fail "ek-verify redirected: progress in the table"
  # The default mode (table and stderr on the terminal): a status line under
  # the table with the rows done and the time left (it showed the table
  # only: minutes without knowing how many). Stopped after 8 s.
  script -qec "timeout -s TERM 8 '$bin/ek-verify' --quick" /dev/null >"$out" 2>&1 </dev/null
  grep -aEq "\[[0-9]+(/~[0-9]+)? rows, 0 failing, [0-9]+ s, ~[0-9]+ s left; [a-z_0-9]+ [1-7]/7\]" "$out" ||
    fail "ek-verify on a terminal: no status line with the time left: $(tr '\r' '\n' <"$out" | tail -2)"
fi
# A folder that root's access(W_OK) passes but that takes no new file
# (/proc): refused before the first row (ek-bench timed its rows, ek-verify
# ran its checks, then both failed writing).
if [ -d /proc ] && ! touch /proc/.ek-cli-test 2>/dev/null; then
  expect "ek-bench --out /proc/b.h5" 1 "$bin/ek-bench" --threads 1 --min-time 0.1 \
    --filter "$one_row" --out /proc/ek-b.h5 --json "$work/proc.json" &&
    one_error "ek-bench --out /proc/b.h5"
  expect "ek-verify --json /proc/v.json" 1 "$bin/ek-verify" --quick --n 100 \
    --filter "$one_check" --json /proc/ek-v.json && one_error "ek-verify --json /proc/v.json"
  grep -q "rows" "$out" && fail "ek-verify --json /proc/v.json: ran the rows first"
fi
# ek-sim names a missing output folder as ek-bench does, before the setup
# (it named the frames' scratch file, after building the mesh); a run that
# writes nothing needs none.
expect "ek-sim --out NO/FOLDER" 1 "$bin/ek-sim" "$scenes/cantilever.json" --steps 1 \
  --out "$work/none/x.h5" && one_error "ek-sim --out NO/FOLDER" &&
  { grep -qF -- "--out $work/none/x.h5: cannot write to folder '$work/none': No such file" "$err" ||
    fail "ek-sim --out NO/FOLDER: not said: $(cat "$err")"; }
expect "ek-sim --explain --out NO/FOLDER" 0 "$bin/ek-sim" "$scenes/cantilever.json" --explain \
  --out "$work/none/x.h5"
# The tools and the quick start: help is no error; a tool run by the wrong
# Python says how to run it (no traceback). python3 -S: without the site
# packages, where Debian's paraview puts its module.
root=$(cd "$(dirname "$0")/.." && pwd)
expect "quickstart.sh --help" 0 "$root/quickstart.sh" --help &&
  { grep -q "usage" "$out" || fail "quickstart.sh --help: no usage on stdout"; }
if command -v python3 >/dev/null; then
  expect "render_frame.py under python3" 1 python3 -S "$root/tools/render_frame.py" \
    "$work/x.xmf" "$work/x.png"
  grep -q Traceback "$err" && fail "render_frame.py under python3: a traceback"
  grep -q "pvpython" "$err" || fail "render_frame.py under python3: not said: $(cat "$err")"
fi

echo "cli: $failures failure(s)"
[ "$failures" -eq 0 ]
