/* Intel Embree 3 beside the oracle: the same scene and the same rays through an independent, widely used tracer.
 * Shared by `rtoracle crosscheck`, the watertightness test and the benchmarks (bench_trace, bench_bvh), so every
 * use creates devices, mirrors scenes and traces rays the same way.
 *
 *   emb_device   an RTCDevice whose errors land in the one message channel: the device error callback keeps the
 *                first error, and every call below turns it into an rto_status with a one-line rto_msg (the
 *                command prints it on stderr; Embree itself prints nothing).
 *   emb_scene    a mirror of an rto_scene: one RTCScene per mesh (BLAS) holding one triangle geometry, and in the
 *                top scene one instance geometry per scene instance, attached with the instance's index as its
 *                geometry ID (so Embree's instID is the instance index), objToWorld as FLOAT3X4_ROW_MAJOR and the
 *                instance mask as the geometry mask.
 *   emb_trace    WfRays through a mirror into HitRecords, threads statically partitioned like rto_trace.
 *
 * Semantics that differ from the oracle's and how they are bridged:
 *   - Embree inverts objToWorld itself (in binary32); the oracle uses the scene's worldToObj, inverted in binary64.
 *     t agrees to rounding, not bit for bit: compare with the §9 tolerance.
 *   - Embree accepts tnear < t <= tfar, the oracle tMin <= t < tMax: the mirror passes tnear and tfar one float
 *     below tMin and tMax, so a hit exactly at tMin counts and one exactly at tMax does not, up to Embree's own
 *     scaled comparison (absDen tnear < T). Embree asserts tnear >= 0, so tMin 0 stays 0: a hit at exactly t = 0
 *     (an origin on a surface) may be the oracle's alone. Rays with tMin < 0, or an origin or direction component
 *     beyond 1.844e18 (Embree's FLT_LARGE; Debian's build asserts both), are refused (RTO_ERR_UNSUPPORTED).
 *   - Cull masks: Embree tests ray.mask & geometry mask, as the oracle tests cullMask & instance.mask, when the
 *     library was built with ray masks (RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED; Debian's is). Without them Embree
 *     ignores masks, so emb_trace refuses (RTO_ERR_UNSUPPORTED, naming the ray) any ray whose cull mask excludes an
 *     instance of the scene, instead of returning hits the oracle would not.
 *   - Ray flags: TERMINATE_ON_FIRST_HIT rays use rtcOccluded1, which answers hit / miss only (the record is a hit
 *     with t = -inf and no IDs, see emb_trace). CULL_BACK_FACING / CULL_FRONT_FACING need an emb_scene_desc with
 *     culling set (intersection filters decide the facing as the oracle does, see embree.c); without it such rays
 *     are refused. OPAQUE and SKIP_CLOSEST_HIT change nothing (no any-hit programs; the record is written anyway).
 *   - Rays whose origin, direction, tMin or tMax is not finite, or whose tMin > tMax, are refused as rto_trace
 *     refuses them. */
#ifndef RTO_ORACLE_EMBREE_H
#define RTO_ORACLE_EMBREE_H

#include "embree_module.h"
#include "rtoracle.h"

#include <embree3/rtcore.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/**
 * Creates a device: config "threads=N" for threads > 0, Embree's default (every hardware thread) for 0, then
 * extra (NULL or "" for nothing; e.g. "verbose=2") appended after a comma. The error callback is installed at once.
 */
rto_status emb_device_create(uint32_t threads, const char *extra, emb_device **out, rto_msg *msg);
/** Releases the device. NULL is fine; every scene of the device must be destroyed first. */
void emb_device_destroy(emb_device *d);
/** The RTCDevice, for code that builds its own Embree objects (benchmarks). */
RTCDevice emb_device_rtc(const emb_device *d);
/** The config string the device was created with. */
const char *emb_device_config(const emb_device *d);
/** Whether the Embree library tests ray masks (RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED). */
bool emb_device_ray_masks(const emb_device *d);
/**
 * Reports the first Embree error since the last call (from the callback, or rtcGetDeviceError) as a status and a
 * one-line message "Embree error during WHAT: CODE (detail)", and clears it; RTO_OK when there was none.
 */
rto_status emb_device_check(emb_device *d, const char *what, rto_msg *msg);

/** "low", "medium", "high" (the default prints as "medium"). */
const char *emb_quality_name(emb_quality q);
enum RTCBuildQuality emb_quality_rtc(emb_quality q);

/**
 * Mirrors a scene into Embree and commits it (meshes first, then the top scene). The mirror borrows the scene (for
 * instance data in hit records and the culling filters): keep it alive and unchanged until emb_scene_destroy.
 * Instances of empty meshes get no geometry (they cannot be hit). At most RTO_TLAS_MAX_INSTANCES instances.
 */
rto_status emb_scene_create(emb_device *d, const rto_scene *scene, const emb_scene_desc *desc, emb_scene **out,
                            rto_msg *msg);
/** Releases a mirror. NULL is fine. */
void emb_scene_destroy(emb_scene *s);
/** The committed top-level scene. */
RTCScene emb_scene_top(const emb_scene *s);
const emb_scene_desc *emb_scene_get_desc(const emb_scene *s);

/* Pieces of a mirror, for the build benchmark, which times their commits itself. */

/** A new, uncommitted RTCScene holding one triangle geometry with a copy of the mesh (quality on scene and
 * geometry, RTC_SCENE_FLAG_ROBUST when robust). NULL after an Embree error (emb_device_check says which). */
RTCScene emb_mesh_scene_new(emb_device *d, const rto_mesh *mesh, emb_quality quality, bool robust);
/** Creates an instance geometry of blas with the instance's objToWorld and mask, commits it and attaches it to top
 * under geometry ID id. Returns false after an Embree error. */
bool emb_instance_attach(emb_device *d, RTCScene top, RTCScene blas, const rto_instance *instance, uint32_t id,
                         emb_quality quality);

/** Checks that every ray can be traced by the mirror as the oracle would trace it (finite, tMin <= tMax; masks;
 * culling): RTO_OK, or RTO_ERR_INVALID_ARGUMENT / RTO_ERR_UNSUPPORTED naming the first ray that cannot. */
rto_status emb_rays_check(const emb_scene *s, const emb_device *d, const rto_wf_ray *rays, size_t n, rto_msg *msg);

/**
 * Traces n rays through a mirror into n hit records (DESIGN.md §6 layout): rtcIntersect1 for closest-hit rays,
 * rtcOccluded1 for TERMINATE_ON_FIRST_HIT rays. A closest hit is recorded as rto_trace records it: t, instanceId
 * (Embree's instID[0], the instance index), primId, hitGroup = the instance's sbtOffset, bary (u, v) (Embree's
 * barycentrics follow the same convention), customIndex and the instance's objToWorld as a column-major mat4x3.
 * A miss is the miss record (missFlag 1, t = tMax, IDs 0xFFFFFFFF, the rest 0). An occluded TERMINATE_ON_FIRST_HIT
 * ray is a hit whose t is -inf and whose four IDs are 0xFFFFFFFF: Embree does not say what occluded it.
 * threads: 0 for one per online CPU; rays are split into contiguous ranges with emb_partition, as rto_trace splits
 * them. The rays are checked first (emb_rays_check).
 */
rto_status emb_trace(const emb_scene *s, emb_device *d, const rto_wf_ray *rays, size_t n, uint32_t threads,
                     rto_hit_record *hits, rto_msg *msg);
/** How emb_trace_api calls Embree: per ray (rtcIntersect1 / rtcOccluded1, emb_trace), or in streams of 256 rays
 * (rtcIntersect1M / rtcOccluded1M), with the context flag that says the rays are incoherent (Embree's default) or
 * coherent. */
typedef enum emb_api { EMB_API_SINGLE = 0, EMB_API_STREAM = 1, EMB_API_STREAM_COHERENT = 2 } emb_api;
/** emb_trace through one of the APIs; the same records. A stream needs a mirror without culling (its filters read
 * one ray per context): RTO_ERR_UNSUPPORTED otherwise. */
rto_status emb_trace_api(const emb_scene *s, emb_device *d, const rto_wf_ray *rays, size_t n, uint32_t threads,
                         emb_api api, rto_hit_record *hits, rto_msg *msg);
/** One ray, closest hit (rtcIntersect1) whatever its flags: how crosscheck asks which triangle occluded a
 * TERMINATE_ON_FIRST_HIT ray. No checks. */
void emb_trace_closest(const emb_scene *s, const rto_wf_ray *ray, rto_hit_record *hit);

/** One thread per online CPU for threads == 0, else threads; at most 256 (rto_trace's rule). */
uint32_t emb_thread_count(uint32_t threads);
/** Part k of n items split into parts contiguous ranges: [k n / parts, (k + 1) n / parts), as rto_trace splits. */
void emb_partition(size_t n, uint32_t parts, uint32_t k, size_t *begin, size_t *end);

#endif
