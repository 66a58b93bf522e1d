/* What the CPU can run: the SIMD paths (the bitonic network's, the tracer's) are chosen at run time. */
#include "internal.h"

#include <stdlib.h>
#include <string.h>

int rto__isa_named(const char *env, const char *(*name)(int), int lowest, int count)
{
    const char *want = getenv(env);
    for (int i = lowest; want && i < count; i++)
        if (strcmp(want, name(i)) == 0)
            return i;
    return -1;
}

int rto__isa_resolve(const char *env, const char *(*name)(int), int (*supported)(int), int lowest, int count, int cap)
{
    const int named = rto__isa_named(env, name, lowest, count);
    if (named >= 0)
        cap = named;
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
