#!/usr/bin/env python3
"""Invariant: `ek-bench --suite tradeoff --quick` writes a whole map (HDF5 and
JSON, read back) whose error at a knob's default equals what ek-verify
reports for that variant on the same seed and set size: for every ISA and
precision, the svd3 and polar3 points labelled "default" have err_max equal
(exactly: the same inputs, kernel and metric give the same number) to the
"worst" of ek-verify's "<kernel> <isa> f<bits> sweeps=def rsqrt=...(def)
random" row, and every pk1/<model> point's err_max equals the P error of
ek-verify's "material <isa> f<bits> <model> clamp=0" row. Equal means: the
same 15 significant digits. ek-verify's JSON (cJSON) prints a number with 15
digits when those read back within cJSON's own tolerance, so its file holds
no more; the map's file holds 17.

Modes:
  (default)  the map and the comparison; standard library only.
  --plot     tools/plot_tradeoff.py on a quick map and a small default-suite
             run: one tradeoff PNG per family and a roofline per kernel
             family appear; the HDF5 points equal the JSON points (h5py);
             a missing file and a file that is not a tradeoff file are
             refused with a message. Runs in the virtual environment (--venv,
             build/venv, which ./quickstart.sh test creates); without it the
             test is skipped (exit 77) and says how to create it.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

SKIP = 77
failures = 0


def check(what, ok, detail=""):
    global failures
    print(f"{'PASS' if ok else 'FAIL'}  {what}{' (' + detail + ')' if detail else ''}")
    if not ok:
        failures += 1


def run(cmd, **kw):
    t0 = time.monotonic()
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    return r, time.monotonic() - t0


def quick_map(ek_bench, tmp, seed, n, extra=()):
    h5, js = os.path.join(tmp, "map.h5"), os.path.join(tmp, "map.json")
    cmd = [ek_bench, "--suite", "tradeoff", "--quick", "--threads", "1", "--seed", str(seed),
           "--n", str(n), "--out", h5, "--json", js, *extra]
    r, secs = run(cmd)
    quick_map.stderr = r.stderr
    check("ek-bench --suite tradeoff --quick", r.returncode == 0,
          f"exit {r.returncode}, {secs:.1f} s: {' '.join(cmd)}"
          + ("" if r.returncode == 0 else "\n" + r.stderr[-3000:]))
    return h5, js, secs


def load_json(path):
    with open(path) as f:
        return json.load(f)


def num(v):
    """A JSON number: "inf" / "-inf" as written, a missing one (NaN) as NaN."""
    if v is None:
        return math.nan
    return {"inf": math.inf, "-inf": -math.inf}.get(v, v) if isinstance(v, str) else v


def check_map(doc, h5):
    with open(h5, "rb") as f:
        check("HDF5 signature", f.read(8) == b"\x89HDF\r\n\x1a\n", h5)
    check("JSON suite", doc.get("suite") == "tradeoff")
    meta = doc.get("metadata", {})
    for key in ("cpu_model", "isas_available", "git_revision", "thread_counts", "seed", "n"):
        check(f"metadata {key}", key in meta, str(meta.get(key)))
    points = doc.get("points", [])
    families = {p["family"] for p in points}
    models = ["linear", "stvk", "corotated_linear", "fixed_corotated", "arap", "psi_r",
              "neo_hookean", "stable_neo_hookean"]
    for fam in ["svd3", "polar3"] + [f"pk1/{m}" for m in models]:
        check(f"family {fam}", fam in families)
    isas = meta.get("isas_available", "").split()
    for fam in ("svd3", "polar3"):
        sel = [p for p in points if p["family"] == fam]
        # precision 2 x sweeps 6 x rsqrt 2 x refine 4 x ISA
        check(f"{fam} settings", len(sel) == 2 * 6 * 2 * 4 * len(isas),
              f"{len(sel)} points, {len(isas)} ISAs")
        mca = [p for p in sel if p["knobs"].get("label") == "mcadams2011"]
        check(f"{fam} McAdams 2011 points", len(mca) == 2 * len(isas) and all(
            p["knobs"]["sweeps"] == "4" and p["knobs"]["refine"] == "none"
            and p["knobs"]["rsqrt"] == "approx" for p in mca), f"{len(mca)}")
        check(f"{fam} one default per precision",
              sorted(p["knobs"]["precision"] for p in sel if p["is_default"]) == ["f32", "f64"])
        front = [p for p in sel if p["on_front_p99"]]
        check(f"{fam} has a front", 0 < len(front) < len(sel), f"{len(front)} of {len(sel)}")
        ok = all(p["count"] > 0 and num(p["err_p50"]) <= num(p["err_p99"]) <= num(p["err_p9999"])
                 <= num(p["err_max"]) and p["time_min"] <= p["time_median"] for p in sel)
        check(f"{fam} distributions ordered", ok)
    # The front's definition (bench/tradeoff.h), checked on the file for
    # every family and thread count: no point of the group is at least as
    # good as a front point in time and p99 and strictly better in one, no
    # two front points are equal in both, and every finite point off the
    # front has a point at least as good in both.
    for fam in sorted({p["family"] for p in points}):
        for th in sorted({p["threads"] for p in points if p["family"] == fam}):
            grp = [p for p in points if p["family"] == fam and p["threads"] == th]

            def key(p):
                return (num(p.get("time_median")), num(p.get("err_p99")))

            def finite(p):
                return not any(math.isnan(v) for v in key(p))

            def covers(q, p):  # q at least as good as p in both
                return q is not p and finite(q) and all(a <= b for a, b in zip(key(q), key(p)))

            front = [p for p in grp if p["on_front_p99"]]
            dominated = [p["setting"] for p in front for q in grp
                         if covers(q, p) and key(q) != key(p)]
            doubled = [p["setting"] for p in front for q in front if covers(q, p)
                       and key(q) == key(p)]
            loose = [p["setting"] for p in grp if finite(p) and not p["on_front_p99"]
                     and not any(covers(q, p) for q in grp)]
            check(f"{fam} {th} threads: front of {len(front)} of {len(grp)}, none dominated, "
                  f"no duplicate, every other point covered",
                  front and not dominated and not doubled and not loose,
                  "; ".join(dominated[:2] + doubled[:2] + loose[:2]))
    check_solver_axis(points, getattr(quick_map, "stderr", ""))
    return points, isas


def check_solver_axis(points, stderr):
    """The loop maps' solver axis (issue 24): with PETSc (ek-bench does not
    say the solvers were skipped) the cantilever's implicit points with
    linear_solver amg and direct (the scene's knobs, f64, newton_tol 1e-4:
    three each), their settings naming the solver; without, none, and
    ek-bench's stderr says they were skipped. The matrix-free implicit points
    name no solver (their names are those of the map before the axis)."""
    sel = [p for p in points if p["family"] == "loop/cantilever"
           and p["knobs"].get("loop") == "implicit"]
    named = [p for p in sel if "linear_solver" in p["knobs"]]
    check("loop/cantilever matrix-free implicit points name no solver",
          len(sel) - len(named) == 7, f"{len(sel) - len(named)} of {len(sel)}")
    for ls in ("amg", "direct"):
        rows = [p for p in named if p["knobs"]["linear_solver"] == ls]
        skipped = f"linear_solver {ls} skipped" in stderr
        if skipped:
            print(f"loop/cantilever: linear_solver {ls} skipped: this build has no PETSc")
            check(f"loop/cantilever: no {ls} points without PETSc", not rows, f"{len(rows)}")
        else:
            ok = (len(rows) == 3 and all(p["setting"].endswith(f";linear_solver={ls}")
                                        and math.isfinite(num(p["time_median"])) for p in rows)
                  and {p["knobs"]["precision"] for p in rows} == {"f32", "f64"})
            check(f"loop/cantilever: implicit {ls} points", ok,
                  "; ".join(p["setting"] for p in rows) or "none")


def verify_rows(ek_verify, tmp, seed, n):
    js = os.path.join(tmp, "verify.json")
    regex = (r"^((svd3|polar3) [a-z0-9]+ f(32|64) sweeps=def rsqrt=[a-z]+\(def\) random"
             r"|material [a-z0-9]+ f(32|64) [a-z_]+ clamp=0 random mix"
             r"|polar_warm [a-z0-9]+ f(32|64) iterations=default random)$")
    cmd = [ek_verify, "--quick", "--seed", str(seed), "--n", str(n), "--filter", regex,
           "--json", js]
    r, secs = run(cmd)
    check("ek-verify on the same seed and n", r.returncode == 0 and os.path.exists(js),
          f"exit {r.returncode}, {secs:.1f} s" + ("" if r.returncode == 0 else r.stdout[-2000:]))
    return load_json(js)["rows"] if os.path.exists(js) else []


def same(got, want):
    """Equal to the digits ek-verify's JSON keeps (see the top)."""
    return got == want or f"{got:.15g}" == f"{want:.15g}"


def compare(points, rows):
    short = {"linear": "linear", "stvk": "stvk", "corotated_linear": "corot_linear",
             "fixed_corotated": "fixed_corot", "arap": "arap", "psi_r": "psi_r",
             "neo_hookean": "nh", "stable_neo_hookean": "snh"}
    compared = 0
    for p in points:
        k = p["knobs"]
        if "isa" not in k:  # the loop maps: no ek-verify counterpart
            continue
        isa, prec = k["isa"], k["precision"]
        if p["family"] == "rotation" and k.get("label") == "default":
            variant = f"{isa} {prec} iterations=default"
            match = [r for r in rows if r["kernel"] == "polar_warm" and r["variant"] == variant
                     and r["inputs"] == "random"]
            if len(match) != 1:
                check(f"ek-verify row polar_warm {variant}", False, f"{len(match)} rows")
                continue
            want, got = match[0]["errors"]["rdiff"], num(p["err_max"])
            check(f"rotation {isa} {prec} warm default: map max == ek-verify rdiff",
                  same(got, want), f"map {got!r}, ek-verify {want!r}")
            compared += 1
        elif p["family"] in ("svd3", "polar3") and k.get("label") == "default":
            pat = re.compile(rf"^{isa} {prec} sweeps=def rsqrt=[a-z]+\(def\)$")
            match = [r for r in rows if r["kernel"] == p["family"] and pat.match(r["variant"])
                     and r["inputs"] == "random"]
            if len(match) != 1:
                check(f"ek-verify row for {p['family']} {p['setting']}", False,
                      f"{len(match)} rows")
                continue
            want, got = match[0]["worst"], num(p["err_max"])
            check(f"{p['family']} {isa} {prec} default: map max == ek-verify worst", same(got, want),
                  f"map {got!r}, ek-verify {want!r}; count {p['count']} vs {match[0]['count']}")
            compared += 1
        elif p["family"].startswith("pk1/"):
            model = short[p["family"][4:]]
            variant = f"{isa} {prec} {model} clamp=0"
            match = [r for r in rows if r["kernel"] == "material" and r["variant"] == variant]
            if len(match) != 1:
                check(f"ek-verify row material {variant}", False, f"{len(match)} rows")
                continue
            want, got = match[0]["errors"]["P"], num(p["err_max"])
            check(f"{p['family']} {isa} {prec}: map max == ek-verify P", same(got, want),
                  f"map {got!r}, ek-verify {want!r}")
            compared += 1
    check("points compared with ek-verify", compared > 0, f"{compared}")


def plot_mode(args, tmp):
    venv_py = os.path.join(args.venv, "bin", "python")
    help_text = ("create it with ./quickstart.sh test, or: python3 -m venv build/venv && "
                 "build/venv/bin/pip install -r tests/requirements-venv.txt")
    if not os.access(venv_py, os.X_OK):
        print(f"plot_tradeoff: SKIP: no virtual environment at {args.venv}; {help_text}")
        return SKIP
    probe = subprocess.run([venv_py, "-c", "import h5py, matplotlib"], capture_output=True)
    if probe.returncode != 0:
        print(f"plot_tradeoff: SKIP: {args.venv} lacks h5py or matplotlib; {help_text}")
        return SKIP
    h5, js, _ = quick_map(args.ek_bench, tmp, 3, 500, ["--isas", "scalar"])
    bench_h5 = os.path.join(tmp, "bench.h5")
    r, secs = run([args.ek_bench, "--filter", "^(svd3/aosoa/scalar|material/.*/scalar/f32)",
                   "--threads", "1", "--min-time", "0.01", "--out", bench_h5])
    check("a small default-suite run", r.returncode == 0, f"exit {r.returncode}, {secs:.1f} s"
          + ("" if r.returncode == 0 else r.stderr[-2000:]))
    outdir = os.path.join(tmp, "png")
    r, secs = run([venv_py, args.plot, h5, outdir, "--bench", bench_h5])
    check("plot_tradeoff.py runs", r.returncode == 0,
          f"exit {r.returncode}, {secs:.1f} s" + ("" if r.returncode == 0 else r.stderr[-3000:]))
    doc = load_json(js) if os.path.exists(js) else {"points": []}
    families = sorted({p["family"] for p in doc["points"]})
    for fam in families:
        png = os.path.join(outdir, "tradeoff_" + fam.replace("/", "_") + ".png")
        check(f"PNG for {fam}", os.path.exists(png) and os.path.getsize(png) > 1000, png)
    for fam in ("svd3", "material"):
        png = os.path.join(outdir, f"roofline_{fam}.png")
        check(f"roofline PNG for {fam}", os.path.exists(png) and os.path.getsize(png) > 1000, png)
    # The HDF5 table holds the JSON's points, field for field.
    code = r"""
import h5py, json, math, sys
doc = json.load(open(sys.argv[2]))
rows = {}
with h5py.File(sys.argv[1], "r") as f:
    def visit(name, obj):
        if name.endswith("points"):
            for r in obj[()]:
                rows[(r["family"].decode(), r["setting"].decode(), int(r["threads"]))] = r
    f["tradeoff"].visititems(visit)
bad = 0
for p in doc["points"]:
    r = rows.get((p["family"], p["setting"], p["threads"]))
    num = lambda v: math.inf if v == "inf" else v
    if r is None or float(r["err_max"]) != num(p["err_max"]) or float(r["time_median"]) != \
            p["time_median"] or bool(r["on_front_p99"]) != p["on_front_p99"]:
        bad += 1
print(len(rows), len(doc["points"]), bad)
"""
    r = subprocess.run([venv_py, "-c", code, h5, js], capture_output=True, text=True)
    parts = r.stdout.split()
    check("HDF5 points equal the JSON points", r.returncode == 0 and len(parts) == 3
          and parts[0] == parts[1] and parts[2] == "0", r.stdout.strip() + r.stderr[-1000:])
    # Bad input: a clear message, no traceback, non-zero exit.
    r, _ = run([venv_py, args.plot, os.path.join(tmp, "missing.h5"), outdir])
    check("missing file refused", r.returncode != 0 and "no such file" in r.stderr
          and "Traceback" not in r.stderr, r.stderr.strip())
    r, _ = run([venv_py, args.plot, bench_h5, outdir])
    check("not a tradeoff file refused", r.returncode != 0 and "not a tradeoff file" in r.stderr
          and "Traceback" not in r.stderr, r.stderr.strip())
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ek-bench", required=True)
    ap.add_argument("--ek-verify")
    ap.add_argument("--plot", help="tools/plot_tradeoff.py: the --plot mode")
    ap.add_argument("--venv", default="build/venv")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="ek_tradeoff_") as tmp:
        if args.plot:
            rc = plot_mode(args, tmp)
            if rc == SKIP:
                return SKIP
        else:
            seed, n = 5, 2000
            h5, js, secs = quick_map(args.ek_bench, tmp, seed, n)
            if os.path.exists(js):
                points, _ = check_map(load_json(js), h5)
                compare(points, verify_rows(args.ek_verify, tmp, seed, n))
            print(f"(the quick map took {secs:.1f} s)")
    print(f"test_tradeoff_map{' --plot' if args.plot else ''}: {'FAIL' if failures else 'PASS'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
