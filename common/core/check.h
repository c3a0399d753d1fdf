// Always-on and debug-only invariant checks: a failed check is a bug, never bad input.
#pragma once

#include <cstdio>
#include <cstdlib>

#define RTPM_CHECK(cond)                                                                  \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            std::fprintf(stderr, "%s:%d: RTPM_CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
            std::abort();                                                                 \
        }                                                                                 \
    } while (0)

#ifdef NDEBUG
#define RTPM_DCHECK(cond) \
    do {                  \
    } while (0)
#else
#define RTPM_DCHECK(cond) RTPM_CHECK(cond)
#endif
