/* Block on an incline (Coulomb friction through the collider, thesis §3.6.3, Algorithm 7): an
 * elastic block on a slip half-space tilted 30 degrees (not grid aligned) with mu = 0.2 slides
 * with acceleration g (sin 30 - mu cos 30) = 3.206 m/s^2 within 2%; with mu = 0.7 >= tan 30 it
 * moves less than dx in 1 s. 2D and 3D. The block is elastic (rho 1000, E 1e6, nu 0.3), starts a
 * quarter cell above the plane and at rest.
 *
 * The static case relies on sm_world_def.static_friction_sticks (default on): with positions and F
 * taken from pre-friction velocities only (thesis §3.6.5), the contact nodes, which hold about 2% of
 * the mass, creep at about g sin(theta) dt M / m_contact (0.14 m/s here) even for mu = 5; that is
 * measured below as well and asserted to be much larger, so a regression to that behaviour is seen.
 * With it, a sliding contact node also moves (positions, F) with its post-friction velocity; with the
 * pre-friction one (the rule until 2026-12-07) the contact fed the block's vibration at long time
 * steps: at elastic_cfl 0.7 the 2D block kept sliding 4.3 mm between 1.0 s and 1.5 s (25.6 mm by 1 s,
 * 29.8 mm by 1.5 s) after its release, and at the default 0.6 it moved 20.7 mm in 1 s (more than dx).
 * Now the release transient (the block rings after its drop onto the plane) ends within 0.4 s at
 * 0.6 (7.0 mm; 6.2 mm at 0.5) and within 1 s at 0.7 (15.6 mm), and then the block holds: asserted
 * below at the default and at 0.7 (float Release, 2026-12-07). */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

static const double TH = 30.0 * 3.14159265358979323846 / 180.0;

/* Returns the fitted acceleration along the slope over [t_fit0, t_end], and the displacement; at
 * elastic_cfl (0: the default), and the displacement at t_mid too (if disp_mid). */
static void run_cfl(int dim, double mu, double t_end, int sticks, double elastic_cfl, double t_mid, double *disp_mid,
                    double *accel, double *disp, double *dx_out) {
    sm_world_def def = sm_world_def_default();
    def.static_friction_sticks = sticks;
    if (elastic_cfl > 0) def.elastic_cfl = elastic_cfl;
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.02;
    def.domain_min[0] = 0;
    def.domain_max[0] = 2.0;
    def.domain_min[1] = 0;
    def.domain_max[1] = 1.3;
    def.domain_max[2] = 0.3;
    *dx_out = def.dx;
    sm_world *w = NULL;
    char err[256];
    CHECK(sm_world_create(&def, &w, err, sizeof err) == SM_OK);
    if (!w) return;
    sm_material_def m = sm_material_def_elastic();
    m.youngs_modulus = 1e6; /* a stiff block: little elastic bouncing at first contact */
    int mat = -1;
    CHECK(sm_world_add_material(w, &m, &mat) == SM_OK);
    const double n[3] = {-sin(TH), cos(TH), 0}, tdown[3] = {-cos(TH), -sin(TH), 0};
    const double p0[3] = {1.0, 0.6, 0.15};
    sm_collider_def c = sm_collider_def_default();
    c.shape_count = 1;
    c.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    for (int a = 0; a < 3; a++) {
        c.shapes[0].center[a] = p0[a];
        c.shapes[0].normal[a] = n[a];
    }
    c.mode = SM_COLLIDE_SLIP;
    c.friction = mu;
    CHECK(sm_world_add_collider(w, &c, NULL) == SM_OK);
    /* Block rotated by theta about z, bottom face on the plane. */
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    const double hx = 0.1, hy = 0.05, hz = 0.05, s_up = 0.6;
    for (int a = 0; a < 3; a++) box.center[a] = p0[a] - s_up * tdown[a] + (hy + 0.25 * def.dx) * n[a];
    box.center[2] = 0.15;
    box.half_extent[0] = hx;
    box.half_extent[1] = hy;
    box.half_extent[2] = hz;
    box.rotation[0] = cos(TH / 2);
    box.rotation[3] = sin(TH / 2);
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = dim == 2 ? 4 : 8;
    size_t added = 0;
    CHECK(sm_world_seed_shape(w, &box, &sd, &added) == SM_OK);
    CHECK(added > 500);
    sm_diagnostics d;
    sm_world_diagnostics(w, &d);
    double c0 = d.center_of_mass[0] * tdown[0] + d.center_of_mass[1] * tdown[1];
    /* Least-squares slope of v(t) on [0.1 s, t_end]; frames of 10 ms. */
    double St = 0, Sv = 0, Stt = 0, Stv = 0;
    int k = 0;
    for (int f = 1; f * 0.01 <= t_end + 1e-9; f++) {
        CHECK(sm_world_advance(w, f * 0.01) == SM_OK);
        sm_world_diagnostics(w, &d);
        double t = sm_world_time(w);
        double v = (d.momentum[0] * tdown[0] + d.momentum[1] * tdown[1]) / d.total_mass;
        if (disp_mid && fabs(t - t_mid) < 1e-9)
            *disp_mid = d.center_of_mass[0] * tdown[0] + d.center_of_mass[1] * tdown[1] - c0;
        if (t >= 0.1 - 1e-9) {
            St += t;
            Sv += v;
            Stt += t * t;
            Stv += t * v;
            k++;
        }
    }
    *accel = (k * Stv - St * Sv) / (k * Stt - St * St);
    *disp = d.center_of_mass[0] * tdown[0] + d.center_of_mass[1] * tdown[1] - c0;
    sm_world_destroy(w);
}

/* run_cfl at the default elastic_cfl, without the displacement at t_mid. */
static void run(int dim, double mu, double t_end, int sticks, double *accel, double *disp, double *dx_out) {
    run_cfl(dim, mu, t_end, sticks, 0, 0, NULL, accel, disp, dx_out);
}

int main(void) {
    const double g = 9.81;
    for (int dim = 2; dim <= 3; dim++) {
        double a, s, dx;
        run(dim, 0.2, 0.5, 1, &a, &s, &dx);
        double expect = g * (sin(TH) - 0.2 * cos(TH));
        printf("%dD mu = 0.2: fitted acceleration %.4f m/s^2, expected %.4f (%.2f%%), moved %.3f m\n", dim, a, expect,
               100 * (a - expect) / expect, s);
        CHECK_REL(a, expect, 0.02, 0);
        run(dim, 0.7, 1.0, 1, &a, &s, &dx);
        printf("%dD mu = 0.7: moved %.2e m in 1 s (dx = %.3f)\n", dim, s, dx);
        CHECK(fabs(s) < dx);
        if (dim == 2) {
            double s2;
            run(dim, 0.7, 0.5, 0, &a, &s2, &dx);
            printf("%dD mu = 0.7, pre-friction positions only: moved %.2e m in 0.5 s\n", dim, s2);
            CHECK(s2 > 2 * dx);
            /* At elastic_cfl 0.7 the release transient is longer, but once it is over the block holds. */
            double s10 = 0, s15;
            run_cfl(dim, 0.7, 1.5, 1, 0.7, 1.0, &s10, &a, &s15, &dx);
            printf("%dD mu = 0.7, elastic_cfl 0.7: moved %.2e m by 1 s, %.2e m from 1 s to 1.5 s\n", dim, s10, s15 - s10);
            CHECK(fabs(s15 - s10) < 0.01 * dx);
        }
    }
    return sm_test_summary("test_incline");
}
