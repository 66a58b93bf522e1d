/* rtoracle: writes what every GPU buffer of a wavefront ray tracer should hold, and checks GPU dumps against it.
 * Exit status: 0 pass, 1 mismatch found, 2 bad usage or input. */
#include "cli.h"

#include <string.h>

static const struct {
    const char *name;
    int (*run)(int, char **);
    const char *summary;
} commands[] = {
    {"keys", cmd_keys, "generate sort keys of a named distribution (.npy)"},
    {"sort", cmd_sort, "sort keys with the bitonic or radix oracle into a bundle"},
    {"check-sort", cmd_check_sort, "validate a GPU's sorted buffer (and checkpoints)"},
    {"suite", cmd_suite, "write the distribution x size matrix of bundles a GPU harness runs"},
    {"build", cmd_build, "build a scene's TLAS and BLAS trees in their GPU layouts into a bundle"},
    {"check-bvh", cmd_check_bvh, "validate a GPU-built TLAS or BLAS node array"},
    {"trace", cmd_trace, "trace rays (camera, shadow, random, grazing, axis or a file) into hit records"},
    {"check-hits", cmd_check_hits, "validate a GPU's hit records against a trace bundle (ties allowed)"},
    {"render", cmd_render, "render a wavefront frame (every queue, hit, counter, accum and image) into a bundle"},
    {"check-frame", cmd_check_frame, "validate a GPU's dump of a frame stage by stage against a frame bundle"},
    {"vbuffer", cmd_vbuffer, "rasterize a visibility buffer (G-buffer per sample, edge mask, image) into a bundle"},
    {"check-vbuffer", cmd_check_vbuffer, "validate a GPU's visibility buffer, edge mask and image against a vbuffer bundle"},
    {"splat", cmd_splat, "splat SPH particles into a fixed-point density volume and occupancy grid (a bundle)"},
    {"check-volume", cmd_check_volume, "validate a GPU's splat volume, resolve and occupancy grid against a splat bundle"},
    {"raymarch", cmd_raymarch, "raymarch a splat bundle's volume with and without empty-space skipping (a bundle)"},
    {"check-raymarch", cmd_check_raymarch, "validate a GPU's raymarch image and crossings against a raymarch bundle"},
    {"info", cmd_info, "load a scene (.gltf / .glb / procedural) and print what was loaded"},
    {"crosscheck", cmd_crosscheck, "trace rays through the oracle and Embree 3 and classify every disagreement"},
    {"compare", cmd_compare, "compare two images (PNG / OpenEXR) with idiff's thresholds and exit statuses"},
};

static void usage(FILE *to)
{
    fprintf(to, "usage: rtoracle COMMAND [options]   (rtoracle COMMAND --help for each)\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(to, "  %-12s %s\n", commands[i].name, commands[i].summary);
    fprintf(to, "\nexit status: 0 pass, 1 mismatch found, 2 bad usage or input\n");
}

int main(int argc, char **argv)
{
    cli_cleanup_on_signals();
    if (argc < 2) {
        usage(stderr);
        return EXIT_BAD_INPUT;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return EXIT_PASS;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("rtoracle %s (bundle format %d)\n", RTO_VERSION_STRING, RTO_BUNDLE_FORMAT_VERSION);
        return EXIT_PASS;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    /* One line, as for an unknown option: the list of commands is one --help away. */
    fprintf(stderr, "rtoracle: unknown command '%s' (rtoracle --help)\n", argv[1]);
    return EXIT_BAD_INPUT;
}
