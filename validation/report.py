#!/usr/bin/python3
"""Writes docs/validation.md and its plots (gnuplot, PNG) from out/validation/full/results.json
(validation/run.py). Every number in the document comes from that file; the prose around the
numbers is in this script. usage: report.py [--quick] [--out out/validation]
--quick reads out/validation/quick and writes out/validation/quick/validation.md (docs/ untouched).
"""
import argparse
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import deposit  # noqa: E402
import text  # noqa: E402

FITS = ["triaxial_compression", "plane_strain", "inscribed", "simple_shear"]
FIT_LABEL = {"triaxial_compression": "triaxial compression (thesis)", "plane_strain": "plane strain",
             "inscribed": "inscribed", "simple_shear": "simple shear"}


# Experimental laws (constants: see text.REFERENCES for where they come from)
def lube2005_runout(a):
    return 1.2 * a if a < 2.3 else 1.9 * a ** (2 / 3)


def lajeunesse2005_runout(a):
    return 1.8 * a if a < 3.0 else 2.3 * a ** (2 / 3)


def lube2004_runout(a):
    return 1.24 * a if a < 1.7 else 1.6 * a ** 0.5


def lube2005_height(a):
    # H/L0 = a while the top is intact (a <~ 1.15, the column's top survives), a^0.4 for large a
    return a if a < 1.0 else a ** 0.4


def fmt(x, nd=2):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    return f"{x:.{nd}f}"


def table(head, rows):
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def gnuplot(script, cwd):
    subprocess.run(["gnuplot"], input=script, text=True, cwd=cwd, check=True)


def collapse_rows(res, group, dim, fit, extra=None):
    rows = []
    for v in res["collapse"].values():
        s = v["sets"]
        if v["group"] != group or v["dim"] != dim or s.get("fit") != fit:
            continue
        if extra and any(s.get(k) != x for k, x in extra.items()):
            continue
        rows.append(v)
    return sorted(rows, key=lambda v: v["a"])


def deviation(rows, law):
    """RMS of log(sim/law) over a: how far a series is from an experimental law (0 = on it)."""
    d = [math.log(v["runout"] / law(v["a"])) for v in rows if v["runout"] > 0]
    return math.sqrt(sum(x * x for x in d) / len(d)) if d else float("nan")


def mean_ratio(rows, law):
    d = [math.log(v["runout"] / law(v["a"])) for v in rows if v["runout"] > 0]
    return math.exp(sum(d) / len(d)) if d else float("nan")


def fits_of(rows, split):
    small = [v for v in rows if v["a"] <= split]
    large = [v for v in rows if v["a"] > split]
    out = {}
    if len(small) >= 2:
        out["small"] = deposit.fit_power([v["a"] for v in small], [v["runout"] for v in small])
    if len(large) >= 2:
        out["large"] = deposit.fit_power([v["a"] for v in large], [v["runout"] for v in large])
        out["height"] = deposit.fit_power([v["a"] for v in large], [v["height"] for v in large])
    return out


def write_dat(path, rows, cols):
    with open(path, "w") as f:
        for r in rows:
            f.write(" ".join(f"{c(r):.6g}" for c in cols) + "\n")


def plot_collapse(res, dim, pdir):
    """runout and height vs a, every fit, log-log, with the experimental laws."""
    plots = []
    for fit in FITS:
        rows = collapse_rows(res, f"collapse{dim}d", dim, fit)
        write_dat(os.path.join(pdir, f"c{dim}_{fit}.dat"), rows,
                  [lambda v: v["a"], lambda v: v["runout"], lambda v: v["height"]])
        if rows:
            plots.append(fit)
    law1, law2 = ("lube2005", "lajeunesse2005") if dim == 2 else ("lube2004", "lajeunesse2004")
    if dim == 2:
        laws = ("(x<2.3 ? 1.2*x : 1.9*x**(2./3))", "(x<3.0 ? 1.8*x : 2.3*x**(2./3))")
        hlaw = "(x<1 ? x : x**0.4)"
        lab = ("Lube et al. 2005", "Lajeunesse et al. 2005", "(L_∞ - L_0)/L_0", "H_∞/L_0")
    else:
        laws = ("(x<1.7 ? 1.24*x : 1.6*x**0.5)", "(x<0.74 ? 1.0*x : 2.0*x**0.5)")
        hlaw = None
        lab = ("Lube et al. 2004", "Lajeunesse et al. 2004", "(R_∞ - R_0)/R_0", "H_∞/R_0")
    lawplot = f"{laws[0]} w l lw 2 lc rgb 'black' t '{lab[0]}'"
    if dim == 2:
        lawplot += f", {laws[1]} w l lw 2 dt 2 lc rgb 'black' t '{lab[1]}'"
    pts = ", ".join(f"'c{dim}_{f}.dat' u 1:2 w lp pt {7 + i} lc {i + 1} t '{FIT_LABEL[f]}'" for i, f in enumerate(plots))
    hpts = ", ".join(f"'c{dim}_{f}.dat' u 1:3 w lp pt {7 + i} lc {i + 1} t '{FIT_LABEL[f]}'" for i, f in enumerate(plots))
    href = f", {hlaw} w l lw 2 dt 1 lc rgb 'black' t 'Lube et al. 2005'" if hlaw else \
        ", 0.74 w l dt 2 lc rgb 'black' t 'saturation 0.74-0.9 (Lube 2004, Lajeunesse 2004)', 0.9 w l dt 2 lc rgb 'black' notitle"
    name = f"collapse{dim}d.png"
    gnuplot(f"""set terminal pngcairo size 900,380 font ',9'
set output '{name}'
set multiplot layout 1,2
set logscale xy
set xlabel 'a = H_0/{'L_0' if dim == 2 else 'R_0'}'
set key top left
set grid
set ylabel '{lab[2]}'
set xrange [0.4:10]
plot {lawplot}, {pts}
set ylabel '{lab[3]}'
set yrange [0.3:3]
plot {hpts}{href}
unset multiplot
""", pdir)
    _ = (law1, law2)
    return name


def plot_flow_time(res, pdir):
    rows = collapse_rows(res, "collapse2d", 2, FITS[0])
    rows3 = collapse_rows(res, "collapse3d", 3, FITS[0])
    write_dat(os.path.join(pdir, "tflow2.dat"), rows, [lambda v: v["tau"], lambda v: v["t_flow"], lambda v: v["a"]])
    write_dat(os.path.join(pdir, "tflow3.dat"), rows3, [lambda v: v["tau"], lambda v: v["t_flow"], lambda v: v["a"]])
    gnuplot("""set terminal pngcairo size 460,360 font ',9'
set output 'flow_duration.png'
set xlabel 'sqrt(H_0/g)  (s)'
set ylabel 'flow duration t_∞ (s)'
set key top left
set grid
plot 'tflow2.dat' u 1:2 w p pt 7 t '2D (thesis fit)', 'tflow3.dat' u 1:2 w p pt 5 t '3D (thesis fit)', 3*x w l lc rgb 'black' t '3 sqrt(H_0/g)'
""", pdir)
    return "flow_duration.png"


def plot_profiles(res, root, pdir):
    """Final deposit surfaces at a = 2 (2D), every fit."""
    cmds = []
    for i, fit in enumerate(FITS):
        name = f"c2_{fit}_a2"
        if name not in res["collapse"]:
            continue
        out = os.path.join(root, "runs", name)
        last = sorted(f for f in os.listdir(out) if f.endswith(".ply"))[-1]
        p = deposit.read_ply(os.path.join(out, last))
        v = res["collapse"][name]
        dx = 0.05 / v["n"]
        r, top = deposit.surface_profile(p, dx, v["ppc"])
        with open(os.path.join(pdir, f"prof_{fit}.dat"), "w") as f:
            for x, y in zip(r, top):
                if not math.isnan(y):
                    f.write(f"{x / 0.05:.5g} {y / 0.05:.5g}\n")
        cmds.append(f"'prof_{fit}.dat' w l lw 2 lc {i + 1} t '{FIT_LABEL[fit]}'")
    gnuplot(f"""set terminal pngcairo size 700,300 font ',9'
set output 'profiles2d.png'
set xlabel 'x / L_0'
set ylabel 'y / L_0'
set size ratio -1
set yrange [0:2.1]
set grid
set object 1 rect from 0,0 to 1,2 fs empty border lc rgb 'gray'
plot {', '.join(cmds)}
""", pdir)
    return "profiles2d.png"


def plot_column(res, pdir):
    rows = res.get("analytic", {}).get("column", [])
    if not rows:
        return None
    rows = [r for r in rows if r["walls"] == "shifted" and r.get("transfer", "apic") == "apic" and int(r.get("ppc", 4)) == 4]
    write_dat(os.path.join(pdir, "column.dat"), rows, [lambda r: r["dx"], lambda r: r["err_syy"], lambda r: r["err_ratio"],
                                                       lambda r: r["err_smooth"], lambda r: abs(r["err_mean"])])
    gnuplot("""set terminal pngcairo size 460,360 font ',9'
set output 'column.png'
set logscale xy
set xlabel 'dx / H'
set ylabel 'relative error'
set key bottom right
set grid
plot 'column.dat' u 1:2 w lp pt 7 t 'σ_yy in bins (RMS)', 'column.dat' u 1:4 w lp pt 9 t 'σ_yy smoothed (RMS)', \\
     'column.dat' u 1:5 w lp pt 11 t '|mean σ_yy|', 'column.dat' u 1:3 w lp pt 5 t 'σ_xx/σ_yy (RMS)', 2*x w l dt 2 lc rgb 'gray' t 'slope 1'
""", pdir)
    return "column.png"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default="out/validation")
    ap.add_argument("--draft", help="read DIR/results.json, write DIR/validation.md (for trying the text)")
    args = ap.parse_args()
    root = args.draft or os.path.join(args.out, "quick" if args.quick else "full")
    res = json.load(open(os.path.join(root, "results.json")))
    if args.quick or args.draft:
        doc, pdir, rel = os.path.join(root, "validation.md"), os.path.join(root, "plots"), "plots"
    else:
        doc, pdir, rel = "docs/validation.md", "docs/validation", "validation"
    os.makedirs(pdir, exist_ok=True)
    figs = {
        "c2": plot_collapse(res, 2, pdir),
        "c3": plot_collapse(res, 3, pdir),
        "tflow": plot_flow_time(res, pdir),
        "prof": plot_profiles(res, root, pdir),
        "column": plot_column(res, pdir),
    }
    for f in os.listdir(pdir):  # keep only the PNGs in docs/
        if not f.endswith(".png"):
            os.remove(os.path.join(pdir, f))
    ctx = dict(res=res, figs={k: f"{rel}/{v}" for k, v in figs.items() if v}, table=table, fmt=fmt,
               collapse_rows=collapse_rows, deviation=deviation, mean_ratio=mean_ratio, fits_of=fits_of,
               laws=dict(lube2005=lube2005_runout, lajeunesse2005=lajeunesse2005_runout, lube2004=lube2004_runout, lube2005_height=lube2005_height),
               FITS=FITS, FIT_LABEL=FIT_LABEL)
    md = text.document(ctx)
    with open(doc, "w") as f:
        f.write(md)
    print(f"report.py: wrote {doc} and {len([v for v in figs.values() if v])} plots in {pdir}")


if __name__ == "__main__":
    main()
