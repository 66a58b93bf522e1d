/* Status names and failure messages. */
#include "internal.h"

#include <stdio.h>
#include <stdlib.h>

const char *rto_status_string(rto_status s)
{
    switch (s) {
    case RTO_OK: return "ok";
    case RTO_ERR_INVALID_ARGUMENT: return "invalid argument";
    case RTO_ERR_OUT_OF_MEMORY: return "out of memory";
    case RTO_ERR_BUFFER_TOO_SMALL: return "buffer too small";
    case RTO_ERR_IO: return "i/o error";
    case RTO_ERR_PARSE: return "parse error";
    case RTO_ERR_UNSUPPORTED: return "unsupported";
    case RTO_ERR_MISMATCH: return "mismatch";
    }
    return "unknown status";
}

rto_status rto_msg_set(rto_msg *m, rto_status s, const char *fmt, ...)
{
    if (m) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(m->text, sizeof m->text, fmt, ap);
        va_end(ap);
    }
    return s;
}

void *rto_alloc(size_t count, size_t size)
{
    if (size != 0 && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    return malloc(bytes ? bytes : 1);
}
