// Case family "vbuffer": the visibility buffer of seed 004 (DESIGN.md §11). rtoracle vbuffer writes the bundle (meshes,
// instances, vb_camera.npy, the manifest's width, height, samples, material, thresholds, sun and ambient, and the
// oracle's planes); the GPU rasterizes the scene into a 1x or 4x multisampled G-buffer (kernels/vb_visibility.wgsl),
// copies every sample of every plane into a buffer (vb_dump.wgsl), runs the material pass on it (vb_material.wgsl) and
// dumps vb_visibility, vb_barycentric, vb_normal, vb_derivatives, vb_depth, vb_edge_mask and vb_image (.npy);
// rtoracle check-vbuffer validates them (§11.6).
//
// WebGPU compatibility mode on Mesa llvmpipe (Dawn's OpenGL backend, featureLevel 'compatibility', as gpu/lib/device.js
// opens it; Mesa 22.3.6, LLVM 15), as found running this family:
//   - rgba16uint (and rgba16float) multisampled render targets: NOT allowed ("The texture format
//     (TextureFormat::RGBA16Uint) does not support multisampling"). At 4x only r8unorm, rg8unorm, rgba8unorm,
//     r16float, rg16float, rgb10a2unorm and the depth formats multisample; no integer format at all, no r32float. So
//     at 4x the G-buffer is split over 7 targets (vb_visibility.wgsl fs_split): the two visibility words byte by
//     byte in two rgba8unorm targets (exact both ways), the normal and derivative planes in two rg16float each; vb_dump
//     puts them back together, so the dump's files are the same. 1x uses §11.4's formats as they are.
//   - 5 attachments at 4x: the compatibility defaults are maxColorAttachments 4 and maxColorAttachmentBytesPerSample
//     32 (adapter: 8 and 128). §11.4's four targets (28 bytes) would fit, but do not multisample (above); the split
//     G-buffer needs 7 targets and 36 bytes (rgba8unorm counts 8), so gpu/lib/device.js requests the adapter's
//     maxColorAttachments (up to 8) and maxColorAttachmentBytesPerSample (up to 64).
//   - textureLoad of multisampled textures in a compute shader: allowed for texture_multisampled_2d<u32> and <f32>;
//     NOT for depth textures ("textureLoad can not be used with depth textures in compatibility mode", both
//     texture_depth_2d and texture_depth_multisampled_2d). vb_dump binds the depth24plus texture as an
//     unfilterable-float texture_multisampled_2d<f32> / texture_2d<f32> instead (explicit layout), which is allowed
//     and reads the same depth.
//   - dpdxFine / dpdyFine: NOT allowed ("fine derivative builtins (dpdxFine, dpdyFine, fwidthFine) can not be used in
//     compatibility mode"). The compatibility entry points use dpdx / dpdy (fine or coarse at the device's choice;
//     llvmpipe's are per row / per column of the quad, i.e. fine); fs_main with the fine built-ins runs on a core
//     device.
//   - @interpolate(flat, either): allowed (and required: compatibility mode refuses flat's default `first` vertex).
//   - storage buffers in the vertex stage: the compatibility default maxStorageBuffersInVertexStage is 0 (adapter: 16);
//     gpu/lib/device.js requests up to 4 for the vertex pulling.
//   - draw(..., firstInstance = i) reaches @builtin(instance_index) as i (IDs agree with the trace family's primary
//     hits at every pixel centre at 1x).
// What check-vbuffer says of llvmpipe, and what DESIGN.md §11 allows for it (the family passes):
//   - binary16: llvmpipe writes RG16float / RGBA16float targets rounded toward zero (the truncation in ~97 % of the
//     values where it differs from nearest-even). Vulkan leaves the rounding of float conversions to the device, so
//     check-vbuffer accepts either unless --f16-rounding nearest is given.
//   - barycentrics: llvmpipe interpolates attributes from unsnapped window positions (b1 = 0.244024 on rtstress:2,
//     instance 6 primitive 7, pixel (23, 16); 0.244296 from positions snapped to 8 bits), and at 4x from a mix of
//     snapped and unsnapped ones (an evaluation point ~1e-3 px from the pixel centre); §11.3 and §11.6 admit both.
//   - the material pass's view depth in binary32 loses most of its digits near the far plane; the mask is compared
//     with the classifier within that error (§11.6).
import path from 'node:path';
import {Bundle} from '../lib/bundle.js';
import {check, checkScenes, rtoracle, scenePath} from '../lib/oracle.js';
import {renderVbuffer, writeVbufferDump} from '../lib/vbuffer.js';

export const family = 'vbuffer';

const MATERIALS = ['normals', 'lambert'];

const sceneName = (s) => (s.includes('/') ? path.basename(s) : s);
const vbCase = (scene, samples, material, width = 64, height = 48) => ({family, scene, width, height, samples,
  material, id: `vbuffer/${sceneName(scene)}/${width}x${height}/${samples}x/${material}`});

/** ci: triangle and rtstress:2 at 64x48, 1x and 4x, normals and lambert, and the Duck fixture at 64x48 4x unlit
 * (texture sampling). full: also rtstress:4 and sphere:3, a clustered instance set, rtstress:4 and the Duck fixture at
 * 160x90, and the Duck unlit at 160x90, 1x and 4x. --scenes: each scene named at 64x48, 1x and 4x, both materials. */
export function list(opts) {
  const each = (scenes, w, h) => scenes.flatMap((s) => [1, 4].flatMap((n) => MATERIALS.map((m) => vbCase(s, n, m, w,
    h))));
  if (opts.scenes) {
    checkScenes(opts.rtoracle, opts.scenes);
    return each(opts.scenes);
  }
  const duck = 'fixtures/Duck/glTF/Duck.gltf'; // textured: unlit samples its base-colour texture (§11.5)
  const ci = [...each(['triangle', 'rtstress:2']), vbCase(duck, 4, 'unlit')];
  if (opts.subset === 'ci') return ci;
  return [...ci, ...each(['rtstress:4', 'sphere:3', 'instances:clustered:257']), ...each(['rtstress:4', duck], 160, 90),
    ...[1, 4].map((n) => vbCase(duck, n, 'unlit', 160, 90))];
}

/** The oracle's vbuffer bundle: the GPU's inputs and the planes, mask and image it expects. */
export function prepare(ctx, c) {
  rtoracle(ctx.rtoracle, ['vbuffer', scenePath(c.scene), '--width', String(c.width), '--height', String(c.height),
    '--msaa', String(c.samples), '--material', c.material, '-o', path.join(ctx.dir, 'expected')]);
}

/** The GPU's G-buffer, edge mask and image, rendered from the bundle's inputs alone, under the dump's file names. */
export async function dump(ctx) {
  const vb = await renderVbuffer(ctx.device, new Bundle(path.join(ctx.dir, 'expected')), {timer: ctx.timer});
  writeVbufferDump(ctx.dumpDir, vb);
}

export function validate(ctx) {
  return {...check(ctx.rtoracle, 'check-vbuffer', ['--expected', path.join(ctx.dir, 'expected'), '--gpu', ctx.dumpDir]),
    check: 'check-vbuffer'};
}
