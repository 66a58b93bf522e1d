/* .npy writing (npy_internal.h): rto_npy_write, and the hashed writer and in-memory hash of bundles, all from the
 * one preamble (rto__npy_preamble), so a file's hash computed from memory is the hash of the file written. */
#define _POSIX_C_SOURCE 200809L /* O_CLOEXEC */

#include "io_internal.h"
#include "npy_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* What the writers and the hasher check and build first: the description, the data's size (*nbytes) and the header
 * (pre, *plen). The one place a file's preamble is made, so a hash from memory is the hash of the file written. */
static rto_status npy_prepare(const char *path, const rto_npy_desc *desc, const void *data, unsigned char *pre,
                              size_t *plen, size_t *nbytes, rto_msg *msg)
{
    if (!path)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL path");
    rto_status s = rto__npy_check_desc(desc, msg);
    if (s != RTO_OK)
        return s;
    int ok = 0;
    uint64_t count = rto_npy_count(desc, &ok);
    uint64_t item = rto_npy_itemsize(desc);
    if (!ok || (item && count > UINT64_MAX / item) || count * item > SIZE_MAX) {
        char shape[128];
        rto__npy_format_shape(desc, shape, sizeof shape);
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "shape %s of %llu-byte elements does not fit in memory", shape,
                        (unsigned long long)item);
    }
    *nbytes = (size_t)(count * item);
    if (!data && *nbytes)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL data for %zu bytes", *nbytes);
    *plen = rto__npy_preamble(desc, pre);
    if (*plen == 0)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "header for '%s' is too long", path);
    return RTO_OK;
}

rto_status rto_npy_write(const char *path, const rto_npy_desc *desc, const void *data, rto_msg *msg)
{
    unsigned char pre[NPY_HEADER_CAP];
    size_t plen = 0, nbytes = 0;
    rto_status s = npy_prepare(path, desc, data, pre, &plen, &nbytes, msg);
    if (s != RTO_OK)
        return s;

    /* Atomically through a temporary sibling (io/atomic.c): a reader never sees half a file and a failed write
     * leaves the previous file intact. /dev/null or a FIFO is written through and never unlinked. */
    rto_atomic_file f;
    s = rto__atomic_open(&f, path, true, msg);
    if (s != RTO_OK)
        return s;
    errno = 0;
    if (fwrite(pre, 1, plen, f.fp) != plen || (nbytes && fwrite(data, 1, nbytes, f.fp) != nbytes)) {
        int e = errno;
        rto__atomic_discard(&f);
        return rto__fail(msg, RTO_ERR_IO, "writing '%s': %s", path, strerror(e ? e : EIO));
    }
    return rto__atomic_close(&f, msg);
}

/* The file's bytes are the preamble then the data: both writers and the hasher go through these two parts. */
static void hex_digest(const unsigned char md[32], char hex[65])
{
    for (unsigned i = 0; i < 32; i++)
        snprintf(hex + 2 * i, 3, "%02x", md[i]);
}

rto_status rto__npy_hash(const char *name, const rto_npy_desc *desc, const void *data, char hex[65],
                         uint64_t *file_bytes, rto_msg *msg)
{
    if (!hex || !file_bytes)
        return rto__fail(msg, RTO_ERR_INVALID_ARGUMENT, "NULL hex or size");
    unsigned char pre[NPY_HEADER_CAP];
    size_t plen = 0, nbytes = 0;
    rto_status s = npy_prepare(name, desc, data, pre, &plen, &nbytes, msg);
    if (s != RTO_OK)
        return s;
    EVP_MD_CTX *ctx = EVP_MD_CTX_new();
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int mdlen = 0;
    int ok = ctx && EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) == 1 && EVP_DigestUpdate(ctx, pre, plen) == 1 &&
             (!nbytes || EVP_DigestUpdate(ctx, data, nbytes) == 1) && EVP_DigestFinal_ex(ctx, md, &mdlen) == 1 &&
             mdlen == 32;
    EVP_MD_CTX_free(ctx);
    if (!ok)
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot compute SHA-256");
    hex_digest(md, hex);
    *file_bytes = (uint64_t)plen + nbytes;
    return RTO_OK;
}

rto_status rto__npy_write_hashed(const char *path, const rto_npy_desc *desc, const void *data, char hex[65],
                                 rto_msg *msg)
{
    unsigned char pre[NPY_HEADER_CAP];
    size_t plen = 0, nbytes = 0;
    rto_status s = npy_prepare(path, desc, data, pre, &plen, &nbytes, msg);
    if (s != RTO_OK)
        return s;
    EVP_MD_CTX *ctx = hex ? EVP_MD_CTX_new() : NULL;
    if (hex && (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), NULL) != 1)) {
        EVP_MD_CTX_free(ctx);
        return rto__fail(msg, RTO_ERR_OUT_OF_MEMORY, "cannot start SHA-256");
    }
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        EVP_MD_CTX_free(ctx);
        return rto__fail(msg, RTO_ERR_IO, "cannot create %s: %s", path, strerror(errno));
    }
    /* The bytes are hashed as they go out, in the same chunks, while they are still in cache. */
    const unsigned char *parts[2] = {pre, data};
    const size_t lens[2] = {plen, nbytes};
    int err = 0;
    for (int k = 0; k < 2 && !err; k++) {
        for (size_t at = 0; at < lens[k] && !err;) {
            size_t chunk = lens[k] - at < (1u << 20) ? lens[k] - at : (1u << 20);
            ssize_t w = write(fd, parts[k] + at, chunk);
            if (w < 0 && errno == EINTR)
                continue;
            if (w <= 0) {
                err = w < 0 ? errno : EIO;
                break;
            }
            if (ctx)
                EVP_DigestUpdate(ctx, parts[k] + at, (size_t)w);
            at += (size_t)w;
        }
    }
    if (close(fd) != 0 && !err)
        err = errno;
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int mdlen = 0;
    if (!err && ctx && (EVP_DigestFinal_ex(ctx, md, &mdlen) != 1 || mdlen != 32))
        err = ENOMEM;
    EVP_MD_CTX_free(ctx);
    if (err) {
        unlink(path); /* ours: created above with O_EXCL */
        return rto__fail(msg, RTO_ERR_IO, "writing '%s': %s", path, strerror(err));
    }
    if (hex)
        hex_digest(md, hex);
    return RTO_OK;
}
