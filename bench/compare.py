#!/usr/bin/env python3
"""Compare two ek-bench JSON files (or any Google Benchmark JSON files).

    bench/compare.py [options] BASELINE.json CONTENDER.json

The comparison of google/benchmark's tools/compare.py in its "benchmarks"
mode, written here with the Python standard library only (that tool needs
numpy, scipy and its own gbench module, and PyPI's google-benchmark package
does not ship it): for every benchmark name present in both files (the time
unit of the baseline's first entry, entries of another unit dropped), the
relative change of real_time and cpu_time, (new - old) / |old|, entry by
entry; a two-sided Mann-Whitney U test over the entries of a name when both
files have at least 2 (ek-bench writes one entry per sample with
--samples); and OVERALL_GEOMEAN, the change of the geometric means of the
non-aggregate entries' times. Negative changes are faster.

The summary comes first: per row (run_name) the change of the median
aggregate (ek-bench writes one per row), their geometric mean, and the rows
whose change is beyond noise: |change| above --noise (default 0.05) and
above twice the larger relative spread of the two runs (1.4826 MAD / median
from ek-bench's mad_ns counter, robust to a few disturbed samples; the cv
aggregate for other files); with per-sample entries on both sides, also a
U test p-value below --alpha. The detail of google/benchmark's compare.py follows.

Options: --no-utest, --alpha A (U test significance, default 0.05),
--filter REGEX (names, as compare.py's --benchmark_filter),
--display-aggregates-only, --dump-to-json FILE (the report as JSON),
--noise F, --top N (rows beyond noise listed, default 20), --summary-only.
Exit status: 0 compared, 1 a file is not valid benchmark JSON, 2 usage.
"""
import argparse
import json
import math
import re
import sys

TIME_UNITS = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
UTEST_MIN_REPETITIONS = 2
UTEST_OPTIMAL_REPETITIONS = 9
# sigma = 1.4826 MAD for a normal sample (the unscaled MAD ek-bench writes).
MAD_TO_SIGMA = 1.4826


class BadInput(Exception):
    pass


def load(path, name_filter):
    """The file's JSON, checked as compare.py checks it (tools/gbench/util.py:
    json_schema_version 1 if present, a 'benchmarks' array of objects with a
    string 'name', numeric real_time/cpu_time and a known time_unit unless
    'error_occurred'), filtered by name and sorted as compare.py sorts."""
    try:
        with open(path) as f:
            data = json.load(f)
    except (OSError, ValueError) as e:
        raise BadInput(f"{path}: cannot read JSON: {e}")
    if not isinstance(data, dict):
        raise BadInput(f"{path}: the root is not an object")
    context = data.get("context", {})
    if not isinstance(context, dict):
        raise BadInput(f"{path}: 'context' is not an object")
    if context.get("json_schema_version", 1) != 1:
        raise BadInput(f"{path}: json_schema_version {context['json_schema_version']!r}, expected 1")
    if str(context.get("partial")).lower() == "true":
        # An interrupted or failed ek-bench run: its rows compare, the rest is missing.
        print(f"compare.py: warning: {path} is a partial ek-bench run "
              f"({context.get('partial_reason', '?')}); only its rows are compared", file=sys.stderr)
    runs = data.get("benchmarks")
    if not isinstance(runs, list):
        raise BadInput(f"{path}: no 'benchmarks' array")
    for i, run in enumerate(runs):
        if not isinstance(run, dict) or not isinstance(run.get("name"), str):
            raise BadInput(f"{path}: benchmarks[{i}] is not an object with a string 'name'")
        if run.get("error_occurred", False):
            continue
        for key in ("real_time", "cpu_time"):
            v = run.get(key)
            if key in run and (isinstance(v, bool) or not isinstance(v, (int, float))):
                raise BadInput(f"{path}: benchmarks[{i}] ({run['name']}): {key} = {v!r} is not a number")
        if "time_unit" in run and run["time_unit"] not in TIME_UNITS:
            raise BadInput(f"{path}: benchmarks[{i}] ({run['name']}): time_unit {run['time_unit']!r}")
    if name_filter:
        rx = re.compile(name_filter)
        runs = [r for r in runs if rx.search(r.get("run_name") or r["name"])]
    # Innermost key first, as compare.py sorts: repetition, iterations
    # before aggregates, instance, family.
    runs = sorted(runs, key=lambda r: r.get("repetition_index", -1))
    runs = sorted(runs, key=lambda r: 1 if r.get("run_type") == "aggregate" else 0)
    runs = sorted(runs, key=lambda r: r.get("per_family_instance_index", -1))
    runs = sorted(runs, key=lambda r: r.get("family_index", -1))
    return runs


def change(old, new):
    if old == 0 and new == 0:
        return 0.0
    if old == 0:
        return float(new - old) / (float(old + new) / 2)
    return float(new - old) / abs(old)


def comparable(run):
    return "time_unit" in run and "real_time" in run and "cpu_time" in run


def partitions(lhs, rhs):
    """Per name in both files (baseline order): the entries of each side
    with the time unit of the baseline's first comparable entry."""
    rhs_names = {r["name"] for r in rhs}
    seen, out = set(), []
    for run in lhs:
        name = run["name"]
        if name in seen or name not in rhs_names:
            continue
        seen.add(name)
        unit = next((r["time_unit"] for r in lhs if r["name"] == name and comparable(r)), None)
        if unit is None:
            continue
        a = [r for r in lhs if r["name"] == name and r.get("time_unit") == unit and comparable(r)]
        b = [r for r in rhs if r["name"] == name and r.get("time_unit") == unit and comparable(r)]
        out.append((name, unit, a, b))
    return out


def normal_sf(z):
    return 0.5 * math.erfc(z / math.sqrt(2))


def mann_whitney_p(x, y):
    """Two-sided p-value of the Mann-Whitney U test (Mann and Whitney 1947).
    Exact distribution when the smaller sample has at most 8 values and
    there are no ties; otherwise the normal approximation with the tie
    correction of the variance and a continuity correction (the rule
    scipy.stats.mannwhitneyu's default method follows)."""
    n1, n2 = len(x), len(y)
    values = sorted((v, k) for k, sample in enumerate((x, y)) for v in sample)
    ranks = [0.0] * len(values)
    ties = []
    i = 0
    while i < len(values):
        j = i
        while j + 1 < len(values) and values[j + 1][0] == values[i][0]:
            j += 1
        for k in range(i, j + 1):
            ranks[k] = (i + j) / 2 + 1
        if j > i:
            ties.append(j - i + 1)
        i = j + 1
    r1 = sum(r for r, (_, k) in zip(ranks, values) if k == 0)
    u1 = r1 - n1 * (n1 + 1) / 2
    u = max(u1, n1 * n2 - u1)
    if min(n1, n2) <= 8 and not ties:
        # counts[m][s]: subsets of size m of 1..t with rank-sum offset s,
        # built up over t: the null distribution of U.
        counts = [[0] * (n1 * n2 + 1) for _ in range(n1 + 1)]
        counts[0][0] = 1
        for t in range(1, n1 + n2 + 1):
            for m in range(min(t, n1), 0, -1):
                shift = t - m  # U contribution of the t-th value taken as the m-th
                if shift > n2:
                    continue
                row, prev = counts[m], counts[m - 1]
                for s in range(n1 * n2, shift - 1, -1):
                    row[s] += prev[s - shift]
        total = sum(counts[n1])
        tail = sum(counts[n1][int(round(u)):]) / total
        return min(1.0, 2 * tail)
    n = n1 + n2
    mu = n1 * n2 / 2
    tie_term = sum(t**3 - t for t in ties) / (n * (n - 1))
    sigma = math.sqrt(n1 * n2 / 12 * ((n + 1) - tie_term))
    if sigma == 0:
        return 1.0
    z = (u - mu - 0.5) / sigma
    return min(1.0, 2 * normal_sf(z))


def geomean(runs):
    """Geometric means of real and CPU time, in seconds, of the entries that
    are not aggregates; None if there are none."""
    logs = []
    for r in runs:
        if r.get("run_type") == "aggregate" or not comparable(r):
            continue
        scale = TIME_UNITS[r["time_unit"]]
        real, cpu = r["real_time"] * scale, r["cpu_time"] * scale
        if real <= 0 or cpu <= 0:
            return None
        logs.append((math.log(real), math.log(cpu)))
    if not logs:
        return None
    return tuple(math.exp(sum(v[i] for v in logs) / len(logs)) for i in (0, 1))


def report(lhs, rhs, utest=True):
    out = []
    for name, unit, a, b in partitions(lhs, rhs):
        measurements = [
            {
                "real_time": x["real_time"],
                "cpu_time": x["cpu_time"],
                "real_time_other": y["real_time"],
                "cpu_time_other": y["cpu_time"],
                "time": change(x["real_time"], y["real_time"]),
                "cpu": change(x["cpu_time"], y["cpu_time"]),
            }
            for x, y in zip(a, b)
        ]
        u = {}
        if utest and min(len(a), len(b)) >= UTEST_MIN_REPETITIONS:
            u = {
                "have_optimal_repetitions": min(len(a), len(b)) >= UTEST_OPTIMAL_REPETITIONS,
                "time_pvalue": mann_whitney_p([x["real_time"] for x in a], [y["real_time"] for y in b]),
                "cpu_pvalue": mann_whitney_p([x["cpu_time"] for x in a], [y["cpu_time"] for y in b]),
                "nr_of_repetitions": len(a),
                "nr_of_repetitions_other": len(b),
            }
        if measurements:
            run_type = a[0].get("run_type", "")
            out.append(
                {
                    "name": name,
                    "label": a[0].get("label", ""),
                    "measurements": measurements,
                    "time_unit": unit,
                    "run_type": run_type,
                    "aggregate_name": a[0].get("aggregate_name", "") if run_type == "aggregate" else "",
                    "utest": u,
                }
            )
    g1, g2 = geomean(lhs), geomean(rhs)
    if g1 and g2:
        out.append(
            {
                "name": "OVERALL_GEOMEAN",
                "label": "",
                "measurements": [
                    {
                        "real_time": g1[0],
                        "cpu_time": g1[1],
                        "real_time_other": g2[0],
                        "cpu_time_other": g2[1],
                        "time": change(g1[0], g2[0]),
                        "cpu": change(g1[1], g2[1]),
                    }
                ],
                "time_unit": "s",
                "run_type": "aggregate",
                "aggregate_name": "geomean",
                "utest": {},
            }
        )
    return out


def aggregate(runs, run_name, which):
    for r in runs:
        if r.get("run_type") == "aggregate" and (r.get("run_name") or r["name"]) == run_name \
                and r.get("aggregate_name") == which and comparable(r):
            return r
    return None


def summarize(lhs, rhs, diff, noise, alpha):
    """Per row in both files: the change of its median (real time), the
    geometric mean of (1 + change) over the rows, and the rows beyond noise
    (see the module's docstring), sorted by change."""
    pvalues = {d["name"]: d["utest"]["time_pvalue"] for d in diff if d["utest"]}
    rows, seen = [], set()
    for r in lhs:
        name = r.get("run_name") or r["name"]
        if name in seen:
            continue
        seen.add(name)
        a, b = aggregate(lhs, name, "median"), aggregate(rhs, name, "median")
        if not a or not b or a["time_unit"] != b["time_unit"] or a["real_time"] <= 0 or b["real_time"] <= 0:
            continue
        # The spread of a row's samples: ek-bench's MAD over the median
        # (robust: a few descheduled samples do not make the whole row
        # noise), else the cv aggregate of Google Benchmark's files.
        spreads = []
        for m, side in ((a, lhs), (b, rhs)):
            if isinstance(m.get("mad_ns"), (int, float)) and m["mad_ns"] >= 0:
                spreads.append(MAD_TO_SIGMA * m["mad_ns"] / m["real_time"])
            else:
                cv_entry = aggregate(side, name, "cv")
                if cv_entry:
                    spreads.append(cv_entry["real_time"])
        cv = max(spreads) if spreads else 0.0
        c = change(a["real_time"], b["real_time"])
        p = pvalues.get(name)
        beyond = abs(c) > max(noise, 2 * cv) and (p is None or p < alpha)
        rows.append({"name": name, "old": a["real_time"], "new": b["real_time"], "unit": a["time_unit"],
                     "change": c, "cv": cv, "pvalue": p, "beyond_noise": beyond})
    geo = math.exp(sum(math.log(1 + x["change"]) for x in rows) / len(rows)) - 1 if rows else None
    changes = sorted(x["change"] for x in rows)
    median = (changes[(len(changes) - 1) // 2] + changes[len(changes) // 2]) / 2 if rows else None
    return {"rows": rows, "geomean_change": geo, "median_change": median}


def print_summary(s, noise, top):
    rows = s["rows"]
    print(f"Summary: {len(rows)} rows with a median in both files")
    if not rows:
        return
    print(f"  geometric mean of the changes of the row medians: {s['geomean_change']:+.2%} "
          f"(median change {s['median_change']:+.2%}; negative = faster)")
    beyond = sorted((x for x in rows if x["beyond_noise"]), key=lambda x: x["change"])
    faster = sum(1 for x in beyond if x["change"] < 0)
    print(f"  beyond noise (|change| > max({noise:g}, 2 sigma of either run)): {len(beyond)} rows, "
          f"{faster} faster, {len(beyond) - faster} slower; {len(rows) - len(beyond)} within noise")
    shown = beyond if len(beyond) <= top else beyond[: top // 2] + beyond[-(top - top // 2):]
    if shown:
        width = max(len(x["name"]) for x in shown)
        for x in shown:
            print(f"    {x['name']:<{width}} {x['change']:+8.1%}  {x['old']:10.4g} -> {x['new']:10.4g} {x['unit']}"
                  f"  (sigma {x['cv']:.1%})")
        if len(shown) < len(beyond):
            print(f"    ... {len(beyond) - len(shown)} more beyond noise in the detail below")
    print()


def print_report(diff, aggregates_only, alpha):
    width = max([len("Benchmark")] + [len(d["name"]) + len("_pvalue") for d in diff])
    head = f"{'Benchmark':<{width}} {'Time':>9} {'CPU':>9} {'Time Old':>12} {'Time New':>12} {'CPU Old':>12} {'CPU New':>12}"
    print(head)
    print("-" * len(head))
    for d in diff:
        if not aggregates_only or d["run_type"] == "aggregate":
            for m in d["measurements"]:
                print(
                    f"{d['name']:<{width}} {m['time']:+9.4f} {m['cpu']:+9.4f} {m['real_time']:12.6g} "
                    f"{m['real_time_other']:12.6g} {m['cpu_time']:12.6g} {m['cpu_time_other']:12.6g}"
                )
        u = d["utest"]
        if u:
            note = f"U Test, Repetitions: {u['nr_of_repetitions']} vs {u['nr_of_repetitions_other']}"
            if not u["have_optimal_repetitions"]:
                note += f". WARNING: Results unreliable! {UTEST_OPTIMAL_REPETITIONS}+ repetitions recommended."
            verdict = "different" if u["time_pvalue"] < alpha else "same"
            print(f"{d['name'] + '_pvalue':<{width}} {u['time_pvalue']:9.4f} {u['cpu_pvalue']:9.4f}  ({verdict} at alpha {alpha}) {note}")


def main(argv):
    p = argparse.ArgumentParser(
        prog="compare.py",
        description="Compare two ek-bench / Google Benchmark JSON files (exit 0 compared, "
        "1 invalid input, 2 usage).",
    )
    p.add_argument("baseline")
    p.add_argument("contender")
    p.add_argument("--no-utest", action="store_true", help="skip the Mann-Whitney U test")
    p.add_argument("--alpha", type=float, default=0.05, help="U test significance level")
    p.add_argument("--filter", default=None, help="only names matching this regex")
    p.add_argument("--display-aggregates-only", action="store_true")
    p.add_argument("--dump-to-json", default=None, help="also write the report to this file")
    p.add_argument("--noise", type=float, default=0.05, help="smallest relative change reported as beyond noise")
    p.add_argument("--top", type=int, default=20, help="rows beyond noise listed in the summary")
    p.add_argument("--summary-only", action="store_true", help="print the summary, not the detail")
    args = p.parse_args(argv)
    try:
        lhs = load(args.baseline, args.filter)
        rhs = load(args.contender, args.filter)
    except BadInput as e:
        print(f"compare.py: {e}", file=sys.stderr)
        return 1
    diff = report(lhs, rhs, utest=not args.no_utest)
    print(f"Comparing {args.baseline} to {args.contender}")
    print_summary(summarize(lhs, rhs, diff, args.noise, args.alpha), args.noise, args.top)
    if not args.summary_only:
        print_report(diff, args.display_aggregates_only, args.alpha)
    if args.dump_to_json:
        with open(args.dump_to_json, "w") as f:
            json.dump(diff, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
