#!/usr/bin/python3
"""The energy each particle/grid round trip loses, per step (docs/validation.md, section 9, "Time
step"): an elastic block in free space (2D, no gravity, no colliders) given one smooth standing
compression mode, its energy followed step by step at several elastic_cfl values, transfers and
wavelengths. Made on commit 9d7ef30; docs/experiments/README.md has the numbers.

usage: PYTHONPATH=BUILD/python OMP_NUM_THREADS=1 /usr/bin/python3 docs/experiments/transfer_loss.py [PART ...]
  BUILD: a build of the library with its Python package (e.g. cmake -DSM_DOUBLE=ON: double, so that
  rounding does not confound); SANDMPM_LIBRARY may name the library instead.
  PART: modes | frozen | edges | affine | probe | scenes (default: all but scenes)

The block: L x 4 cells (L = 8, 16, 32), particles on the regular 2 x 2 lattice of ppc 4 (cell
quarter points, no jitter), quadratic kernel, dx = 0.01 m, density 1000, E = 1e5, nu = 0 (so the 1D
mode is exact in a free 2D block: no Poisson coupling to the free top and bottom; c = 10 m/s),
velocity v_x = A cos(n pi (x - x0) / L), A = 1e-3 m/s, undeformed, B = 0 (the API cannot set B;
the first step is then a PIC step, a one-off transient that the fits leave out, see `affine`).
cos, not sin: the free-free bar's modes are cos (zero strain at the free ends) and sin(pi x / L)
also carries net momentum. k dx = n pi / L.

modes   the fundamental (n = 1) for L = 8, 16, 32; apic, pic, flip (flip_ratio 0.95);
        elastic_cfl 0.5, 0.25, 0.125, 0.0625; T_END = 0.64 s for all (10, 20, 40 periods of L = 32, 16,
        8). Energy: the leapfrog energy H_n = 1/2 sum m v^n . v^(n+1) + 1/2 sum m B^n : B^(n+1) / D
        + sum V0 psi(F^n) (v^n, B^n, F^n the particle state after step n; D = dx^2/4; the affine
        part is APIC's share of the kinetic energy, 0 for PIC and FLIP), the quantity symplectic
        Euler keeps: with APIC and FLIP the plain kinetic + elastic energy of sm_diagnostics swings
        by about +-omega dt / 2 within a period (10% peak to peak at L = 16, elastic_cfl 0.5) and H
        by 100x less; with PIC the plain energy is the smooth one and H swings (5% at L = 32, 0.5).
        r: least-squares slope of -ln H_n over steps n >= 2 (up to the first H_n < 1e-4 H_0: PIC's
        short modes are gone within the run, and below ~1e-6 H_0 a creeping, almost purely elastic
        remainder decays more slowly at the smallest steps); r2: the same over the second half of
        those steps (equal if the decay is one exponential); r_diag: the same fit of
        sm_diagnostics' kinetic + elastic energy. left: H at T_END / E0 (E0 = the initial kinetic
        energy); diag: sm_diagnostics' kinetic + elastic energy, mean over the last mode period,
        / E0. step1: that energy after the first step / E0 (with B = 0 a PIC step).
frozen  transfer only: the same blocks with E = 1e-6 Pa (no force worth the name) and dt = 1e-4 s
        fixed, 2000 steps (the block moves 2e-4 m, 0.02 dx): r is the loss of the kinetic energy
        per P2G + G2P round trip of a field that does not change but by the transfer (with APIC not
        one exponential: the field settles into what the round trip keeps, r2 << r).
edges   bulk against free ends: k dx = pi/8 as n = 1, 2, 4, 8 half-waves in L = 8, 16, 32, 64, and
        k dx = pi/16 as n = 1, 2, 4 in L = 16, 32, 64; apic and pic; frozen and elastic (cfl 0.5,
        0.125; T_END as modes).
affine  APIC keeps an affine velocity field: uniform translation (B = 0 is consistent) and rigid
        rotation about the block's centre (B = C D written into the library's B array through
        the pointer of sm_world_particles, which the API gives read-only: a test-only shortcut;
        and with B = 0 for comparison), elastic_cfl 0.5, 2000 steps.
probe   the loss of one round trip of the current state, measured on a copy: the world is copied
        (sm_world_save into memory, sm_world_load) and the copy takes one step of dt = 1e-12 s, in
        which forces, gravity and motion do nothing; what remains is P2G, the colliders' node
        velocities and G2P. The kinetic energy the copy loses, summed over probes every 10 steps
        and divided by the energy summed at the same steps, against the r fitted above.
scenes  the probe in scenes: the 2D collapse of the validation study (validation/scenes/
        collapse2d.lua, a = 2, n = 12, apic, elastic_cfl 0.5 .. 0.0625, probe every 5 steps) and the
        free elastic blocks (docs/experiments/dt_free_blocks.lua, model=elastic, apic 0.5 .. 0.125
        and pic 0.5, 0.125, probe every step); the probed losses (each standing for `every`
        steps) summed over the run against the energy the run loses (potential m g y + kinetic +
        elastic, start - end). In the collapse also without colliders: the particles (positions,
        velocities, B) copied into a world of the same grid without colliders (B through the same
        pointer as in `affine`), so that the base's and the back wall's share is left out.
"""
import math
import os
import sys
import time

import numpy as np

import sandmpm as sm
from sandmpm import ffi, lib

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
DX = 0.01
H_CELLS = 4
PAD = 8
RHO, YOUNG = 1000.0, 1e5
C_WAVE = math.sqrt(YOUNG / RHO)  # nu = 0: sqrt((lambda + 2 mu) / rho) = sqrt(E / rho)
AMP = 1e-3
T_END = 0.64
D_APIC = DX * DX / 4  # quadratic kernel


def ids_of(w):
    return w._array("id", (), np.dtype(np.uint32))


def block(transfer, L, cfl, young=YOUNG, nmode=1, velocity=None, threads=1):
    """A world with the L x H_CELLS block on the regular ppc-4 lattice; velocity(P) -> (n, 2)
    overrides the standing mode."""
    w = sm.World(dim=2, dx=DX, domain_min=(0, 0), domain_max=((L + 2 * PAD) * DX, (H_CELLS + 2 * PAD) * DX),
                 gravity=(0, 0), transfer=transfer, elastic_cfl=cfl, threads=threads)
    m = sm.Material.elastic(youngs_modulus=young, poisson_ratio=0.0, density=RHO)
    x0 = y0 = PAD * DX
    o = np.array([0.25, 0.75])
    xs = x0 + (np.arange(L)[:, None] + o[None, :]).ravel() * DX
    ys = y0 + (np.arange(H_CELLS)[:, None] + o[None, :]).ravel() * DX
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    P = np.c_[X.ravel(), Y.ravel()]
    if velocity is None:
        V = np.c_[AMP * np.cos(nmode * np.pi * (P[:, 0] - x0) / (L * DX)), np.zeros(len(P))]
    else:
        V = velocity(P)
    w.add_particles(P, m, V, ppc=4)
    return w, P, V


def state(w):
    """v, B in id order (copies), elastic and kinetic energy of sm_diagnostics."""
    ids = ids_of(w)
    v = np.empty(w.velocities.shape)
    v[ids] = w.velocities
    B = np.empty(w.B.shape)
    B[ids] = w.B
    d = w.diagnostics()
    return v, B, d["elastic_energy"], d["kinetic_energy"]


def fit_rate(E, n0=2, floor=1e-4):
    """Least-squares slope of -ln E[n] over n >= n0 up to the first E < floor E[0] (see the module
    doc), and the same over the second half of those steps."""
    n = np.arange(len(E))
    below = np.nonzero(E < floor * E[0])[0]
    ok = (n >= n0) & (n < (below[0] if len(below) else len(E)))
    nn, ee = n[ok], np.log(E[ok])

    def slope(a, b):
        return -np.polyfit(a, b, 1)[0] if len(a) > 2 else float("nan")

    h = len(nn) // 2
    return slope(nn, ee), slope(nn[h:], ee[h:])


def run_mode(transfer, L, cfl, nmode=1, t_end=T_END):
    """Elastic standing mode; returns a dict of the measures (see the module doc)."""
    w, P, V = block(transfer, L, cfl, nmode=nmode)
    mp = w.masses()[0]
    dt = w.next_dt()
    N = int(round(t_end / dt))
    E0 = 0.5 * mp * np.sum(V * V)
    vp, Bp, pep, _ = state(w)
    Hs = [E0]
    raw = [E0]
    vymax = 0.0
    t0 = time.process_time()
    for _ in range(N):
        w.step(dt)
        v, B, pe, ke = state(w)
        Hs.append(0.5 * mp * np.sum(vp * v) + 0.5 * mp * np.sum(Bp * B) / D_APIC + pep)
        raw.append(ke + pe)
        vymax = max(vymax, float(np.abs(v[:, 1]).max()))
        vp, Bp, pep = v, B, pe
    cpu = time.process_time() - t0
    w.close()
    Hs, raw = np.array(Hs), np.array(raw)
    r, r2 = fit_rate(Hs)
    r_diag, _ = fit_rate(raw)
    period = 2 * L * DX / nmode / C_WAVE
    last = max(1, int(round(period / dt)))
    return dict(transfer=transfer, L=L, n=nmode, kdx=nmode * math.pi / L, cfl=cfl, dt=dt, steps=N, r=r, r2=r2, r_diag=r_diag,
                left=Hs[-1] / E0, diag=raw[-last:].mean() / E0, step1=raw[1] / E0, vy=vymax / AMP, cpu=cpu)


def run_frozen(transfer, L, nmode=1, steps=2000, dt=1e-4):
    """Transfer only: E = 1e-6 Pa, fixed dt; kinetic (+ APIC affine) energy per step."""
    w, P, V = block(transfer, L, 0.5, young=1e-6, nmode=nmode)
    mp = w.masses()[0]
    E0 = 0.5 * mp * np.sum(V * V)
    K = [E0]
    Ka = [E0]
    for _ in range(steps):
        w.step(dt)
        v, B, pe, ke = state(w)
        K.append(ke)
        Ka.append(ke + 0.5 * mp * np.sum(B * B) / D_APIC)
    w.close()
    K, Ka = np.array(K), np.array(Ka)
    r, r2 = fit_rate(K)
    ra, _ = fit_rate(Ka)
    return dict(transfer=transfer, L=L, n=nmode, kdx=nmode * math.pi / L, r=r, r2=r2, ra=ra, step1=K[1] / E0,
                left=K[-1] / E0)


def exponent(rows, key="r"):
    k = np.array([q["kdx"] for q in rows])
    r = np.array([q[key] for q in rows])
    return np.polyfit(np.log(k), np.log(r), 1)[0]


def part_modes():
    print("== modes: elastic fundamental mode, T_END = %g s ==" % T_END, flush=True)
    print("transfer L  kdx     cfl     steps  r(per step)  r2(2nd half) r_diag       r/r(cfl 0.5) left      diag      "
          "step1     max|vy|/A  cpu s")
    res = {}
    for transfer in ("apic", "pic", "flip"):
        for L in (8, 16, 32):
            for cfl in (0.5, 0.25, 0.125, 0.0625):
                q = run_mode(transfer, L, cfl)
                res[(transfer, L, cfl)] = q
                ref = res[(transfer, L, 0.5)]["r"]
                print("%-8s %-2d %.4f  %-7g %-6d %.4e   %.4e   %.4e   %.3f        %.3e %.3e %.6f  %.1e    %.1f" %
                      (transfer, L, q["kdx"], cfl, q["steps"], q["r"], q["r2"], q["r_diag"], q["r"] / ref, q["left"],
                       q["diag"],
                       q["step1"], q["vy"], q["cpu"]), flush=True)
    print("exponent of r against k dx (L = 8, 16, 32):")
    for transfer in ("apic", "pic", "flip"):
        s = []
        for cfl in (0.5, 0.25, 0.125, 0.0625):
            rows = [res[(transfer, L, cfl)] for L in (8, 16, 32)]
            s.append("cfl %g: %.2f (8-16: %.2f, 16-32: %.2f)" % (
                cfl, exponent(rows), exponent(rows[:2]), exponent(rows[1:])))
        print("  %-5s " % transfer + "; ".join(s))
    return res


def part_frozen():
    print("== frozen: transfer only (E = 1e-6 Pa, dt = 1e-4 s, 2000 steps) ==", flush=True)
    print("transfer L  kdx     r(kinetic)  r2          r(kin+affine) step1     left")
    res = {}
    for transfer in ("apic", "pic", "flip"):
        for L in (8, 16, 32):
            q = run_frozen(transfer, L)
            res[(transfer, L)] = q
            print("%-8s %-2d %.4f  %.4e  %.4e  %.4e    %.6f  %.6f" %
                  (transfer, L, q["kdx"], q["r"], q["r2"], q["ra"], q["step1"], q["left"]), flush=True)
    for transfer in ("apic", "pic", "flip"):
        rows = [res[(transfer, L)] for L in (8, 16, 32)]
        print("  exponent %-5s %.2f (8-16: %.2f, 16-32: %.2f)" %
              (transfer, exponent(rows), exponent(rows[:2]), exponent(rows[1:])))
    return res


def part_edges():
    print("== edges: the same k dx in longer blocks (n half-waves) ==", flush=True)
    print("transfer kdx     L   n  frozen r    frozen r2   elastic r cfl 0.5  elastic r cfl 0.125")
    res = {}
    for transfer in ("apic", "pic"):
        for base in (8, 16):
            for n in ((1, 2, 4, 8) if base == 8 else (1, 2, 4)):
                L = base * n
                fz = run_frozen(transfer, L, nmode=n)
                e1 = run_mode(transfer, L, 0.5, nmode=n)
                e2 = run_mode(transfer, L, 0.125, nmode=n)
                res[(transfer, base, n)] = (fz, e1, e2)
                print("%-8s pi/%-3d  %-3d %d  %.4e  %.4e  %.4e         %.4e" %
                      (transfer, base, L, n, fz["r"], fz["r2"], e1["r"], e2["r"]), flush=True)
    return res


def set_B(w, Bfun):
    """Writes B into the library's array through the read-only view's pointer (test-only)."""
    view = ffi.new("sm_particles_view *")
    lib.sm_world_particles(w._w, view)
    n = view.n
    Bp = ffi.cast("sm_real *", view.B)
    x = np.frombuffer(ffi.buffer(view.x, n * 2 * 8), dtype=np.float64).reshape(n, 2)
    Bv = np.frombuffer(ffi.buffer(Bp, n * 4 * np.dtype(sm.real_dtype).itemsize), dtype=sm.real_dtype).reshape(n, 2, 2)
    Bv[:] = Bfun(x)
    w._views.retire()


def part_affine():
    print("== affine: APIC, elastic_cfl 0.5, 2000 steps ==", flush=True)
    L = 16
    cx, cy = (PAD + L / 2) * DX, (PAD + H_CELLS / 2) * DX

    def rot(omega):
        return lambda P: np.c_[-omega * (P[:, 1] - cy), omega * (P[:, 0] - cx)]

    def rotB(omega):
        return lambda x: np.tile(np.array([[0, -omega], [omega, 0]]) * D_APIC, (len(x), 1, 1))

    cases = [("translation (3e-3, 1e-3) m/s, B = 0", lambda P: np.tile([3e-3, 1e-3], (len(P), 1)), None)]
    for omega in (0.02, 0.2):
        cases.append(("rotation %g rad/s, B = C D" % omega, rot(omega), rotB(omega)))
    cases.append(("rotation 0.02 rad/s, B = 0", rot(0.02), None))
    for name, vel, Bfun in cases:
        w, P, V = block("apic", L, 0.5, velocity=vel)
        if Bfun is not None:
            set_B(w, Bfun)
        mp = w.masses()[0]
        dt = w.next_dt()
        v0, B0, pe0, ke0 = state(w)

        def energy(v, B, pe):  # kinetic (particles + APIC affine part) + elastic
            return 0.5 * mp * np.sum(v * v) + 0.5 * mp * np.sum(B * B) / D_APIC + pe

        E0 = energy(v0, B0, pe0)
        L0 = w.diagnostics()["angular_momentum"][2]
        w.step(dt)
        v1, B1, pe1, _ = state(w)
        E1 = energy(v1, B1, pe1)
        scale = np.abs(v0).max()
        dv1 = np.abs(v1 - v0).max() / scale
        dB1 = np.abs(B1 - B0).max() / (scale * DX)  # B ~ C dx^2 / 4 ~ v dx
        worst = 0.0
        for _ in range(1999):
            w.step(dt)
            v, B, pe, ke = state(w)
            worst = max(worst, abs(energy(v, B, pe) / E1 - 1))
        L1 = w.diagnostics()["angular_momentum"][2]
        print("%-36s step 1: max|dv|/max|v| %.1e, max|dB|/(max|v| dx) %.1e, E1/E0 - 1 = %.1e; steps 2..2000: "
              "max |E/E1 - 1| %.1e (E: kinetic + APIC affine + elastic); angular momentum %.6e -> %.6e" %
              (name, dv1, dB1, E1 / E0 - 1, worst, L0, L1), flush=True)
        w.close()


def load_clone(w):
    """A copy of world w (sm_world_save into memory, sm_world_load), as a sandmpm.World."""
    chunks = []

    @ffi.callback("int(void *, const void *, size_t)")
    def write(user, data, n):
        chunks.append(bytes(ffi.buffer(data, n)))
        return 0

    if lib.sm_world_save(w._w, write, ffi.NULL) != lib.SM_OK:
        raise RuntimeError("sm_world_save failed")
    blob = b"".join(chunks)
    out = ffi.new("sm_world **")
    err = ffi.new("char[512]")
    if lib.sm_world_load(blob, len(blob), out, err, 512) != lib.SM_OK:
        raise RuntimeError(ffi.string(err).decode())
    from sandmpm.world import ViewTracker, _Native  # the binding's own owner of a world pointer

    c = sm.World.__new__(sm.World)
    c._native = _Native(out[0])
    c._views = ViewTracker(c._native)
    c._materials, c._motions, c.dim = {}, [], w.dim
    return c


PROBE_DT = 1e-12


def probe_loss(w):
    """Kinetic energy one round trip takes from w's current state: a copy steps PROBE_DT (forces,
    gravity and motion do nothing in it; P2G, the colliders' node velocities and G2P remain)."""
    c = load_clone(w)
    k0 = c.diagnostics()["kinetic_energy"]
    c.step(PROBE_DT)
    k1 = c.diagnostics()["kinetic_energy"]
    c.close()
    return k0 - k1


def probe_loss_bare(w, material):
    """The same without colliders: w's particles (positions, velocities, APIC B; undeformed, which
    does not matter over PROBE_DT) in a world of the same grid and transfer and no colliders."""
    d = w.definition
    b = sm.World(dim=w.dim, dx=d["dx"], domain_min=d["domain_min"], domain_max=d["domain_max"], gravity=(0, 0, 0),
                 transfer=d["transfer"], kernel=d["kernel"], elastic_cfl=d["elastic_cfl"], threads=1)
    ids = ids_of(w)
    n = len(ids)
    x = np.empty((n, w.dim))
    x[ids] = w.positions
    v = np.empty((n, w.dim))
    v[ids] = w.velocities
    B = np.empty((n, w.dim, w.dim))
    B[ids] = w.B
    b.add_particles(x, material, v, ppc=PPC_SCENE)
    assert np.allclose(np.sort(b.masses()), np.sort(w.masses()), rtol=1e-12)
    set_B(b, lambda xb: B)  # add_particles keeps id order, and nothing has reordered them yet
    k0 = b.diagnostics()["kinetic_energy"]
    b.step(PROBE_DT)
    k1 = b.diagnostics()["kinetic_energy"]
    b.close()
    return k0 - k1


def part_probe():
    print("== probe: the loss of one round trip of the current state against the measured decay ==", flush=True)
    print("(elastic mode; from step 200 to 1200, a probe every 10 steps; loss / E summed over the probes)")
    for transfer, L, n, cfl in (("apic", 8, 1, 0.5), ("apic", 32, 1, 0.5), ("apic", 64, 8, 0.5),
                                ("apic", 64, 8, 0.125), ("pic", 32, 1, 0.5), ("flip", 32, 1, 0.5)):
        w, P, V = block(transfer, L, cfl, nmode=n)
        dt = w.next_dt()
        loss = E = 0.0
        for s in range(1200):
            if s >= 200 and s % 10 == 0:
                d = w.diagnostics()
                loss += probe_loss(w)
                E += d["kinetic_energy"] + d["elastic_energy"]
            w.step(dt)
        w.close()
        r = run_mode(transfer, L, cfl, nmode=n)["r"]
        print("%-5s L %-2d n %d k dx %.4f cfl %-6g probe loss / E per step %.3e, fitted r %.3e (probe / r %.2f)" %
              (transfer, L, n, n * math.pi / L, cfl, loss / E, r, loss / E / r), flush=True)


PPC_SCENE = 4  # both scenes' particles per cell


def part_scenes():
    print("== scenes: the per-step loss of each state, probed every `every` steps, summed over the run's steps, "
          "against the energy the run loses ==", flush=True)
    sand = sm.Material.sand(hardening=False, friction_angle=30)  # density 2200 as both scenes; stress unused
    cases = [("2D collapse a = 2, n = 12", os.path.join(ROOT, "validation", "scenes", "collapse2d.lua"),
              dict(a=2, n=12), "apic", (0.5, 0.25, 0.125, 0.0625), 5),
             ("free elastic blocks", os.path.join(ROOT, "docs", "experiments", "dt_free_blocks.lua"),
              dict(model="elastic"), "apic", (0.5, 0.25, 0.125), 1),
             ("free elastic blocks", os.path.join(ROOT, "docs", "experiments", "dt_free_blocks.lua"),
              dict(model="elastic"), "pic", (0.5, 0.125), 1)]
    for label, scene, params, transfer, cfls, every in cases:
        for cfl in cfls:
            s = sm.load_scene(scene, threads=1, transfer=transfer, elastic_cfl=cfl, **params)
            w = s.world
            w.set_threads(1)
            g = -w.definition["gravity"][1]
            colliders = lib.sm_world_collider_count(w._w) > 0
            end = s.settings["frames"] / s.settings["fps"]

            def energy():
                d = w.diagnostics()
                pot = float(np.sum(w.masses() * g * w.positions[:, 1]))
                return pot + d["kinetic_energy"] + d["elastic_energy"], d["kinetic_energy"]

            E_start, _ = energy()
            steps = 0
            probes = []
            t0 = time.process_time()
            while w.time < end:
                if steps % every == 0:
                    _, k = energy()
                    probes.append((k, probe_loss(w), probe_loss_bare(w, sand) if colliders else 0.0))
                w.step(w.next_dt(end))
                steps += 1
            E_end, _ = energy()
            s.close()
            pr = np.array(probes)
            lost_all = float(np.sum(pr[:, 1]) * every)  # each probe stands for `every` steps
            lost_bare = float(np.sum(pr[:, 2]) * every)
            K_steps = float(np.sum(pr[:, 0]) * every)
            dis = E_start - E_end
            bare = (", without colliders %.4g J (%.1f%%)" % (lost_bare, 100 * lost_bare / dis)) if colliders else ""
            print("%s, %s, elastic_cfl %g, probe every %d: %d steps to %.3f s; energy %.4g -> %.4g J, lost %.4g J; probed loss "
                  "summed over the steps %.4g J (%.1f%% of the lost)%s; mean probed loss per step / kinetic "
                  "energy %.2e; cpu %.0f s" %
                  (label, transfer, cfl, every, steps, end, E_start, E_end, dis, lost_all, 100 * lost_all / dis, bare,
                   lost_all / K_steps, time.process_time() - t0), flush=True)


def main():
    parts = sys.argv[1:] or ["modes", "frozen", "edges", "affine", "probe"]
    print("sandmpm %s, %s, double=%s; threads 1" %
          (sm.__version__, sm.library_path, sm.real_is_double), flush=True)
    for p in parts:
        {"modes": part_modes, "frozen": part_frozen, "edges": part_edges, "affine": part_affine,
         "probe": part_probe, "scenes": part_scenes}[p]()


if __name__ == "__main__":
    main()
