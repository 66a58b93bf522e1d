/* An example material plugin: three-band toon shading, ported the way a user ports the WGSL of their material pass.
 *
 *     cc -shared -fPIC -I<rtoracle include dir> toon.c -o librto_material_toon.so
 *     rtoracle vbuffer scene.gltf --material ./librto_material_toon.so -o out/
 *     rtoracle check-vbuffer --expected out/ --gpu dump/ --material ./librto_material_toon.so
 *
 * The material reads what the visibility pass stored for the sample (the decoded normal, the mesh's base colour) and
 * the pass's sun, and returns RGBA; the material pass calls it once for an interior pixel (sample 0) and once per
 * sample of an edge pixel, then averages. Its WGSL twin computes the same expression in binary32: the check allows
 * 2 binary16 ulps + 2^-12, so the two must agree on which band a sample falls in, which they do away from the band
 * boundaries (a port that differs there is the kind of bug the check exists to find). It needs only rtoracle.h. */
#include <rtoracle.h>

static void shade(const rto_vb_sample *s, float rgba[4])
{
    const float nl = (s->normal[0] * s->sun[0] + s->normal[1] * s->sun[1]) + s->normal[2] * s->sun[2];
    const float band = nl > 0.6f ? 1.0f : nl > 0.1f ? 0.6f : 0.25f;
    for (int a = 0; a < 3; a++)
        rgba[a] = s->base_color[a] * band;
    rgba[3] = s->base_color[3];
}

static const rto_material_def toon = {
    RTO_MATERIAL_ABI_VERSION,
    "toon",
    "three bands of the sun's N.L times the base colour",
    shade,
};

__attribute__((visibility("default"))) const rto_material_def *rto_material_entry_v1(void);
const rto_material_def *rto_material_entry_v1(void) { return &toon; }
