#!/usr/bin/env bash
# CI step (called by .ci/run after the tests): build the libFuzzer harnesses
# (clang, ASan + UBSan + leak checks) and run each for EK_FUZZ_SECONDS
# (default 60) from its seed corpus (tests/fuzz/corpus/<name>/: the
# reproducers of issue 14 and good files). Fails on any crash, leak,
# undefined behaviour, over-large allocation (a header trusted), slow input
# or loaded mesh with a non-finite volume; the input that did it is left in
# build/fuzz/artifacts/ and named in the log.
#   tests/fuzz/run.sh            all harnesses
#   tests/fuzz/run.sh gmsh       one (fuzz_gmsh)
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${EK_FUZZ_SECONDS:-60}
jobs=${EK_FUZZ_JOBS:-2}

# clang; libFuzzer's runtime is in libclang-rt-14-dev (only recommended by
# clang-14 on Debian 12); OpenMP for clang in libomp-14-dev.
packages="clang libclang-rt-14-dev libomp-14-dev"
missing=""
for p in $packages; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  echo "fuzz: installing:$missing"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo=sudo
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq $missing
fi

names=("$@")
if [ ${#names[@]} -eq 0 ]; then
  for f in tests/fuzz/fuzz_*.c; do
    n=$(basename "$f" .c)
    names+=("${n#fuzz_}")
  done
fi

build=build/fuzz
cmake -S . -B "$build" -DCMAKE_C_COMPILER=clang -DCMAKE_BUILD_TYPE=Debug -DEK_FUZZ=ON \
  >/dev/null
targets=()
for n in "${names[@]}"; do targets+=("fuzz_$n"); done
cmake --build "$build" -j "$jobs" --target "${targets[@]}"

# Each harness: a fresh working corpus seeded from the repository's, its
# files in a private TMPDIR, its log beside the artifacts.
mkdir -p "$build/artifacts" "$build/logs"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:allocator_may_return_null=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
run_one() {
  local n=$1 work="$build/corpus/$1" tmp
  rm -rf "$work"
  mkdir -p "$work"
  cp tests/fuzz/corpus/"$n"/* "$work"/
  tmp=$(mktemp -d)
  # -rss_limit_mb also caps any one malloc: a header trusted for memory is
  # an "out-of-memory (malloc(...))" crash. -timeout: a slow input fails.
  local rc=0
  TMPDIR=$tmp "$build/bin/fuzz_$n" "$work" -max_total_time="$seconds" -timeout=10 \
    -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
    -artifact_prefix="$build/artifacts/${n}-" >"$build/logs/$n.log" 2>&1 || rc=$?
  rm -rf "$tmp"
  return $rc
}

failed=()
pids=()
running=()
for n in "${names[@]}"; do
  run_one "$n" &
  pids+=($!)
  running+=("$n")
  if [ ${#pids[@]} -ge "$jobs" ]; then
    if ! wait "${pids[0]}"; then failed+=("${running[0]}"); fi
    pids=("${pids[@]:1}")
    running=("${running[@]:1}")
  fi
done
for i in "${!pids[@]}"; do
  if ! wait "${pids[$i]}"; then failed+=("${running[$i]}"); fi
done

for n in "${names[@]}"; do
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$build/logs/$n.log" | grep -o '[0-9]*$' || true)
  echo "fuzz_$n: ${runs:-?} inputs in ${seconds} s"
done
if [ ${#failed[@]} -gt 0 ]; then
  for n in "${failed[@]}"; do
    echo "fuzz_$n FAILED; the end of $build/logs/$n.log:"
    tail -n 40 "$build/logs/$n.log"
  done
  exit 1
fi
echo "fuzz: all ${#names[@]} harnesses clean for ${seconds} s each"
