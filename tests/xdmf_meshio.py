#!/usr/bin/env python3
"""Invariant: the XDMF that ek-sim writes beside its HDF5 frames is read by
meshio's time-series reader (meshio 5.3, meshio.xdmf.TimeSeriesReader) with
every frame: its time, the positions (a point vector, the same dataset as the
frame's geometry) and every per-element and per-vertex field equal bit for bit
to the HDF5 datasets read with h5py, the mesh (tetrahedra or, for a cloth,
triangles) equal to /mesh/tets or /mesh/triangles and its points to frame 0's
positions, the frame count equal to /frames/time's length. The output is named 'R&D<1>.h5' so the XDMF must escape it to parse.

Runs with the system python3 and re-executes itself in the virtual
environment (--venv, build/venv) that holds meshio and h5py; when that is
missing it fails and says how to create it.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

VENV_HELP = (
    "create it with ./quickstart.sh test, or:\n"
    "  python3 -m venv build/venv && build/venv/bin/pip install -r tests/requirements-venv.txt"
)


def in_venv(venv):
    return os.path.realpath(sys.prefix) == os.path.realpath(venv)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--venv", required=True)
    ap.add_argument("--ek-sim", required=True)
    args = ap.parse_args()
    # The marker stops a second re-execution where sys.prefix differs from
    # the path given (symbolic links).
    if not in_venv(args.venv) and not os.environ.get("EK_XDMF_MESHIO_IN_VENV"):
        py = os.path.join(args.venv, "bin", "python")
        if not os.access(py, os.X_OK):
            print(f"xdmf_meshio: FAIL: no virtual environment at {args.venv}; {VENV_HELP}")
            return 1
        probe = subprocess.run([py, "-c", "import meshio, h5py"], capture_output=True, text=True)
        if probe.returncode != 0:
            print(f"xdmf_meshio: FAIL: {args.venv} lacks meshio or h5py "
                  f"({probe.stderr.strip().splitlines()[-1] if probe.stderr.strip() else '?'}); "
                  f"{VENV_HELP}")
            return 1
        os.environ["EK_XDMF_MESHIO_IN_VENV"] = "1"
        os.execv(py, [py, os.path.abspath(__file__)] + sys.argv[1:])

    import h5py
    import meshio
    import numpy as np

    print(f"xdmf_meshio: meshio {meshio.__version__}, h5py {h5py.__version__}, "
          f"python {sys.version.split()[0]} in {args.venv}")
    failures = 0

    def check(what, ok, detail=""):
        nonlocal failures
        print(f"{what:52s} {'PASS' if ok else 'FAIL'}  {detail}")
        failures += not ok

    # A tet scene and a cloth scene (triangles, with the per-triangle smax).
    cases = [
        ("tets", "tetra", "/mesh/tets", {
            "mesh": {"box": [6, 2, 2], "size": [1.0, 0.25, 0.25]},
            "material": {"model": "stable_neo_hookean", "E": 1.0e6, "nu": 0.3,
                         "density": 1000.0},
            "boundary": [{"type": "pin",
                          "region": {"min": [0, 0, 0], "max": [0, 0.25, 0.25]}}],
            "gravity": [0, 0, -9.81], "damping": 10.0, "dt": 1e-4, "steps": 20,
            "output": {"file": "unused.h5", "every": 3},
        }),
        ("triangles", "triangle", "/mesh/triangles", {
            "mesh": {"grid": [6, 6], "size": [1.0, 1.0], "plane": "xz"},
            "material": {"model": "stvk", "E": 1.0e6, "nu": 0.3, "density": 400.0},
            "cloth": {"thickness": 5.0e-4},
            "boundary": [{"type": "pin", "region": {"min": [0, 0, 1], "max": [0, 0, 1]}},
                         {"type": "pin", "region": {"min": [1, 0, 1], "max": [1, 0, 1]}}],
            "gravity": [0, 0, -9.81], "damping": 1.0, "dt": 2e-4, "steps": 20,
            "output": {"file": "unused.h5", "every": 3},
        }),
    ]
    for kind, cell_type, mesh_ds, scene_json in cases:
        with tempfile.TemporaryDirectory(prefix="ek_xdmf_meshio_") as tmp:
            print(f"-- {kind}")
            scene = os.path.join(tmp, "scene.json")
            with open(scene, "w") as f:
                json.dump(scene_json, f)
            h5 = os.path.join(tmp, "R&D<1>.h5")
            xmf = os.path.join(tmp, "R&D<1>.xmf")
            run = subprocess.run([args.ek_sim, scene, "--out", h5, "--threads", "1"],
                                 capture_output=True, text=True)
            check("ek-sim run", run.returncode == 0,
                  f"exit {run.returncode}" + (f": {run.stderr.strip()}" if run.returncode else ""))
            if run.returncode != 0:
                return 1
            try:
                ET.parse(xmf)
                check("XDMF parses as XML (escaped file name)", True)
            except ET.ParseError as e:
                check("XDMF parses as XML (escaped file name)", False, str(e))
                return 1

            with h5py.File(h5, "r") as f:
                times = f["/frames/time"][()]
                steps = f["/frames/step"][()]
                tets = f[mesh_ds][()]
                groups = sorted(k for k in f["/frames"] if isinstance(f["/frames"][k], h5py.Group))
                frames = [{g: f[f"/frames/{g}/{k:06d}"][()] for g in groups}
                          for k in range(len(times))]
            # Node-centred in the XDMF (sim.h); every other field is per tet.
            point_fields = sorted(g for g in groups if g in ("positions", "vertex_rotation"))
            fields = [g for g in groups if g not in point_fields]
            expect_steps = list(range(0, 20, 3)) + [20]
            check("HDF5 frames", list(steps) == expect_steps and fields,
                  f"{len(times)} frames at steps {list(steps)}, per-element fields {fields}")

            with meshio.xdmf.TimeSeriesReader(xmf) as reader:
                points, cells = reader.read_points_cells()
                ok = (len(cells) == 1 and cells[0].type == cell_type
                      and np.array_equal(cells[0].data, tets)
                      and np.array_equal(points, frames[0]["positions"]))
                check(f"mesh: {cell_type} cells = {mesh_ds}, points = frame 0", ok,
                      f"{len(points)} points, {sum(len(c.data) for c in cells)} {kind}")
                check("frame count = len(/frames/time)", reader.num_steps == len(times),
                      f"meshio {reader.num_steps}, HDF5 {len(times)}")
                bad = []
                for k in range(reader.num_steps):
                    t, point_data, cell_data = reader.read_data(k)
                    if k < len(times) and t != times[k]:
                        bad.append(f"frame {k}: time {t!r} != {times[k]!r}")
                    if sorted(point_data) != point_fields or sorted(cell_data) != sorted(fields):
                        bad.append(f"frame {k}: arrays {sorted(point_data)} + {sorted(cell_data)}")
                        continue
                    got_all = [(name, point_data[name]) for name in point_fields]
                    got_all += [(name, cell_data[name][0]) for name in fields]
                    for name, got in got_all:
                        want = frames[k][name]
                        if not np.array_equal(got, want, equal_nan=True):
                            i = int(np.argmax((got != want).ravel()))
                            bad.append(f"frame {k} {name}[{i}]: meshio {got.ravel()[i]!r}, "
                                       f"HDF5 {want.ravel()[i]!r}")
                check("every frame: time, positions, every field", not bad,
                      "; ".join(bad[:5]) if bad else
                      f"{reader.num_steps} frames x ({len(point_fields)} point + {len(fields)} cell "
                      "fields) bit-equal")
    print("ALL PASSED" if failures == 0 else "FAILED")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
