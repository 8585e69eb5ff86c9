/* The app's functions take a message buffer (char *err, size_t errlen) and most accept none
 * (NULL or 0): sm_errbuf_or_own then points them at a small buffer of the caller's own. */
#ifndef SM_APP_ERRBUF_H
#define SM_APP_ERRBUF_H

#include <stddef.h>

static inline void sm_errbuf_or_own(char **err, size_t *errlen, char *own, size_t ownlen) {
    if (!*err || *errlen == 0) {
        *err = own;
        *errlen = ownlen;
    }
    (*err)[0] = 0;
}

#endif
