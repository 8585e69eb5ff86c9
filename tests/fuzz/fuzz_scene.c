/* libFuzzer harness (and, through replay.c, a CTest case): the Lua scene loader on arbitrary bytes.
 *
 * The input is the scene file's text (up to the first NUL byte). sm_scene_load must return SM_OK
 * with a scene, or an error code with no scene and a message; never crash, leak, hang or trip a
 * sanitizer. The sandbox's limits are lowered (sc_scene_limits, app/scene/scene_internal.h) so that
 * one input runs in milliseconds; the mechanism is the one the defaults use (tests/test_scene.c
 * proves the limits themselves, issue 12 item 6). A scene that loads is built (seeded, motion
 * functions called at t = 0) only if the loader's own estimate says it is small: the fuzzer must
 * not spend its time and memory seeding millions of particles, which the memory guard allows. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/scene.h"
#include "app/scene/scene_internal.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FUZZ_BUILD_BYTES ((size_t)1 << 20) /* build the world only below this estimate (1 MB: a few thousand particles) */

static void fuzz_fail(const char *what, const char *err) {
    fprintf(stderr, "fuzz_scene: %s (message: \"%s\")\n", what, err);
    abort();
}

static void lower_limits(void) {
    sc_scene_limits.scene_insn = 200000;
    sc_scene_limits.motion_insn = 20000;
    sc_scene_limits.scene_time = 0.05;
    sc_scene_limits.motion_time = 0.01;
    sc_scene_limits.mem = (size_t)16 << 20;
}

static void check_loaded(sm_scene *s, int verbose) {
    char err[512] = "";
    const sm_scene_settings *set = sm_scene_get_settings(s);
    if (verbose) fprintf(stderr, "fuzz_scene: loaded, estimate %zu bytes\n", set ? set->estimated_bytes : 0);
    if (!set || !(set->fps > 0) || set->frames < 0) fuzz_fail("loaded scene with bad settings", err);
    const sm_world_def *def = sm_scene_world_def(s);
    if (!def || !(def->dx > 0)) fuzz_fail("loaded scene with bad world definition", err);
    int nm = sm_scene_material_count(s);
    for (int i = 0; i < nm; i++)
        if (!sm_scene_material_name(s, i)) fuzz_fail("material without a name", err);
    if (sm_scene_material_name(s, nm) != NULL) fuzz_fail("material past the count", err);
    if (set->estimated_bytes > FUZZ_BUILD_BYTES) return;
    sm_status st = sm_scene_build(s, err, sizeof err);
    if (st == SM_OK && !sm_scene_world(s)) fuzz_fail("built without a world", err);
    if (st != SM_OK && err[0] == '\0') fuzz_fail("build failed without a message", err);
    if (verbose) fprintf(stderr, "fuzz_scene: build: %d %s\n", (int)st, err);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    lower_limits();
    char *src = malloc(size + 1);
    if (!src) return 0;
    memcpy(src, data, size);
    src[size] = '\0';
    /* a --set parameter, for the scenes that read it (an unread one is an error, tested once) */
    static const sm_scene_param params[] = {{"n", "3"}};
    int np = strstr(src, "params.n") ? 1 : 0;
    sm_scene *s = NULL;
    char err[512] = "";
    sm_status st = sm_scene_load("fuzz.lua", src, params, np, "test", 1, &s, err, sizeof err);
    const int verbose = getenv("SM_FUZZ_VERBOSE") != NULL; /* to see what an input does */
    if (verbose) fprintf(stderr, "fuzz_scene: load: %d %s\n", (int)st, err);
    if (st == SM_OK) {
        if (!s) fuzz_fail("SM_OK without a scene", err);
        check_loaded(s, verbose);
    } else {
        if (s) fuzz_fail("an error with a scene", err);
        if (err[0] == '\0') fuzz_fail("an error without a message", err);
    }
    sm_scene_destroy(s);
    free(src);
    return 0;
}
