/* sm_world_set_interrupt (sandmpm.h): sm_world_advance asks the poll before each step and returns
 * SM_OK at once when it answers non-zero, the world at the end of its last step:
 *  - a poll that answers 1 at its 6th call stops the advance after exactly 5 steps, before t_end,
 *    with sm_world_interrupted 1 (and 0 after an advance that was not interrupted);
 *  - the world there is whole: advanced on to t_end it has the state hash of a run that was never
 *    interrupted, and so has a world restored from a checkpoint saved there (bitwise resume in
 *    the middle of a frame);
 *  - removing the poll (NULL) lets the next advance run to its end. */
#include "test_util.h"
#include "sandmpm/sandmpm.h"

#include <stdlib.h>
#include <string.h>

static sm_world *build(void) {
    sm_world_def def = sm_world_def_default();
    def.dim = 2;
    def.dx = 0.02;
    def.threads = 1;
    const double c[3] = {0.5, 0.3, 0}, h[3] = {0.1, 0.15, 0};
    return sm_test_sand_box(&def, 0.1, c, h);
}

/* Answers 1 from its `at`-th call on. */
typedef struct poll_count {
    int calls, at;
} poll_count;

static int poll(void *user) {
    poll_count *p = user;
    return ++p->calls >= p->at;
}

int main(void) {
    const double t_end = 0.05;
    sm_world *ref = build(), *w = build();
    if (!ref || !w) return sm_test_summary("test_interrupt");
    CHECK(sm_world_advance(ref, t_end) == SM_OK);
    CHECK(sm_world_interrupted(ref) == 0);
    sm_diagnostics d;
    sm_world_diagnostics(ref, &d);
    const uint64_t steps_all = d.steps, h_ref = sm_world_state_hash(ref);
    CHECK(steps_all > 10);

    poll_count pc = {0, 6};
    sm_world_set_interrupt(w, poll, &pc);
    CHECK(sm_world_advance(w, t_end) == SM_OK);
    sm_world_diagnostics(w, &d);
    printf("interrupted after %llu of %llu steps at t = %.6g s (t_end %g)\n", (unsigned long long)d.steps,
           (unsigned long long)steps_all, sm_world_time(w), t_end);
    CHECK(sm_world_interrupted(w) == 1);
    CHECK(d.steps == 5 && pc.calls == 6);
    CHECK(sm_world_time(w) > 0 && sm_world_time(w) < t_end);

    sm_test_membuf ck = {NULL, 0, 0};
    CHECK(sm_world_save(w, sm_test_mem_write, &ck) == SM_OK);
    sm_world *resumed = NULL;
    char err[256];
    CHECK(sm_world_load(ck.data, ck.len, &resumed, err, sizeof err) == SM_OK);
    free(ck.data);

    sm_world_set_interrupt(w, NULL, NULL);
    CHECK(sm_world_advance(w, t_end) == SM_OK);
    CHECK(sm_world_interrupted(w) == 0);
    CHECK(sm_world_time(w) == t_end);
    CHECK(sm_world_state_hash(w) == h_ref);
    if (resumed) {
        CHECK(sm_world_advance(resumed, t_end) == SM_OK);
        CHECK(sm_world_state_hash(resumed) == h_ref);
        sm_world_destroy(resumed);
    }
    sm_world_destroy(ref);
    sm_world_destroy(w);
    return sm_test_summary("test_interrupt");
}
