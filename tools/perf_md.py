#!/usr/bin/env python3
"""Write the generated part of docs/perf.md from ek-bench JSON files.

    tools/perf_md.py --bench RUN.json --cpu "LABEL" [--bench RUN2.json --cpu "LABEL2"] \
                     [--out docs/perf.md]

Per run (one CPU, its ISA, its threads): per kernel group, every row's
median and minimum ns per item, its declared flops and bytes per item (as
ek-bench records them), GFLOP/s against the FMA peak and GB/s against the
triad measured in the same run, the bound (the larger of flops / peak and,
for the rows that stream from memory (STREAMING), bytes / triad: "FMA" or
"triad"; a cache-resident row without declared flops has none), the fraction of that bound reached
(bound time / median time) and the 2-thread / 1-thread speed-up; then the
AoS API / AoSoA kernel ratios. Rows without declared flops are bound by
bytes alone. Everything between the markers below is replaced; the hand-
written analysis outside them is kept. Standard library only.
"""
import argparse
import json
import re
import sys

BEGIN = "<!-- perf_md.py: generated, do not edit below -->"
END = "<!-- perf_md.py: generated, do not edit above -->"

# Rows whose data stream from memory (batches far beyond the caches): their
# bound may be the triad; every other row's data stay in the caches, so
# their bytes / triad is shown but only the FMA peak bounds them.
STREAMING = r"^svd3/(aosoa_big|aos)/|tets:998250"

GROUPS = [
    ("SVD, AoSoA, cache-resident (4096 matrices)", r"^svd3/aosoa/"),
    ("Polar from the SVD, AoSoA, cache-resident", r"^svd3/polar_aosoa/"),
    ("SVD, AoSoA, 2^20 f32 / 2^18 f64 matrices (beyond the caches)", r"^svd3/aosoa_big/"),
    ("SVD, AoS API (same batch as aosoa_big)", r"^svd3/aos/"),
    ("LAPACK ?gesvd per 3x3 (baseline)", r"^svd3/lapack/"),
    ("Warm polar (AoSoA)", r"^polar/warm/"),
    ("FVM force per model (thread buffers scatter)", r"^fvm/"),
    ("Hessian product and gradient pass", r"^hessian/"),
    ("Cloth", r"^cloth/"),
]


def medians(doc):
    return {b["run_name"]: b for b in doc["benchmarks"] if b.get("aggregate_name") == "median"}


def fmt(x, nd=2):
    if x is None:
        return "-"
    if abs(x) >= 100:
        return f"{x:.0f}"
    return f"{x:.{nd}f}"


def row_cells(b, rows):
    t = b["real_time"]
    fl = b.get("flops_per_item")
    by = b.get("bytes_per_item")
    peak = b.get("peak_gflops")
    triad = b.get("triad_gbs") if not b.get("triad_disturbed") else None
    gf = fl / t if fl else None
    gbs = by / t if by else None
    t_fma = fl / peak if fl and peak else None
    t_bw = by / triad if by and triad else None
    if not re.search(STREAMING, b["run_name"]):
        t_bw = None
    bounds = [(v, n) for v, n in ((t_fma, "FMA"), (t_bw, "triad")) if v]
    bound, reached = ("-", None)
    if bounds:
        v, bound = max(bounds)
        reached = v / t
    sp = None
    name = b["run_name"]
    if name.endswith("threads:2"):
        one = rows.get(name[: -len("threads:2")] + "threads:1")
        if one:
            sp = one["real_time"] / t
    flags = [k for k in ("noisy", "twin_suspect", "peak_estimated", "triad_disturbed") if b.get(k)]
    return [
        "`" + name + "`",
        f"{fmt(t)} ({fmt(b.get('min_ns'))})",
        fmt(fl, 0) if fl else "-",
        fmt(by, 0) if by else "-",
        fmt(gf),
        f"{100 * gf / peak:.1f}%" if gf and peak else "-",
        fmt(gbs),
        f"{100 * gbs / triad:.0f}%" if gbs and triad else "-",
        bound,
        f"{100 * reached:.0f}%" if reached else "-",
        f"{sp:.2f}x" if sp else "-",
        ",".join(flags) or "",
    ]


def section(doc, label):
    ctx = doc["context"]
    rows = medians(doc)
    out = [f"### {label}", ""]
    isas = ctx.get("isas_available", "")
    out.append(
        f"ek-bench `{ctx.get('arguments', '')}`, {ctx.get('date', '')}, revision "
        f"{ctx.get('git_revision', '?')}, ISAs {isas}, load average {ctx.get('load_avg')}."
    )
    peaks = []
    for t in (1, 2):
        p = [
            f"{isa} {float(ctx.get(f'peak_gflops.{isa}.f32.threads:{t}', 0)):.1f}/"
            f"{float(ctx.get(f'peak_gflops.{isa}.f64.threads:{t}', 0)):.1f}"
            for isa in ("avx2", "avx512")
            if f"peak_gflops.{isa}.f32.threads:{t}" in ctx
        ]
        tri = ctx.get(f"triad_gbs.threads:{t}")
        tri = float(tri) if tri else None
        peaks.append(
            f"{t} thread{'s' if t > 1 else ''}: FMA peak GFLOP/s (f32/f64) {', '.join(p)}; "
            f"triad {fmt(tri)} GB/s"
        )
    out += ["Machine limits of this run: " + "; ".join(peaks) + "."]
    if ctx.get("probe_warnings"):
        out.append(f"Probe warnings: {ctx['probe_warnings']}")
    out.append("")
    head = ["row", "ns/item med (min)", "flops", "bytes", "GFLOP/s", "%FMA peak", "GB/s",
            "%triad", "bound", "bound reached", "2T/1T", "flags"]
    for title, rx in GROUPS:
        sel = [b for n, b in rows.items() if re.search(rx, n)]
        if not sel:
            continue
        out += [f"#### {title}", "", "| " + " | ".join(head) + " |",
                "|" + "---|" * len(head)]
        for b in sel:
            out.append("| " + " | ".join(row_cells(b, rows)) + " |")
        out.append("")
    # AoS entry point / its AoSoA kernel (cache-resident), same ISA, precision, threads.
    ratios = []
    for n, b in rows.items():
        m = re.match(r"^svd3/aos/(.*)$", n)
        if m:
            for k in ("aosoa", "aosoa_big"):
                base = rows.get(f"svd3/{k}/{m.group(1)}")
                if base:
                    ratios.append(f"| `{n}` | `{k}` | {b['real_time'] / base['real_time']:.2f} |")
    if ratios:
        out += ["#### AoS API / AoSoA kernel (medians; target <= 1.3 against aosoa)", "",
                "| AoS row | against | ratio |", "|---|---|---|"] + ratios + [""]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bench", action="append", required=True)
    ap.add_argument("--cpu", action="append", required=True)
    ap.add_argument("--out", default="docs/perf.md")
    a = ap.parse_args()
    if len(a.bench) != len(a.cpu):
        ap.error("one --cpu per --bench")
    gen = [BEGIN, ""]
    for path, label in zip(a.bench, a.cpu):
        try:
            with open(path) as f:
                doc = json.load(f)
        except (OSError, ValueError) as e:
            print(f"perf_md.py: {path}: {e}", file=sys.stderr)
            return 1
        ctx = doc.get("context", {}) if isinstance(doc, dict) else {}
        if str(ctx.get("partial")).lower() == "true":
            # An interrupted or failed ek-bench run (ek-bench names it *.partial.json).
            print(f"perf_md.py: {path}: a partial ek-bench run ({ctx.get('partial_reason', '?')}); "
                  "the tables need a whole run", file=sys.stderr)
            return 1
        gen += section(doc, label)
    gen.append(END)
    try:
        with open(a.out) as f:
            text = f.read()
    except OSError:
        text = ""
    if BEGIN in text and END in text:
        text = text[: text.index(BEGIN)] + "\n".join(gen) + text[text.index(END) + len(END):]
    else:
        text = text + ("\n" if text else "") + "\n".join(gen) + "\n"
    with open(a.out, "w") as f:
        f.write(text)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
