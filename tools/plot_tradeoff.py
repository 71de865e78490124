#!/usr/bin/env python3
"""Plot the speed/accuracy map of `ek-bench --suite tradeoff`.

usage: plot_tradeoff.py TRADEOFF.h5 OUTDIR [--bench BENCH.h5] [--threads N]
       plot_tradeoff.py OUTDIR --bench BENCH.h5 [--threads N]   (rooflines only)

One PNG per family of the map (OUTDIR/tradeoff_<family>.png, '/' in the
family name as '_'): error vs time per point, log-log, the p99 error as the
marker and the maximum as a whisker above it, the Pareto front on p99 drawn
as a line (bench/tradeoff.h: non-dominated, one of exact duplicates), the
default and McAdams et al. 2011 settings labelled; the implicit loop's points
with an assembled linear solver (a setting naming linear_solver=amg or direct)
drawn with a marker of their own ("implicit amg", "implicit direct") and the
f32 one at the scene's knobs labelled; a point with error 0 (a
loop's reference) on the bottom edge, marked and labelled "reference (error
0)". Points are
those of one thread count (--threads, default the most the file has).

With --bench BENCH.h5 (a default-suite file of ek-bench), one roofline per
kernel as well (OUTDIR/roofline_<kernel>.png, the rows' first name part:
svd3, fvm, hessian, xpbd, material, ...; axes fitted to the rows): left, each row's
achieved GFLOP/s against its arithmetic intensity (declared flops / declared
bytes) under the roofs of that run, the measured FMA peak per ISA and
precision and the measured triad bandwidth (rows that declare flops); right,
each row's achieved GB/s against the triad (rows that declare bytes; the
only panel when no row declares flops); at the same thread count.

Needs h5py and matplotlib (installed into build/venv by ./quickstart.sh test,
tests/requirements-venv.txt); the build never needs them.
"""
import argparse
import math
import os
import sys

PROG = "plot_tradeoff"
# An error of exactly 0 (a loop's reference: the run it is measured
# against) has no place on a log axis. It is drawn as what it is: on the
# bottom edge of the plot, a decade below the smallest error > 0, with a
# marker of its own and the label "reference (error 0)" (issue 26: it was
# drawn at 1e-18 as if it had that error).
ZERO_MARKER = "v"


def zero_row(pts):
    """The y at which errors of 0 are drawn: a decade below the smallest
    positive p99 or max error of the points (1 when there is none)."""
    pos = [v for p in pts for v in (p["err_p99"], p["err_max"]) if math.isfinite(v) and v > 0]
    return min(pos) / 10 if pos else 1.0


def y_of(e, zero_y):
    """Where an error is drawn: itself, or the zero row for 0."""
    return e if e > 0 else zero_y


def fail(msg):
    sys.exit(f"{PROG}: {msg}")


def text(v):
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


def knobs_of(setting):
    out = {}
    for kv in setting.split(";"):
        if kv:
            k, _, v = kv.partition("=")
            out[k] = v
    return out


def group_of(setting):
    """A point's group in a map: its ISA (kernel maps), else its loop, the
    implicit loop with its linear solver when that is not the default
    matrix_free ("implicit amg", "implicit direct")."""
    k = knobs_of(setting)
    if "isa" in k:
        return k["isa"]
    loop = k.get("loop", "?")
    ls = k.get("linear_solver", "matrix_free")
    return loop if ls == "matrix_free" else f"{loop} {ls}"


def open_h5(path, what, group):
    import h5py
    if not os.path.exists(path):
        fail(f"{path}: no such file ({what})")
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        fail(f"{path}: not an HDF5 file ({e})")
    if group not in f:
        f.close()
        fail(f"{path}: not {what}: no /{group} group")
    return f


def read_points(f, path):
    """{family: [point dict]} from every /tradeoff/.../points dataset."""
    families = {}

    def visit(name, obj):
        if name.endswith("points") and hasattr(obj, "dtype") and obj.dtype.names:
            needed = {"family", "setting", "time_median", "err_p99", "err_max", "threads"}
            missing = needed - set(obj.dtype.names)
            if missing:
                fail(f"{path}: /tradeoff/{name}: missing fields {sorted(missing)}")
            for row in obj[()]:
                p = {k: (text(row[k]) if obj.dtype[k].kind == "S" else row[k].item())
                     for k in obj.dtype.names}
                families.setdefault(p["family"], []).append(p)

    f["tradeoff"].visititems(visit)
    if not families:
        fail(f"{path}: /tradeoff holds no points")
    return families


def front_line(points):
    """The p99 front's points, by time."""
    sel = [p for p in points if p.get("on_front_p99")]
    return sorted(sel, key=lambda p: p["time_median"])


def plot_family(plt, family, points, threads, outdir, meta):
    pts = [p for p in points if p["threads"] == threads]
    if not pts:
        return None
    fig, ax = plt.subplots(figsize=(8, 6))
    zero_y = zero_row(pts)
    zeros = []  # points with p99 error 0, drawn on the zero row
    groups = {}
    # Kernel maps group by ISA; the loop maps (no ISA: the scene's) by loop,
    # the implicit loop also by its linear solver (issue 24: a setting with
    # "linear_solver=amg|direct"; none named is the default matrix_free).
    for p in pts:
        groups.setdefault((knobs_of(p["setting"]).get("precision", "?"), group_of(p["setting"])),
                          []).append(p)
    markers = {"scalar": "s", "avx2": "^", "avx512": "o",
               "explicit": "s", "implicit": "^", "xpbd": "o",
               "implicit amg": "v", "implicit direct": "P"}
    colors = {"f32": "tab:blue", "f64": "tab:orange"}
    nonfinite = 0
    for (prec, isa), sel in sorted(groups.items()):
        xs, ys, tops = [], [], []
        for p in sel:
            t, e, m = p["time_median"], p["err_p99"], p["err_max"]
            if not (math.isfinite(t) and math.isfinite(e)):
                nonfinite += 1
                continue
            if e == 0:
                zeros.append(p)
                continue
            xs.append(t)
            ys.append(e)
            tops.append(max(m, e) if math.isfinite(m) else None)
        if not xs:
            continue
        ax.scatter(xs, ys, s=18, marker=markers.get(isa, "D"), color=colors.get(prec, "gray"),
                   label=f"{prec} {isa} (p99)", alpha=0.8, zorder=3)
        for x, y, top in zip(xs, ys, tops):
            if top is not None and top > y:
                ax.plot([x, x], [y, top], color=colors.get(prec, "gray"), lw=0.6, alpha=0.5)
                ax.plot([x], [top], marker="_", color=colors.get(prec, "gray"), ms=6, alpha=0.7)
    if zeros:
        ax.scatter([p["time_median"] for p in zeros], [zero_y] * len(zeros), s=70,
                   marker=ZERO_MARKER, color="black", label="reference (error 0)", zorder=5,
                   clip_on=False)
        for p in zeros:
            k = knobs_of(p["setting"])
            what = " ".join(v for v in (k.get("loop", ""), k.get("precision", "")) if v)
            ax.annotate(f"reference {what} (error 0)".replace("  ", " "),
                        (p["time_median"], zero_y), xytext=(6, 6), textcoords="offset points",
                        fontsize=8)
    front = [p for p in front_line(pts)
             if math.isfinite(p["time_median"]) and math.isfinite(p["err_p99"])]
    if front:
        ax.step([p["time_median"] for p in front], [y_of(p["err_p99"], zero_y) for p in front],
                where="post", color="black", lw=1.2, label="Pareto front (p99)", zorder=2)
    for p in pts:
        k = knobs_of(p["setting"])
        label = None
        if p.get("is_reference") and p["err_p99"] == 0:
            label = None  # labelled on the zero row above
        elif p.get("is_reference"):
            label = f"reference {k.get('loop', '')} {k.get('precision', '')}"
        elif p.get("is_default"):
            label = f"default {k.get('loop', '')} {k.get('precision', '')}".replace("  ", " ")
        elif (k.get("linear_solver") and k.get("precision") == "f32"
              and k.get("newton_tol") == "1e-06"):
            # Each assembled solver at the scene's implicit knobs (f32).
            label = f"implicit {k['linear_solver']} f32"
        elif k.get("label") == "mcadams2011" and k.get("isa") == best_isa(pts):
            label = f"McAdams 2011 {k.get('precision', '')}"
        if label and math.isfinite(p["time_median"]) and math.isfinite(p["err_p99"]):
            # f32 labels above right, f64 below right: the two McAdams points
            # sit at the same error.
            ax.annotate(label, (p["time_median"], y_of(p["err_p99"], zero_y)),
                        xytext=(8, 8 if k.get("precision") != "f64" else -16),
                        textcoords="offset points", fontsize=8,
                        arrowprops={"arrowstyle": "-", "lw": 0.5})
            ax.scatter([p["time_median"]], [y_of(p["err_p99"], zero_y)], s=60,
                       facecolors="none", edgecolors="red", zorder=4)
    ax.set_xscale("log")
    ax.set_yscale("log")
    if zeros:
        # The zero row is the plot's bottom edge: nothing is drawn below it.
        ax.set_ylim(bottom=zero_y)
    unit = pts[0].get("time_unit", "ns")
    ax.set_xlabel(f"time, median ({unit}), {threads} thread{'s' if threads > 1 else ''}")
    ax.set_ylabel("error p99 (marker) to max (whisker)"
                  + ("; bottom edge: error 0" if zeros else ""))
    budgets = sorted({p["budget"] for p in pts if math.isfinite(p.get("budget", math.nan))})
    for b in budgets:
        ax.axhline(b, color="gray", ls=":", lw=0.8)
        ax.annotate(f"budget {b:g}", (ax.get_xlim()[0], b), fontsize=7, color="gray",
                    xytext=(2, 2), textcoords="offset points")
    title = f"{family}: error vs time ({meta.get('cpu_model', '?')}, git {meta.get('git_revision', '?')[:10]})"
    if nonfinite:
        title += f"\n{nonfinite} points with a non-finite error not drawn"
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.2)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    out = os.path.join(outdir, "tradeoff_" + family.replace("/", "_") + ".png")
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def best_isa(points):
    isas = {knobs_of(p["setting"]).get("isa") for p in points}
    for isa in ("avx512", "avx2", "scalar"):
        if isa in isas:
            return isa
    return None


def roofline_group(name):
    """The figure a row goes to: the first part of its name (svd3, fvm,
    hessian, xpbd, material, ...), so that one figure holds rows of one
    kernel and their labels stay readable."""
    return name.split("/", 1)[0]


def roofline(plt, bench_path, outdir, threads_opt):
    f = open_h5(bench_path, "an ek-bench default-suite file", "benchmarks")
    attrs = {k: (text(v) if isinstance(v, (bytes, str)) else v) for k, v in f.attrs.items()}
    rows = []

    def visit(name, obj):
        if "flops_per_item" in obj.attrs and "gflops" in obj.attrs:
            a = obj.attrs
            rows.append({"name": text(a["name"]), "family": text(a["family"]),
                         "isa": text(a["isa"]), "precision": text(a["precision"]),
                         "threads": int(a["threads"]), "flops": float(a["flops_per_item"]),
                         "bytes": float(a["bytes_per_item"]), "gflops": float(a["gflops"]),
                         "gbs": float(a["gbytes_per_second"])})

    f["benchmarks"].visititems(visit)
    f.close()
    if not rows:
        fail(f"{bench_path}: no rows under /benchmarks")
    threads = threads_opt or max(r["threads"] for r in rows)
    triad = float(attrs.get(f"triad_gbs.threads:{threads}", math.nan))
    # ek-bench leaves the triad NaN when its probe was disturbed (a busy
    # machine) and keeps the measured value beside it: drawn, and named so.
    triad_note = ""
    if not math.isfinite(triad):
        triad = float(attrs.get(f"triad_measured_gbs.threads:{threads}", math.nan))
        triad_note = " (disturbed probe)"
    markers = {"scalar": "s", "avx2": "^", "avx512": "o"}
    colors = {"f32": "tab:blue", "f64": "tab:orange"}
    roof_style = {"scalar": ":", "avx2": "--", "avx512": "-"}
    outs = []
    for group in sorted({roofline_group(r["name"]) for r in rows}):
        here = [r for r in rows if roofline_group(r["name"]) == group and r["threads"] == threads]
        sel = [r for r in here if r["flops"] > 0 and r["bytes"] > 0 and math.isfinite(r["gflops"])
               and r["gflops"] > 0]
        bw = [r for r in here if r["bytes"] > 0 and math.isfinite(r["gbs"])]
        if not sel and not bw:
            continue
        # Bar labels without the group and the thread count, at a size that
        # prints: the figure grows with the rows instead of the font
        # shrinking.
        names = [r["name"].replace(f"/threads:{threads}", "").split("/", 1)[-1] for r in bw]
        bar_h = max(4.0, 0.24 * len(bw) + 1.5)
        if sel:
            fig, (ax, axb) = plt.subplots(1, 2, figsize=(15, max(6.5, bar_h)),
                                          gridspec_kw={"width_ratios": [1, 1]})
        else:  # no row declares its flops: the bandwidth panel only
            fig, axb = plt.subplots(1, 1, figsize=(9, bar_h))
            ax = None
        if sel:
            ai = [r["flops"] / r["bytes"] for r in sel]
            # Axes from the data: intensity within a factor 2 of the rows,
            # GFLOP/s from below the slowest row to above the highest roof
            # drawn (only the roofs of ISAs and precisions with rows).
            lo, hi = min(ai) / 2, max(ai) * 2
            xs = [lo * (hi / lo) ** (k / 200) for k in range(201)]
            ytop = max(r["gflops"] for r in sel)
            for isa in ("scalar", "avx2", "avx512"):
                for prec in ("f32", "f64"):
                    peak = attrs.get(f"peak_gflops.{isa}.{prec}.threads:{threads}")
                    if peak is None or not math.isfinite(float(peak)) or not any(
                            r["isa"] == isa and r["precision"] == prec for r in sel):
                        continue
                    peak = float(peak)
                    ytop = max(ytop, peak)
                    ys = [min(peak, x * triad) if math.isfinite(triad) else peak for x in xs]
                    ax.plot(xs, ys, lw=1.2, ls=roof_style[isa], color=colors[prec],
                            label=f"roof {isa} {prec}: FMA peak {peak:.0f} GFLOP/s")
            if math.isfinite(triad):
                ax.plot(xs, [x * triad for x in xs], color="gray", ls="-.", lw=0.8,
                        label=f"triad{triad_note} {triad:.1f} GB/s x intensity")
            for r, x in zip(sel, ai):
                ax.scatter([x], [r["gflops"]], marker=markers.get(r["isa"], "D"),
                           color=colors.get(r["precision"], "gray"), s=28, alpha=0.85, zorder=3)
            # What the markers and colours mean (the points carry no label).
            for isa in ("scalar", "avx2", "avx512"):
                if any(r["isa"] == isa for r in sel):
                    ax.scatter([], [], marker=markers[isa], color="black", s=28,
                               label=f"rows {isa}")
            for prec in ("f32", "f64"):
                if any(r["precision"] == prec for r in sel):
                    ax.scatter([], [], marker="o", color=colors[prec], s=28, label=f"rows {prec}")
            ax.set_xscale("log")
            ax.set_yscale("log")
            # Plain numbers on the log axes (1, 2, 5, 10 rather than 2 x 10^0).
            from matplotlib.ticker import FormatStrFormatter
            for axis in (ax.xaxis, ax.yaxis):
                axis.set_major_formatter(FormatStrFormatter("%g"))
            # Minor labels only where the axis spans less than a decade and
            # a half (else they crowd).
            if hi / lo < 30:
                ax.xaxis.set_minor_formatter(FormatStrFormatter("%g"))
            ax.set_xlim(lo, hi)
            ax.set_ylim(min(r["gflops"] for r in sel) / 2, ytop * 1.6)
            ax.legend(fontsize=8, loc="lower right")
            ax.set_xlabel("arithmetic intensity (declared flops / declared bytes)", fontsize=10)
            ax.set_ylabel("achieved GFLOP/s (declared flops / median time)", fontsize=10)
            ax.set_title(f"{len(sel)} rows that declare flops and bytes", fontsize=10)
            ax.grid(True, which="both", alpha=0.25)
        # Achieved bandwidth per row against the triad.
        axb.barh(range(len(bw)), [r["gbs"] for r in bw],
                 color=[colors.get(r["precision"], "gray") for r in bw])
        axb.set_yticks(range(len(bw)), names, fontsize=8)
        axb.set_ylim(len(bw) - 0.5, -0.5)
        xmax = max([r["gbs"] for r in bw] + ([triad] if math.isfinite(triad) else []))
        axb.set_xlim(0, xmax * 1.12)
        if math.isfinite(triad):
            axb.axvline(triad, color="black", ls="--", lw=0.8,
                        label=f"triad{triad_note} {triad:.1f} GB/s")
        from matplotlib.patches import Patch
        handles, _ = axb.get_legend_handles_labels()
        handles += [Patch(color=colors[prec], label=prec) for prec in ("f32", "f64")
                    if any(r["precision"] == prec for r in bw)]
        axb.legend(handles=handles, fontsize=8, loc="lower right")
        axb.set_xlabel("achieved GB/s (declared bytes / median time)", fontsize=10)
        axb.set_title(f"{group}/...: {len(bw)} rows" + ("" if sel else " (none declares flops)"),
                      fontsize=10)
        axb.grid(True, axis="x", alpha=0.25)
        fig.suptitle(f"roofline: {group}, {threads} thread{'s' if threads > 1 else ''} "
                     f"({attrs.get('cpu_model', '?')}, git {str(attrs.get('git_revision', '?'))[:10]})",
                     fontsize=11)
        fig.tight_layout()
        out = os.path.join(outdir, "roofline_" + group.replace("/", "_") + ".png")
        fig.savefig(out, dpi=110)
        plt.close(fig)
        outs.append(out)
    return outs


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", metavar="[TRADEOFF.h5] OUTDIR",
                    help="HDF5 file of ek-bench --suite tradeoff (may be left out with "
                    "--bench: rooflines only), and the folder for the PNG files (created)")
    ap.add_argument("--bench", help="HDF5 file of the default suite, for the rooflines")
    ap.add_argument("--threads", type=int, help="thread count to plot (default: the most)")
    args = ap.parse_args()
    try:
        import h5py  # noqa: F401
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        fail(f"needs h5py and matplotlib ({e}); ./quickstart.sh test installs them into "
             "build/venv (build/venv/bin/python tools/plot_tradeoff.py ...)")
    if len(args.files) > 2 or (len(args.files) == 1 and not args.bench):
        ap.error("expected TRADEOFF.h5 OUTDIR, or OUTDIR with --bench")
    args.tradeoff = args.files[0] if len(args.files) == 2 else None
    args.outdir = args.files[-1]
    families, meta = {}, {}
    if args.tradeoff:
        f = open_h5(args.tradeoff, "a tradeoff file (ek-bench --suite tradeoff)", "tradeoff")
        meta = {k: text(v) for k, v in f.attrs.items()}
        families = read_points(f, args.tradeoff)
        f.close()
    os.makedirs(args.outdir, exist_ok=True)
    written = []
    for family, points in sorted(families.items()):
        threads = args.threads or max(p["threads"] for p in points)
        out = plot_family(plt, family, points, threads, args.outdir, meta)
        if out:
            written.append(out)
    if args.bench:
        written += roofline(plt, args.bench, args.outdir, args.threads)
    if not written:
        fail("nothing to plot (no points at that thread count)")
    for w in written:
        print(w)


if __name__ == "__main__":
    main()
