/* Same results: prints state hashes of a fixed set of scenarios, step by step, so that a refactor
 * can prove it keeps the bits (scripts/same-results.sh compares this output with a stored
 * reference). Not a CTest test: the reference belongs to one machine and one compiler; the
 * script is run before and after a change, back to back.
 *
 * The scenarios cover every branch of the step: 2D and 3D, both kernels, APIC / PIC / FLIP,
 * hardening and fixed-angle sand and an elastic body, sticky / slip / separating colliders with
 * friction, moving colliders (constant velocity, angular velocity, motion function), the domain
 * walls, an emitter, Poisson seeding, the storage reorder, and the implicit integrator. Each line
 * is "scenario step hash" plus, at the end, the diagnostics that are not particle state
 * (projected, clamped, Newton and GMRES counts, energies printed with %.17g). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "sandmpm/sandmpm.h"

static void motion(void *user, double t, sm_pose *pose) {
    (void)user;
    pose->position[0] = 0.05 * sin(6.0 * t);
    pose->position[1] = 0.02 * t;
    pose->position[2] = 0;
    double h = 0.5 * 0.8 * t; /* rotation about z at 0.8 rad/s */
    pose->rotation[0] = cos(h);
    pose->rotation[1] = pose->rotation[2] = 0;
    pose->rotation[3] = sin(h);
}

typedef struct scenario {
    const char *name;
    int dim;
    sm_kernel kernel;
    sm_transfer transfer;
    sm_integrator integrator;
    int fixed_angle; /* sand without hardening */
    int emitter;
    int steps;
} scenario;

static sm_world *build(const scenario *s, int threads) {
    sm_world_def def = sm_world_def_default();
    def.dim = s->dim;
    def.dx = s->dim == 2 ? 0.01 : 0.04;
    def.kernel = s->kernel;
    def.transfer = s->transfer;
    def.integrator = s->integrator;
    def.threads = threads;
    def.wall_mode = SM_COLLIDE_SLIP;
    def.wall_friction = 0.3;
    if (s->integrator == SM_INTEGRATOR_IMPLICIT) {
        def.max_dt = 4e-3;
        def.cfl = 0.9; /* cfl = 1 trips the CFL self-rejection (issue 12) within 5 steps */
    }
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) {
        fprintf(stderr, "%s: %s\n", s->name, err);
        return NULL;
    }
    sm_material_def m = sm_material_def_sand();
    if (s->fixed_angle) {
        m.hardening = 0;
        m.friction_angle = 32;
    }
    int sand = -1;
    sm_world_add_material(w, &m, &sand);
    sm_material_def e = sm_material_def_elastic();
    int ball = -1;
    sm_world_add_material(w, &e, &ball);

    sm_collider_def g = sm_collider_def_default();
    g.shape_count = 1;
    g.shapes[0] = sm_shape_default(SM_SHAPE_HALFSPACE);
    g.shapes[0].center[1] = 0.1;
    g.shapes[0].normal[0] = 0.1;
    g.shapes[0].normal[1] = 1;
    g.mode = SM_COLLIDE_SLIP;
    g.friction = 0.4;
    sm_world_add_collider(w, &g, NULL);

    sm_collider_def sp = sm_collider_def_default();
    sp.shape_count = 1;
    sp.shapes[0] = sm_shape_default(SM_SHAPE_SPHERE);
    sp.shapes[0].center[0] = 0.72;
    sp.shapes[0].center[1] = 0.25;
    sp.shapes[0].center[2] = 0.5;
    sp.shapes[0].radius = 0.08;
    sp.velocity[0] = -1.0;
    sp.angular_velocity[2] = 2.0;
    sp.mode = SM_COLLIDE_SEPARATE;
    sp.friction = 0.2;
    sm_world_add_collider(w, &sp, NULL);

    sm_collider_def bx = sm_collider_def_default();
    bx.shape_count = 2;
    bx.shapes[0] = sm_shape_default(SM_SHAPE_BOX);
    bx.shapes[0].center[0] = 0.2;
    bx.shapes[0].center[1] = 0.2;
    bx.shapes[0].center[2] = 0.5;
    bx.shapes[0].half_extent[0] = 0.03;
    bx.shapes[0].half_extent[1] = 0.08;
    bx.shapes[0].half_extent[2] = 0.2;
    bx.shapes[1] = sm_shape_default(SM_SHAPE_CYLINDER);
    bx.shapes[1].center[0] = 0.2;
    bx.shapes[1].center[1] = 0.3;
    bx.shapes[1].center[2] = 0.5;
    bx.shapes[1].radius = 0.03;
    bx.shapes[1].half_height = 0.05;
    bx.mode = SM_COLLIDE_STICKY;
    bx.motion = motion;
    sm_world_add_collider(w, &bx, NULL);

    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.45;
    box.center[1] = 0.3;
    box.center[2] = 0.5;
    box.half_extent[0] = box.half_extent[1] = box.half_extent[2] = 0.14;
    box.rotation[0] = cos(0.1);
    box.rotation[3] = sin(0.1);
    sm_seed_def sd = sm_seed_def_default();
    sd.material = sand;
    sd.ppc = s->dim == 2 ? 4 : 8;
    sd.velocity[0] = 0.3;
    sm_world_seed_shape(w, &box, &sd, NULL);
    sm_shape sph = sm_shape_default(SM_SHAPE_SPHERE);
    sph.center[0] = 0.45;
    sph.center[1] = 0.62;
    sph.center[2] = 0.5;
    sph.radius = 0.07;
    sd.material = ball;
    sd.velocity[0] = 0;
    sd.velocity[1] = -3;
    sd.angular_velocity[2] = 4;
    sd.method = SM_SEED_POISSON;
    sd.seed = 7;
    sm_world_seed_shape(w, &sph, &sd, NULL);
    if (s->emitter) {
        sm_emitter_def em = sm_emitter_def_default();
        em.shape = sm_shape_default(SM_SHAPE_SPHERE);
        em.shape.center[0] = 0.6;
        em.shape.center[1] = 0.8;
        em.shape.center[2] = 0.5;
        em.shape.radius = 0.05;
        em.material = sand;
        em.ppc = s->dim == 2 ? 4 : 8;
        em.velocity[1] = -1;
        em.rate = s->dim == 2 ? 40 : 4;
        em.start = 0;
        em.stop = 1;
        em.seed = 11;
        sm_world_add_emitter(w, &em, NULL);
    }
    return w;
}

static int run(const scenario *s, int threads) {
    sm_world *w = build(s, threads);
    if (!w) return 1;
    printf("%s threads=%d start %016llx\n", s->name, threads, (unsigned long long)sm_world_state_hash(w));
    int rc = 0;
    for (int i = 1; i <= s->steps; i++) {
        sm_status st = sm_world_step(w, sm_world_next_dt(w, 10.0));
        for (int tries = 0; st != SM_OK && sm_world_step_refused(w) && tries < 60; tries++)
            st = sm_world_step(w, sm_world_next_dt(w, 10.0)); /* a refused dt, retried at half of it */
        if (st != SM_OK) {
            printf("%s threads=%d step %d failed: %s\n", s->name, threads, i, sm_world_errmsg(w));
            rc = 1;
            break;
        }
        if (i % 10 == 0 || i == s->steps)
            printf("%s threads=%d step %d %016llx\n", s->name, threads, i, (unsigned long long)sm_world_state_hash(w));
    }
    sm_diagnostics dg;
    sm_world_diagnostics(w, &dg);
    printf("%s threads=%d diag n=%zu t=%.17g mass=%.17g ke=%.17g ee=%.17g projected=%llu clamped=%llu newton=%llu "
           "gmres=%llu unconverged=%llu residual=%.17g\n",
           s->name, threads, dg.particles, dg.time, dg.total_mass, dg.kinetic_energy, dg.elastic_energy,
           (unsigned long long)dg.projected_particles, (unsigned long long)dg.clamped_particles,
           (unsigned long long)dg.newton_iterations, (unsigned long long)dg.gmres_iterations,
           (unsigned long long)dg.newton_unconverged, dg.last_newton_residual);
    sm_world_destroy(w);
    return rc;
}

int main(int argc, char **argv) {
    const scenario all[] = {
        {"2d-quad-apic", 2, SM_KERNEL_QUADRATIC, SM_TRANSFER_APIC, SM_INTEGRATOR_EXPLICIT, 0, 1, 120},
        {"2d-cubic-flip", 2, SM_KERNEL_CUBIC, SM_TRANSFER_FLIP, SM_INTEGRATOR_EXPLICIT, 1, 0, 80},
        {"2d-quad-pic", 2, SM_KERNEL_QUADRATIC, SM_TRANSFER_PIC, SM_INTEGRATOR_EXPLICIT, 1, 1, 60},
        {"3d-quad-apic", 3, SM_KERNEL_QUADRATIC, SM_TRANSFER_APIC, SM_INTEGRATOR_EXPLICIT, 0, 1, 80},
        {"3d-cubic-flip", 3, SM_KERNEL_CUBIC, SM_TRANSFER_FLIP, SM_INTEGRATOR_EXPLICIT, 0, 0, 40},
        {"3d-cubic-pic", 3, SM_KERNEL_CUBIC, SM_TRANSFER_PIC, SM_INTEGRATOR_EXPLICIT, 1, 0, 30},
        {"2d-implicit", 2, SM_KERNEL_QUADRATIC, SM_TRANSFER_APIC, SM_INTEGRATOR_IMPLICIT, 0, 1, 12},
        {"3d-implicit", 3, SM_KERNEL_QUADRATIC, SM_TRANSFER_APIC, SM_INTEGRATOR_IMPLICIT, 1, 0, 6},
    };
    const char *only = argc > 1 ? argv[1] : NULL;
    int rc = 0;
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) {
        if (only && strcmp(only, all[i].name) != 0) continue;
        rc |= run(&all[i], 1);
        rc |= run(&all[i], 2);
    }
    return rc;
}
