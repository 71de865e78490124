#!/usr/bin/env bash
# ek-sim across MPI ranks (sim/README.md "MPI"): shipped implicit scenes
# with integrator.linear_solver "amg", a few steps, run plainly (one
# process), under mpirun with 1 rank, 2 ranks, and 4 ranks oversubscribed;
# "direct" on 2 ranks; "matrix_free" (twist_implicit as shipped, and its
# corotated linear variant) on 1, 2 and 4 ranks, the variant with "amg" on 2.
# Each run exits 0; the 1-rank run has the plain run's bits; the 2- and
# 4-rank runs' last frame is within EK_SIM_MPI_GAP_PER_STEP newton_tol per
# step of the plain run's (tests/frames_gap.c); only rank 0 writes (the
# output folder holds the one frames file and its XDMF); the cloth is
# refused across ranks; a rank that fails ends the job with its status.
#   mpi.sh BIN_DIR SCENES_DIR PETSC_FOUND
# Exit 77 (ctest: skipped) without PETSc or mpirun.
set -u
bin=$1 scenes=$2 petsc=$3
case "$petsc" in
1 | ON | TRUE | YES) ;;
*)
  echo "mpi: skipped: this build has no PETSc (and so no MPI; apt-get install petsc-dev)"
  exit 77
  ;;
esac
if ! command -v mpirun >/dev/null; then
  echo "mpi: skipped: no mpirun on PATH"
  exit 77
fi
mpirun=(mpirun)
if mpirun --version 2>&1 | grep -q "Open MPI"; then
  mpirun+=(--oversubscribe)
  [ "$(id -u)" -eq 0 ] && mpirun+=(--allow-run-as-root)
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
fail() {
  echo "FAIL $*"
  failures=$((failures + 1))
}

# run WHAT DIR COMMAND...: the command writes its frames into DIR/f.h5 and
# exits 0; DIR then holds f.h5 and f.xmf only.
run() {
  local what=$1 dir=$2
  shift 2
  mkdir -p "$dir"
  local t0=$SECONDS
  if ! "$@" --threads 1 --out "$dir/f.h5" >"$dir.log" 2>&1 </dev/null; then
    fail "$what: exit $?"
    sed 's/^/  | /' "$dir.log" | tail -8
    return 1
  fi
  local files
  files=$(cd "$dir" && ls | tr '\n' ' ')
  [ "$files" = "f.h5 f.xmf " ] || fail "$what: the output folder holds: $files"
  echo "ok   $what ($((SECONDS - t0)) s): $(grep -E '^newton' "$dir.log" | cut -c12-80)"
}

for name in cantilever_implicit twist_implicit; do
  scene=$tmp/$name.json
  sed 's/"type": *"implicit"/"type": "implicit", "linear_solver": "amg"/' \
    "$scenes/$name.json" >"$scene"
  grep -q '"linear_solver": "amg"' "$scene" || {
    fail "$name: no integrator.type to extend"
    continue
  }
  steps=3
  run "$name plain" "$tmp/$name.plain" "$bin/ek-sim" "$scene" --steps $steps || continue
  # One process with CG multiplying by the SBAIJ upper triangle (on from 1
  # Mi nonzeros; these scenes are smaller: implicit_petsc.c): the same
  # trajectory to the ranks' tolerance (rounding of the products only).
  if PETSC_OPTIONS="-ek_sbaij_min_nnz 0" run "$name plain, SBAIJ" "$tmp/$name.sbaij" \
    "$bin/ek-sim" "$scene" --steps $steps; then
    "$bin/frames_gap" "$scene" "$tmp/$name.plain/f.h5" "$tmp/$name.sbaij/f.h5" ||
      fail "$name SBAIJ: the trajectory"
  fi
  for n in 1 2 4; do
    if run "$name mpirun -n $n" "$tmp/$name.$n" "${mpirun[@]}" -n $n "$bin/ek-sim" "$scene" \
      --steps $steps; then
      exact=()
      [ $n -eq 1 ] && exact=(exact)
      "$bin/frames_gap" "$scene" "$tmp/$name.plain/f.h5" "$tmp/$name.$n/f.h5" "${exact[@]}" ||
        fail "$name -n $n: the trajectory"
    fi
  done
  # 2 ranks with CG multiplying by the MPISBAIJ upper triangle (on from 1
  # Mi nonzeros per rank): the ranks' tolerance against the plain run.
  if PETSC_OPTIONS="-ek_sbaij_min_nnz 0" run "$name mpirun -n 2, SBAIJ" "$tmp/$name.2s" \
    "${mpirun[@]}" -n 2 "$bin/ek-sim" "$scene" --steps $steps; then
    "$bin/frames_gap" "$scene" "$tmp/$name.plain/f.h5" "$tmp/$name.2s/f.h5" ||
      fail "$name -n 2 SBAIJ: the trajectory"
  fi
done
# The direct solver across ranks (MUMPS's parallel Cholesky): 2 ranks
# against the plain run.
scene=$tmp/twist_direct.json
sed 's/"type": *"implicit"/"type": "implicit", "linear_solver": "direct"/' \
  "$scenes/twist_implicit.json" >"$scene"
if run "twist_implicit direct plain" "$tmp/direct.plain" "$bin/ek-sim" "$scene" --steps 3 &&
  run "twist_implicit direct mpirun -n 2" "$tmp/direct.2" "${mpirun[@]}" -n 2 "$bin/ek-sim" \
    "$scene" --steps 3; then
  "$bin/frames_gap" "$scene" "$tmp/direct.plain/f.h5" "$tmp/direct.2/f.h5" ||
    fail "twist_implicit direct -n 2: the trajectory"
fi
# matrix_free across ranks (each CG product and the preconditioner's blocks
# summed over the ranks): twist_implicit as shipped, and with corotated
# linear (each rank keeps its tets' R^n; twisted, so a wrong R^n shows),
# also with "amg" on 2 ranks; against the plain run.
sed 's/"stable_neo_hookean"/"corotated_linear"/' "$scenes/twist_implicit.json" \
  >"$tmp/twist_corot.json"
sed 's/"type": *"implicit"/"type": "implicit", "linear_solver": "amg"/' \
  "$tmp/twist_corot.json" >"$tmp/twist_corot_amg.json"
if ! grep -q '"corotated_linear"' "$tmp/twist_corot.json" ||
  ! grep -q '"linear_solver": "amg"' "$tmp/twist_corot_amg.json"; then
  fail "twist_implicit: no model or integrator.type to replace"
fi
for case in "twist_mf:$scenes/twist_implicit.json:1 2 4" "twist_corot:$tmp/twist_corot.json:1 2 4" \
  "twist_corot_amg:$tmp/twist_corot_amg.json:2"; do
  IFS=: read -r name scene ranks <<<"$case"
  run "$name plain" "$tmp/$name.plain" "$bin/ek-sim" "$scene" --steps 3 || continue
  for n in $ranks; do
    if run "$name mpirun -n $n" "$tmp/$name.$n" "${mpirun[@]}" -n $n "$bin/ek-sim" "$scene" \
      --steps 3; then
      exact=()
      [ "$n" -eq 1 ] && exact=(exact)
      "$bin/frames_gap" "$scene" "$tmp/$name.plain/f.h5" "$tmp/$name.$n/f.h5" "${exact[@]}" ||
        fail "$name -n $n: the trajectory"
    fi
  done
done
# What cannot be split is refused with a message, and every rank ends: the
# cloth (its body has no part Hessian).
if "${mpirun[@]}" -n 2 "$bin/ek-sim" "$scenes/cloth_hang_implicit.json" --steps 1 --no-output \
  >"$tmp/cloth.log" 2>&1 </dev/null; then
  fail "cloth on 2 ranks: exit 0, expected a refusal"
elif ! grep -q 'cannot be split across ranks' "$tmp/cloth.log"; then
  fail "cloth on 2 ranks: no message saying it cannot be split"
  sed 's/^/  | /' "$tmp/cloth.log" | head -5
else
  echo "ok   cloth on 2 ranks refused"
fi
# A rank that fails (rank 0 cannot create its frames) ends every rank with
# its exit status (1), instead of leaving the others in a collective call.
timeout 120 "${mpirun[@]}" -n 2 "$bin/ek-sim" "$tmp/twist_implicit.json" --steps 2 --threads 1 \
  --out "$tmp/no/such/dir/f.h5" >"$tmp/abort.log" 2>&1 </dev/null
status=$?
if [ $status -eq 1 ]; then
  echo "ok   a failing rank ends the job with exit 1"
else
  fail "a failing rank: exit $status, expected 1 (124: the job hung)"
  sed 's/^/  | /' "$tmp/abort.log" | head -5
fi
[ $failures -eq 0 ] && echo "mpi: all passed" || echo "mpi: $failures failed"
[ $failures -eq 0 ]
