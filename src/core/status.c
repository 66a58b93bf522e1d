/* Status names and failure messages. */
#include "internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

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
        /* Formatted aside first: a caller may pass m->text itself as an argument ("bounce %u: %s", ..., m->text) to
         * prefix the message, and vsnprintf over its own source repeats the prefix. */
        char text[sizeof m->text];
        va_start(ap, fmt);
        vsnprintf(text, sizeof text, fmt, ap);
        va_end(ap);
        memcpy(m->text, text, sizeof text);
    }
    return s;
}

void *rto__alloc(size_t count, size_t size)
{
    if (size != 0 && count > SIZE_MAX / size)
        return NULL;
    size_t bytes = count * size;
    return malloc(bytes ? bytes : 1);
}

void *rto__alloc_lines(size_t count, size_t size)
{
    if (size != 0 && count > SIZE_MAX / size)
        return NULL;
    const size_t bytes = count * size;
    void *p = NULL;
    return posix_memalign(&p, 64, bytes ? bytes : 1) ? NULL : p;
}

/* Buffers from 4 MiB up are aligned to 2 MiB and advised as transparent huge pages (the kernel's default mode on
 * Debian is "madvise"): a 1080p frame touches about a GiB of new memory, and first-touch page faults on 4 KiB pages
 * cost more than tracing it. Smaller ones are cache-line aligned (rto__alloc_lines). Either way free() releases it. */
#define HUGE_FROM ((size_t)4 << 20)
#define HUGE_PAGE ((size_t)2 << 20)

void *rto__alloc_large(size_t count, size_t size)
{
    if (size != 0 && count > SIZE_MAX / size)
        return NULL;
    const size_t bytes = count * size;
    if (bytes < HUGE_FROM)
        return rto__alloc_lines(count, size);
    void *p = NULL;
    if (posix_memalign(&p, HUGE_PAGE, bytes))
        return NULL;
#ifdef MADV_HUGEPAGE
    madvise(p, bytes & ~(HUGE_PAGE - 1), MADV_HUGEPAGE); /* advice only: a kernel without THP ignores it */
#endif
    return p;
}

/* The cgroup v2 memory limit of this process's group as the group sees itself (a container's limit); 0 when there
 * is none ("max") or no cgroup v2 file. */
static uint64_t cgroup_memory_max(void)
{
    FILE *fp = fopen("/sys/fs/cgroup/memory.max", "r");
    if (!fp)
        return 0;
    char line[64] = "";
    const int ok = fgets(line, sizeof line, fp) != NULL;
    fclose(fp);
    char *end = NULL;
    const unsigned long long v = ok ? strtoull(line, &end, 10) : 0;
    return ok && end != line ? (uint64_t)v : 0;
}

uint64_t rto_memory_budget_default(void)
{
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    uint64_t budget = pages > 0 && page > 0 ? (uint64_t)pages * (uint64_t)page / 2 : 0;
    struct rlimit rl;
    if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && (!budget || rl.rlim_cur / 2 < budget))
        budget = (uint64_t)rl.rlim_cur / 2;
    const uint64_t group = cgroup_memory_max();
    if (group && (!budget || group / 2 < budget))
        budget = group / 2;
    return budget;
}
