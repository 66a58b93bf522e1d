/* libFuzzer target for the .npy reader (build: clang -fsanitize=fuzzer,address,undefined).
 *
 * Beyond "no crash", it checks what every accepted file must satisfy: the data size agrees with the description,
 * the description can be written back as a descr, and a canonical file rebuilt from that descr parses to the same
 * description and bytes. A refused file must leave the output zeroed and give a one-line reason. */
#include "rtoracle.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(int cond, const char *what)
{
    if (!cond) {
        fprintf(stderr, "fuzz_npy invariant violated: %s\n", what);
        abort();
    }
}

static int desc_equal(const rto_npy_desc *a, const rto_npy_desc *b)
{
    if (a->dtype != b->dtype || a->ndim != b->ndim)
        return 0;
    for (uint32_t i = 0; i < a->ndim; i++)
        if (a->shape[i] != b->shape[i])
            return 0;
    if (a->dtype != RTO_DTYPE_STRUCT)
        return 1;
    if (a->nfields != b->nfields)
        return 0;
    for (uint32_t i = 0; i < a->nfields; i++)
        if (strcmp(a->fields[i].name, b->fields[i].name) != 0 || a->fields[i].type != b->fields[i].type ||
            a->fields[i].count != b->fields[i].count || a->fields[i].offset != b->fields[i].offset)
            return 0;
    return 1;
}

/* The file numpy would write for npy's description and bytes, minus the alignment padding, which the reader does
 * not need. */
static void reparse(const rto_npy *npy, const char *descr)
{
    char header[8192];
    int n = snprintf(header, sizeof header, "{'descr': %s%s%s, 'fortran_order': False, 'shape': (",
                     npy->desc.dtype == RTO_DTYPE_STRUCT ? "" : "'", descr,
                     npy->desc.dtype == RTO_DTYPE_STRUCT ? "" : "'");
    for (uint32_t i = 0; i < npy->desc.ndim && n > 0 && (size_t)n < sizeof header; i++)
        n += snprintf(header + n, sizeof header - (size_t)n, "%s%llu", i ? ", " : "",
                      (unsigned long long)npy->desc.shape[i]);
    if (n > 0 && (size_t)n < sizeof header)
        n += snprintf(header + n, sizeof header - (size_t)n, "%s), }\n", npy->desc.ndim == 1 ? "," : "");
    check(n > 0 && (size_t)n < sizeof header, "rebuilt header fits");

    size_t hlen = (size_t)n;
    size_t len = 10 + hlen + npy->nbytes;
    unsigned char *buf = malloc(len);
    check(buf != NULL, "malloc");
    memcpy(buf, "\x93NUMPY\x01\x00", 8);
    buf[8] = (unsigned char)(hlen & 0xff);
    buf[9] = (unsigned char)(hlen >> 8);
    memcpy(buf + 10, header, hlen);
    if (npy->nbytes)
        memcpy(buf + 10 + hlen, npy->data, npy->nbytes);

    rto_npy again;
    rto_msg msg = {{0}};
    rto_status s = rto_npy_parse(buf, len, &again, &msg);
    if (s != RTO_OK)
        fprintf(stderr, "re-parse of %s failed: %s\n", header, msg.text);
    check(s == RTO_OK, "canonical re-serialisation parses");
    check(desc_equal(&npy->desc, &again.desc), "re-parsed description matches");
    check(again.nbytes == npy->nbytes, "re-parsed size matches");
    check(npy->nbytes == 0 || memcmp(again.data, npy->data, npy->nbytes) == 0, "re-parsed bytes match");
    rto_npy_free(&again);
    free(buf);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    rto_npy npy;
    rto_msg msg = {{0}};
    rto_status s = rto_npy_parse(data, size, &npy, &msg);
    if (s != RTO_OK) {
        check(s == RTO_ERR_PARSE || s == RTO_ERR_UNSUPPORTED || s == RTO_ERR_OUT_OF_MEMORY, "failure status");
        check(msg.text[0] != '\0', "failure has a message");
        check(memchr(msg.text, '\0', sizeof msg.text) != NULL, "message is terminated");
        check(strchr(msg.text, '\n') == NULL, "message is one line");
        check(npy.data == NULL && npy.nbytes == 0 && npy.desc.dtype == RTO_DTYPE_NONE, "refused output is zeroed");
        return 0;
    }

    int ok = 0;
    uint64_t count = rto_npy_count(&npy.desc, &ok);
    check(ok, "count of an accepted file does not overflow");
    size_t item = rto_npy_itemsize(&npy.desc);
    check(item > 0, "accepted dtype has a size");
    check(count * item == npy.nbytes, "nbytes = count * itemsize");
    check(npy.data != NULL, "data block allocated");

    char descr[4096];
    check(rto_npy_descr(&npy.desc, descr, sizeof descr) == RTO_OK, "accepted description can be written back");
    reparse(&npy, descr);

    rto_key_format f;
    size_t n = 0;
    rto_msg kmsg = {{0}};
    if (rto_npy_as_keys(&npy, &f, &n, &kmsg) == RTO_OK)
        check(n * (f == RTO_KEY_U32 ? 4u : 8u) == npy.nbytes, "keys cover the data");
    else
        check(kmsg.text[0] != '\0', "as_keys refusal has a message");

    rto_npy_free(&npy);
    check(npy.data == NULL, "free zeroes");
    return 0;
}
