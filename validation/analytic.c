/* sm_validate: the analytic benchmarks of docs/validation.md, printed as CSV (one header line,
 * comment lines start with '#'). Run by validation/run.py; built as tests/sm_validate.
 *
 *   sm_validate incline [--quick]   block on an incline: an elastic block (rho 1000, E 1e6, nu 0.3)
 *       on a Coulomb plane, released at rest a quarter cell above it. Expected acceleration along
 *       the slope a = g (sin th - mu cos th) if tan th > mu, else 0 (Coulomb friction through the
 *       collider, thesis §3.6.3 / Algorithm 7; the plane "separate", and "slip" for two cases).
 *       Three set-ups: "tilted" = the plane turned by th in the grid (not grid aligned), gravity
 *       vertical; "aligned" = the plane y = 0.2 m, on a grid line, and gravity turned by th;
 *       "shifted" = the same half a cell higher (y = 0.2 m + dx/2, between node rows). a is the
 *       least-squares slope of the mean velocity along the slope over [0.5 s, 1.2 s], after the
 *       ringing of the block's drop onto the plane has died down (docs/validation.md section 6,
 *       "the fit window"); the slope is long enough for the fastest case to stay on it. max_dt =
 *       2e-5 s (fine; one case also at 1e-4 s; 3D at 1e-4 s, tilted only). --quick: the first two
 *       cases per set-up fitted over [0.05 s, 0.15 s] on the short slope (the CTest subset).
 *       Also printed: normal_accel, the same fit of the block's mean velocity along the plane's
 *       normal, and rel_error_normal, the error against Coulomb's law with the normal force the
 *       block had, M (g cos th + normal_accel): a = g (sin th - mu cos th) - mu normal_accel
 *       (sliding cases; a bouncing block's normal force over the window is not M g cos th); and
 *       normal_rms, the RMS of that normal velocity about its mean over the window (m/s).
 *   sm_validate incline_gate [--quick]   the same with the contact gate, contact_gap = 0.35 cells
 *       (sm_world_def.contact_gap; off by default).
 *   sm_validate incline_stiffness [--quick]   the cases near the sliding threshold (30 deg, mu 0.5
 *       and 0.7, separating plane, max_dt 2e-5 s) of every set-up for E = 1e6, 3e6, 1e7, 3e7, 1e8
 *       Pa: how the block's elasticity (its ringing) moves the error. At 1e8 the elastic step
 *       (elastic_cfl 0.6 dx / c, about 1.8e-5 s) binds. --quick: E = 1e6 and 1e7, tilted and
 *       aligned, on the short window.
 *   sm_validate incline_resolution [--quick]   mu 0.5 at 30 deg (separating plane, max_dt 2e-5 s)
 *       on every set-up at dx = 0.02, 0.01, 0.005 m with APIC, and at 0.01 m with PIC: the block's
 *       normal vibration and what it does to the plain error, by resolution and transfer. --quick:
 *       dx 0.02 only.
 *   sm_validate column [--quick]    gravity-loaded elastic column, 2D plane strain: width H/4
 *       between slip walls on a slip base, H = 1 m, rho 1000, E 1e7, nu 0.3 (strain 1e-3), released
 *       stress free (explicit steps). Uniaxial strain: sigma_yy = -rho g (H - y), sigma_xx / sigma_yy
 *       = nu / (1 - nu) (Hencky: tau = 2 mu eps + lambda tr eps with eps_xx = 0 gives lambda /
 *       (lambda + 2 mu) exactly). The column oscillates about that state (period 4 H / c = 34 ms,
 *       odd harmonics at integer fractions of it; APIC hardly damps it), so the stress is averaged
 *       over 8 periods from 0.1 s, 25 samples a period, in bins of dx in y: the average of a linear
 *       oscillation over whole periods is its equilibrium. Cauchy stress per particle from F^E:
 *       sigma = U diag(2 mu ln s_i + lambda sum ln s_k) U^T / det F^E (3.70). Errors: RMS over the
 *       bins of mean sigma_yy - exact, relative to the RMS of the exact; the ratio over bins below
 *       0.8 H. Finite strain moves y by <= 5e-4 H: below the errors measured. Twice: the walls on
 *       grid lines (x = 0, x = W, y = 0), and moved 1e-6 dx into the column ("shifted").
 *   sm_validate shear [--quick]     steady simple shear of one material point (validation/
 *       mp_shear.h) for phi = 20..40 and every cone fit, 2D and 3D: tau_xy / (-tau_yy) against
 *       mu_eff = d alpha / sqrt(2). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "material/material.h"
#include "math/svd.h"
#include "sandmpm/sandmpm.h"
#include "mp_shear.h"

static const double PI = 3.14159265358979323846, G = 9.81;

static int fail(const char *what, sm_world *w) {
    fprintf(stderr, "sm_validate: %s: %s\n", what, w ? sm_world_errmsg(w) : "");
    exit(3);
}

/* The incline's set-ups, in the order of the table. */
enum { INCLINE_TILTED, INCLINE_ALIGNED, INCLINE_SHIFTED, INCLINE_SETUPS };
static const char *const setup_names[INCLINE_SETUPS] = {"tilted", "aligned", "shifted"};

/* The contact gate of the incline runs (sm_world_def.contact_gap): `sm_validate incline_gate` runs the
 * same table with 0.35 cells. */
static double incline_gap = INFINITY;
/* The block's Young's modulus (Pa): 1e6, or each of incline_stiffness's. */
static double incline_youngs = 1e6;
/* The 2D cell size (m) and the transfer: 0.01 and APIC, or each of incline_resolution's. */
static double incline_dx2 = 0.01;
static sm_transfer incline_transfer = SM_TRANSFER_APIC;

/* One block-on-incline run (setup: INCLINE_*); returns the acceleration along the slope fitted
 * over [t0, t_end], and in *a_normal the same fit of the block's mean velocity along the plane's
 * normal (0 for a block that stays on the plane; a bouncing block's normal momentum changes over the
 * window, and the normal force with it), in *vn_rms that velocity's RMS about its mean (m/s). `extra` (m) lengthens the slope above the plane's
 * anchor p0: the block starts that much farther up it. */
static double incline_run(int dim, double th_deg, double mu, int setup, sm_collide_mode mode, double max_dt,
                          double t0, double t_end, double extra, double *a_normal, double *vn_rms) {
    const double th = th_deg * PI / 180;
    const int tilted = setup == INCLINE_TILTED;
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? incline_dx2 : 0.02;
    def.transfer = incline_transfer;
    def.max_dt = max_dt;
    def.contact_gap = incline_gap;
    def.domain_max[0] = 2.5 + extra; /* the aligned block's upper end (1.6 + 0.3 + extra + 0.1) clear of the wall */
    def.domain_max[1] = 1.3 + (tilted ? extra * sin(th) : 0);
    def.domain_max[2] = 0.3;
    /* tilted: plane through p0 with normal n, gravity -y; aligned and shifted: plane y = p0[1],
     * gravity along (-sin th, -cos th) in the grid: down the slope is -x */
    double n[3], tdown[3];
    if (tilted) {
        n[0] = -sin(th), n[1] = cos(th), n[2] = 0;
        tdown[0] = -cos(th), tdown[1] = -sin(th), tdown[2] = 0;
    } else {
        n[0] = 0, n[1] = 1, n[2] = 0;
        tdown[0] = -1, tdown[1] = 0, tdown[2] = 0;
        def.gravity[0] = -G * sin(th);
        def.gravity[1] = -G * cos(th);
    }
    const double p0[3] = {tilted ? 1.0 : 1.6, tilted ? 0.6 : 0.2 + (setup == INCLINE_SHIFTED ? 0.5 * def.dx : 0), 0.15};
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "sm_validate: %s\n", err);
        exit(2);
    }
    sm_material_def m = sm_material_def_elastic();
    m.youngs_modulus = incline_youngs;
    int mat = -1;
    if (sm_world_add_material(w, &m, &mat) != SM_OK) fail("material", w);
    sm_collider_def c = sm_collider_def_default();
    c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    for (int a = 0; a < 3; a++) c.shapes[0].center[a] = p0[a], c.shapes[0].normal[a] = n[a];
    c.mode = mode;
    c.friction = mu;
    if (sm_world_add_collider(w, &c, NULL) != SM_OK) fail("collider", w);
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    const double hy = 0.05, up = 0.6 * (tilted ? 1 : 0.5) + extra;
    for (int a = 0; a < 3; a++) box.center[a] = p0[a] - up * tdown[a] + (hy + 0.25 * def.dx) * n[a];
    box.center[2] = 0.15;
    box.half_extent[0] = 0.1, box.half_extent[1] = hy, box.half_extent[2] = 0.05;
    if (tilted) box.rotation[0] = cos(th / 2), box.rotation[3] = sin(th / 2);
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = dim == 2 ? 4 : 8;
    if (sm_world_seed_shape(w, &box, &sd, NULL) != SM_OK) fail("seed", w);
    double St = 0, Sv = 0, Stt = 0, Stv = 0, Sn = 0, Stn = 0, Snn = 0;
    int k = 0;
    sm_diagnostics d;
    for (int f = 1; f * 0.005 <= t_end + 1e-9; f++) {
        if (sm_world_advance(w, f * 0.005) != SM_OK) fail("advance", w);
        sm_world_diagnostics(w, &d);
        double t = sm_world_time(w), v = (d.momentum[0] * tdown[0] + d.momentum[1] * tdown[1]) / d.total_mass;
        double vn = (d.momentum[0] * n[0] + d.momentum[1] * n[1]) / d.total_mass;
        if (t >= t0 - 1e-9) St += t, Sv += v, Stt += t * t, Stv += t * v, Sn += vn, Stn += t * vn, Snn += vn * vn, k++;
    }
    sm_world_destroy(w);
    *a_normal = (k * Stn - St * Sn) / (k * Stt - St * St);
    *vn_rms = sqrt(fmax(Snn / k - (Sn / k) * (Sn / k), 0));
    return (k * Stv - St * Sv) / (k * Stt - St * St);
}

static void incline(int quick) {
    printf("dim,setup,mode,theta,mu,max_dt,expected,measured,rel_error,normal_accel,rel_error_normal,normal_rms\n");
    /* theta, mu, mode (0 separate, 1 slip), max_dt; 3D: the first case, tilted only */
    const double cases[][4] = {{30, 0.2, 0, 2e-5}, {30, 0.0, 0, 2e-5}, {30, 0.5, 0, 2e-5}, {30, 0.7, 0, 2e-5},
                               {45, 0.3, 0, 2e-5}, {30, 0.2, 0, 1e-4}, {30, 0.2, 1, 2e-5}};
    const int nc = quick ? 2 : (int)(sizeof cases / sizeof cases[0]);
    /* the fit window, and the slope the fastest case (45 deg, mu 0.3: 4.9 m/s^2) needs for it */
    const double t0 = quick ? 0.05 : 0.5, t_end = quick ? 0.15 : 1.2, extra = quick ? 0 : 2.6;
    for (int dim = 2; dim <= 3; dim++)
        for (int setup = 0; setup < INCLINE_SETUPS; setup++) {
            const int tilted = setup == INCLINE_TILTED;
            const int count = dim == 3 ? (tilted ? 1 : 0) : (tilted ? nc : (nc < 4 ? nc : 4));
            for (int i = 0; i < count; i++) {
                double th = cases[i][0], mu = cases[i][1], dt = dim == 3 ? 1e-4 : cases[i][3];
                sm_collide_mode mode = cases[i][2] > 0 ? SM_COLLIDE_SLIP : SM_COLLIDE_SEPARATE;
                double r = th * PI / 180;
                double expect = tan(r) > mu ? G * (sin(r) - mu * cos(r)) : 0;
                double an = 0, vr = 0, a = incline_run(dim, th, mu, setup, mode, dt, t0, t_end, extra, &an, &vr);
                /* Coulomb's law with the block's own normal motion: N = M (g cos th + a_n), so a
                 * sliding block's acceleration is g (sin th - mu cos th) - mu a_n (sliding cases) */
                printf("%d,%s,%s,%g,%g,%g,%.6f,%.6f,%.3g,%.6f,%.3g,%.3g\n", dim, setup_names[setup],
                       mode == SM_COLLIDE_SLIP ? "slip" : "separate", th, mu, dt, expect, a,
                       expect > 0 ? (a - expect) / expect : a / G, an,
                       expect > 0 ? (a - (expect - mu * an)) / expect : NAN, vr);
                fflush(stdout);
            }
        }
}

/* sm_validate incline_stiffness: the threshold cases against the block's stiffness. */
static void incline_stiffness(int quick) {
    static const double youngs[] = {1e6, 3e6, 1e7, 3e7, 1e8}, mus[] = {0.5, 0.7};
    printf("dim,setup,mode,theta,mu,youngs,max_dt,expected,measured,rel_error,normal_accel,rel_error_normal,normal_rms\n");
    const double t0 = quick ? 0.05 : 0.5, t_end = quick ? 0.15 : 1.2, extra = quick ? 0 : 2.6, th = 30;
    const int ne = quick ? 3 : 5, nsetups = quick ? 2 : INCLINE_SETUPS;
    for (int e = 0; e < ne; e += quick ? 2 : 1)
        for (int setup = 0; setup < nsetups; setup++)
            for (int i = 0; i < 2; i++) {
                incline_youngs = youngs[e];
                const double r = th * PI / 180, mu = mus[i];
                const double expect = tan(r) > mu ? G * (sin(r) - mu * cos(r)) : 0;
                double an = 0, vr = 0;
                const double a = incline_run(2, th, mu, setup, SM_COLLIDE_SEPARATE, 2e-5, t0, t_end, extra, &an, &vr);
                printf("2,%s,separate,%g,%g,%g,2e-05,%.6f,%.6f,%.3g,%.6f,%.3g,%.3g\n", setup_names[setup], th, mu, youngs[e],
                       expect, a, expect > 0 ? (a - expect) / expect : a / G, an,
                       expect > 0 ? (a - (expect - mu * an)) / expect : NAN, vr);
                fflush(stdout);
            }
    incline_youngs = 1e6;
}

/* sm_validate incline_resolution: the threshold case by resolution and transfer. */
static void incline_resolution(int quick) {
    static const struct { double dx; sm_transfer tr; } runs[] = {
        {0.02, SM_TRANSFER_APIC}, {0.01, SM_TRANSFER_APIC}, {0.005, SM_TRANSFER_APIC}, {0.01, SM_TRANSFER_PIC}};
    printf("dim,setup,mode,theta,mu,dx,transfer,max_dt,expected,measured,rel_error,normal_accel,rel_error_normal,"
           "normal_rms\n");
    const double t0 = quick ? 0.05 : 0.5, t_end = quick ? 0.15 : 1.2, extra = quick ? 0 : 2.6, th = 30, mu = 0.5;
    const double r = th * PI / 180, expect = G * (sin(r) - mu * cos(r));
    for (int i = 0; i < (quick ? 1 : 4); i++)
        for (int setup = 0; setup < INCLINE_SETUPS; setup++) {
            incline_dx2 = runs[i].dx, incline_transfer = runs[i].tr;
            double an = 0, vr = 0;
            const double a = incline_run(2, th, mu, setup, SM_COLLIDE_SEPARATE, 2e-5, t0, t_end, extra, &an, &vr);
            printf("2,%s,separate,%g,%g,%g,%s,2e-05,%.6f,%.6f,%.3g,%.6f,%.3g,%.3g\n", setup_names[setup], th, mu, runs[i].dx,
                   runs[i].tr == SM_TRANSFER_PIC ? "pic" : "apic", expect, a, (a - expect) / expect, an,
                   (a - (expect - mu * an)) / expect, vr);
            fflush(stdout);
        }
    incline_dx2 = 0.01, incline_transfer = SM_TRANSFER_APIC;
}

/* The elastic column's results (sm_validate column). */
typedef struct column_result {
    size_t particles;
    double err_bins;   /* RMS over bins of dx of the mean sigma_yy - exact, over the RMS of the exact */
    double err_smooth; /* the same at the interior node rows, sigma_yy smoothed with the kernel */
    double err_mean;   /* the volume mean of sigma_yy against -rho g H / 2 */
    double err_slope;  /* the least-squares slope of the bins' sigma_yy over [0.1 H, 0.9 H] against rho g */
    double ratio, err_ratio;
    double exx_eyy;    /* the particles' mean lateral log strain over their mean vertical one (exact: 0) */
} column_result;

/* Cauchy sigma_yy and sigma_xx of a 2D particle from F^E (3.70), J, and the log strains
 * eps_xx, eps_yy (eps = U diag(ln s) U^T). */
static void column_stress(const sm_real *F, double mu_l, double la, double *syy, double *sxx, double *J,
                          double eps[2]) {
    sm_real U[4], V[4], s[2];
    sm_svd2(F, U, s, V);
    const double l0 = log((double)s[0]), l1 = log((double)s[1]);
    const double t0 = 2 * mu_l * l0 + la * (l0 + l1), t1 = 2 * mu_l * l1 + la * (l0 + l1);
    *J = (double)s[0] * (double)s[1];
    *syy = ((double)U[2] * U[2] * t0 + (double)U[3] * U[3] * t1) / *J;
    *sxx = ((double)U[0] * U[0] * t0 + (double)U[1] * U[1] * t1) / *J;
    eps[0] = (double)U[0] * U[0] * l0 + (double)U[1] * U[1] * l1;
    eps[1] = (double)U[2] * U[2] * l0 + (double)U[3] * U[3] * l1;
}

/* Adds a particle's sigma_yy at y to the node rows its quadratic kernel reaches (rows j dx). */
static void column_smooth_add(double *rows, int nrows, double y, double dx, double syy) {
    const double X = y / dx;
    const int j0 = (int)floor(X - 0.5);
    for (int k = 0; k < 3; k++) {
        const int j = j0 + k;
        const double r = fabs(X - j);
        const double wq = r < 0.5 ? 0.75 - r * r : (r < 1.5 ? 0.5 * (1.5 - r) * (1.5 - r) : 0);
        if (j >= 0 && j < nrows) rows[2 * j] += wq * syy, rows[2 * j + 1] += wq;
    }
}

/* The errors of column_result from the accumulated sums. */
static void column_errors(const double *acc, const double *rows, int nb, int cells, double H, double dx, double rho,
                          double nu, double vol_syy, double vol, column_result *r) {
    double se = 0, sx = 0, rs = 0, re = 0, S0 = 0, S1 = 0, S2 = 0, T0 = 0, T1 = 0;
    int nr = 0;
    const double rexact = nu / (1 - nu);
    for (int b = 0; b < nb; b++) {
        if (acc[4 * b + 3] == 0) continue;
        const double n = acc[4 * b + 3], syy = acc[4 * b] / n, sxx = acc[4 * b + 1] / n, y = acc[4 * b + 2] / n;
        const double ex = -rho * G * (H - y);
        se += (syy - ex) * (syy - ex), sx += ex * ex;
        if (y < 0.8 * H) rs += sxx / syy, re += (sxx / syy - rexact) * (sxx / syy - rexact), nr++;
        if (y >= 0.1 * H && y <= 0.9 * H) S0 += 1, S1 += y, S2 += y * y, T0 += syy, T1 += syy * y;
    }
    r->err_bins = sqrt(se / sx);
    r->ratio = rs / nr;
    r->err_ratio = sqrt(re / nr) / rexact;
    r->err_slope = (S0 * T1 - S1 * T0) / (S0 * S2 - S1 * S1) / (rho * G) - 1;
    r->err_mean = vol_syy / vol / (-rho * G * H / 2) - 1;
    double e2 = 0, x2 = 0; /* rows 2 .. cells - 2: the kernel's whole support is inside */
    for (int j = 2; j <= cells - 2; j++) {
        const double ex = -rho * G * (H - j * dx), d = rows[2 * j] / rows[2 * j + 1] - ex;
        e2 += d * d, x2 += ex * ex;
    }
    r->err_smooth = sqrt(e2 / x2);
}

/* Elastic column at `cells` cells over its height, ppc particles per cell (transfer: APIC, or PIC,
 * which brings it to rest). */
static void column_run(int cells, int shifted, sm_transfer transfer, int ppc, column_result *res) {
    const double H = 1.0, W = 0.25, dx = H / cells, nu = 0.3, E = 1e7, rho = 1000;
    sm_world_def def = sm_world_def_default();
    def.dim = 2;
    def.dx = dx;
    def.transfer = transfer;
    def.domain_min[0] = def.domain_min[1] = -4 * dx;
    def.domain_max[0] = W + 4 * dx;
    def.domain_max[1] = H + 4 * dx;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "sm_validate: %s\n", err);
        exit(2);
    }
    sm_material_def m = sm_material_def_elastic();
    m.density = rho, m.youngs_modulus = E, m.poisson_ratio = nu;
    int mat = -1;
    if (sm_world_add_material(w, &m, &mat) != SM_OK) fail("material", w);
    /* shifted: the walls 1e-6 dx into the column (the nodes on the column's faces inside them) */
    const double e = shifted ? 1e-6 * dx : 0;
    const double pts[3][3] = {{0, e, 0}, {e, 0, 0}, {W - e, 0, 0}}, nrm[3][3] = {{0, 1, 0}, {1, 0, 0}, {-1, 0, 0}};
    for (int i = 0; i < 3; i++) {
        sm_collider_def c = sm_collider_def_default();
        c.shape_count = 1;
        c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
        for (int a = 0; a < 3; a++) c.shapes[0].center[a] = pts[i][a], c.shapes[0].normal[a] = nrm[i][a];
        c.mode = SM_COLLIDE_SLIP;
        if (sm_world_add_collider(w, &c, NULL) != SM_OK) fail("collider", w);
    }
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = W / 2, box.center[1] = H / 2;
    box.half_extent[0] = W / 2, box.half_extent[1] = H / 2;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = ppc;
    if (sm_world_seed_shape(w, &box, &sd, NULL) != SM_OK) fail("seed", w);
    double mu_l, la;
    sm_lame(E, nu, &mu_l, &la);
    /* time average over 8 periods of the fundamental, 4 H / c, sampled 25 times a period, from 0.1 s */
    const double c = sqrt((la + 2 * mu_l) / rho), T1 = 4 * H / c, t0 = 0.1;
    const int nb = cells + 4, ns = 8 * 25;
    double *acc = calloc((size_t)nb * 4, sizeof *acc); /* per y-bin: sum syy, sum sxx, sum y, count */
    double *rows = calloc((size_t)nb * 2, sizeof *rows); /* per node row: sum w syy, sum w */
    if (!acc || !rows) exit(5);
    double vol_syy = 0, vol = 0; /* sum J syy, sum J: particle volumes are V0 J */
    double exx = 0, eyy = 0;      /* sums of the particles' eps_xx, eps_yy */
    for (int k = 0; k < ns; k++) {
        if (sm_world_advance(w, t0 + k * T1 / 25) != SM_OK) fail("advance", w);
        sm_particles_view pv;
        sm_world_particles(w, &pv);
        for (size_t i = 0; i < pv.n; i++) {
            double syy, sxx, J, eps[2];
            column_stress(pv.F + 4 * i, mu_l, la, &syy, &sxx, &J, eps);
            exx += eps[0], eyy += eps[1];
            const double y = (double)pv.x[2 * i + 1];
            vol_syy += J * syy, vol += J;
            column_smooth_add(rows, nb, y, dx, syy);
            const int b = (int)floor(y / dx);
            if (b < 0 || b >= nb) continue;
            acc[4 * b] += syy, acc[4 * b + 1] += sxx, acc[4 * b + 2] += y, acc[4 * b + 3] += 1;
        }
        res->particles = pv.n;
    }
    column_errors(acc, rows, nb, cells, H, dx, rho, nu, vol_syy, vol, res);
    res->exx_eyy = exx / eyy;
    free(acc);
    free(rows);
    sm_world_destroy(w);
}

static void column(int quick) {
    printf("walls,transfer,ppc,cells,dx,particles,err_syy,err_smooth,err_mean,err_slope,ratio_mean,ratio_exact,"
           "err_ratio,exx_eyy\n");
    const int cells[] = {8, 16, 32, 64};
    /* walls (1 shifted), transfer (0 APIC, 1 PIC), particles per cell, resolutions (the first
     * nres of cells, from the first'th) */
    const int runs[][5] = {{1, 0, 4, 0, 4}, {0, 0, 4, 0, 4}, {1, 1, 4, 0, 3}, {1, 0, 9, 1, 2}};
    for (int k = 0; k < (quick ? 1 : 4); k++)
        for (int i = runs[k][3]; i < (quick ? 2 : runs[k][3] + runs[k][4]); i++) {
            column_result r;
            column_run(cells[i], runs[k][0], runs[k][1] ? SM_TRANSFER_PIC : SM_TRANSFER_APIC, runs[k][2], &r);
            printf("%s,%s,%d,%d,%g,%zu,%.4g,%.4g,%.4g,%.4g,%.5f,%.5f,%.4g,%.4g\n", runs[k][0] ? "shifted" : "on_grid_lines",
                   runs[k][1] ? "pic" : "apic", runs[k][2], cells[i], 1.0 / cells[i], r.particles, r.err_bins,
                   r.err_smooth, r.err_mean, r.err_slope, r.ratio, 0.3 / 0.7, r.err_ratio, r.exx_eyy);
            fflush(stdout);
        }
}

static void shear(int quick) {
    (void)quick;
    static const char *names[] = {"triaxial_compression", "plane_strain", "inscribed", "simple_shear"};
    double mu_l, la;
    sm_lame(3.537e5, 0.3, &mu_l, &la);
    printf("dim,fit,phi,alpha,mu_eff,mu_sim,angle_eff\n");
    for (int d = 2; d <= 3; d++)
        for (int fit = 0; fit < 4; fit++)
            for (double phi = 20; phi <= 40.01; phi += 5) {
                double a = sm_cone_alpha(phi, (sm_cone_fit)fit, d);
                mp_shear_result r;
                mp_shear_run(d, a, mu_l, la, 1e-3, 1e-3, 2.0, &r);
                double me = sm_effective_friction(a, d);
                printf("%d,%s,%g,%.6f,%.6f,%.6f,%.3f\n", d, names[fit], phi, a, me, r.mu, atan(me) * 180 / PI);
            }
}

int main(int argc, char **argv) {
    int quick = argc > 2 && !strcmp(argv[2], "--quick");
    if (argc >= 2 && !strcmp(argv[1], "incline")) incline(quick);
    else if (argc >= 2 && !strcmp(argv[1], "incline_gate")) incline_gap = 0.35, incline(quick);
    else if (argc >= 2 && !strcmp(argv[1], "incline_stiffness")) incline_stiffness(quick);
    else if (argc >= 2 && !strcmp(argv[1], "incline_resolution")) incline_resolution(quick);
    else if (argc >= 2 && !strcmp(argv[1], "column")) column(quick);
    else if (argc >= 2 && !strcmp(argv[1], "shear")) shear(quick);
    else {
        fprintf(stderr, "usage: sm_validate incline|incline_gate|incline_stiffness|incline_resolution|column|shear [--quick]\n");
        return 2;
    }
    return 0;
}
