/* Moving colliders act through the grid (thesis §3.6.3: v_o in 3.100, constraints relative to the
 * collider): (1) a sticky ground sliding sideways at 0.3 m/s carries a sand block with it: after
 * 0.4 s the block's mean horizontal velocity is 0.3 m/s within 3%; (2) a separating plate rising
 * at 0.5 m/s lifts an elastic block resting on it: the block's mean vertical velocity over
 * [0.1 s, 0.4 s] is 0.5 m/s within 3% and the block stays on (not in) the plate; (3) a scripted motion function (the plate's
 * height as a function of time) gives the same lift. 2D and 3D. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

static void plate_motion(void *user, double t, sm_pose *pose) {
    (void)user;
    pose->position[0] = pose->position[2] = 0;
    pose->position[1] = 0.5 * t;
    pose->rotation[0] = 1;
    pose->rotation[1] = pose->rotation[2] = pose->rotation[3] = 0;
}

static sm_world *world(int dim, int *mat, int elastic) {
    sm_world_def def = sm_world_def_default();
    def.dim = dim;
    def.dx = dim == 2 ? 0.01 : 0.02;
    def.domain_max[0] = 1.0;
    def.domain_max[1] = 0.8;
    def.domain_max[2] = 0.4;
    sm_world *w = NULL;
    char err[256];
    if (sm_world_create(&def, &w, err, sizeof err) != SM_OK) return NULL;
    sm_material_def m = elastic ? sm_material_def_elastic() : sm_material_def_sand();
    if (elastic) m.youngs_modulus = 3e5;
    CHECK(sm_world_add_material(w, &m, mat) == SM_OK);
    return w;
}

static void seed_block(sm_world *w, int dim, int mat, double y0) {
    sm_shape box = sm_shape_default(SM_SHAPE_BOX);
    box.center[0] = 0.4;
    box.center[1] = y0 + 0.05;
    box.center[2] = 0.2;
    box.half_extent[0] = 0.1;
    box.half_extent[1] = 0.05;
    box.half_extent[2] = 0.08;
    sm_seed_def sd = sm_seed_def_default();
    sd.material = mat;
    sd.ppc = dim == 2 ? 4 : 8;
    CHECK(sm_world_seed_shape(w, &box, &sd, NULL) == SM_OK);
}

int main(void) {
    for (int dim = 2; dim <= 3; dim++) {
        /* (1) conveyor */
        int mat = 0;
        sm_world *w = world(dim, &mat, 0);
        sm_collider_def g = sm_test_ground(0.1);
        g.mode = SM_COLLIDE_STICKY;
        g.velocity[0] = 0.3;
        CHECK(sm_world_add_collider(w, &g, NULL) == SM_OK);
        seed_block(w, dim, mat, 0.1);
        CHECK(sm_world_advance(w, 0.4) == SM_OK);
        sm_diagnostics d;
        sm_world_diagnostics(w, &d);
        double vx = d.momentum[0] / d.total_mass;
        printf("%dD conveyor: block velocity %.4f m/s (ground 0.3)\n", dim, vx);
        CHECK_REL(vx, 0.3, 0.03, 0);
        sm_world_destroy(w);

        /* (2) rising plate (constant velocity) and (3) the same by a motion function */
        for (int scripted = 0; scripted < 2; scripted++) {
            w = world(dim, &mat, 1);
            sm_collider_def p = sm_collider_def_default();
            p.shape_count = 1;
            p.shapes[0] = sm_shape_default(SM_SHAPE_BOX);
            p.shapes[0].center[0] = 0.4;
            p.shapes[0].center[1] = 0.05;
            p.shapes[0].center[2] = 0.2;
            p.shapes[0].half_extent[0] = 0.25;
            p.shapes[0].half_extent[1] = 0.05;
            p.shapes[0].half_extent[2] = 0.15;
            p.mode = SM_COLLIDE_SEPARATE;
            if (scripted) p.motion = plate_motion;
            else p.velocity[1] = 0.5;
            CHECK(sm_world_add_collider(w, &p, NULL) == SM_OK);
            seed_block(w, dim, mat, 0.1);
            /* Mean velocity from the centre of mass over [0.1 s, 0.4 s]: the elastic block rings
             * after the plate starts at full speed, so the instantaneous velocity oscillates. */
            CHECK(sm_world_advance(w, 0.1) == SM_OK);
            sm_world_diagnostics(w, &d);
            double y1 = d.center_of_mass[1];
            CHECK(sm_world_advance(w, 0.4) == SM_OK);
            sm_world_diagnostics(w, &d);
            double vy = (d.center_of_mass[1] - y1) / 0.3;
            sm_pose pose;
            sm_world_collider_pose(w, 0, &pose);
            sm_particles_view pv;
            sm_world_particles(w, &pv);
            double lowest = 1e9;
            for (size_t i = 0; i < pv.n; i++) lowest = fmin(lowest, pv.x[i * dim + 1]);
            double top = 0.1 + pose.position[1];
            printf("%dD plate (%s): block velocity %.4f m/s (plate 0.5), plate top %.4f m, lowest particle %.4f m\n", dim,
                   scripted ? "motion function" : "constant velocity", vy, top, lowest);
            CHECK_REL(pose.position[1], 0.2, 1e-9, 0);
            CHECK_REL(vy, 0.5, 0.03, 0);
            CHECK(lowest >= top - 1e-6);
            CHECK(lowest <= top + 2 * sm_world_get_def(w)->dx);
            sm_world_destroy(w);
        }
    }
    return sm_test_summary("test_moving");
}
