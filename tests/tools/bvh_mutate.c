/* Test tool: injects one named fault into a correct node array (TlasNode or BlasNode records) and prints the node
 * where it put it, so the command-line tests can assert that check-bvh names it. Knows nothing of the validator.
 *   bvh_mutate tlas-item|tlas-drop|tlas-box|tlas-swap|tlas-leaf-box|tlas-leaf-ulp|tlas-empty-box IN OUT
 *   bvh_mutate karras-item|karras-drop|karras-box|karras-swap|karras-cycle IN OUT */
#include "rtoracle.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int die(const char *m)
{
    fprintf(stderr, "bvh_mutate: %s\n", m);
    return 2;
}

static void swap_tlas(rto_tlas_node *a, rto_tlas_node *b)
{
    rto_tlas_node t = *a;
    *a = *b;
    *b = t;
}

int main(int argc, char **argv)
{
    if (argc != 4)
        return die("usage: bvh_mutate MUTATION IN OUT");
    const char *m = argv[1];
    rto_msg msg = {{0}};
    rto_npy a = {0};
    if (rto_npy_read(argv[2], &a, &msg))
        return die(msg.text);
    size_t count = (size_t)a.desc.shape[0];
    long node = -1;
    if (!strncmp(m, "tlas-", 5)) {
        rto_tlas_node *t = a.data;
        size_t np = (count + 1) / 2, leaf0 = np - 1;
        if (count < 7)
            return die("tree too small");
        if (!strcmp(m, "tlas-item")) { /* leaf 1 takes leaf 2's instance */
            node = (long)(leaf0 + 1);
            t[node].item = t[leaf0 + 2].item;
        } else if (!strcmp(m, "tlas-drop")) { /* leaf 1 becomes EMPTY (its box left as is) */
            node = (long)(leaf0 + 1);
            t[node].item = RTO_TLAS_EMPTY;
        } else if (!strcmp(m, "tlas-box")) { /* root's max.x shrunk by one ulp */
            node = 0;
            t[0].max[0] = nextafterf(t[0].max[0], -INFINITY);
        } else if (!strcmp(m, "tlas-leaf-box")) { /* leaf 3's max.x one unit out, its ancestors left alone */
            node = (long)(leaf0 + 3);
            t[node].max[0] += 1.0f;
        } else if (!strcmp(m, "tlas-leaf-ulp")) { /* leaf 3's max.x one ulp out, its ancestors following it */
            node = (long)(leaf0 + 3);
            t[node].max[0] = nextafterf(t[node].max[0], INFINITY);
            for (size_t i = (size_t)node; i > 0;) {
                i = (i - 1) / 2;
                t[i].max[0] = fmaxf(t[2 * i + 1].max[0], t[2 * i + 2].max[0]);
            }
        } else if (!strcmp(m, "tlas-empty-box")) { /* the last leaf, EMPTY, given leaf 0's box */
            node = (long)(count - 1);
            if (t[node].item != RTO_TLAS_EMPTY)
                return die("the last leaf is not EMPTY");
            memcpy(t[node].min, t[leaf0].min, sizeof t[node].min);
            memcpy(t[node].max, t[leaf0].max, sizeof t[node].max);
        } else if (!strcmp(m, "tlas-swap")) { /* exchange the subtrees under the root */
            node = 0;
            for (size_t x = 1, y = 2, w = 1; x < count; x = 2 * x + 1, y = 2 * y + 1, w *= 2)
                for (size_t k = 0; k < w; k++)
                    swap_tlas(&t[x + k], &t[y + k]);
        } else {
            return die("unknown mutation");
        }
    } else {
        rto_bvh_node *t = a.data;
        if (count < 3)
            return die("tree too small");
        /* the first node with a leaf child and an internal child, and the first with two leaves */
        long mixed = -1, two = -1;
        for (size_t i = 1; i < count; i++) {
            int l = (t[i].left & RTO_BVH_LEAF_BIT) != 0, r = (t[i].right & RTO_BVH_LEAF_BIT) != 0;
            if (l != r && mixed < 0)
                mixed = (long)i;
            if (l && r && two < 0)
                two = (long)i;
        }
        if (mixed < 0 || two < 0)
            return die("no suitable node");
        if (!strcmp(m, "karras-item")) {
            node = two;
            t[two].right = t[two].left;
        } else if (!strcmp(m, "karras-drop")) { /* the parent of a mixed node links to its internal child */
            node = mixed;
            rto_bvh_node *x = &t[mixed];
            uint32_t keep = (x->left & RTO_BVH_LEAF_BIT) ? x->right : x->left, p = x->parent;
            if (t[p].left == (uint32_t)mixed)
                t[p].left = keep;
            else
                t[p].right = keep;
            t[keep].parent = p;
        } else if (!strcmp(m, "karras-box")) {
            node = mixed;
            /* the internal child's box: held to the exact union, whatever the leaf tolerance */
            float *v = (t[mixed].left & RTO_BVH_LEAF_BIT) ? &t[mixed].rmin[1] : &t[mixed].lmin[1];
            *v = nextafterf(*v, INFINITY);
        } else if (!strcmp(m, "karras-swap")) {
            node = mixed;
            rto_bvh_node *x = &t[mixed], y = *x;
            x->left = y.right;
            x->right = y.left;
            memcpy(x->lmin, y.rmin, 12);
            memcpy(x->lmax, y.rmax, 12);
            memcpy(x->rmin, y.lmin, 12);
            memcpy(x->rmax, y.lmax, 12);
        } else if (!strcmp(m, "karras-cycle")) {
            node = mixed;
            if (t[mixed].left & RTO_BVH_LEAF_BIT)
                t[mixed].left = 0;
            else
                t[mixed].right = 0;
        } else {
            return die("unknown mutation");
        }
    }
    if (rto_npy_write(argv[3], &a.desc, a.data, &msg))
        return die(msg.text);
    rto_npy_free(&a);
    printf("%ld\n", node);
    return 0;
}
