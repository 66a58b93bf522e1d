/* What the three files of unit.scene share: test_scene.c (fixtures, procedural scenes, transforms, main()),
 * test_scene_gltf.c (hand-made glTF files, hostile inputs) and test_scene_textures.c (textures). Each helper is
 * defined in the file named above it; main() in test_scene.c runs the tests of the two others. */
#ifndef RTO_TEST_SCENE_H
#define RTO_TEST_SCENE_H

#include "testutil.h"

/* One triangle's positions (x, y, z per vertex) as a buffer, a bufferView and a POSITION accessor 0. */
#define TRI_BODY_PREFIX                                                                                              \
    "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}], \"accessors\": [{\"bufferView\": 0, \"componentType\": " \
    "5126, \"count\": 3, \"type\": \"VEC3\"}]"

/* The group's scratch directory (setup_tmp / teardown_tmp in test_scene.c). */
extern char tmp_dir[256];

/* Defined in test_scene.c */
const char *assimp_dir(void);
void write_bytes(const char *path, const void *data, size_t len);
unsigned char *read_all(const char *path, size_t *len);
void check_loaded(const char *path, const rto_scene *s);
void assert_one_line(const rto_msg *m);
rto_scene *load_ok(const char *spec);
void expect_refusal(const char *spec, rto_status want, const char *substring);
int has_warning(const rto_scene *s, const char *substring);
void assimp_path(char *buf, size_t cap, const char *rel);

/* Defined in test_scene_gltf.c */
char *base64(const unsigned char *b, size_t n);
const char *gltf_file(const char *name, const void *bin, size_t binlen, const char *body);
void memory_cap_on(void);
void memory_cap_off(void);
const char *text_file(const char *name, const char *text);
const char *tmp_path(const char *name);
const char *external_gltf(const char *name, const char *buffer_uri, const char *image_uri);

/* The tests of test_scene_gltf.c */
void test_gltf_nan_position_refused(void **state);
void test_gltf_primitives_and_nodes(void **state);
void test_gltf_no_scene_uses_root_nodes(void **state);
void test_gltf_sparse_accessors(void **state);
void test_gltf_refusals(void **state);
void test_gltf_malformed_files(void **state);
void test_glb_truncation_and_flips(void **state);
void test_non_regular_files(void **state);
void test_buffer_file_size(void **state);
void test_accessor_amplification(void **state);
void test_accessor_count_zero(void **state);
void test_bounds_overflow(void **state);
void test_names_utf8(void **state);
void test_gltf1_refused(void **state);

/* The tests of test_scene_textures.c */
void test_png_decoding(void **state);
void test_texture_budget(void **state);
void test_jpeg_textures(void **state);
void test_embedded_only(void **state);

#endif /* RTO_TEST_SCENE_H */
