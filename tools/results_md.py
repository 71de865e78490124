#!/usr/bin/env python3
"""Write a results page (Markdown) from ek-bench and ek-verify JSON files.

    tools/results_md.py --bench BENCH.json [--verify VERIFY.json] [--extremes EXT.json]
                        [--out docs/results/<cpu>.md | --out-dir docs/results]

The page is generated, never typed: every number comes from the files, and
the page names the CPU, the ISAs, the build (compiler, flags, git
revision), the date, the threads and ek-bench's arguments, as recorded by
ek-bench in its JSON's context. ek-bench records /proc/cpuinfo's model
name, which a virtual machine may cut short ("AMD EPYC"): --cpu adds what
is known beside it (e.g. the cpuid family), marked as given. With --out-dir
the file name is made from the CPU name and the best ISA
(amd-epyc-avx512.md). Sections:
  - the run: CPU, ISAs available and built, compiler and flags, revision,
    date, load average, ek-bench arguments, the machine probe's warnings;
  - per ek-bench family (the first part of a row name), one table: row,
    median and minimum ns per item, fraction of the FMA peak and of the
    triad bandwidth, speed-up over the row's baseline, 2-thread / 1-thread
    speed-up, flags (noisy, twin, peak~, triad?);
  - ek-verify: rows per status, and every row: kernel, variant, inputs,
    worst error, budget, worst / budget, status;
  - ek-verify --extremes: rows per model, loop and status, and the known
    failures.
Standard library only. Exit status 0 written, 1 a file is unreadable, 2 usage.
"""
import argparse
import datetime
import json
import math
import os
import re
import sys
from collections import Counter, OrderedDict


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise SystemExit(f"results_md.py: {path}: {e}")


def num(v, fmt="{:.3g}"):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return fmt.format(v)


def pct(v):
    return "-" if v is None or not math.isfinite(v) or v <= 0 else f"{100 * v:.0f}%"


def md(v):
    """A table cell: pipes escaped, no line breaks."""
    return str(v).replace("|", "\\|").replace("\n", " ")


def slug(cpu):
    s = re.sub(r"\(r\)|\(tm\)|processor|\d+-core", "", cpu.lower())
    s = re.sub(r"[^a-z0-9]+", "-", s).strip("-")
    return s or "unknown-cpu"


def bench_rows(data):
    """One dict per row: its median entry with the min aggregate's time."""
    rows = OrderedDict()
    for e in data.get("benchmarks", []):
        if e.get("run_type") != "aggregate":
            continue
        name = e.get("run_name") or e["name"]
        r = rows.setdefault(name, {"name": name})
        r[e.get("aggregate_name")] = e
    return [r for r in rows.values() if "median" in r]


def bench_section(data, out):
    ctx = data.get("context", {})
    rows = bench_rows(data)
    out.append(f"## ek-bench: {len(rows)} rows\n")
    out.append("Times are per item (ns; an item is a matrix, a tet, a constraint or a step, as the "
               "row says), the median over the row's samples and its minimum. %peak: declared "
               "flops against the FMA peak measured in the same run for the row's ISA, precision "
               "and threads; %bw: declared bytes against the measured stream triad (a cache-resident "
               "batch can exceed 100%). vs base: speed-up over the row's baseline in the same run; "
               "xT/1T: over the same row at 1 thread. Same-run ratios are steadier than absolute "
               "times on a shared machine.\n")
    families = OrderedDict()
    for r in rows:
        families.setdefault(r["name"].split("/")[0], []).append(r)
    for fam, rs in families.items():
        out.append(f"### {fam} ({len(rs)} rows)\n")
        out.append("| row | median ns | min ns | %peak | %bw | vs base | xT/1T | flags |")
        out.append("|---|---|---|---|---|---|---|---|")
        for r in rs:
            m = r["median"]
            mn = r.get("min", {}).get("real_time")
            label = m.get("label", "")
            flags = label.split("; flags ")[1] if "; flags " in label else ""
            out.append(
                f"| `{md(r['name'])}` | {num(m.get('real_time'), '{:.4g}')} | {num(mn, '{:.4g}')} "
                f"| {pct(m.get('peak_fraction'))} | {pct(m.get('bw_fraction'))} "
                f"| {num(m.get('speedup_vs_baseline'), '{:.2f}x')} | {num(m.get('speedup_threads'), '{:.2f}x')} "
                f"| {flags} |")
        out.append("")
    return ctx


def verify_section(data, out):
    rows = data.get("rows", [])
    status = Counter(r.get("status", "?") for r in rows)
    out.append(f"## ek-verify: {len(rows)} rows, result {data.get('result', '?')}\n")
    out.append(f"Seed {data.get('seed')}, {data.get('n_random')} random inputs and "
               f"{data.get('n_family')} per extremes family{' (--quick)' if data.get('quick') else ''}. "
               "Rows per status: " + ", ".join(f"{k} {v}" for k, v in sorted(status.items())) + ". "
               "worst / budget above 0.5 is MARGINAL, above 1 FAIL; trade rows (non-default "
               "knobs) are reported, not judged.\n")
    out.append("| kernel | variant | inputs | n | worst | budget | worst / budget | status |")
    out.append("|---|---|---|---|---|---|---|---|")
    for r in rows:
        worst_in = f" ({r['worst_inputs']})" if r.get("worst_inputs") else ""
        out.append(f"| {md(r.get('kernel'))} | {md(r.get('variant'))} | {md(r.get('inputs'))}{md(worst_in)} | {r.get('count')} "
                   f"| {num(r.get('worst'), '{:.2e}')} | {num(r.get('budget'), '{:.0e}')} "
                   f"| {num(r.get('ratio'), '{:.3g}')} | {r.get('status')} |")
    out.append("")


def extremes_section(data, out):
    rows = data.get("rows", [])
    out.append(f"## ek-verify --extremes: {len(rows)} rows, result {data.get('result', '?')}\n")
    out.append("Rows per model, loop and status, both precisions: PASS / FAIL expected to survive; "
               "xfail expected not to and did not; ok / broke no expectation (the table of "
               "expectations and their sources is in verify/verify_extremes.c).\n")
    table = OrderedDict()
    keys = ("model", "loop", "status")
    for r in rows:
        if not all(k in r for k in keys):
            continue
        table.setdefault(r["model"], OrderedDict()).setdefault(r["loop"], Counter())[r["status"]] += 1
    loops = sorted({loop for m in table.values() for loop in m})
    if table:
        out.append("| model | " + " | ".join(loops) + " |")
        out.append("|---|" + "---|" * len(loops))
        for model, per in table.items():
            cells = [" ".join(f"{n} {s}" for s, n in sorted(per.get(loop, {}).items())) or "-" for loop in loops]
            out.append(f"| {model} | " + " | ".join(cells) + " |")
        out.append("")
    known = data.get("known_failures") or []
    if known:
        out.append(f"Known failures ({len(known)}; rows expected to survive that did not, which "
                   "make `ek-verify --extremes` exit 1):\n")
        out.extend(f"- {k if isinstance(k, str) else json.dumps(k)}" for k in known)
        out.append("")


def main(argv):
    p = argparse.ArgumentParser(prog="results_md.py", description=__doc__.split("\n")[0])
    p.add_argument("--bench", required=True, help="ek-bench JSON (Google Benchmark schema)")
    p.add_argument("--verify", help="ek-verify --json output")
    p.add_argument("--extremes", help="ek-verify --extremes --json output")
    p.add_argument("--cpu", help="what is known of the CPU beyond ek-bench's model name (shown as given)")
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--out", help="the page to write")
    g.add_argument("--out-dir", help="folder: the page is <cpu model>.md in it")
    args = p.parse_args(argv)

    bench = load(args.bench)
    ctx = bench.get("context", {})
    if str(ctx.get("partial")).lower() == "true":
        # An interrupted or failed ek-bench run (ek-bench names it *.partial.json).
        raise SystemExit(f"results_md.py: {args.bench}: a partial ek-bench run "
                         f"({ctx.get('partial_reason', '?')}); the results page needs a whole run")
    cpu = ctx.get("cpu_model", "unknown CPU")
    isas = (ctx.get("isas_available") or "").split()
    best = isas[-1] if isas else "unknown-isa"
    path = args.out or os.path.join(args.out_dir, f"{slug(cpu)}-{best}.md")
    out = [f"# Results on {cpu} ({best})\n",
           f"Generated by `tools/results_md.py` from {' and '.join(os.path.basename(f) for f in (args.bench, args.verify, args.extremes) if f)}; "
           "do not edit: run the programs and the script again (docs/results/README.md).\n",
           "| | |", "|---|---|"]
    facts = [
        ("CPU (ek-bench)", cpu),
        ("CPU (given)", args.cpu),
        ("ISAs available (run) / built", f"{ctx.get('isas_available', '?')} / {ctx.get('isas_built', '?')}"),
        ("cores (num_cpus)", ctx.get("num_cpus")),
        ("OpenMP threads (max)", ctx.get("omp_max_threads")),
        ("ek", f"{ctx.get('library_version', '?')}, git {ctx.get('git_revision', '?')}, {ctx.get('build_type', '?')}"),
        ("compiler", ctx.get("compiler")),
        ("C flags", f"`{ctx.get('c_flags', '')}`"),
        ("kernel flags", f"`{ctx.get('kernel_flags', '')}`"),
        ("date", ctx.get("date")),
        ("load average at the start", ", ".join(f"{x:.2f}" for x in ctx.get("load_avg", [])) or None),
        ("ek-bench arguments", f"`{ctx.get('arguments', '')}`"),
        ("OMP_PROC_BIND / OMP_PLACES", f"{ctx.get('omp_proc_bind_effective') or ctx.get('omp_proc_bind')} / {ctx.get('omp_places')}"),
    ]
    for k, v in facts:
        if v not in (None, ""):
            out.append(f"| {k} | {md(v)} |")
    out.append("")
    warnings = (ctx.get("probe_warnings") or "").strip()
    if warnings:
        out.append("Machine probe warnings:\n\n```\n" + warnings + "\n```\n")
    notes = (ctx.get("notes") or "").strip()
    if notes:
        out.append("ek-bench notes: " + notes + "\n")
    bench_section(bench, out)
    if args.verify:
        verify_section(load(args.verify), out)
    if args.extremes:
        extremes_section(load(args.extremes), out)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write("\n".join(out).rstrip() + "\n")
    print(f"results_md.py: wrote {path} ({len(out)} lines) for {cpu} "
          f"(generated {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
