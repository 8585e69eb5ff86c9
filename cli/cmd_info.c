/* sandmpm info SCENE: the resolved scene without running it. */
#include <string.h>

#include "cli/cli.h"

/* The settings and estimates, before the world is built. */
static void print_settings(const cli_scene_opts *so, const sm_scene *sc) {
    const sm_scene_settings *st = sm_scene_get_settings(sc);
    const sm_world_def *d = sm_scene_world_def(sc);
    printf("scene        %s (quality %s)\n", so->scene ? so->scene : "built-in default", so->quality ? so->quality : "preview");
    printf("dimension    %d\n", d->dim);
    printf("dx           %g m\n", d->dx);
    printf("domain       [%g, %g] x [%g, %g]", d->domain_min[0], d->domain_max[0], d->domain_min[1], d->domain_max[1]);
    if (d->dim == 3) printf(" x [%g, %g]", d->domain_min[2], d->domain_max[2]);
    printf(" m\n");
    printf("frames       %d at %g fps (end time %g s)\n", st->frames, st->fps, st->end_time);
    printf("estimate     %zu particles seeded, %zu emitted; world memory %.3f GB (machine %.1f GB)\n", st->estimated_particles,
           st->estimated_emitted, (double)st->estimated_bytes / 1e9, cli_machine_bytes() / 1e9);
    for (int i = 0; i < sm_scene_mesh_count(sc); i++) {
        sm_scene_mesh_info m;
        if (!sm_scene_mesh(sc, i, &m)) continue;
        const sm_mesh_field_stats *f = m.field;
        char anim[64] = "";
        if (m.frames > 0) snprintf(anim, sizeof anim, " (%d frames at %g fps)", m.frames, m.fps);
        printf("mesh         %s: %s%s: %zu %s; field %zu bricks, %.3f MB, spacing %g m, band %g m, %s%s; %s in %.3f s\n",
               m.key, m.file, anim, m.triangles, f->dim == 3 ? "triangles" : "segments", f->bricks, (double)f->bytes / 1e6,
               f->spacing, f->band, m.sign, f->container ? " (container)" : "",
               !strcmp(m.source, "built") ? "built" : !strcmp(m.source, "cache") ? "read from the cache" : "shared",
               m.seconds);
    }
}

/* What the built world holds. */
static void print_world(sm_scene *sc) {
    sm_world *w = sm_scene_world(sc);
    const sm_world_def *wd = sm_world_get_def(w);
    int n[3];
    sm_world_grid_size(w, n);
    sm_diagnostics dg;
    sm_world_diagnostics(w, &dg);
    printf("particles    %zu (mass %.6g kg)\n", dg.particles, dg.total_mass);
    printf("grid         %d x %d", n[0], n[1]);
    if (wd->dim == 3) printf(" x %d", n[2]);
    printf(" nodes\n");
    printf("materials    %d:", sm_scene_material_count(sc));
    for (int m = 0; m < sm_scene_material_count(sc); m++) printf(" %s", sm_scene_material_name(sc, m));
    printf("\ncolliders    %d\n", sm_world_collider_count(w));
    printf("integrator   %s, kernel %s, transfer %s\n", wd->integrator == SM_INTEGRATOR_IMPLICIT ? "implicit" : "explicit",
           wd->kernel == SM_KERNEL_CUBIC ? "cubic" : "quadratic",
           wd->transfer == SM_TRANSFER_APIC ? "APIC" : wd->transfer == SM_TRANSFER_PIC ? "PIC" : "FLIP");
    double first = sm_world_next_dt(w, 1e30);
    printf("time step    max %g s, CFL %g; first step %g s\n", wd->max_dt, wd->cfl, first);
}

static sm_status info_command(int argc, char **argv) {
    if (cli_help_requested(argc, argv)) {
        cli_usage_info(stdout);
        return SM_OK;
    }
    cli_scene_opts so;
    memset(&so, 0, sizeof so);
    for (int i = 0; i < argc; i++) {
        int r = cli_parse_scene_opt("info", argc, argv, &i, &so);
        if (r < 0) return SM_ERR_INVALID;
        if (r > 0) continue;
        if (argv[i][0] == '-' || so.scene) {
            fprintf(stderr, "sandmpm info: unexpected argument \"%s\" (see sandmpm info --help)\n", argv[i]);
            return SM_ERR_INVALID;
        }
        so.scene = argv[i];
    }
    sm_scene *sc = NULL;
    sm_status st = cli_load_scene("info", &so, &sc);
    if (st != SM_OK) return st;
    print_settings(&so, sc);
    st = cli_check_memory("info", sm_scene_get_settings(sc));
    if (st == SM_OK) st = cli_build_scene("info", sc);
    if (st == SM_OK) print_world(sc);
    if (st == SM_OK) st = cli_info_estimates(sc);
    sm_scene_destroy(sc);
    return st;
}

int cli_info(int argc, char **argv) { return cli_exit_code(info_command(argc, argv)); }
