/* What the CPU can run: the SIMD paths (the bitonic network's, the tracer's) are chosen at run time. */
#include "internal.h"

#include <stdlib.h>
#include <string.h>

int rto__isa_resolve(const char *env, const char *(*name)(int), int (*supported)(int), int lowest, int count, int cap)
{
    const char *want = getenv(env);
    if (want && *want)
        for (int i = lowest; i < count; i++)
            if (strcmp(want, name(i)) == 0)
                cap = i;
    for (int i = cap; i > lowest; i--)
        if (supported(i))
            return i;
    return lowest;
}

int rto__cpu_avx2(void)
{
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2");
#else
    return 0;
#endif
}

int rto__cpu_avx512(void)
{
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
#else
    return 0;
#endif
}
