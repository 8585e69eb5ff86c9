/* Tier-1 assertion failures (DESIGN §5): a broken invariant is a bug in the caller or in the
 * library; there is no sane way to continue, so abort (the one place the library stops). */
#include <stdio.h>
#include <stdlib.h>

#include "core/common.h"

void sm_assert_fail(const char *expr, const char *file, int line) {
    fprintf(stderr, "sandmpm: internal assertion failed: %s (%s:%d)\n", expr, file, line);
    abort();
}
