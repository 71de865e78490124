#!/usr/bin/env python3
"""Summarise or plot an ek-bench run.

Reads the JSON file ek-bench writes beside its HDF5 file (Google Benchmark
schema; ek's fields are on the "median" aggregate rows), so it needs only the
standard library to print a table. With --plot OUT.png and matplotlib
installed it also draws ns/item per row (median, with the min..max range of
the samples as an error bar), one panel per family.

usage: plot_bench.py RUN.json [--filter REGEX] [--plot OUT.png]
"""
import argparse
import json
import math
import re
import sys


def median_rows(run, pattern):
    rows = []
    for b in run.get("benchmarks", []):
        if b.get("run_type") != "aggregate" or b.get("aggregate_name") != "median":
            continue
        if pattern and not re.search(pattern, b["run_name"]):
            continue
        rows.append(b)
    return rows


def fmt(value, spec):
    """format(value, spec), or "-" right-aligned to the spec's width."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-".rjust(int(re.match(r"\d*", spec).group() or 0))
    return format(value, spec)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("json", help="results JSON written by ek-bench")
    ap.add_argument("--filter", help="regex on the row name")
    ap.add_argument("--plot", metavar="OUT.png", help="write a bar chart (needs matplotlib)")
    args = ap.parse_args()
    try:
        with open(args.json) as f:
            run = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        sys.exit(f"plot_bench: cannot read {args.json}: {e}")
    rows = median_rows(run, args.filter)
    if not rows:
        sys.exit(f"plot_bench: no median rows in {args.json} match the filter")
    ctx = run.get("context", {})
    if str(ctx.get("partial")).lower() == "true":
        print(f"plot_bench: {args.json} is a partial ek-bench run "
              f"({ctx.get('partial_reason', '?')}): PARTIAL", file=sys.stderr)
    print(f"{ctx.get('cpu_model', '?')}, {ctx.get('num_cpus', '?')} CPUs, "
          f"ISAs {ctx.get('isas_available', '?')}, git {ctx.get('git_revision', '?')}, "
          f"{ctx.get('date', '?')}")
    width = max(len(r["run_name"]) for r in rows)
    print(f"{'name':<{width}} {'ns/item':>10} {'GFLOP/s':>8} {'%peak':>6} {'vs base':>8}")
    for r in rows:
        peak = r.get("peak_fraction")
        print(f"{r['run_name']:<{width}} {fmt(r['real_time'], '10.4g')} "
              f"{fmt((r.get('flops_per_second') or math.nan) / 1e9, '8.2f')} "
              f"{fmt(peak * 100 if peak is not None else None, '6.1f')} "
              f"{fmt(r.get('speedup_vs_baseline'), '8.2f')}")
    if not args.plot:
        return
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.exit("plot_bench: --plot needs matplotlib (pip install matplotlib)")
    families = sorted({r.get("family", "?") for r in rows})
    fig, axes = plt.subplots(len(families), 1, squeeze=False,
                             figsize=(10, 0.3 * len(rows) + 1.5 * len(families)))
    for ax, fam in zip(axes[:, 0], families):
        sel = [r for r in rows if r.get("family", "?") == fam]
        med = [r["real_time"] for r in sel]
        lo = [m - (r.get("min_ns") or m) for m, r in zip(med, sel)]
        hi = [(r.get("max_ns") or m) - m for m, r in zip(med, sel)]
        ax.barh(range(len(sel)), med, xerr=[lo, hi])
        ax.set_yticks(range(len(sel)), [r["run_name"] for r in sel], fontsize=7)
        ax.invert_yaxis()
        ax.set_xscale("log")
        ax.set_xlabel("ns per item (median; bars: min..max sample)")
        ax.set_title(fam)
    fig.tight_layout()
    fig.savefig(args.plot, dpi=120)
    print(f"wrote {args.plot}")


if __name__ == "__main__":
    main()
