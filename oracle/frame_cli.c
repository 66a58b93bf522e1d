/* What render needs beyond the scene (scene_cli.c): program parameters from the command line, the list of built-in
 * programs, the frame's memory plan, a progress bar, the frame's bundle and the summary line. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>
#include <time.h>

/* --param NAME=V[,V..][:NAME=V..] into values (at most RTO_PROGRAM_PARAMS_MAX). */
bool cli_parse_params(const char *text, rto_param_value *out, uint32_t *n)
{
    *n = 0;
    const char *p = text;
    while (*p) {
        const char *eq = strchr(p, '='), *end = strchr(p, ':');
        if (!end)
            end = p + strlen(p);
        if (!eq || eq > end || eq == p || (size_t)(eq - p) >= sizeof out->name || *n == RTO_PROGRAM_PARAMS_MAX) {
            cli_fail("render", "--param %s: expected NAME=V[,V..] items separated by ':'", text);
            return false;
        }
        rto_param_value *v = &out[(*n)++];
        memset(v, 0, sizeof *v);
        memcpy(v->name, p, (size_t)(eq - p));
        char values[256];
        const size_t len = (size_t)(end - eq - 1);
        if (len >= sizeof values) {
            cli_fail("render", "--param %s: value too long", v->name);
            return false;
        }
        memcpy(values, eq + 1, len);
        values[len] = '\0';
        uint32_t count = 1;
        for (const char *c = values; *c; c++)
            count += *c == ',';
        if (count > 4 || !cli_parse_floats(values, v->value, count)) {
            cli_fail("render", "--param %s=%s: expected 1 to 4 comma-separated finite numbers", v->name, values);
            return false;
        }
        v->count = count;
        p = *end ? end + 1 : end;
    }
    return true;
}

void cli_list_programs(void)
{
    for (uint32_t i = 0; rto_program_builtin_at(i); i++) {
        const rto_program *p = rto_program_builtin_at(i);
        printf("%s (maxDepth %u, payload %u bytes): %s\n", p->name, p->max_depth, p->payload_size, p->description);
        for (uint32_t k = 0; k < p->param_count; k++) {
            char v[96];
            size_t len = 0;
            for (uint32_t c = 0; c < p->params[k].count; c++)
                len += (size_t)snprintf(v + len, sizeof v - len, "%s%g", c ? "," : "", (double)p->params[k].value[c]);
            printf("  --param %s=%-18s %s\n", p->params[k].name, v, p->params[k].help);
        }
    }
}

double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void cli_progress(void *arg, double fraction)
{
    cli_progress_bar *p = arg;
    const double t = cli_now();
    if (!p->on || (fraction < 1.0 && t - p->last < 0.1))
        return;
    p->last = t;
    const int width = 30, full = (int)(fraction * width + 0.5);
    fprintf(stderr, "\rrender [%.*s%*s] %3d%%", full, "##############################", width - full, "",
            (int)(fraction * 100 + 0.5));
    p->drawn = 1;
}

bool cli_frame_within_budget(const rto_frame_desc *fd, uint64_t memory_mb, const char *stages)
{
    char what[160];
    snprintf(what, sizeof what, "a %ux%u frame of %s (maxDepth %u, --stages %s)", fd->width, fd->height,
             fd->program->name, fd->max_depth ? fd->max_depth : fd->program->max_depth, stages);
    return cli_within_budget("render", rto_frame_memory_bound(fd), memory_mb, what);
}

void cli_frame_summary(const char *spec, const rto_frame *frame, double seconds, const char *out)
{
    uint64_t traced = 0, hits = 0, emitted = 0, dropped = 0, conflicts = 0;
    for (uint32_t d = 0; d <= frame->max_depth; d++) {
        traced += frame->counters[d].traced;
        hits += frame->counters[d].hits;
        emitted += frame->counters[d].emitted;
        dropped += frame->counters[d].dropped;
        conflicts += frame->counters[d].conflicts;
    }
    char sum[64];
    printf("render %s: %s %ux%u maxDepth %u: %llu rays traced (%llu hits), %llu emitted, %llu dropped, "
           "%llu conflicts; %.2f s -> %s (%s)\n",
           spec, frame->program, frame->width, frame->height, frame->max_depth, (unsigned long long)traced,
           (unsigned long long)hits, (unsigned long long)emitted, (unsigned long long)dropped,
           (unsigned long long)conflicts, seconds, out, cli_dir_summary(out, sum, sizeof sum));
}

const rto_program *cli_pick_program(const char *name, bool is_plugin, rto_plugin **plugin)
{
    *plugin = NULL;
    if (!is_plugin) {
        const rto_program *prog = rto_program_builtin(name);
        if (!prog)
            cli_fail("render", "--program %s: not a built-in program (triangle, sun-shadow, normals) or a .so", name);
        return prog;
    }
    rto_msg msg = {{0}};
    if (rto_plugin_load(name, plugin, &msg)) {
        cli_fail("render", "--program %s", msg.text);
        return NULL;
    }
    return rto_plugin_program(*plugin);
}

rto_status cli_frame_bundle(const char *out, const char *request, const cli_traced_scene *ts, const char *plugin,
                            const rto_frame *frame, bool timings, rto_msg *msg)
{
    rto_bundle *b = NULL;
    rto_status s = rto_bundle_begin(out, "frame", &b, msg);
    if (!s)
        s = cli_set_request(b, request, ts ? ts->scene : NULL, plugin, msg);
    if (!s && ts)
        s = rto_bvh_bundle_write(ts->accel, b, msg);
    if (!s && ts)
        s = rto_scene_bundle_write(ts->scene, b, msg);
    if (!s)
        s = rto_frame_bundle_write(frame, timings, b, msg);
    if (s) {
        rto_bundle_abort(b);
        return s;
    }
    rto_bundle_set_str(b, "frame", "scene_kind", ts ? "mesh" : "stage2");
    if (!ts)
        rto_bundle_set_str(b, "", "scene", "stage2");
    return rto_bundle_commit(b, msg);
}
