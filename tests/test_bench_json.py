#!/usr/bin/env python3
"""Invariant: ek-bench's JSON is Google Benchmark's, and two runs compare.

Runs the real ek-bench three times on two cheap rows (twice with --samples,
once without) and checks:
  - every file has the keys Google Benchmark's JSON reporter writes, with
    its types (integers as JSON integers, times as floating point, bools,
    arrays; the list and its source are in bench/results.c), ek's metadata
    as string custom context, ek's row fields as number counters plus the
    label, and no null anywhere;
  - without --samples: no "iteration" entries, the five aggregates (mean,
    median, stddev, cv, min) per row, a few KB per row (the default suite's
    JSON was 42 MB with per-sample entries);
  - with --samples: one iteration entry per sample (repetitions);
  - bench/compare.py (compare.py's comparison of google/benchmark, written
    with the standard library: PyPI's google-benchmark package ships no
    compare.py or gbench) compares the files: every common name reported,
    each change equal to (new - old) / |old| recomputed from the files, a U
    test with p-values in [0, 1] where both sides have samples, the
    OVERALL_GEOMEAN of the sample entries; it refuses a file of another
    json_schema_version naming the file (exit 1); its exact U-test p-value
    is right on a case done by hand.

Usage: test_bench_json.py --ek-bench PATH --compare PATH/bench/compare.py
Exit status 0 pass, 1 a check failed, 2 usage.
"""
import argparse
import importlib.util
import json
import math
import os
import subprocess
import sys
import tempfile

ROWS = "^svd3/(aosoa/scalar/f32/sweeps:2/rsqrt:approx|lapack/f32)/threads:1$"
AGGREGATES = {"mean", "median", "stddev", "cv", "min"}
# Google Benchmark's keys and types (google/benchmark src/json_reporter.cc,
# ReportContext and PrintRunData; see bench/results.c).
CONTEXT_KEYS = {
    "date": str,
    "host_name": str,
    "executable": str,
    "num_cpus": int,
    "mhz_per_cpu": int,
    "cpu_scaling_enabled": bool,
    "caches": list,
    "load_avg": list,
    "library_version": str,
    "library_build_type": str,
    "json_schema_version": int,
}
CACHE_KEYS = {"type": str, "level": int, "size": int, "num_sharing": int}
ENTRY_KEYS = {
    "name": str,
    "family_index": int,
    "per_family_instance_index": int,
    "run_name": str,
    "run_type": str,
    "repetitions": int,
    "threads": int,
    "iterations": int,
    "real_time": float,
    "cpu_time": float,
    "time_unit": str,
}
ITERATION_KEYS = {"repetition_index": int}
AGGREGATE_KEYS = {"aggregate_name": str, "aggregate_unit": str}
MAX_BYTES_PER_ROW = 6000

failures = 0


def check(what, ok, detail=""):
    global failures
    print(f"{'PASS' if ok else 'FAIL'}  {what} ({detail})")
    if not ok:
        failures += 1


def typed(value, t):
    # bool is an int in Python: keep them apart, as JSON does.
    if t is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if t is float:
        return isinstance(value, float)
    return isinstance(value, t)


def keys_ok(obj, schema):
    for k, t in schema.items():
        if k not in obj:
            return f"'{k}' missing"
        if not typed(obj[k], t):
            return f"'{k}' = {obj[k]!r} is not {t.__name__}"
    return ""


def find_null(x, path="$"):
    if x is None:
        return path
    items = x.items() if isinstance(x, dict) else enumerate(x) if isinstance(x, list) else []
    for k, v in items:
        p = find_null(v, f"{path}.{k}")
        if p:
            return p
    return ""


def check_schema(path, samples):
    with open(path) as f:
        text = f.read()
    data = json.loads(text)
    null = find_null(data)
    check("no null anywhere", not null, f"{path} {null}")
    ctx = data["context"]
    check("context: Google Benchmark's keys and types", not keys_ok(ctx, CONTEXT_KEYS), keys_ok(ctx, CONTEXT_KEYS) or path)
    check("json_schema_version is 1", ctx.get("json_schema_version") == 1, repr(ctx.get("json_schema_version")))
    bad = [keys_ok(c, CACHE_KEYS) for c in ctx.get("caches", []) if keys_ok(c, CACHE_KEYS)]
    check("caches: type, level, size, num_sharing", not bad, bad[0] if bad else f"{len(ctx.get('caches', []))} caches")
    check("load_avg: numbers", all(typed(v, float) for v in ctx.get("load_avg", [None])), repr(ctx.get("load_avg")))
    custom = [k for k, v in ctx.items() if k not in CONTEXT_KEYS and not isinstance(v, str)]
    check("custom context: strings", not custom, ", ".join(custom) or f"{len(ctx) - len(CONTEXT_KEYS)} keys")

    entries = data["benchmarks"]
    problems = []
    per_run = {}
    for e in entries:
        why = keys_ok(e, ENTRY_KEYS)
        why = why or keys_ok(e, ITERATION_KEYS if e["run_type"] == "iteration" else AGGREGATE_KEYS)
        extra = [k for k in e if k not in ENTRY_KEYS and k not in ITERATION_KEYS and k not in AGGREGATE_KEYS]
        why = why or next(
            (f"'{k}' = {e[k]!r}" for k in extra if not (typed(e[k], str) if k == "label" else typed(e[k], float))), ""
        )
        if e["run_type"] not in ("iteration", "aggregate"):
            why = why or f"run_type {e['run_type']!r}"
        if why:
            problems.append(f"{e.get('name')}: {why}")
        per_run.setdefault(e["run_name"], []).append(e)
    check("entries: Google Benchmark's keys and types; counters numbers, label a string", not problems, problems[0] if problems else f"{len(entries)} entries")
    check("two rows written", len(per_run) == 2, ", ".join(per_run))
    for run, es in per_run.items():
        aggs = {e["aggregate_name"] for e in es if e["run_type"] == "aggregate"}
        iters = [e for e in es if e["run_type"] == "iteration"]
        reps = es[0]["repetitions"]
        check("five aggregates per row", aggs == AGGREGATES, f"{run}: {sorted(aggs)}")
        want = reps if samples else 0
        check("iteration entries: one per sample with --samples, none without", len(iters) == want, f"{run}: {len(iters)}, expected {want}")
        median = next((e for e in es if e.get("aggregate_name") == "median"), {})
        minimum = next((e for e in es if e.get("aggregate_name") == "min"), {})
        low, mid = minimum.get("real_time"), median.get("real_time")
        check("min and median reported", low is not None and mid is not None and low <= mid and median.get("min_ns") == low, f"{run}: min {low}, median {mid}")
    if not samples:
        start = text.index('"benchmarks"')
        per_row = (len(text) - start) / max(1, len(per_run))
        check("default JSON is small", per_row < MAX_BYTES_PER_ROW, f"{per_row:.0f} bytes per row (limit {MAX_BYTES_PER_ROW})")
    return data


def run_bench(ek_bench, out, samples):
    cmd = [ek_bench, "--filter", ROWS, "--threads", "1", "--min-time", "0.05", "--out", out + ".h5", "--json", out + ".json"]
    if samples:
        cmd.append("--samples")
    p = subprocess.run(cmd, capture_output=True, text=True)
    check("ek-bench runs", p.returncode == 0, f"{' '.join(cmd)}: exit {p.returncode} {p.stderr[-500:] if p.returncode else ''}")
    return out + ".json"


def close(a, b):
    return a == b or abs(a - b) <= 1e-12 * max(abs(a), abs(b))


def check_compare(compare, a_path, b_path, tmp):
    a = json.load(open(a_path))["benchmarks"]
    b = json.load(open(b_path))["benchmarks"]
    dump = os.path.join(tmp, "diff.json")
    p = subprocess.run([sys.executable, compare, a_path, b_path, "--dump-to-json", dump], capture_output=True, text=True)
    check("compare.py compares two ek-bench files", p.returncode == 0, f"exit {p.returncode} {p.stderr[-300:]}")
    if p.returncode:
        return
    diff = json.load(open(dump))
    names = [d["name"] for d in diff]
    common = []
    for e in a:
        if e["name"] not in common and any(x["name"] == e["name"] for x in b):
            common.append(e["name"])
    check("every common name reported, in the baseline's order", names[: len(common)] == common, f"{len(common)} names")
    wrong = []
    for d in diff:
        if d["name"] == "OVERALL_GEOMEAN":
            continue
        xs = [e for e in a if e["name"] == d["name"]]
        ys = [e for e in b if e["name"] == d["name"]]
        for m, x, y in zip(d["measurements"], xs, ys):
            want = (y["real_time"] - x["real_time"]) / abs(x["real_time"])
            if not close(m["time"], want) or m["real_time"] != x["real_time"]:
                wrong.append(f"{d['name']}: {m['time']} vs {want}")
        if len(d["measurements"]) != min(len(xs), len(ys)):
            wrong.append(f"{d['name']}: {len(d['measurements'])} measurements")
        u = d["utest"]
        has_samples = min(len(xs), len(ys)) >= 2
        if bool(u) != has_samples or (u and not (0 <= u["time_pvalue"] <= 1 and 0 <= u["cpu_pvalue"] <= 1)):
            wrong.append(f"{d['name']}: U test {u}")
    check("changes = (new - old) / |old|, U test where both have samples", not wrong, wrong[0] if wrong else f"{len(diff)} report entries")

    def gm(es):
        logs = [(math.log(e["real_time"] * 1e-9)) for e in es if e["run_type"] != "aggregate"]
        return math.exp(sum(logs) / len(logs))

    g = [d for d in diff if d["name"] == "OVERALL_GEOMEAN"]
    if all(any(e["run_type"] != "aggregate" for e in es) for es in (a, b)):
        want = (gm(b) - gm(a)) / gm(a)
        got = g[0]["measurements"][0]["time"] if len(g) == 1 else None
        check("OVERALL_GEOMEAN of the sample entries", got is not None and close(got, want), f"{got} vs {want}")
    else:
        check("no OVERALL_GEOMEAN without sample entries on both sides", not g, f"{len(g)} entries")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ek-bench", required=True)
    ap.add_argument("--compare", required=True)
    args = ap.parse_args()
    spec = importlib.util.spec_from_file_location("ek_compare", args.compare)
    cmp = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cmp)
    # By hand: x = 1,2,3 below y = 4,5,6: U = 0, P(U <= 0) = 1 / C(6,3),
    # two-sided p = 2 / 20.
    p = cmp.mann_whitney_p([1, 2, 3], [4, 5, 6])
    check("exact U-test p-value of a separated 3 + 3 sample", p == 0.1, f"{p}")
    p = cmp.mann_whitney_p([1.0] * 5, [1.0] * 5)
    check("U test of identical samples: p = 1", p == 1.0, f"{p}")

    with tempfile.TemporaryDirectory(prefix="ek_bench_json_") as tmp:
        a = run_bench(args.ek_bench, os.path.join(tmp, "a"), True)
        b = run_bench(args.ek_bench, os.path.join(tmp, "b"), True)
        c = run_bench(args.ek_bench, os.path.join(tmp, "c"), False)
        if failures:
            return 1
        for path, samples in ((a, True), (b, True), (c, False)):
            check_schema(path, samples)
        check_compare(args.compare, a, b, tmp)
        check_compare(args.compare, a, c, tmp)
        bad = os.path.join(tmp, "v2.json")
        data = json.load(open(c))
        data["context"]["json_schema_version"] = 2
        json.dump(data, open(bad, "w"))
        r = subprocess.run([sys.executable, args.compare, c, bad], capture_output=True, text=True)
        check("compare.py refuses json_schema_version 2, naming the file", r.returncode == 1 and bad in r.stderr, f"exit {r.returncode}: {r.stderr.strip()}")
    print(f"test_bench_json: {'FAILED' if failures else 'passed'} ({failures} failure{'s' if failures != 1 else ''})")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
