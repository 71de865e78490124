#!/usr/bin/env bash
# Does a second thread ever slow a shipped scene down? Runs every scene at 1
# and 2 threads, on a quiet machine and with a busy loop on core 1 (where
# ek-sim pins its second thread), and prints the median and 95th percentile
# of the step time and their 2-thread / 1-thread ratios. The target (issue
# 8): 2 threads never more than 10% slower than 1 thread, median and p95.
#
#   tools/scene_threads.sh [--steps N] [--reps R] [--ek-sim PATH] [SCENE.json ...]
#
# Defaults: every scenes/*.json, 250 steps per run (ek-sim times the 225
# that run the fused force kernel), 3 repetitions, build/release/bin/ek-sim.
# Runs alternate 1T, 2T, 1T, 2T, ... so that a slow spell of the machine
# hits both; each row is the median over the repetitions. ek-sim's own
# OpenMP defaults apply (threads pinned) unless OMP_*
# variables are set in the environment.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
steps=250
reps=3
ek_sim="$root/build/release/bin/ek-sim"
scenes=()
while (($#)); do
  case $1 in
  --steps) steps=$2; shift 2 ;;
  --reps) reps=$2; shift 2 ;;
  --ek-sim) ek_sim=$2; shift 2 ;;
  -h | --help) sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  -*) echo "scene_threads.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
  *) scenes+=("$1"); shift ;;
  esac
done
((${#scenes[@]})) || scenes=("$root"/scenes/*.json)
[[ -x $ek_sim ]] || { echo "scene_threads.sh: $ek_sim: not built" >&2; exit 2; }
command -v taskset >/dev/null || { echo "scene_threads.sh: needs taskset (util-linux)" >&2; exit 2; }

results=$(mktemp)
busy_pid=
stop_busy() {
  if [[ -n $busy_pid ]]; then
    kill "$busy_pid" 2>/dev/null || true
    wait "$busy_pid" 2>/dev/null || true
    busy_pid=
  fi
}
trap 'stop_busy; rm -f "$results"' EXIT
trap 'exit 130' INT TERM

# One run: appends "scene load threads median p95" (ms) to $results.
run() {
  local scene=$1 load=$2 threads=$3 out
  if ! out=$("$ek_sim" "$scene" --steps "$steps" --threads "$threads" --no-output 2>&1); then
    echo "scene_threads.sh: ek-sim $scene --threads $threads failed:" >&2
    echo "$out" >&2
    exit 1
  fi
  awk -v s="$(basename "$scene" .json)" -v l="$load" -v t="$threads" \
    '/^step time/ { print s, l, t, $4, $7 }' <<<"$out" >>"$results"
}

# Median of the numbers on stdin.
median() {
  sort -g | awk '{ a[NR] = $1 } END { print NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2 }'
}

# Median over the repetitions of column 4 (median) or 5 (p95).
over_reps() {
  awk -v s="$1" -v l="$2" -v t="$3" -v c="$4" '$1 == s && $2 == l && $3 == t { print $c }' \
    "$results" | median
}

total=$((2 * reps * ${#scenes[@]} * 2))
done_runs=0
for load in quiet loaded; do
  if [[ $load == loaded ]]; then
    taskset -c 1 sh -c 'while :; do :; done' &
    busy_pid=$!
  fi
  for ((rep = 1; rep <= reps; rep++)); do
    for scene in "${scenes[@]}"; do
      for threads in 1 2; do
        run "$scene" "$load" "$threads"
        done_runs=$((done_runs + 1))
        [[ ! -t 2 ]] || printf '\r  %d / %d runs' "$done_runs" "$total" >&2
      done
    done
  done
  stop_busy
done
[[ ! -t 2 ]] || printf '\n' >&2

echo "ek-sim --steps $steps, repetitions $reps (rows: median over them of each run's median" \
  "and p95); loaded: busy loop on core 1"
echo "environment: OMP_PROC_BIND=${OMP_PROC_BIND-(ek-sim default)}" \
  "OMP_PLACES=${OMP_PLACES-(ek-sim default)} OMP_WAIT_POLICY=${OMP_WAIT_POLICY-(ek-sim default)}"
printf '%-12s %-7s %7s %12s %12s %13s %11s\n' scene load threads "median ms" "p95 ms" \
  "2T/1T median" "2T/1T p95"
met=0 rows=0
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .json)
  for load in quiet loaded; do
    m1=$(over_reps "$name" "$load" 1 4) p1=$(over_reps "$name" "$load" 1 5)
    m2=$(over_reps "$name" "$load" 2 4) p2=$(over_reps "$name" "$load" 2 5)
    printf '%-12s %-7s %7d %12.4f %12.4f %13s %11s\n' "$name" "$load" 1 "$m1" "$p1" - -
    read -r rm rp ok < <(awk -v m1="$m1" -v p1="$p1" -v m2="$m2" -v p2="$p2" \
      'BEGIN { rm = m2 / m1; rp = p2 / p1; printf "%.3f %.3f %d\n", rm, rp, rm <= 1.10 && rp <= 1.10 }')
    printf '%-12s %-7s %7d %12.4f %12.4f %13s %11s%s\n' "$name" "$load" 2 "$m2" "$p2" "$rm" "$rp" \
      "$( ((ok)) || echo '  above 1.10')"
    met=$((met + ok)) rows=$((rows + 1))
  done
done
echo "2 threads within 10% of 1 thread (median and p95): $met of $rows scene x load pairs"
