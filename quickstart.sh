#!/usr/bin/env bash
# One-command setup on a fresh Debian 12 machine, as in README.md:
#   ./quickstart.sh bench   install, build, run the default benchmark suite
#   ./quickstart.sh test    install, build, run the tests (what CI runs)
# Extra arguments after the mode go to ek-bench (e.g. --filter svd3).
set -euo pipefail
cd "$(dirname "$0")"
mode=${1:-}
[ $# -gt 0 ] && shift
case "$mode" in bench | test) ;; *)
  echo "usage: $0 bench|test [ek-bench options]" >&2
  exit 2
  ;;
esac

packages="build-essential cmake git pkg-config liblapack-dev libhdf5-dev libcjson-dev python3-venv"
missing=""
for p in $packages; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
  echo "installing:$missing"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo=sudo
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq $missing >/dev/null
fi

cmake --preset release >/dev/null
cmake --build --preset release
# The tests read the frames' XDMF with meshio (PyPI): a virtual environment
# in build/venv holds it and h5py (tests/requirements-venv.txt).
if [ "$mode" = test ] && ! build/venv/bin/python -c "import meshio, h5py" 2>/dev/null; then
  echo "creating build/venv (meshio, h5py from PyPI, for the XDMF test)"
  python3 -m venv build/venv
  build/venv/bin/python -m pip install -q --disable-pip-version-check -r tests/requirements-venv.txt
fi

case "$mode" in
bench) ./build/release/bin/ek-bench "$@" ;;
test) ctest --preset release ;;
esac
