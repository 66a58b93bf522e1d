/* Test tool: edits one .npy file of a bundle the way a careless or hostile hand would, then rewrites the file's
 * sha256 (and dtype and shape) in the bundle's manifest.json, so that only the validation of the arrays themselves
 * can refuse it. Knows nothing of the validators.
 *
 *   bundle_edit FILE truncate N          keep the first N elements (rows) of the array
 *   bundle_edit FILE set-u32 I VALUE     set 32-bit word I of the data to VALUE (decimal or 0x hex)
 *   bundle_edit FILE set-f32 I VALUE     set 32-bit word I to the float VALUE ("nan" and "inf" accepted)
 *   bundle_edit FILE copy-u32 I J        set 32-bit word J to word I
 *   bundle_edit FILE as-u32              the same bytes as a flat uint32 array
 *
 * FILE is edited in place. When its directory holds a manifest.json with an entry for FILE's name, that entry is
 * updated; otherwise (a GPU dump) only the file changes. Prints the old value of a word it sets. */
#include "rtoracle.h"

#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int die(const char *m)
{
    fprintf(stderr, "bundle_edit: %s\n", m);
    return 2;
}

/* Rewrites sha256, dtype and shape of FILE's entry in DIR/manifest.json, if there is one. */
static int update_manifest(const char *path, const rto_npy_desc *d)
{
    char dir[4096], manifest[4200], hex[65], descr[512];
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - path) : 1, slash ? path : ".");
    snprintf(manifest, sizeof manifest, "%s/manifest.json", dir);
    json_t *root = json_load_file(manifest, 0, NULL);
    if (!root)
        return 0; /* not in a bundle */
    json_t *files = json_object_get(root, "files"), *e;
    size_t i;
    int found = 0;
    rto_msg msg = {{0}};
    if (rto_sha256_file(path, hex, &msg) || rto_npy_descr(d, descr, sizeof descr)) {
        json_decref(root);
        return die(msg.text[0] ? msg.text : "cannot describe the array");
    }
    json_array_foreach(files, i, e)
    {
        const char *n = json_string_value(json_object_get(e, "name"));
        if (!n || strcmp(n, name))
            continue;
        json_t *shape = json_array();
        for (uint32_t k = 0; k < d->ndim; k++)
            json_array_append_new(shape, json_integer((json_int_t)d->shape[k]));
        json_object_set_new(e, "sha256", json_string(hex));
        json_object_set_new(e, "dtype", json_string(descr));
        json_object_set_new(e, "shape", shape);
        found = 1;
    }
    int rc = 0;
    if (found && json_dump_file(root, manifest, JSON_INDENT(2)) != 0)
        rc = die("cannot rewrite manifest.json");
    json_decref(root);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc < 3)
        return die("usage: bundle_edit FILE truncate N | set-u32 I V | set-f32 I V | copy-u32 I J | as-u32");
    const char *path = argv[1], *op = argv[2];
    rto_msg msg = {{0}};
    rto_npy a = {0};
    if (rto_npy_read(path, &a, &msg))
        return die(msg.text);
    const size_t words = a.nbytes / 4;
    uint32_t *w = a.data;
    if (!strcmp(op, "truncate") && argc == 4) {
        uint64_t keep = strtoull(argv[3], NULL, 0);
        if (a.desc.ndim < 1 || keep > a.desc.shape[0])
            return die("truncate: N beyond the array");
        a.desc.shape[0] = keep;
    } else if ((!strcmp(op, "set-u32") || !strcmp(op, "set-f32") || !strcmp(op, "copy-u32")) && argc == 5) {
        size_t k = strtoull(argv[3], NULL, 0);
        if (k >= words)
            return die("word index beyond the data");
        printf("0x%08x\n", (unsigned)w[k]);
        if (!strcmp(op, "set-u32")) {
            w[k] = (uint32_t)strtoull(argv[4], NULL, 0);
        } else if (!strcmp(op, "set-f32")) {
            float f = strtof(argv[4], NULL);
            memcpy(&w[k], &f, 4);
        } else {
            size_t j = strtoull(argv[4], NULL, 0);
            if (j >= words)
                return die("word index beyond the data");
            w[j] = w[k];
        }
    } else if (!strcmp(op, "as-u32") && argc == 3) {
        a.desc = rto_npy_desc_array(RTO_DTYPE_U32, 1, words, 0, 0);
    } else {
        return die("unknown operation or wrong arguments");
    }
    if (rto_npy_write(path, &a.desc, a.data, &msg))
        return die(msg.text);
    int rc = update_manifest(path, &a.desc);
    rto_npy_free(&a);
    return rc;
}
