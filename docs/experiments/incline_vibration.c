/* EXPERIMENT (not built; made on commit 70303ae, 2026-12-07): why the static block slides on the
 * grid-aligned plane (docs/validation.md section 6, "the static rows hide a slide"). sm_validate
 * incline's 2D block (validation/analytic.c, incline_run, aligned set-up, the table's geometry with
 * EXTRA 2.6) stepped by hand, printing per frame: displacement along the slope, the slope and normal
 * velocity of the centre of mass, the rotation rate and the kinetic energy of the motion relative to
 * the centre of mass ("Eint", the block's vibration).
 *   gcc -O2 -std=c11 -fopenmp -I include -I build-fric -I build-fric/include \
 *       docs/experiments/incline_vibration.c build-fric/libsandmpm.a -lm -o /tmp/incline_vibration
 *   /tmp/incline_vibration THETA MU MAX_DT OFFSET EXTRA TRANSFER T_END [DUMP_T [MODE]]
 *     (TRANSFER 0 APIC, 1 PIC, 2 FLIP; MODE 1 slip, 2 separate (default); OFFSET in cells as in
 *      incline_window.c; DUMP_T: print every contact node and the bottom particles at that step)
 * Environment: FRAME (s, default 0.05), QUIET=1 (no per-row grid table), TILTED=1 (the plane turned in
 * the grid instead), DX, PPC, LIFT (release height in cells, default 0.25), FLIPR, ECFL, GEOM=1 (the
 * block's extent and height above the plane), LAYERS=1, ROWLINE=1 (contact statistics per frame),
 * KICK_T/KICK_W/KICK_VY (add a rotation and a normal velocity at that time), FREEZE_T (zero v and B),
 * MU_T/MU2 (change the collider's friction at that time; casts away sm_world_collider_def's const).
 * The per-node grid statistics (QUIET unset, ROWLINE, DUMP_T) need the library built with
 * incline_vibration_hook.patch (a node hook in src/collide/grid_collide_dim.c; DBGMODE=1 also makes
 * v-bar = v-tilde at every contact node, DBGMODE=2 counts only the compressive part of a contact's
 * normal impulse in its Coulomb limit) and this file compiled with -DHOOK; without them those rows
 * stay empty. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "sandmpm/sandmpm.h"
typedef void (*sm_dbg_node_fn)(int dim, const double xi[3], double m, const double vstar[3], const double vcol[3],
                               const sm_real *vbar, const sm_real *vtilde, int count, int sticky);
#ifdef HOOK
extern sm_dbg_node_fn sm_dbg_node_hook;
extern int sm_dbg_mode;
#endif
static const double PI = 3.14159265358979323846, G = 9.81;
static double DX = 0.01, Y0 = 0.2;
enum { NR = 8, R0 = -2 }; /* rows j - jplane from -2 to 5 */
typedef struct { double n, m, pstar, pcol, pbar, ptil, Jn, Jt, stuck, slip, freen, contact, Jn_stuck, Jn_slip, Jt_slip, pfree, vnpos_in; } rowacc;
static rowacc acc[NR];
static int dump = 0;
static double Dfric = 0, Dproj = 0;
static void hook(int dim, const double xi[3], double m, const double vs[3], const double vc[3], const sm_real *vb,
                 const sm_real *vt, int count, int sticky) {
    (void)dim; (void)sticky;
    { double a2 = 0, b2 = 0, c2 = 0; for (int q = 0; q < 2; q++) a2 += vs[q]*vs[q], b2 += vc[q]*vc[q], c2 += (double)vt[q]*(double)vt[q];
      Dproj += 0.5 * m * (a2 - b2); Dfric += 0.5 * m * (b2 - c2); }
    double r = (xi[1] - Y0) / DX;
    int j = (int)floor(r + 0.5) ;
    if (xi[0] < 0.5) return; /* skip anything far (none) */
    int k = j - R0;
    if (k < 0 || k >= NR) return;
    rowacc *a = &acc[k];
    a->n++;
    a->m += m;
    a->pstar += m * vs[0];
    a->pcol += m * vc[0];
    a->pbar += m * vb[0];
    a->ptil += m * vt[0];
    if (count > 0) {
        a->contact++;
        double jn = m * (vc[1] - vs[1]), jt = m * (vt[0] - vc[0]);
        a->Jn += jn;
        a->Jt += jt;
        int stuck = vt[0] == 0.0;
        if (stuck) a->stuck++, a->Jn_stuck += jn;
        else a->slip++, a->Jn_slip += jn, a->Jt_slip += jt;
        if (dump) printf("  node x=%.3f j=%d m=%.4e v*=(%.5f,%.5f) dvn=%.5f vt_before=%.6f vt_after=%.6f %s ratio=%.3f\n", xi[0], j, m, vs[0], vs[1], vc[1]-vs[1], vc[0], vt[0], stuck ? "STICK" : "SLIP", fabs(vt[0]-vc[0])/fabs(vc[1]-vs[1]));
    } else {
        a->freen++;
        a->pfree += m * vs[0];
        if (j <= 0) a->vnpos_in++;
        if (dump && j <= 0) printf("  node x=%.3f j=%d m=%.4e v*=(%.5f,%.5f) FREE (separating)\n", xi[0], j, m, vs[0], vs[1]);
    }
}
int main(int argc, char **argv) {
    double th_deg = argc > 1 ? atof(argv[1]) : 30, mu = argc > 2 ? atof(argv[2]) : 0.7;
    double max_dt = argc > 3 ? atof(argv[3]) : 2e-5, offset = argc > 4 ? atof(argv[4]) : 0, extra = argc > 5 ? atof(argv[5]) : 2.6;
    int transfer = argc > 6 ? atoi(argv[6]) : 0; /* 0 apic 1 pic */
    double t_end = argc > 7 ? atof(argv[7]) : 1.2, dump_t = argc > 8 ? atof(argv[8]) : -1;
    double frame = getenv("FRAME") ? atof(getenv("FRAME")) : 0.05;
    int tilted = getenv("TILTED") ? atoi(getenv("TILTED")) : 0;
    int quiet = getenv("QUIET") ? 1 : 0;
    const double th = th_deg * PI / 180;
    sm_world_def def = sm_world_def_default();
    if (getenv("DX")) DX = atof(getenv("DX"));
    def.dim = 2; def.dx = DX; def.max_dt = max_dt; def.threads = 1;
    def.transfer = (sm_transfer)transfer; if (getenv("FLIPR")) def.flip_ratio = atof(getenv("FLIPR")); if (getenv("KERNEL")) def.kernel = (sm_kernel)atoi(getenv("KERNEL"));
    def.domain_max[0] = 2.0 + (extra > 0 ? extra + 0.5 : 0);
    def.domain_max[1] = 1.3 + (tilted ? extra * sin(th) : 0); def.domain_max[2] = 0.3;
    if (getenv("ECFL")) def.elastic_cfl = atof(getenv("ECFL"));
    Y0 = 0.2 + offset * DX;
    double p0[3] = {1.6, Y0, 0.15}, n[3] = {0, 1, 0}, tdown[3] = {-1, 0, 0};
    if (tilted) {
        p0[0] = 1.0; p0[1] = 0.6; Y0 = -1e9;
        n[0] = -sin(th), n[1] = cos(th), n[2] = 0;
        tdown[0] = -cos(th), tdown[1] = -sin(th), tdown[2] = 0;
    } else {
        def.gravity[0] = -G * sin(th); def.gravity[1] = -G * cos(th);
    }
    sm_world *w = NULL; char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) { fprintf(stderr, "%s\n", err); return 2; }
    sm_material_def m = sm_material_def_elastic(); m.youngs_modulus = 1e6; int mat = -1;
    sm_world_add_material(w, &m, &mat);
    sm_collider_def c = sm_collider_def_default(); c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    for (int a = 0; a < 3; a++) c.shapes[0].center[a] = p0[a], c.shapes[0].normal[a] = n[a];
    c.mode = argc > 9 ? atoi(argv[9]) : SM_COLLIDE_SEPARATE; c.friction = mu;
    sm_world_add_collider(w, &c, NULL);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    const double hy = 0.05, up = 0.6 * (tilted ? 1 : 0.5) + extra;
    for (int a = 0; a < 3; a++) box.center[a] = p0[a] - up * tdown[a] + (hy + (getenv("LIFT") ? atof(getenv("LIFT")) : 0.25) * DX) * n[a];
    box.center[2] = 0.15; box.half_extent[0] = 0.1; box.half_extent[1] = hy; box.half_extent[2] = 0.05;
    if (tilted) box.rotation[0] = cos(th / 2), box.rotation[3] = sin(th / 2);
    sm_seed_def sd = sm_seed_def_default(); sd.material = mat; sd.ppc = getenv("PPC") ? atoi(getenv("PPC")) : 4;
    sm_world_seed_shape(w, &box, &sd, NULL);
#ifdef HOOK
    sm_dbg_node_hook = hook;
    if (getenv("DBGMODE")) sm_dbg_mode = atoi(getenv("DBGMODE"));
#else
    (void)hook;
#endif
    sm_diagnostics d; sm_world_diagnostics(w, &d);
    double c0 = d.center_of_mass[0] * tdown[0] + d.center_of_mass[1] * tdown[1];
    long steps = 0;
    printf("t com_disp(mm) v_slope(mm/s) | per row j(rel plane): mass-frac contact stuck slip free  Jn Jt Jt/Jn(slip) pbar-ptil\n");
    for (int f = 1; f * frame <= t_end + 1e-9; f++) {
        memset(acc, 0, sizeof acc);
        long s0 = steps;
        while (sm_world_time(w) < f * frame - 1e-12) {
            double dt = sm_world_next_dt(w, f * frame);
            dump = dump_t >= 0 && sm_world_time(w) >= dump_t && sm_world_time(w) < dump_t + dt * 0.999;
            if (dump) printf("--- dump step t=%.6f dt=%.3e\n", sm_world_time(w), dt);
            if (sm_world_step(w, dt) != SM_OK) { fprintf(stderr, "step failed %s\n", sm_world_errmsg(w)); return 3; }
            steps++;
            if (dump) {
                sm_particles_view pv; sm_world_particles(w, &pv);
                double ymin = 1e9; for (size_t p = 0; p < pv.n; p++) if (pv.x[2*p+1] < ymin) ymin = pv.x[2*p+1];
                for (size_t p = 0; p < pv.n; p++) if (pv.x[2*p+1] < ymin + 0.6*DX)
                    printf("  particle x=(%.5f,%.6f) v=(%.6f,%.6f) B=[%.3e %.3e; %.3e %.3e] Cxy=%.4f Cyy=%.4f\n", pv.x[2*p], pv.x[2*p+1], pv.v[2*p], pv.v[2*p+1], pv.B[4*p], pv.B[4*p+1], pv.B[4*p+2], pv.B[4*p+3], pv.B[4*p+1]*4/(DX*DX), pv.B[4*p+3]*4/(DX*DX));
            }
        }
        long ns = steps - s0;
        if (getenv("MU_T") && fabs(sm_world_time(w) - atof(getenv("MU_T"))) < 1e-9) {
            ((sm_collider_def *)sm_world_collider_def(w, 0))->friction = atof(getenv("MU2"));
            printf("MU -> %g (now %g)\n", atof(getenv("MU2")), sm_world_collider_def(w, 0)->friction);
        }
        if (getenv("FREEZE_T") && fabs(sm_world_time(w) - atof(getenv("FREEZE_T"))) < 1e-9) {
            sm_particles_view pv0; sm_world_particles(w, &pv0); sm_real *vv = sm_world_particle_velocities(w);
            for (size_t p = 0; p < pv0.n * 2; p++) vv[p] = 0;
            for (size_t p = 0; p < pv0.n * 4; p++) ((sm_real *)pv0.B)[p] = 0;
            printf("FREEZE\n");
        }
        if (getenv("KICK_T") && fabs(sm_world_time(w) - atof(getenv("KICK_T"))) < 1e-9) {
            sm_particles_view pv0; sm_world_particles(w, &pv0); sm_real *vv = sm_world_particle_velocities(w);
            double M0 = 0, c[2] = {0, 0}; for (size_t p = 0; p < pv0.n; p++) { double mp = sm_world_particle_mass(w, p); M0 += mp; c[0] += mp * pv0.x[2*p]; c[1] += mp * pv0.x[2*p+1]; }
            c[0] /= M0; c[1] /= M0; double om = atof(getenv("KICK_W")), vy = getenv("KICK_VY") ? atof(getenv("KICK_VY")) : 0;
            for (size_t p = 0; p < pv0.n; p++) { vv[2*p] += -om * (pv0.x[2*p+1] - c[1]); vv[2*p+1] += om * (pv0.x[2*p] - c[0]) + vy; }
            printf("KICK omega %g vy %g\n", om, vy);
        }
        sm_world_diagnostics(w, &d);
        double v = (d.momentum[0] * tdown[0] + d.momentum[1] * tdown[1]) / d.total_mass;
        /* internal kinetic energy and rotation rate about the centre of mass (slope frame) */
        sm_particles_view pv; sm_world_particles(w, &pv);
        double Mt = 0, cm[2] = {0, 0}, vm[2] = {0, 0};
        for (size_t p = 0; p < pv.n; p++) { double mp = sm_world_particle_mass(w, p); Mt += mp; for (int a = 0; a < 2; a++) cm[a] += mp * pv.x[2*p+a], vm[a] += mp * pv.v[2*p+a]; }
        for (int a = 0; a < 2; a++) cm[a] /= Mt, vm[a] /= Mt;
        double Ek = 0, L = 0, I = 0;
        for (size_t p = 0; p < pv.n; p++) { double mp = sm_world_particle_mass(w, p), r[2], u[2];
            for (int a = 0; a < 2; a++) r[a] = pv.x[2*p+a] - cm[a], u[a] = pv.v[2*p+a] - vm[a];
            Ek += 0.5 * mp * (u[0]*u[0] + u[1]*u[1]); L += mp * (r[0]*u[1] - r[1]*u[0]); I += mp * (r[0]*r[0] + r[1]*r[1]); }
        double vn = vm[0]*n[0] + vm[1]*n[1];
        double Eaff = 0; for (size_t p = 0; p < pv.n; p++) { double mp = sm_world_particle_mass(w, p), b2 = 0; for (int q = 0; q < 4; q++) b2 += (double)pv.B[4*p+q]*(double)pv.B[4*p+q]; Eaff += 0.5 * mp * b2 * 4 / (DX*DX); }
        double Epot = -Mt * ((tilted ? 0 : def.gravity[0]) * cm[0] + (tilted ? -G : def.gravity[1]) * cm[1]);
        double Etot = d.kinetic_energy + Eaff + d.elastic_energy + Epot;
        static double Eprev = 0; static int first = 1;
        if (getenv("ENERGY")) printf("   E: KE %.4e aff %.4e el %.4e | dE %.4e Dfric %.4e Dproj %.4e residual(dE+D) %.4e  gravity work %.4e\n", d.kinetic_energy, Eaff, d.elastic_energy, first ? 0 : Etot - Eprev, Dfric, Dproj, first ? 0 : Etot - Eprev + Dfric + Dproj, 0.0);
        Eprev = Etot; first = 0; Dfric = Dproj = 0;
        printf("t=%.4f disp=%.4f mm v=%.4f mm/s vn=%.4f mm/s omega=%.4f rad/s Eint=%.4e J steps=%ld\n", sm_world_time(w), (d.center_of_mass[0] * tdown[0] + d.center_of_mass[1] * tdown[1] - c0) * 1e3, v * 1e3, vn * 1e3, L / I, Ek, ns);
        if (getenv("GEOM")) {
            double ymin = 1e9, ymax = -1e9, xmin = 1e9, xmax = -1e9; size_t below = 0;
            for (size_t p = 0; p < pv.n; p++) { double px = pv.x[2*p], py = pv.x[2*p+1]; if (py < ymin) ymin = py; if (py > ymax) ymax = py; if (px < xmin) xmin = px; if (px > xmax) xmax = px; if (py < Y0) below++; }
            printf("      geom: ymin-plane %.3f dx, ymax-plane %.3f dx, x [%.4f, %.4f] len %.4f, below %zu, com y-plane %.4f dx\n", (ymin - Y0)/DX, (ymax - Y0)/DX, xmin, xmax, xmax - xmin, below, (cm[1] - Y0)/DX);
        }
        if (getenv("LAYERS")) {
            double eL[64] = {0}, nL[64] = {0}, vxL[64] = {0}, vyL[64] = {0}, bL[64] = {0};
            for (size_t p = 0; p < pv.n; p++) { double mp = sm_world_particle_mass(w, p), u0 = pv.v[2*p]-vm[0], u1 = pv.v[2*p+1]-vm[1];
                int L = (int)floor((pv.x[2*p+1] - Y0) / DX * 2); if (L < 0) L = 0; if (L > 63) L = 63;
                eL[L] += 0.5 * mp * (u0*u0+u1*u1); nL[L] += mp; vxL[L] += mp * pv.v[2*p]; vyL[L] += mp * pv.v[2*p+1];
                double b2 = 0; for (int q = 0; q < 4; q++) b2 += (double)pv.B[4*p+q]*(double)pv.B[4*p+q]; bL[L] += 0.5 * mp * b2 * 4 / (DX*DX); }
            for (int L = 0; L < 64; L++) if (nL[L] > 0 && (L < 6 || L % 8 == 0)) printf("      layer %d (y-plane %.2f dx) m %.3f Eint %.3e Eaff %.3e vx %.4f vy %.4f\n", L, L * 0.5, nL[L], eL[L], bL[L], vxL[L]/nL[L], vyL[L]/nL[L]);
        }
        if (getenv("ROWLINE")) {
            double Jn = 0, Jt = 0, ct = 0, st = 0, sl = 0, fr = 0, Jns = 0, Jts = 0;
            for (int k = 0; k < NR; k++) { rowacc *a = &acc[k]; if (k + R0 > 0) continue; Jn += a->Jn; Jt += a->Jt; ct += a->contact; st += a->stuck; sl += a->slip; fr += a->freen; Jns += a->Jn_slip; Jts += a->Jt_slip; }
            printf("      contacts %.1f stuck %.1f slip %.1f free %.1f Jn/dt %.3f Jt/dt %.3f (Mg cos %.3f, sin %.3f) Jt/Jn %.3f slipJt/Jn %.3f\n", ct/ns, st/ns, sl/ns, fr/ns, Jn/(ns*max_dt), Jt/(ns*max_dt), Mt*G*cos(th), Mt*G*sin(th), Jn != 0 ? Jt/Jn : 0, Jns != 0 ? Jts/Jns : 0);
        }
        if (quiet) continue;
        for (int k = 0; k < NR; k++) {
            rowacc *a = &acc[k];
            if (a->n == 0) continue;
            double jtsum = 0; for (int q = 0; q < NR; q++) jtsum += 0;
            printf("   j=%+d n/step=%.1f m=%.4e contact=%.1f stuck=%.1f slip=%.1f free=%.1f | Jn=%.4e Jt=%.4e Jt/Jn=%.3f Jn_stuck=%.3e Jn_slip=%.3e | p*=%.3e pcol=%.3e ptil=%.3e pbar-ptil=%.3e pfree=%.3e\n",
                   k + R0, a->n / ns, a->m / ns, a->contact / ns, a->stuck / ns, a->slip / ns, a->freen / ns,
                   a->Jn / ns, a->Jt / ns, a->Jn != 0 ? a->Jt / a->Jn : 0, a->Jn_stuck / ns, a->Jn_slip / ns,
                   a->pstar / ns, a->pcol / ns, a->ptil / ns, (a->pbar - a->ptil) / ns, a->pfree / ns);
        }
        fflush(stdout);
    }
    sm_world_destroy(w);
    return 0;
}
