#!/usr/bin/env python3
"""tracer_mutations.py: which tests catch each fault planted in the tracer (issue: "every listed tracer mutation
caught by a test other than golden").

  tests/tools/tracer_mutations.py run BUILD_DIR OUT.json [NAME]
                                                            plant each mutation (or the one named) in turn in the
                                                            source tree BUILD_DIR was configured from, rebuild, run the
                                                            tests below, put the source back; OUT.json: mutation ->
                                                            failing tests and the commit, merged into OUT.json's
                                                            earlier rows when one mutation is named (a new one
                                                            added in the list's order)
  tests/tools/tracer_mutations.py table OUT.json DOC.md      rewrite the section of DOC.md between
                                                            "<!-- tracer-mutations begin -->" and "... end -->"

Run it on a scratch checkout (git worktree): it edits src/trace/ and restores each file after each mutation, but a
stopped run can leave one planted."""
import json
import os
import subprocess
import sys

TESTS = ["unit.trace", "unit.trace_lanes", "unit.check_hits", "unit.conformance", "unit.rays", "unit.embree",
         "cli.check_hits", "cli.crosscheck"]

# (name, file, exact text, replacement): each text must occur exactly once.
MUTATIONS = [
    ("t <= bestT (ties keep the later triangle)", "src/trace/trace_internal.h",
     "t_min <= h.t && h.t < best_t;", "t_min <= h.t && h.t <= best_t;"),
    ("tMin dropped from the triangle test", "src/trace/trace_internal.h",
     "t_min <= h.t && h.t < best_t;", "h.t < best_t;"),
    ("translation added first in the ray transform", "src/trace/trace_internal.h",
     "obj_origin[r] = ((m[r][0] * origin[0] + m[r][1] * origin[1]) + m[r][2] * origin[2]) + m[r][3];",
     "obj_origin[r] = ((m[r][3] + m[r][0] * origin[0]) + m[r][1] * origin[1]) + m[r][2] * origin[2];"),
    ("dot product summed right to left", "src/trace/trace_internal.h",
     "return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2];", "return a[0] * b[0] + (a[1] * b[1] + a[2] * b[2]);"),
    ("division by det instead of the reciprocal", "src/trace/trace_internal.h",
     "h.u = rto__dot3(s, p) * inv;", "h.u = rto__dot3(s, p) / h.det;"),
    ("u and v swapped in the hit record", "src/trace/trace_internal.h",
     "h->bary[0] = hit->u;\n    h->bary[1] = hit->v;", "h->bary[0] = hit->v;\n    h->bary[1] = hit->u;"),
    ("CULL_BACK_FACING culls front faces", "src/trace/intersect.c",
     "((flags & RTO_RAY_FLAG_CULL_BACK_FACING) && det < 0.0f)", "((flags & RTO_RAY_FLAG_CULL_BACK_FACING) && det > 0.0f)"),
    ("slab tNear ignores tMin", "src/trace/trace_internal.h",
     "const float t_near = rto__maxf(rto__maxf(rto__maxf(lo[0], lo[1]), lo[2]), t_min);",
     "const float t_near = rto__maxf(rto__maxf(lo[0], lo[1]), lo[2]);"),
    ("farther child visited first", "src/trace/traverse.c",
     "if (tl <= tr) {", "if (tl > tr) {"),
    ("BLAS pop-time skip dropped (t > bestT)", "src/trace/traverse.c",
     "        if (e.t > st->best_t)\n            continue;\n        st->c.nodes_visited++;\n        if (e.ref & RTO_BVH_LEAF_BIT) {\n            const uint32_t prim",
     "        st->c.nodes_visited++;\n        if (e.ref & RTO_BVH_LEAF_BIT) {\n            const uint32_t prim"),
    ("instance mask ignored", "src/trace/traverse.c",
     "if (tr->scene->instances[inst].mask & st->ray->cull_mask)", "if (tr->scene->instances[inst].mask | 1u)"),
    ("customIndex of the next instance", "src/trace/trace_internal.h",
     "h->custom_index = instance->custom_index;", "h->custom_index = instance->custom_index + 1;"),
    ("hitGroup from the mask", "src/trace/trace_internal.h",
     "h->hit_group = instance->sbt_offset;", "h->hit_group = instance->mask;"),
    ("lanes: farther child visited first", "src/trace/lanes.c", "if (tl <= tr) {", "if (tl > tr) {"),
    ("packed: farther child visited first", "src/trace/packed.c", "if (t[0] <= t[1]) {", "if (t[0] > t[1]) {"),
    ("packed: the left child taken when only the right was hit", "src/trace/packed.c",
     "    if (hit == 2) {\n        *cur = n->child[1];", "    if (hit == 2) {\n        *cur = n->child[0];"),
    ("packed: slab tNear ignores tMin", "src/trace/packed.c",
     "_mm_max_ps(_mm_max_ps(_mm_max_ps(lo[0], lo[1]), lo[2]), r->t_min);",
     "_mm_max_ps(_mm_max_ps(lo[0], lo[1]), lo[2]);"),
    ("packed: pop-time skip dropped (t > bestT)", "src/trace/packed.c",
     "        if (e.t > best_t)\n            continue;\n", ""),
    ("packed: a sweep node counts two box tests, EMPTY children too", "src/trace/packed.c",
     "            st->c.box_tests += n->tests;\n            if (descend(",
     "            st->c.box_tests += 2;\n            if (descend("),
    ("packed in turn: a sweep node counts two box tests, EMPTY children too", "src/trace/packed.c",
     "    st->c.box_tests += n->tests & (0u - (uint32_t)live);",
     "    st->c.box_tests += 2u & (0u - (uint32_t)live);"),
    ("packed in turn: farther child visited first", "src/trace/packed.c",
     "c = (both & !(t[0] <= t[1])) | (hit == 2)", "c = (both & (t[0] <= t[1])) | (hit == 2)"),
    ("packed in turn: a child pushed when only one was hit", "src/trace/packed.c",
     "*top = below + ((at + both - below)", "*top = below + ((at + any - below)"),
    ("packed in turn: a ray ends with its first BLAS", "src/trace/packed.c",
     "back to the TLAS's stack */\n        return stream_tlas_take(tr, pa, s);",
     "back to the TLAS's stack */\n        return 1;"),
    ("packed in turn: a new ray keeps the last ray's TLAS stack", "src/trace/packed.c",
     "        s->ttop = 0;\n        return 1;", "        return 1;"),
    ("packed in turn: an entry taken from the stack is visited without its check against the best t",
     "src/trace/packed.c", "const int live = s->cur_t <= st->best_t;", "const int live = 1;"),
    ("packed in turn: a skipped entry counted as a visited BLAS node", "src/trace/packed.c",
     "            st->c.nodes_visited += (uint32_t)live;", "            st->c.nodes_visited += 1u;"),
    ("packed groups: rays that take the first side second never go back to it", "src/trace/groups_kernel.h",
     "        if (rfirst)\n            PN(push)(stack, top, n->child[0], rfirst, tl);\n", ""),
    ("packed groups: pop-time skip dropped (t > bestT)", "src/trace/groups_kernel.h",
     "        if (m)\n            m &= VNGT(VLDU(e->t), g->best);\n", ""),
    ("packed groups: a first hit does not end the ray's walk", "src/trace/groups_kernel.h",
     "            st->done = 1;\n            g->alive &= ~(1u << l);\n", "            st->done = 1;\n"),
    ("packed groups: BLAS nodes counted for every ray of the group", "src/trace/groups_kernel.h",
     "        visits = VI_ADD(visits, act, 1);\n        if (cur & RTO_BVH_LEAF_BIT) {\n            PN(triangle)",
     "        visits = VI_ADD(visits, 0xffffu, 1);\n        if (cur & RTO_BVH_LEAF_BIT) {\n            PN(triangle)"),
    ("packed groups: translation added first in the ray transform", "src/trace/groups_kernel.h",
     "VADD(VADD(VADD(VMUL(m0, w->o[0]), VMUL(m1, w->o[1])), VMUL(m2, w->o[2])), VSET1(m[a][3]))",
     "VADD(VADD(VADD(VSET1(m[a][3]), VMUL(m0, w->o[0])), VMUL(m1, w->o[1])), VMUL(m2, w->o[2]))"),
    ("packed groups: t <= bestT (ties keep the later triangle)", "src/trace/groups_kernel.h",
     "VLT(t, g->best)", "VLE(t, g->best)"),
    ("packed groups: the object-space inverse direction taken from the world direction",
     "src/trace/groups_kernel.h",
     "VMUL(m2, w->d[2]));\n        r.inv[a] = PN(inv_dir)(r.d[a]);",
     "VMUL(m2, w->d[2]));\n        r.inv[a] = PN(inv_dir)(w->d[a]);"),
    ("packed: leaf vertices copied one corner on", "src/trace/packed.c",
     "&t->mesh->positions[3 * (size_t)ix[v]]", "&t->mesh->positions[3 * (size_t)ix[(v + 1) % 3]]"),
    ("lanes: slab tNear ignores tMin", "src/trace/lanes_kernel.h",
     "const VF near = VMAX(VMAX(VMAX(VMIN(a0, c0), VMIN(a1, c1)), VMIN(a2, c2)), tmin);",
     "const VF near = VMAX(VMAX(VMIN(a0, c0), VMIN(a1, c1)), VMIN(a2, c2));"),
    ("lanes: t <= bestT (ties keep the later triangle)", "src/trace/lanes_kernel.h",
     "VLT(t, VLD(L->best))", "VLE(t, VLD(L->best))"),
    ("lanes: the right box gathered from the left's fields", "src/trace/lanes_kernel.h",
     "const int f = 8 * k;", "const int f = 0 * k;"),
    ("objToWorld translation dropped", "src/trace/trace_internal.h",
     "h->obj_to_world[c][r] = instance->obj_to_world.m[r][c];",
     "h->obj_to_world[c][r] = c < 3 ? instance->obj_to_world.m[r][c] : 0.0f;"),
]


def run(build, out, only=None):
    with open(os.path.join(build, "meson-info", "meson-info.json")) as f:
        root = json.load(f)["directories"]["source"]
    commit = subprocess.run(["git", "-C", root, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    results = []
    if only:
        with open(out) as f:
            results = json.load(f)["results"]
        if not any(m[0] == only for m in MUTATIONS):
            sys.exit(f"tracer_mutations.py: no mutation '{only}'")
    for name, rel, old, new in MUTATIONS:
        if only and name != only:
            continue
        path = os.path.join(root, rel)
        with open(path) as f:
            text = f.read()
        if text.count(old) != 1:
            sys.exit(f"tracer_mutations.py: '{name}': the text occurs {text.count(old)} times in {rel}")
        try:
            with open(path, "w") as f:
                f.write(text.replace(old, new))
            subprocess.run(["ninja", "-C", build], capture_output=True, check=True)
            caught = []
            for t in TESTS:
                r = subprocess.run(["meson", "test", "-C", build, "--no-rebuild", t], capture_output=True, text=True)
                if r.returncode != 0:
                    caught.append(t)
        finally:
            with open(path, "w") as f:
                f.write(text)
        print(f"{name}: caught by {', '.join(caught) if caught else 'NOTHING'}", flush=True)
        row = {"mutation": name, "file": rel, "caught_by": caught, "commit": commit}
        results = [r for r in results if r["mutation"] != name] + [row]
    order = {m[0]: i for i, m in enumerate(MUTATIONS)}  # a named row, new or rerun, takes its place in the list
    results.sort(key=lambda r: order.get(r["mutation"], len(order)))
    subprocess.run(["ninja", "-C", build], capture_output=True, check=True)
    with open(out, "w") as f:
        json.dump({"tests": TESTS, "results": results}, f, indent=1)
        f.write("\n")


def table(path, doc):
    with open(path) as f:
        data = json.load(f)
    begin, end = "<!-- tracer-mutations begin -->", "<!-- tracer-mutations end -->"
    rows = [begin, "", "| mutation of the tracer | tests that catch it (besides `golden`) | run at |", "|---|---|---|"]
    for r in data["results"]:
        rows.append(f"| {r['mutation']} (`{r['file']}`) | {', '.join('`' + t + '`' for t in r['caught_by']) or '**none**'} "
                    f"| {r.get('commit', '-')} |")
    rows += ["", f"Tests run for each: {', '.join('`' + t + '`' for t in data['tests'])} (`{path}`).", "", end]
    with open(doc) as f:
        text = f.read()
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    with open(doc, "w") as f:
        f.write(head + "\n".join(rows) + tail)


if __name__ == "__main__":
    if len(sys.argv) in (4, 5) and sys.argv[1] == "run":
        run(sys.argv[2], sys.argv[3], sys.argv[4] if len(sys.argv) == 5 else None)
    elif len(sys.argv) == 4 and sys.argv[1] == "table":
        table(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
