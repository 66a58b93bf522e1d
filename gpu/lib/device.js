// A WebGPU device through Dawn (npm `webgpu`): Vulkan when a GPU is there, else Mesa's llvmpipe through Dawn's
// OpenGL backend in compatibility mode (needs Debian libegl1 libgles2 libegl-mesa0 libgl1-mesa-dri and
// EGL_PLATFORM=surfaceless).
import fs from 'node:fs';
import path from 'node:path';

import {create, globals} from 'webgpu';

import {shaderError} from './gpu.js';

Object.assign(globalThis, globals);

/** Whether libvulkan.so.1 is where the dynamic loader would find it (LD_LIBRARY_PATH, then the system's folders). */
function vulkanLoader() {
  const dirs = [...(process.env.LD_LIBRARY_PATH || '').split(':').filter(Boolean), '/usr/lib/x86_64-linux-gnu',
    '/lib/x86_64-linux-gnu', '/usr/lib/aarch64-linux-gnu', '/usr/lib64', '/usr/lib', '/lib64', '/lib'];
  return dirs.some((d) => fs.existsSync(path.join(d, 'libvulkan.so.1')));
}

/** {device, adapter, backend}: backend 'vulkan' or 'opengl' (RTO_GPU_BACKEND forces one). */
export async function openDevice() {
  const want = process.env.RTO_GPU_BACKEND;
  // Vulkan is tried only where its loader is installed: Dawn warns (three lines) when it cannot load it.
  const tries = want ? [want] : [...(vulkanLoader() ? ['vulkan'] : []), 'opengl'];
  for (const backend of tries) {
    if (backend === 'opengl' && !process.env.EGL_PLATFORM) process.env.EGL_PLATFORM = 'surfaceless';
    // Dawn quantizes timestamp-query values (to 65,536 ns) unless told not to: --timestamps wants the real ones
    // (RTO_GPU_QUANTIZED_TIMESTAMPS=1 keeps Dawn's default).
    const flags = process.env.RTO_GPU_QUANTIZED_TIMESTAMPS ? [] : ['disable-dawn-features=timestamp_quantization'];
    const gpu = create([`backend=${backend}`, ...flags]);
    const adapter = await gpu.requestAdapter(backend === 'opengl' ? {featureLevel: 'compatibility'} : {});
    if (!adapter) continue;
    const features = adapter.features.has('timestamp-query') ? ['timestamp-query'] : [];
    // Compatibility mode's defaults give the vertex stage no storage buffers and a render pass 4 colour targets of 32
    // bytes a sample; the vbuffer family pulls vertices from two storage buffers and splits its G-buffer over 7
    // targets of 36 bytes at 4x there (llvmpipe's adapter offers 16, 8 and 128).
    const limits = {};
    const raise = (name, want) => {
      const have = adapter.limits[name] ?? 0;
      if (have > 0) limits[name] = Math.min(have, want);
    };
    raise('maxStorageBuffersInVertexStage', 4);
    raise('maxColorAttachments', 8);
    raise('maxColorAttachmentBytesPerSample', 64);
    // The fluid family's kernels use the seed's workgroups of 256 invocations (256x1x1, 8x8x4): compatibility mode's
    // defaults are 128 invocations and 128 in x (llvmpipe's adapter offers 1024).
    raise('maxComputeInvocationsPerWorkgroup', 256);
    raise('maxComputeWorkgroupSizeX', 256);
    const device = await adapter.requestDevice({requiredFeatures: features, requiredLimits: limits});
    // Uncaptured errors: a kernel's WGSL or pipeline error is kept for takeShaderError (a setup error, reported once
    // by gpu/run, with no verdict); what follows from it ("invalid due to a previous error") is dropped; any other
    // error is printed as Dawn would.
    device.rtoShaderErrors = [];
    device.addEventListener('uncapturederror', (ev) => {
      ev.preventDefault();
      const msg = String(ev.error && ev.error.message || ev.error);
      const line = shaderError(msg);
      if (line) device.rtoShaderErrors.push(line);
      else if (!device.rtoShaderErrors.length || !/previous error|Invalid/.test(msg))
        console.error(`${ev.error && ev.error.constructor ? ev.error.constructor.name : 'error'}: ${msg.trim()}`);
    });
    return {device, adapter, backend, gpu};
  }
  throw new Error('no WebGPU adapter (neither Vulkan nor OpenGL/llvmpipe)');
}

/** The first WGSL or pipeline error the device reported since the last call (one line), or null; clears the list. */
export function takeShaderError(device) {
  if (!device || !device.rtoShaderErrors || !device.rtoShaderErrors.length) return null;
  const first = device.rtoShaderErrors[0];
  device.rtoShaderErrors.length = 0;
  return first;
}
