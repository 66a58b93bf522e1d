/* A user's harness in miniature, built against an installed rtoracle through pkg-config (tests/install.sh): generate
 * clustered TLAS keys, sort them with the oracle, then validate a "GPU" result — once correct, once with two slots
 * exchanged — and print the fault the validator names. Compiles as C11 and as C++. */
#include <rtoracle.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(void)
{
    enum { N = 4097 };
    const size_t np = rto_next_pow2(N);
    uint32_t *keys = (uint32_t *)malloc(N * sizeof *keys), *gpu = (uint32_t *)malloc(np * sizeof *gpu);
    rto_msg msg;
    memset(&msg, 0, sizeof msg);
    if (!keys || !gpu || rto_keys_generate("clustered", RTO_KEY_U32, 1, N, keys, &msg) ||
        rto_bitonic_sort(RTO_KEY_U32, keys, N, gpu, NULL, NULL, &msg)) {
        fprintf(stderr, "setup failed: %s\n", msg.text);
        return 2;
    }
    rto_sort_check_desc d;
    memset(&d, 0, sizeof d);
    d.format = RTO_KEY_U32;
    d.input = keys;
    d.n = N;
    d.gpu_keys = gpu;
    d.gpu_n = np;
    rto_sort_report r;
    rto_status ok = rto_sort_check(&d, &r, &msg);
    uint32_t t = gpu[100];
    gpu[100] = gpu[101];
    gpu[101] = t;
    rto_status bad = rto_sort_check(&d, &r, &msg);
    printf("correct: %s; swapped: %s, fault %s at slot %zu\n", rto_status_string(ok), rto_status_string(bad),
           rto_fault_name(r.fault), r.first_slot);
    free(keys);
    free(gpu);
    return ok == RTO_OK && bad == RTO_ERR_MISMATCH && r.fault == RTO_FAULT_ORDER && r.first_slot == 100 ? 0 : 1;
}
