#!/usr/bin/env bash
# ek-verify --extremes --quick exits 0 (every row expected to survive did)
# and its table and JSON hold every row of the quick set: each model x case
# x loop x precision below, once.
#   extremes_quick.sh EK_VERIFY
set -u
exe=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
failures=0

"$exe" --extremes --quick --json "$dir/x.json" >"$dir/out" 2>"$dir/err"
rc=$?
cat "$dir/out"
if [ "$rc" -ne 0 ]; then
  echo "FAIL ek-verify --extremes --quick: exit $rc, expected 0"
  sed 's/^/  | /' "$dir/err" | tail -5
  failures=$((failures + 1))
fi

# The quick set (verify_extremes.c: the rows marked quick).
models="stvk fixed_corot+clamp nh snh+clamp"
cases="rest crush_plane crush_point crush_plane_E=1e9 crush_plane_L=1e-4"
loops="explicit_0.5cfl explicit_2cfl implicit_1/30"
want=0
for m in $models; do
  for c in $cases; do
    for l in $loops; do
      for p in f64 f32; do
        want=$((want + 1))
        c2=${c/_E/ E}
        c2=${c2/_L/ L}
        pattern="^${m//+/\\+} +${l/_/ +} +$p +$c2 +(none|survive|not) "
        n=$(grep -cE -- "$pattern" "$dir/out")
        if [ "$n" -ne 1 ]; then
          echo "FAIL row '$m | ${l/_/ } | $p | $c2': $n lines in the table, expected 1"
          failures=$((failures + 1))
        fi
      done
    done
  done
done
if ! grep -qE "^ek-verify --extremes: $want rows, " "$dir/out"; then
  echo "FAIL the summary line does not count $want rows"
  failures=$((failures + 1))
fi
njson=$(grep -c '"status":' "$dir/x.json")
if [ "$njson" -ne "$want" ]; then
  echo "FAIL --json holds $njson rows, expected $want"
  failures=$((failures + 1))
fi
echo "extremes_quick: $want rows expected, $failures failures"
[ "$failures" -eq 0 ]
