/* json_get FILE [PATH]: a strict JSON check for the command-line tests. Loads FILE ("-" for stdin) with jansson,
 * which accepts only RFC 8259 JSON in well-formed UTF-8 (no NaN / Infinity literals, no stray bytes), and prints
 * the value at PATH (keys and array indices separated by '/', e.g. "meshes/0/name") as compact JSON.
 * Exit status: 0 found, 1 not valid JSON, 3 no value at PATH, 2 usage. */
#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: json_get FILE [PATH]\n");
        return 2;
    }
    json_error_t err;
    json_t *root = strcmp(argv[1], "-") ? json_load_file(argv[1], JSON_REJECT_DUPLICATES | JSON_DECODE_ANY, &err)
                                        : json_loadf(stdin, JSON_REJECT_DUPLICATES | JSON_DECODE_ANY, &err);
    if (!root) {
        fprintf(stderr, "json_get: %s: not valid JSON: %s (line %d, column %d)\n", argv[1], err.text, err.line,
                err.column);
        return 1;
    }
    json_t *v = root;
    if (argc == 3 && argv[2][0]) {
        char *path = strdup(argv[2]);
        for (char *part = strtok(path, "/"); v && part; part = strtok(NULL, "/")) {
            if (json_is_array(v)) {
                char *end;
                unsigned long i = strtoul(part, &end, 10);
                v = *end ? NULL : json_array_get(v, i);
            } else {
                v = json_object_get(v, part);
            }
        }
        free(path);
    }
    if (!v) {
        fprintf(stderr, "json_get: %s: no value at %s\n", argv[1], argv[2]);
        json_decref(root);
        return 3;
    }
    char *text = json_dumps(v, JSON_COMPACT | JSON_ENCODE_ANY);
    int rc = text && puts(text) >= 0 ? 0 : 2;
    free(text);
    json_decref(root);
    return rc;
}
