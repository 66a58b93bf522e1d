// A WebGPU device through Dawn (npm `webgpu`): Vulkan when a GPU is there, else Mesa's llvmpipe through Dawn's
// OpenGL backend in compatibility mode (needs Debian libegl1 libgles2 libegl-mesa0 libgl1-mesa-dri and
// EGL_PLATFORM=surfaceless).
import {create, globals} from 'webgpu';

Object.assign(globalThis, globals);

/** {device, adapter, backend}: backend 'vulkan' or 'opengl' (RTO_GPU_BACKEND forces one). */
export async function openDevice() {
  const want = process.env.RTO_GPU_BACKEND;
  const tries = want ? [want] : ['vulkan', 'opengl'];
  for (const backend of tries) {
    if (backend === 'opengl' && !process.env.EGL_PLATFORM) process.env.EGL_PLATFORM = 'surfaceless';
    const gpu = create([`backend=${backend}`]);
    const adapter = await gpu.requestAdapter(backend === 'opengl' ? {featureLevel: 'compatibility'} : {});
    if (!adapter) continue;
    const features = adapter.features.has('timestamp-query') ? ['timestamp-query'] : [];
    const device = await adapter.requestDevice({requiredFeatures: features});
    return {device, adapter, backend, gpu};
  }
  throw new Error('no WebGPU adapter (neither Vulkan nor OpenGL/llvmpipe)');
}
