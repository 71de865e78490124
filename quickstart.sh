#!/usr/bin/env bash
# One-command setup on a fresh Debian 12 machine, as in README.md:
#   ./quickstart.sh bench   install, build, run the default benchmark suite
#   ./quickstart.sh test    install, build, run the tests (what CI runs)
# Extra arguments after the mode go to ek-bench (e.g. --filter svd3).
set -euo pipefail
cd "$(dirname "$0")"
mode=${1:-}
[ $# -gt 0 ] && shift
usage="usage: $0 bench [ek-bench options] | test"
case "$mode" in
bench) ;;
test)
  # Nothing takes test's extra words: refused before installing anything.
  if [ $# -gt 0 ]; then
    printf "quickstart.sh: 'test' takes no arguments (got: %s)\n%s\n" "$*" "$usage" >&2
    exit 2
  fi
  ;;
-h | --help)
  echo "$usage"
  exit 0
  ;;
*)
  echo "$usage" >&2
  exit 2
  ;;
esac

packages="build-essential cmake git pkg-config liblapack-dev libhdf5-dev libcjson-dev python3 python3-venv petsc-dev"
# petsc-dev: the implicit loop's "amg" and "direct" linear solvers (optional:
# without it they are refused and their tests skip): 101 packages, 86 MB to
# download, 489 MB on disk; 32 s to install on the 2-core Zen 5 machine
# (30 MB of it downloaded, the rest in apt's cache) with builds beside it.
# The tests also render a frame with ParaView offscreen (ctest render_frame,
# tools/render_frame.py): paraview and xvfb, 255 packages, 254 MB to
# download; 169 s to install on the 2-core Zen 4 machine with a build
# running beside it. Without them that test is skipped.
[ "$mode" = test ] && packages="$packages paraview xvfb"
missing=""
for p in $packages; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
done
# apt-get's output, condensed: its download size, then a line per 10% of
# the download and of the installation (from APT::Status-Fd, apt's
# machine-readable progress: "dlstatus:N:PERCENT:TEXT",
# "pmstatus:PACKAGE:PERCENT:TEXT"), with the seconds since the start. Every
# other line goes to $apt_log, shown if apt-get fails. Status on stdout, not
# fd 3: sudo closes descriptors above 2.
apt_progress() {
  local line kind pct text step next_dl=0 next_pm=0
  while IFS= read -r line; do
    case "$line" in
    dlstatus:* | pmstatus:*)
      IFS=: read -r kind _ pct text <<<"$line"
      step=${pct%%.*}
      if [ "$kind" = dlstatus ] && [ "$step" -ge "$next_dl" ]; then
        printf '  [%3ds] download %3d%%  %s\n' "$SECONDS" "$step" "$text"
        next_dl=$((step / 10 * 10 + 10))
      elif [ "$kind" = pmstatus ] && [ "$step" -ge "$next_pm" ]; then
        printf '  [%3ds] install  %3d%%  %s\n' "$SECONDS" "$step" "$text"
        next_pm=$((step / 10 * 10 + 10))
      fi
      ;;
    "Need to get "* | "After this operation"*) echo "  $line" ;;
    *) echo "$line" >>"$apt_log" ;;
    esac
  done
}

if [ -n "$missing" ]; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo=sudo
  apt_log=$(mktemp)
  trap 'rm -f "$apt_log"' EXIT
  SECONDS=0
  echo "apt-get update (package lists) ..."
  if ! $sudo apt-get update -q >"$apt_log" 2>&1; then
    cat "$apt_log" >&2
    echo "quickstart: apt-get update failed (its output above)" >&2
    exit 1
  fi
  : >"$apt_log"
  # What will be installed: the missing packages and their dependencies.
  count=$($sudo apt-get install -s -q $missing 2>/dev/null | grep -c '^Inst ' || true)
  echo "installing:$missing ($count packages with their dependencies)"
  if ! $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q -o APT::Status-Fd=1 \
    $missing 2>&1 | apt_progress; then
    cat "$apt_log" >&2
    echo "quickstart: apt-get install failed (its output above)" >&2
    exit 1
  fi
  echo "installed in ${SECONDS}s"
fi

cmake --preset release >/dev/null
cmake --build --preset release
# The tests read the frames' XDMF with meshio (PyPI) and plot the tradeoff
# map (tools/plot_tradeoff.py): a virtual environment in build/venv holds
# meshio, h5py and matplotlib (tests/requirements-venv.txt).
if [ "$mode" = test ] && ! build/venv/bin/python -c "import meshio, h5py, matplotlib" 2>/dev/null; then
  echo "creating build/venv (meshio, h5py, matplotlib from PyPI, for the XDMF and plot tests)"
  python3 -m venv build/venv
  build/venv/bin/python -m pip install -q --disable-pip-version-check -r tests/requirements-venv.txt
fi

case "$mode" in
bench) ./build/release/bin/ek-bench "$@" ;;
test) ctest --preset release ;;
esac
