/* Checks after validation, where the whole scene is known:
 *   - objects and emitters against the domain's usable region (2 cells inside its walls);
 *   - --set keys the scene never read;
 *   - the particles the objects will seed (their exact volume inside the usable region, volume.c)
 *     and the emitters will add, and the memory that takes, against the memory this process can
 *     still get (MemAvailable, and the room under RLIMIT_AS and RLIMIT_DATA): refused above
 *     SCENE_MEMORY_SHARE of it;
 *   - the time steps the run needs: end_time / dt with dt = min(max_dt, elastic_cfl dx / c
 *     (explicit; c = sqrt((lambda + 2 mu) / rho), the fastest material's elastic wave speed),
 *     cfl dx / v), v the largest speed the scene starts with (objects with their spin, emitters,
 *     rigid and keyframed colliders) plus |gravity| end_time: refused above SCENE_MAX_STEPS, a run
 *     that cannot finish (E = 1e300, cfl = 1e-300, fps = 1e-300 give 1e149 steps and more). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

#include "app/scene/scene_internal.h"

/* The usable region (domain rounded up to whole cells, less 2 dx on each side) where the library
 * seeds and emits. */
static void usable_region(const sm_world_def *d, double lo[3], double hi[3]) {
    for (int a = 0; a < 3; a++) lo[a] = hi[a] = 0;
    for (int a = 0; a < d->dim; a++) {
        double cells = ceil((d->domain_max[a] - d->domain_min[a]) / d->dx - 1e-9);
        lo[a] = d->domain_min[a] + 2 * d->dx;
        hi[a] = d->domain_min[a] + cells * d->dx - 2 * d->dx;
    }
}

/* Seeded particles (cell = dx^d); an object outside the usable region is an error. */
static sm_status estimate_objects(sm_scene *s, const double lo[3], const double hi[3], double cell, double *est,
                                  char *err, size_t errlen) {
    for (int i = 0; i < s->nobj; i++) {
        scene_object *o = &s->objs[i];
        double blo[3], bhi[3];
        char key[64], at[1100];
        snprintf(key, sizeof key, "objects[%d].shape", i + 1);
        int bounded = sc_shape_bbox(&o->shape, s->def.dim, blo, bhi);
        for (int a = 0; bounded && a < s->def.dim; a++)
            if (!(bhi[a] > lo[a] && blo[a] < hi[a]))
                return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                                   "%s: %s: outside the domain along %c (the shape spans %g .. %g; particles go in %g "
                                   ".. %g, 2 cells inside the domain)",
                                   sc_where(s, key, at, sizeof at), key, "xyz"[a], blo[a], bhi[a], lo[a], hi[a]);
        *est += sc_volume_in_box(&o->shape, o->has_clip ? &o->clip : NULL, s->def.dim, lo, hi, s->def.dx) / cell *
                o->seed.ppc;
    }
    return SM_OK;
}

/* Emitted particles up to end_time; an emitter outside the usable region is an error. */
static sm_status estimate_emitters(sm_scene *s, const double lo[3], const double hi[3], double cell, double *est,
                                   char *err, size_t errlen) {
    for (int i = 0; i < s->nemit; i++) {
        const sm_emitter_def *e = &s->emits[i];
        char at[1100], key[64];
        snprintf(key, sizeof key, "emitters[%d].shape", i + 1);
        if (!(sc_volume_in_box(&e->shape, NULL, s->def.dim, lo, hi, s->def.dx) > 0))
            return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                               "%s: %s: outside the domain (particles are emitted only in the part of the shape at "
                               "least 2 cells inside the domain's walls)",
                               sc_where(s, key, at, sizeof at), key);
        double t = fmin(e->stop, s->set.end_time) - e->start;
        if (t > 0) *est += e->rate * t / (s->mats[e->material].density * cell / e->ppc);
    }
    return SM_OK;
}

/* A number from a "Key: value" line of a /proc file (0 if absent). */
static double proc_value(const char *file, const char *key) {
    FILE *f = fopen(file, "r");
    if (!f) return 0;
    char line[256];
    double v = 0;
    size_t kl = strlen(key);
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, key, kl) && line[kl] == ':') {
            sscanf(line + kl + 1, "%lf", &v);
            break;
        }
    fclose(f);
    return v;
}

double sc_available_bytes(char *why, size_t n) {
    double avail = proc_value("/proc/meminfo", "MemAvailable") * 1024; /* kB */
    double vm = proc_value("/proc/self/status", "VmSize") * 1024, data = proc_value("/proc/self/status", "VmData") * 1024;
    if (!(avail > 0)) avail = INFINITY;
    int len = snprintf(why, n, "MemAvailable %.3g GB", avail / 1e9);
    const int res[2] = {RLIMIT_AS, RLIMIT_DATA};
    const char *names[2] = {"RLIMIT_AS", "RLIMIT_DATA"};
    const double used[2] = {vm, data};
    for (int k = 0; k < 2; k++) {
        struct rlimit rl;
        if (getrlimit(res[k], &rl) != 0 || rl.rlim_cur == RLIM_INFINITY) continue;
        double room = fmax(0, (double)rl.rlim_cur - used[k]);
        avail = fmin(avail, room);
        if (len >= 0 && (size_t)len < n)
            len += snprintf(why + len, n - (size_t)len, ", %s %.3g GB (%.3g GB of it free)", names[k],
                            (double)rl.rlim_cur / 1e9, room / 1e9);
    }
    return avail;
}

/* The speed |v| + |w| lever of a start (velocity v, spin w): if it is the fastest so far, keeps it
 * in *vmax and names it in what (fmt with the item's number). */
static void keep_fastest(const double v[3], const double w[3], double lever, double *vmax, char *what, size_t n,
                         const char *fmt, int item) {
    double sp = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * lever;
    if (!(sp > *vmax)) return;
    *vmax = sp;
    snprintf(what, n, fmt, item);
}

/* The largest speed the scene starts with, and which key gives it (in what). */
static double start_speed(const sm_scene *s, char *what, size_t n) {
    const sm_world_def *d = &s->def;
    double diag = 0, vmax = 0;
    for (int a = 0; a < d->dim; a++) diag += pow(d->domain_max[a] - d->domain_min[a], 2);
    diag = 0.5 * sqrt(diag); /* a lever arm for spins: half the domain's diagonal */
    snprintf(what, n, "nothing moves at the start");
    const double none[3] = {0, 0, 0};
    for (int i = 0; i < s->nobj; i++)
        keep_fastest(s->objs[i].seed.velocity, s->objs[i].seed.angular_velocity, diag, &vmax, what, n, "objects[%d]",
                     i + 1);
    for (int i = 0; i < s->nemit; i++)
        keep_fastest(s->emits[i].velocity, none, diag, &vmax, what, n, "emitters[%d].velocity", i + 1);
    for (int i = 0; i < s->ncol; i++) {
        const scene_collider *c = &s->cols[i];
        keep_fastest(c->def.velocity, c->def.angular_velocity, diag, &vmax, what, n, "colliders[%d]", i + 1);
        for (int k = 0; k + 1 < c->nkf; k++) {
            double v[3];
            for (int a = 0; a < 3; a++) v[a] = (c->kf[k + 1].pos[a] - c->kf[k].pos[a]) / (c->kf[k + 1].t - c->kf[k].t);
            keep_fastest(v, none, diag, &vmax, what, n, "colliders[%d].keyframes", i + 1);
        }
    }
    return vmax;
}

/* The run's time steps against SCENE_MAX_STEPS. */
static sm_status check_steps(const sm_scene *s, char *err, size_t errlen) {
    const sm_world_def *d = &s->def;
    double T = s->set.end_time, dt = d->max_dt, c = 0;
    char why[300], src[96];
    snprintf(why, sizeof why, "max_dt");
    int fastest = -1;
    for (int i = 0; i < s->nmat; i++) {
        const sm_material_def *m = &s->mats[i];
        double mu = m->youngs_modulus / (2 * (1 + m->poisson_ratio));
        double lambda = m->youngs_modulus * m->poisson_ratio / ((1 + m->poisson_ratio) * (1 - 2 * m->poisson_ratio));
        double ci = sqrt((lambda + 2 * mu) / m->density);
        if (ci > c) c = ci, fastest = i;
    }
    if (d->integrator == SM_INTEGRATOR_EXPLICIT && d->elastic_cfl > 0 && c > 0 && d->elastic_cfl * d->dx / c < dt) {
        dt = d->elastic_cfl * d->dx / c;
        snprintf(why, sizeof why, "elastic_cfl dx / c with the elastic wave speed c = %.3g m/s of materials.%s", c,
                 s->mat_names[fastest]);
    }
    double g = sqrt(d->gravity[0] * d->gravity[0] + d->gravity[1] * d->gravity[1] + d->gravity[2] * d->gravity[2]);
    double v = start_speed(s, src, sizeof src) + g * T;
    if (v > 0 && d->cfl * d->dx / v < dt) {
        dt = d->cfl * d->dx / v;
        snprintf(why, sizeof why, "cfl dx / v with v = %.3g m/s: the fastest start (%s) plus |gravity| end_time", v, src);
    }
    double steps = T / dt + s->set.frames;
    if (steps <= SCENE_MAX_STEPS) return SM_OK;
    return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                       "%s: the run cannot finish: about %.3g time steps for end_time %g s (%d frames at %g fps), dt "
                       "about %.3g s from %s; at most %.0e steps are allowed (check E, cfl, max_dt, fps and the "
                       "speeds)",
                       s->path, steps, T, s->set.frames, s->set.fps, dt, why, (double)SCENE_MAX_STEPS);
}

sm_status sc_finish_load(sm_scene *s, char *err, size_t errlen) {
    sm_world_def *d = &s->def;
    char msg[256];
    if (sm_world_def_check(d, msg, sizeof msg) != SM_OK) /* validation checked it: not reached */
        return sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: %s", s->path, msg);
    size_t grid = sm_world_def_grid_bytes(d);
    double lo[3], hi[3], est = 0, emitted = 0, cell = pow(d->dx, d->dim);
    usable_region(d, lo, hi);
    sm_status st = estimate_objects(s, lo, hi, cell, &est, err, errlen);
    if (st == SM_OK) st = estimate_emitters(s, lo, hi, cell, &emitted, err, errlen);
    if (st != SM_OK) return st;
    for (int i = 0; i < s->nparams; i++)
        if (!s->params[i].used) {
            const char *sug = sc_closest(s->params[i].key, (const char *const *)s->read_keys, s->nread);
            char hint[200] = "";
            if (sug) snprintf(hint, sizeof hint, " (did you mean \"%s\"?)", sug);
            return sc_fail_msg(err, errlen, SM_ERR_INVALID, "%s: --set %s=%s: the scene does not use params.%s%s",
                               s->path, s->params[i].key, s->params[i].value, s->params[i].key, hint);
        }
    s->set.estimated_particles = est < 1e18 ? (size_t)llround(est) : (size_t)-1;
    s->set.estimated_emitted = emitted < 1e18 ? (size_t)llround(emitted) : (size_t)-1;
    double bytes = (double)grid + (est + emitted) * (double)sm_particle_bytes(d->dim);
    s->set.estimated_bytes = bytes > 1e18 ? (size_t)-1 : (size_t)bytes;
    char why[300];
    double avail = sc_available_bytes(why, sizeof why);
    if (bytes > SCENE_MEMORY_SHARE * avail)
        return sc_fail_msg(err, errlen, SM_ERR_INVALID,
                           "%s: the scene needs about %.3g GB (%.0f particles seeded, %.0f emitted, grid included) but "
                           "this process can have about %.3g GB (%s), and a scene may take %.0f%% of it: use a coarser "
                           "quality or a larger dx",
                           s->path, bytes / 1e9, est, emitted, avail / 1e9, why, 100 * SCENE_MEMORY_SHARE);
    return check_steps(s, err, errlen);
}
