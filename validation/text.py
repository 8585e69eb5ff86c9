"""The text of docs/validation.md around the numbers (report.py fills them in from results.json).
Each section is a function of the results; nothing here holds a measured number."""
import math

from text_analytic import analytic

REFERENCES = """## References and where the constants come from

- Lube, Huppert, Sparks, Freundt 2005, *Collapses of two-dimensional granular columns*, Phys. Rev. E 72,
  041301: (L∞ − L0)/L0 ≈ 1.2 a for small a and ≈ 1.9 a^(2/3) beyond (the transition near a ≈ 1.8–2.8;
  2.3 is used here); H∞/L0 ≈ a^0.4 for large a. Below a ≈ 1 the top of the column survives and
  H∞ = H0; the plotted height law switches from a to a^0.4 at a = 1 (that break is this document's).
- Lajeunesse, Monnier, Homsy 2005, *Granular slumping on a horizontal surface*, Phys. Fluids 17,
  103302: (L∞ − L0)/L0 ≈ 1.8 a below a ≈ 3 and ≈ 2.3 a^(2/3) above.
- Balmforth, Kerswell 2005, *Granular collapse in two dimensions*, J. Fluid Mech. 538, 399: exponents
  only, with material-dependent prefactors: (l∞ − L)/L ∼ a^(0.9±0.1) and H/h∞ ∼ a^0.6 in wide
  channels; (l∞ − L)/L ∼ a^(0.65±0.05) and H/h∞ ∼ a^0.5 in narrow slots (the abstract).
- Lube, Huppert, Sparks, Hallworth 2004, *Axisymmetric collapses of granular columns*, J. Fluid Mech.
  508, 175: (R∞ − R0)/R0 ≈ 1.24 a for a ≲ 1.7 and ≈ 1.6 a^(1/2) beyond; H∞/R0 saturating near 0.74–0.9
  with Lajeunesse et al. 2004.
- Lajeunesse, Mangeney-Castelnau, Vilotte 2004, *Spreading of a granular mass on a horizontal plane*,
  Phys. Fluids 16, 2371: the final height saturating with a (quoted with Lube 2004's 0.74–0.9); its
  runout law is quoted inconsistently by the secondary sources seen here and is not used.

Balmforth & Kerswell's exponents were checked against the paper's abstract. The prefactors of Lube
2005, Lajeunesse 2005 (as collected in Lagrée, Staron & Popinet 2011, J. Fluid Mech. 686, 378,
Eq. 3.1) and Lube 2004 were checked against secondary sources quoting them, not
against the original papers (not available here): treat them as the commonly quoted values.
Experiments scatter by 10–30% between materials and set-ups around these laws.
"""


def provenance(r):
    """Which commits and machines made the runs (run.py records it per run)."""
    p = r.get("provenance")
    if not p:
        return "The commit and machine of the runs were not recorded."
    parts = [f"{n} at {k}" for k, n in sorted(p.items())]
    return "Runs: " + "; ".join(parts) + "."


def intro(c):
    r = c["res"]
    mode = "quick (coarse) subset" if r["quick"] else "full study"
    total = sum(v["wall_s"] for grp in ("collapse", "pile") for v in r.get(grp, {}).values())
    return f"""# Validation against experiments and analytic solutions

This document is written by `scripts/validate.sh` (validation/run.py runs and measures the
simulations, validation/report.py writes this file and the plots from out/validation/…/results.json):
every number and plot below is an output of that command; do not edit them by hand. This is the
{mode}: {len(r['collapse']) + len(r.get('pile', {}))} simulations, {total / 60:.0f} minutes of wall time added over the runs
(one thread per run, two runs at a time, on 2 cores shared with other work: the times in section 8
are not benchmarks). {provenance(r)} Scenes: `validation/scenes/` (collapse2d.lua, collapse3d.lua,
pile.lua, heap.lua), runnable by themselves with `sandmpm run SCENE --set KEY=VALUE`.

Sand everywhere: the thesis's Table 4.2 (ρ 2200 kg/m³, E 3.537e5 Pa, ν 0.3), a fixed friction angle
φ_F = 30° unless said otherwise, APIC, quadratic B-splines, explicit steps at the default CFL and
elastic-wave bounds, the default departures from the thesis on (static_friction_sticks,
particle_projection; README).

## Measuring a deposit

From a frame's PLY file (validation/deposit.py): s = dx / ppc^(1/d) is the particle spacing. The
deposit thickness in bins of width dx (2D: x from the back wall; 3D: annuli in r = √(x² + z²) of the
quarter) is the particles' current volume V0 Jᴱ per unit base length or area. The **front** (L∞ or
R∞) is found going outward: the last bin at least 0.75 s thick (a particle layer less a quarter, so
that a layer compacted a little, Jᴱ < 1, still counts), bridging single thinner bins, and within it
the farthest particle plus s/2; scattered particles beyond do not count.
The **height** H∞ is the highest particle inside the front plus s/2. At t = 0 these return L0 (R0)
and H0 to within the seeding jitter (s/2). The **flow duration** t∞ is the first frame time after
which the front stays within 2% of its final advance (frames every √(H0/g)/4). The **repose angle**
of a pile or heap is the slope of a least-squares line through the top surface (highest particle per
bin plus s/2) where it lies between 20% and 80% of the peak height.

The threshold decides whether a one-layer tongue at the front belongs to the deposit. Until
2026-12-03 it was s itself, which a one-layer bin reaches only when its particles are not
compacted (Jᴱ ≥ 1), so rounding decided it: the thesis-fit 2D collapse at a = 8 ran out 11.26 L0
in the float build and 12.52 L0 in the double build, whose deposits differ at the rounding level. Measured by hand on
this study's 2D thesis-fit runs (float) and reruns in the double build, (L∞ − L0)/L0 for a = 0.5,
1, 2, 3, 4, 6, 8: with 0.75 s (or 0.6 s) 0.49, 1.31, 3.65, 5.93, 7.67, 9.66, 12.52 in both builds;
with s (or 1.25 s) 0.43, 1.23, 3.26, 5.18, 5.93 (5.94 double), 8.27, and 11.26 / 12.52 at a = 8. So the
tongue is worth 0.06 to 1.7 L0, and the 2D runouts below are 10–30% longer than the document's
figures before that date.
"""


def collapse2d(c):
    res, T, fmt = c["res"], c["table"], c["fmt"]
    L = c["laws"]
    tc = c["collapse_rows"](res, "collapse2d", 2, c["FITS"][0])
    if not tc:
        return ""
    n = tc[0]["n"]
    rows = []
    for v in tc:
        rows.append([fmt(v["a"], 2), fmt(v["runout"]), fmt(L["lube2005"](v["a"])), fmt(L["lajeunesse2005"](v["a"])),
                     fmt(v["height"]), fmt(L["lube2005_height"](v["a"])), fmt(v["t_flow"] / v["tau"], 1)])
    fit = c["fits_of"](tc, 2.3)
    fit_rows = []
    for fname in c["FITS"]:
        fr = c["collapse_rows"](res, "collapse2d", 2, fname)
        f = c["fits_of"](fr, 2.3)
        if not f:
            continue
        s = f.get("small", (float("nan"),) * 2)
        lg = f.get("large", (float("nan"),) * 2)
        h = f.get("height", (float("nan"),) * 2)
        fit_rows.append([c["FIT_LABEL"][fname], f"{s[0]:.2f} a^{s[1]:.2f}", f"{lg[0]:.2f} a^{lg[1]:.2f}",
                         f"{h[0]:.2f} a^{h[1]:.2f}"])
    fit_rows.append(["Lube et al. 2005", "1.2 a^1", "1.9 a^0.67", "a^0.4"])
    fit_rows.append(["Lajeunesse et al. 2005", "1.8 a^1", "2.3 a^0.67", "–"])
    fit_rows.append(["Balmforth & Kerswell 2005 (slot / wide)", "–", "a^(0.65±0.05) / a^(0.9±0.1)", "a^0.5 / a^0.6 (as H0/H∞)"])
    _ = fit
    return f"""## 1. Granular column collapse in 2D (plane strain)

A column of length L0 = 5 cm and height H0 = a L0 against a slip (frictionless) back wall at x = 0,
on a sticky base, released at once; L0/dx = {n}, 4 particles per cell, φ_F = 30°, simulated for
5 √(H0/g) (8 for a < 1.5). The thesis's cone fit (triaxial compression):

{T(["a", "(L∞−L0)/L0", "Lube 2005", "Lajeunesse 2005", "H∞/L0", "Lube 2005", "t∞/√(H0/g)"], rows)}

![2D collapse: runout and height against a, every cone fit, with the experimental laws]({c['figs']['c2']})

Power laws fitted to the simulations (least squares in log–log; "small a": a ≤ 2.3, "large a": a > 2.3;
the height fit over a > 2.3):

{T(["series", "runout, small a", "runout, large a", "H∞/L0, large a"], fit_rows)}

Deposits at a = 2 (every fit; the grey box is the initial column):

![2D deposits at a = 2]({c['figs']['prof']})

Flow duration against √(H0/g); the line t = 3 √(H0/g) is drawn as the scale of the flow durations
commonly quoted for the experiments (not checked against the papers here):

![flow duration]({c['figs']['tflow']})
"""


def collapse3d(c):
    res, T, fmt = c["res"], c["table"], c["fmt"]
    L = c["laws"]
    tc = c["collapse_rows"](res, "collapse3d", 3, c["FITS"][0])
    if not tc:
        return ""
    n = tc[0]["n"]
    rows = []
    for fname in c["FITS"]:
        for v in c["collapse_rows"](res, "collapse3d", 3, fname):
            rows.append([c["FIT_LABEL"][fname], fmt(v["a"], 2), fmt(v["runout"]), fmt(L["lube2004"](v["a"])),
                         fmt(v["height"]), fmt(v["t_flow"] / v["tau"], 1)])
    return f"""## 2. Axisymmetric collapse in 3D

A cylinder of radius R0 = 5 cm and height H0 = a R0 on a sticky base; the quarter x, z ≥ 0 is
simulated with slip walls on the symmetry planes x = 0 and z = 0; R0/dx = {n}, 8 particles per cell,
φ_F = 30°.

{T(["cone fit", "a", "(R∞−R0)/R0", "Lube 2004", "H∞/R0", "t∞/√(H0/g)"], rows)}

The experiments' final height saturates near H∞/R0 ≈ 0.74–0.9 (Lube et al. 2004, Lajeunesse et al.
2004) for large a.

![3D collapse: runout and height against a, every cone fit, with the experimental laws]({c['figs']['c3']})
"""


def friction(c):
    res, T = c["res"], c["table"]
    sh = res.get("analytic", {}).get("shear", [])
    rows = []
    for r in sh:
        if r["phi"] in (20, 30, 40):
            rows.append([int(r["dim"]), c["FIT_LABEL"][r["fit"]], int(r["phi"]), f"{r['alpha']:.4f}", f"{r['mu_eff']:.4f}",
                         f"{r['angle_eff']:.1f}", f"{r['mu_sim']:.4f}"])
    piles = res.get("pile", {})
    prow = []
    for name, v in sorted(piles.items()):
        if v["group"] != "pile":
            continue
        s = v["sets"]
        dim = s.get("dim", 3)
        from_fit = next((r for r in sh if r["dim"] == dim and r["fit"] == s["fit"] and r["phi"] == s["phi"]), None)
        ae = from_fit["angle_eff"] if from_fit else float("nan")
        prow.append([dim, c["FIT_LABEL"][s["fit"]], s["phi"], s["n"], f"{ae:.1f}", f"{v['angle']:.1f}", f"{v['peak'] * 1000:.1f}"])
    return f"""## 3. What the friction angle means

The return mapping (Algorithm 2) projects onto the cone ‖dev τ‖ + α tr τ ≤ 0 along −dev ε: its plastic
flow is deviatoric (volume-preserving, non-associative), and α comes from φ_F by (3.80), the
Drucker–Prager cone through Mohr–Coulomb's compression meridian (triaxial compression, the
circumscribed cone in 3D). In 2D the code takes d = 2 traces: dev A = A − (tr A/2) I and the cone
constant d λ + 2 μ.

**Steady simple shear.** Shear at rate γ̇ on planes normal to y: v_x = γ̇ y, D = (γ̇/2)(e_x e_y + e_y e_x),
a trace-free rate. In a steady state the elastic strain does not change, so the plastic rate equals D
(up to the co-rotation of the small elastic strain, below). The plastic rate of case III is along
dev τ (the projection moves ε along −dev ε, and dev τ = 2μ dev ε), so dev τ ∥ D: the stress is
τ = −p I + t (e_x e_y + e_y e_x), with normal stresses all equal to −p, −tr τ = d p, and
‖dev τ‖ = √2 |t|. On the cone √2 t = d α p, so the stress ratio on the shear plane — the friction
coefficient that flowing sand shows — is

  μ_eff = t / p = τ_xy / (−τ_yy) = 3α/√2 in 3D,  √2 α in 2D,

whatever fit gave α. With (3.80), s = sin φ_F:

  3D: μ_eff = 2√3 s / (3 − s)  (30° → 0.693, atan 34.7°);  2D: μ_eff = (4/√3) s / (3 − s)  (30° → 0.462, atan 24.8°).

So the thesis's fit makes 3D sand flow like sand of friction angle 34.7° (stronger than φ_F: the
circumscribed cone is wider than Mohr–Coulomb everywhere but at triaxial compression) and 2D sand
like 24.8° (weaker: in 2D the cone is exactly Mohr–Coulomb in the plane, sin φ_2D = √2 α = 0.462 for
α(30°), i.e. φ_2D = 27.5°, and the flowing friction of a non-dilatant Mohr–Coulomb material in simple
shear is sin φ, not tan φ: the shear plane of a non-dilatant steady flow is the plane of maximum shear
stress, τ/σ = R/c = sin φ). The cone fits that `cone_fit` offers (sm_cone_fit, material.c):

| fit | α(φ) 3D | α(φ) 2D | μ_eff |
|---|---|---|---|
| triaxial compression (thesis, default) | √(2/3) 2s/(3 − s) | same | 3D 2√3 s/(3 − s), 2D (4/√3) s/(3 − s) |
| plane strain (Mohr–Coulomb in plane strain with this non-dilatant flow) | √2 s/3 | s/√2 | sin φ |
| inscribed (inside the Mohr–Coulomb pyramid) | √(2/3) s/√(3 + s²) | same | 3D √3 s/√(3 + s²), 2D (2/√3) s/√(3 + s²) |
| simple shear (flows at τ/σ = tan φ) | √2 tan φ/3 | tan φ/√2 | tan φ |

The "plane strain" fit makes the cone pass through Mohr–Coulomb where this flow rule puts plane
strain (s₂ = 0); "simple shear" makes φ_F the angle that a steadily flowing layer of the sand takes,
the usual meaning of a granular friction angle (μ = tan φ in μ(I) rheology) and of a (dynamic) repose
angle. The material key `repose_angle` (docs/scene-format.md) takes that angle θ and sets φ_F =
sm_friction_angle_for_effective_friction(tan θ, fit, dim), the inverse of the formulas above (tested
in tests/test_cone_fit.c for every fit and dimension, with NaN where a fit cannot reach a friction:
plane strain and inscribed cap μ_eff below 1 and 0.87).

**Check by simulation** — one material point sheared steadily with the step's own kinematics
(F ← (I + Δt ∇v) F, SVD, PROJECT; validation/mp_shear.h) at an elastic compression of 1e-3, to a shear
strain of 2 (`sm_validate shear`); μ_sim = τ_xy/(−τ_yy) at the end:

{T(["d", "fit", "φ_F", "α", "μ_eff (derived)", "atan μ_eff (°)", "μ_sim"], rows)}

μ_sim falls short of μ_eff by a fraction of the elastic shear strain: the finite-strain update
co-rotates the elastic strain, which turns the stress off the rate's axes by that order (at an
elastic compression of 1e-2 the shortfall is 2–6%, tests/test_cone_fit.c).

**Repose angle of poured piles** (pile.lua: a spout of half-width 4 mm, 4 cm above a sticky plate,
20 g/s in 3D (a quarter simulated) or 2 kg/(m s) in 2D, for 1 s at 0.5 m/s downward, then 0.4 s at
rest; dx = 6 mm / n):

{T(["d", "fit", "φ_F", "n", "atan μ_eff (°)", "flank angle (°)", "peak (mm)"], prow)}
"""


def which_fit(c):
    res, T = c["res"], c["table"]
    L = c["laws"]
    rows = []
    best = {}
    for dim, law_a, law_b in ((2, "lube2005", "lajeunesse2005"), (3, "lube2004", None)):
        for fname in c["FITS"]:
            fr = c["collapse_rows"](res, f"collapse{dim}d", dim, fname)
            fr = [v for v in fr if v["a"] in (0.5, 1, 2, 4, 8)]
            if not fr:
                continue
            da, ra = c["deviation"](fr, L[law_a]), c["mean_ratio"](fr, L[law_a])
            db = c["deviation"](fr, L[law_b]) if law_b else float("nan")
            rb = c["mean_ratio"](fr, L[law_b]) if law_b else float("nan")
            rows.append([f"{dim}D", c["FIT_LABEL"][fname], ", ".join(f"{v['a']:g}" for v in fr), f"{ra:.2f}", f"{da:.2f}",
                         c["fmt"](rb), c["fmt"](db)])
            key = da
            if dim not in best or key < best[dim][1]:
                best[dim] = (fname, key, da, db)
    sh = res.get("analytic", {}).get("shear", [])
    mu30 = lambda d, f: next((r["mu_eff"] for r in sh if r["dim"] == d and r["fit"] == f and r["phi"] == 30),  # noqa: E731
                             float("nan"))
    lines = [f"- {d}D: **{c['FIT_LABEL'][b[0]]}** (RMS log deviation {b[2]:.2f} from {'Lube 2005' if d == 2 else 'Lube 2004'};"
             f" μ_eff = {mu30(d, b[0]):.3f} at φ_F = 30°, the thesis's fit {mu30(d, c['FITS'][0]):.3f})"
             for d, b in sorted(best.items())]
    lines.append("\nWhat the collapses ask for is the flowing friction, not a particular fit: the best fits of "
                 "both dimensions give sand that flows at μ_eff ≈ " +
                 " and ".join(f"{mu30(d, b[0]):.2f} ({d}D)" for d, b in sorted(best.items())) +
                 " for φ_F = 30°. The material key `repose_angle` gives that friction directly, the same in 2D and "
                 "3D, whatever the fit; the default stays the thesis's fit (the thesis's scenes and results "
                 "depend on it).")
    return f"""## 4. Which cone fit matches the collapses

For each fit and dimension: the geometric-mean ratio of the simulated runout to each experimental
law over the aspect ratios listed, and the RMS of log(simulated / law) (0.1 ≈ 10% typical deviation);
the best fit is chosen by the deviation from Lube et al. (2005 in 2D, 2004 in 3D).

{T(["d", "fit", "a", "mean ratio to Lube", "RMS log dev.", "mean ratio to Lajeunesse", "RMS log dev."], rows)}

Closest to the experiments:

""" + "\n".join(lines) + "\n"


def base_condition(c):
    res, T, fmt = c["res"], c["table"], c["fmt"]
    rows = []
    for fname in (c["FITS"][0], c["FITS"][3]):
        sticky = {v["a"]: v for v in c["collapse_rows"](res, "collapse2d", 2, fname)}
        for v in c["collapse_rows"](res, "base2d", 2, fname):
            st = sticky.get(v["a"])
            rows.append([c["FIT_LABEL"][fname], fmt(v["a"], 2), fmt(st["runout"]) if st else "–", fmt(v["runout"]),
                         fmt(st["height"]) if st else "–", fmt(v["height"])])
    if not rows:
        return ""
    return f"""## 5. Sticky against frictional base

The thesis's ground is sticky (no slip). Experiments have rough or smooth bases with a basal friction
of their own. The same 2D collapses on a Coulomb base (`mode = "separate"`, μ = 0.5, about 26.6°):

{T(["fit", "a", "runout, sticky", "runout, μ = 0.5", "H∞/L0, sticky", "H∞/L0, μ = 0.5"], rows)}
"""


def pile_finding(c):
    res, T = c["res"], c["table"]
    piles = res.get("pile", {})
    rows = []
    for name, v in sorted(piles.items()):
        if v["group"] not in ("pilexp", "heap"):
            continue
        s = dict(v["sets"])
        rows.append([name, ", ".join(f"{k}={x}" for k, x in sorted(s.items())
                               if not (k == "fit" and x == "triaxial_compression")),
                     f"{v['angle']:.1f}", v["points"], f"{v['peak'] * 1000:.1f}", f"{v['front'] * 1000:.1f}"])
    ref3 = piles.get("pile3_triaxial_compression_phi30")
    ang = lambda k: piles[k]["angle"] if k in piles else float("nan")  # noqa: E731
    b3 = ang("pile3_triaxial_compression_phi30")
    pts = lambda k: piles[k]["points"] if k in piles else 0  # noqa: E731
    finding = f"""
The 3D piles here are small (dx 3 mm, a quarter pile of ~19 mm peak): their flank fits use only
{pts("pile3_triaxial_compression_phi30")}–{pts("pile3_exp_finer")} surface bins, so single 3D numbers carry a few degrees of
scatter; the 2D ones use 17–50 bins. What they say:

- **The pile stands below atan μ_eff in both dimensions**, with or without a stream: 2D poured piles
  (φ_F = 30°, thesis fit, μ_eff = 0.462, atan 24.8°) at {ang("pile2_exp_n2"):.1f}°, {ang("pile2_triaxial_compression_phi30"):.1f}°,
  {ang("pile2_exp_n6"):.1f}° for n = 2, 4, 6 — no trend with resolution in 2D; a 2D heap built at 45° and let go
  (no stream) at {ang("heap2_n4"):.1f}° and {ang("heap2_n8"):.1f}° (n = 4, 8), from 35° at {ang("heap2_slope35"):.1f}°. The flank
  fails, avalanches and stops below the angle at which it flowed: this rate-independent cone has no
  static friction above the dynamic one, and a layer decelerating on a slope below atan μ_eff keeps
  moving until its momentum is gone.
- **In 3D, the symmetry planes were part of it.** The quarter pile lies against two slip planes on
  grid lines (x = 0, z = 0), which until commit 0a862d6 did not hold the grid nodes on them (section
  6, the elastic column): that pile stood at 20.7° (the document at 0a862d6); with the planes holding
  their nodes it stands at {b3:.1f}°. One step finer (2 mm) {ang("pile3_exp_finer"):.1f}°; poured at 0.1 m/s from
  2.5 cm instead of 0.5 m/s from 4 cm {ang("pile3_exp_slow"):.1f}° (against 34.7° = atan μ_eff): a gentler
  stream stands steeper. Issue 13's 24° at dx 1.5 mm (the thesis's scene, implicit, full pile, before the fix)
  is below these.
- **Not particle projection**: without it the pile stands at {ang("pile3_exp_noproj"):.1f}° (2D heap
  {ang("heap2_noproj"):.1f}°). A Coulomb plate (μ = 0.7) instead of the sticky one: 3D
  {ang("pile3_exp_slipbase"):.1f}°, 2D heap {ang("heap2_friction"):.1f}° — the sticky plate, which catches arriving nodes,
  is not what flattens the pile.
- **Numerical dissipation raises it**: with PIC the heap stands at {ang("heap2_pic"):.1f}° and the 3D pile at
  {ang("pile3_exp_pic"):.1f}° — PIC's damping freezes the avalanches (and PIC's collapse at a = 2 runs out a third
  as far, section 8), so APIC's low dissipation is what lets the flank relax.
- With the simple-shear fit (μ_eff = tan 30°) the 2D pile stands at {ang("pile2_simple_shear_phi30"):.1f}° and the
  heap at {ang("heap2_ss"):.1f}°.

One bug was found on the pile's path and fixed: the slip planes of the quarter pile (above). Particle
projection does not move the angle, and the sticky plate does not flatten it. What is left is the
material: the flat pile and the steep collapse deposits are the same material seen on two paths: the
collapse is stopped while flowing at μ_eff (3D: 0.693 for φ_F = 30°, steep), the pile's flank is what is
left after avalanches that stop below it, in a flank resolved by few cells.
"""
    return f"""## 7. Why the poured pile is flatter than the input angle

Issue 13 measured a pile poured from a spout (3D, φ_F = 30°, sticky plate, 20 g/s at 0.5 m/s, dx 1.5 mm)
settling at about 24°, below φ_F and far below atan μ_eff = 34.7°, while collapse deposits stand too
steep. Targeted runs, one thing changed at a time (pile3_exp_*: 3D, thesis fit, φ_F = 30°, from the
3D pile of section 3{f', {ref3["angle"]:.1f}°' if ref3 else ''}; pile2_exp_n*: the 2D pile at two more
resolutions; heap2_*: a 2D wedge (heap.lua) built at 45° (or 35°) at rest and let go, no stream; n =
cells per 6 mm):

{T(["run", "parameters", "flank angle (°)", "bins in the fit", "peak (mm)", "front (mm)"], rows)}
""" + finding


def convergence(c):
    res, T, fmt = c["res"], c["table"], c["fmt"]
    rows = []
    for v in sorted((v for v in res["collapse"].values() if v["group"] in ("conv2d", "conv3d")),
                    key=lambda v: (v["dim"], str(sorted(v["sets"].items())))):
        s = v["sets"]
        what = ", ".join(f"{k}={x}" for k, x in sorted(s.items()) if k not in ("a", "fit"))
        rows.append([f"{v['dim']}D", what, fmt(v["runout"]), fmt(v["height"]), fmt(v["t_flow"] / v["tau"], 1),
                     f"{v['wall_s']:.0f}"])
    return f"""## 8. Convergence and numerical choices

One collapse (a = 2, thesis fit, φ_F = 30°, sticky base) at three resolutions (n = cells across L0 or
R0), with 16 instead of 4 particles per cell, the cubic kernel, PIC and FLIP (0.95) instead of APIC,
and each departure from the thesis switched off (projection = particle_projection,
sticks = static_friction_sticks):

{T(["d", "parameters", "runout", "height", "t∞/√(H0/g)", "wall s"], rows)}
"""


def _ratio(c, group, dim, fit, law, amin=0, amax=99):
    rows = [v for v in c["collapse_rows"](c["res"], group, dim, fit) if amin <= v["a"] <= amax]
    return c["mean_ratio"](rows, law) if rows else float("nan")


def honesty(c):
    L, F = c["laws"], c["FITS"]
    res = c["res"]
    pct = lambda r: f"{100 * (r - 1):+.0f}%"  # noqa: E731
    r2 = _ratio(c, "collapse2d", 2, F[0], L["lube2005"])
    r2s = _ratio(c, "collapse2d", 2, F[3], L["lube2005"])
    r3 = _ratio(c, "collapse3d", 3, F[0], L["lube2004"])
    r3s = _ratio(c, "collapse3d", 3, F[3], L["lube2004"])
    h3 = [v["height"] for v in c["collapse_rows"](res, "collapse3d", 3, F[0]) if v["a"] >= 2]
    h2 = [(v["a"], v["height"]) for v in c["collapse_rows"](res, "collapse2d", 2, F[0]) if v["a"] >= 3]
    h2r = math.exp(sum(math.log(h / L["lube2005_height"](a)) for a, h in h2) / len(h2)) if h2 else float("nan")
    bs = [(v, {w["a"]: w for w in c["collapse_rows"](res, "collapse2d", 2, v["sets"]["fit"])}.get(v["a"]))
          for v in res["collapse"].values() if v["group"] == "base2d"]
    bs = [(f, s) for f, s in bs if s]
    bchange = (math.exp(sum(math.log(f["runout"] / s["runout"]) for f, s in bs) / len(bs)) if bs else float("nan"))
    an = res.get("analytic", {})
    col = an.get("column", [])
    last = lambda w: next((r["ratio_mean"] for r in reversed(col) if r["walls"] == w and r.get("transfer", "apic") == "apic"  # noqa: E731
                           and int(r.get("ppc", 4)) == 4), float("nan"))
    col_on, col_sh = f"{last('on_grid_lines'):.3f}", f"{last('shifted'):.3f}"
    inc = [r for r in an.get("incline", []) if r["expected"] > 0]
    fr = [abs(r["rel_error"]) for r in inc if r["mu"] > 0]
    inc_worst = max(fr) if fr else float("nan")
    inc_n = len(fr)
    fz = [abs(r["rel_error"]) for r in inc if r["mu"] == 0]
    inc_free = max(fz) if fz else float("nan")
    fn = [abs(r["rel_error_normal"]) for r in inc if isinstance(r.get("rel_error_normal"), float)
          and r["rel_error_normal"] == r["rel_error_normal"]]
    inc_normal = max(fn) if fn else float("nan")
    return f"""## 9. Where the simulator differs from the experiments, and why

- **2D runout, thesis fit:** on average {pct(r2)} against Lube et al. 2005 over the aspect ratios run
  (geometric mean of simulated/law). Known reason: with d = 2 traces the thesis's α gives flowing
  friction μ_eff = √2 α = 0.462 (24.8°) for φ_F = 30°, weaker than the sand of the experiments (section
  3). With the simple-shear fit (μ_eff = tan 30°) the mean is {pct(r2s)}.
- **3D runout, thesis fit:** {pct(r3)} against Lube et al. 2004 (simple-shear fit: {pct(r3s)}). In 3D the
  thesis's cone flows at μ_eff = 0.693 (34.7°) for φ_F = 30°, stronger than its φ_F. Issue 13 found the
  runout 35–40% short at a = 1–2 (R0/dx = 10 and 16); see section 2 for the values at this resolution.
- **Final heights:** 2D, a ≥ 3: mean ratio to a^0.4 {h2r:.2f}; 3D, a ≥ 2: H∞/R0 =
  {", ".join(f"{h:.2f}" for h in h3) or "–"} against the experiments' 0.74–0.9.
- **Base:** a Coulomb base (μ = 0.5) instead of the sticky one changes the 2D runout by a factor
  {bchange:.2f} on average (section 5); the experiments' rough bases are closer to sticky for the grains
  that stop on them, but sliding over the base at the front is real in them and absent on a sticky
  base.
- **What the continuum model lacks:** no dilatancy (the flow rule keeps the volume; real sand dilates
  when it starts to flow and compacts when it stops), no rate dependence (Drucker–Prager is rate
  independent; granular friction grows with the inertial number I, μ(I)), no distinction between static
  and dynamic friction (real piles stand at a repose angle a few degrees steeper than the one they
  flow at), elasticity far softer than sand grains (E = 3.5e5 Pa: columns compress by ρ g H0 / E,
  2.4% at H0 = 40 cm), and grid resolution: a front one or two cells thick has no resolved pressure,
  so its thin layers spread further than a granular front (the front definition ignores layers
  thinner than one particle spacing).
- **Boundaries:** slip walls on grid lines now hold their nodes (section 6, the elastic column:
  σ_xx/σ_yy {col_on} with the walls on grid lines, {col_sh} with them moved by 1e-6 dx; exact 0.429;
  before the fix 0.086 on grid lines). Coulomb friction on
  the grid: the incline's friction cases are off by up to {inc_worst:.1%} of the expected acceleration
  ({inc_n} cases; the frictionless ones within {inc_free:.0e}); with the normal force the vibrating
  block had, within {inc_normal:.1e} (section 6, "the block's normal motion"). A block that should
  hold on a grid-aligned plane slides at a steady few cm/s instead (section 6).
- **Resolution:** runout and height still move with dx at these resolutions (section 8): the
  numbers above are for the resolutions stated, not converged values.
- **Time step:** at a fixed grid the deposit depends on the time step and does not settle as it
  shrinks. The 2D collapse at a = 2, n = 12 (section 8's reference) runs out 3.65, 3.15, 2.76, 2.41
  at elastic_cfl = 0.5 (the program's default until 2026-12-07; the runs above use 0.6), 0.25, 0.125, 0.0625 (3,580
  to 28,520 steps; heights 1.11, 1.13, 1.17, 1.23); at n = 24 4.04, 4.05, 3.92 at 0.5, 0.25, 0.125;
  with FLIP at n = 12 1.97, 1.73 at 0.5, 0.25; in 3D (n = 8) 1.41, 1.28 at 0.5, 0.25. Longer steps
  than 0.5 barely move it (3D n = 8: 1.41 at 0.5, 0.7 and 0.9; 2D n = 24: 4.04 at 0.5 and
  0.9; 2D n = 12: 3.65, 3.51, 3.93 at 0.5, 0.7, 0.9, this resolution's scatter): the loss sets in
  below 0.5. The explicit
  step is dt = elastic_cfl dx / c, so section 8's resolution rows change dx and dt together, and a
  stiffer E shortens dt and with it the runout. The same holds for a block dropped on the ground
  (scenes/youngs_modulus.lua, explicit, E = 1e6): its settled centre of mass rises from 0.0891 to
  0.0912 and 0.0939 m as elastic_cfl goes 0.5, 0.25, 0.125 (PIC 0.1176 and FLIP 0.1014 m at 0.5
  against 0.1377 and 0.1115 m at 0.125), and at elastic_cfl 0.5 from 0.0891 to 0.0946 and 0.0980 m
  as E goes 1e6, 1e7, 1e8. More steps, less spreading. Switching off particle_projection or
  static_friction_sticks leaves the trend (2D n = 12: 3.65, 3.15 and 3.60, 3.14 at 0.5, 0.25). A
  Coulomb base shows it in 3D too (μ = 0.5: 1.53, 1.41; μ = 2: 1.41, 1.28, as the sticky base, at
  0.5, 0.25), in 2D not clearly (μ = 0.5, n = 12: 3.37, 3.60, 3.27 at 0.5, 0.25, 0.125; n = 24: 4.05,
  4.05 at 0.5, 0.25). On a frictionless base (2D, n = 12) the front reaches the domain's end in
  every run, but the column left standing at the end is taller with more steps (height 0.93, 1.01,
  1.09 at 0.5, 0.25, 0.125), so the bulk flow slows with the step count too, not the base alone.
  Without any base (docs/experiments/dt_free_blocks.lua: two blocks meeting head-on at 1 m/s
  each, no gravity, E = 3.5e5) the energy left at 0.5 s, of 88 J, is at 0.5, 0.25, 0.125: sand
  8.1, 7.6, 6.5 J; elastic 61.4, 56.2, 49.3 J (PIC 39.0 and 26.6 J, FLIP 57.6 and 46.6 J at 0.5
  and 0.125). So the bulk loses more with more steps, plastic or not, and most with the most
  dissipative transfer. Measured by hand on commit 17ac394's program (Release; the collapses and
  the free blocks in float, with docs/experiments/collapse_dt.py and dt_free_blocks.lua; the
  dropped block in double), not by this document's runs. **The transfer's loss is per step**
  (docs/experiments/transfer_loss.py, commit 9d7ef30, double; an elastic block in free space
  started in one standing mode of wavenumber k): per step APIC loses a fraction r ≈ 0.024 (k dx)^4
  of the mode's energy (k dx = 0.39: 7.5e-4 at elastic_cfl 0.5, 5.2e-4 at 0.0625), PIC (k dx)^2/4,
  FLIP 0.95 between them (3.4e-3 at k dx = 0.39); with 8 times the steps r changes by a factor
  0.70–1.00 where a loss per second would give 0.125, so the energy lost per second grows 5.6–8
  times as the step shrinks. Summed over the steps of the free elastic blocks (APIC) it is 9.7,
  15.8, 24.9 J of the 26.6, 31.8, 38.7 J lost at 0.5, 0.25, 0.125: it accounts for the growth
  with the step count. In the 2D collapse (a = 2, n = 12) it is 0.28 to 0.61 J of the 3.5 to
  3.2 J dissipated (elastic_cfl 0.5 to 0.0625; plasticity dissipates the rest), so the energy
  alone does not say that it sets the runout. **A transfer without that loss removes most of
  the dependence**: pure FLIP (the collapse scenes' `flip_ratio=1`: no PIC share, so no per-step
  damping of the resolved motion) runs out 3.43, 3.49, 3.27, 3.01 at elastic_cfl 0.5, 0.25,
  0.125, 0.0625 (2D, n = 12; APIC 3.65, 3.15, 2.76, 2.41), 4.01 and 4.01 at n = 24 (0.5, 0.25),
  and in 3D (n = 8) 1.53 and 1.53 at 0.5 and 0.25 (APIC 1.41, 1.28); a PIC share of 1% per
  step (flip_ratio 0.99) brings it back (2D n = 12: 2.63, 2.34, 2.04). So the deposit's
  dependence on the step is mostly the transfers' per-step damping of the flow (pure FLIP keeps a
  12% drop over 8 times the steps on the sticky base, but on a Coulomb base, μ = 0.5, no trend
  beyond this resolution's scatter: 3.94, 3.98, 3.52, 4.10 at 0.5 to 0.0625; the sticky base's
  own per-step loss may be that rest), and the runout is very sensitive to it:
  1% PIC per step costs a quarter of the 2D runout. Part of the 3D shortfall is this damping:
  with pure FLIP the 3D runouts of section 2 (thesis fit, R0/dx = 8) are 0.40, 0.91, 1.53, 2.65 at
  a = 0.5, 1, 2, 4 (APIC 0.28, 0.78, 1.41, 2.40), −28% against Lube et al. 2004 instead of −40%
  (geometric means). Measured by hand on commit ffeb8c8's program
  (float, Release, docs/experiments/collapse_dt.py with flip_ratio=...). For users: at a coarse
  grid a max_dt far below the elastic limit costs spreading as well as time, and the PIC share of
  FLIP (flip_ratio below 1) is a strong damper.
"""


def document(c):
    parts = [intro(c), collapse2d(c), collapse3d(c), friction(c), which_fit(c), base_condition(c), analytic(c),
             pile_finding(c), convergence(c), honesty(c), REFERENCES]
    return "\n".join(p for p in parts if p)
