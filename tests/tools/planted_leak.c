/* A planted leak for the sanitizer build's own test (tests/sanitizer_leak.sh): loads a textured glTF scene, which
 * dlopens the image module (OpenImageIO and its thread-local storage: the path on which LeakSanitizer's runtime
 * crashed while scanning TLS, google/sanitizers#1322), frees everything, and with "leak" leaks one block from a
 * function whose name the leak report must give.
 *   planted_leak SCENE.gltf [leak] */
#include <rtoracle.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Not inlined, so that the leak report's allocation stack names it. */
__attribute__((noinline)) static void *planted_leak_alloc(size_t n)
{
    void *p = malloc(n);
    if (p)
        memset(p, 0x5a, n);
    return p;
}

static void *volatile lost;

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: planted_leak SCENE.gltf [leak]\n");
        return 2;
    }
    rto_scene *scene = NULL;
    rto_msg msg = {0};
    if (rto_scene_load(argv[1], &scene, &msg) != RTO_OK) {
        fprintf(stderr, "planted_leak: %s\n", msg.text);
        return 2;
    }
    rto_scene_destroy(scene);
    if (argc > 2 && strcmp(argv[2], "leak") == 0) {
        lost = planted_leak_alloc(4096);
        lost = NULL; /* the only pointer gone: a definite leak */
    }
    return 0;
}
