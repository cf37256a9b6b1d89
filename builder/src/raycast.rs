//! Ray casting on Embree 4: the only module that speaks to Embree.
//!
//! Inputs: triangles (positions + indices). Outputs: closest hits and occlusion
//! answers for single rays, 8-wide packets, and parallel batches over rayon.
//!
//! ABI: `embree4-sys` 0.0.12 carries Embree 4.2 headers, where `RTCRayHit` is 80
//! bytes; Embree >= 4.3 built with instance arrays (the library we ship with)
//! writes an extra `instPrimID` after the hit, 84 bytes for one ray and 672 for
//! a packet of 8. So every hit struct handed to Embree here is the bindgen
//! struct followed by spare room ([`RayHit1`], [`RayHit8`]), and a test checks
//! canary bytes after them survive. Intersect/occluded arguments (also grown in
//! 4.4) get the same treatment ([`QueryArgs`]); they carry the query flags.
//!
//! Packets: 8-wide (native on AVX2; 16-wide overrun their struct there). Embree
//! traverses a packet flagged COHERENT as one frustum: 2.5× faster for camera
//! and cube-map rays here (80 against 33 Mrays/s), but slower for scattered
//! rays, so the caller says which kind it has ([`Packing`]).

use embree4_sys as sys;
use glam::Vec3;
use rayon::prelude::*;
use std::ptr::null_mut;

/// A ray segment from `origin + t_min·dir` to `origin + t_max·dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    /// Need not be normalized; `t` is measured in units of its length.
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir, t_min: 0.0, t_max: f32::INFINITY }
    }
    /// The segment from `a` to `b`, for visibility tests between two points.
    pub fn segment(a: Vec3, b: Vec3) -> Ray {
        Ray { origin: a, dir: b - a, t_min: 0.0, t_max: 1.0 }
    }
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// The closest hit along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Index of the triangle in the slice the scene was built from.
    pub triangle: u32,
    /// Barycentric coordinates of the hit: point = (1-u-v)·a + u·b + v·c.
    pub u: f32,
    pub v: f32,
    /// Unit geometric normal, (b-a)×(c-a) oriented: it faces the side the
    /// triangle's corners wind counter-clockwise around.
    pub normal: Vec3,
}

#[derive(Debug, thiserror::Error)]
pub enum RaycastError {
    #[error("Embree could not create a device ({0:?}); is libembree4 the right version (>= 4.0) for this CPU?")]
    Device(sys::RTCError),
    #[error("Embree failed while building the ray-casting structure ({0:?}); the machine may be out of memory")]
    Build(sys::RTCError),
    #[error("the scene has {0} triangles; Embree takes at most 2^32-2")]
    TooLarge(usize),
}

/// One ray with its hit record, with room for what Embree 4.4 writes past
/// Embree 4.2's `RTCRayHit` (see the module header).
#[repr(C, align(16))]
struct RayHit1 {
    inner: sys::RTCRayHit,
    abi_tail: [u32; 8],
}

/// Eight rays with their hit records (structure of arrays), with spare room likewise.
#[repr(C, align(32))]
struct RayHit8 {
    inner: sys::RTCRayHit8,
    abi_tail: [u32; 16],
}

/// Query arguments with spare room after the Embree 4.2 layout (4.4 appends
/// fields); the padding is zero, which is what Embree's initializer sets.
#[repr(C)]
struct QueryArgs<T> {
    inner: T,
    abi_tail: [u64; 8],
}

fn query_flags(coherent: bool) -> sys::RTCRayQueryFlags {
    if coherent {
        sys::RTCRayQueryFlags::COHERENT
    } else {
        sys::RTCRayQueryFlags::INCOHERENT
    }
}

fn intersect_args(coherent: bool) -> QueryArgs<sys::RTCIntersectArguments> {
    let inner = sys::RTCIntersectArguments {
        flags: query_flags(coherent),
        feature_mask: sys::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
        context: null_mut(),
        filter: None,
        intersect: None,
    };
    QueryArgs { inner, abi_tail: [0; 8] }
}

fn occluded_args(coherent: bool) -> QueryArgs<sys::RTCOccludedArguments> {
    let inner = sys::RTCOccludedArguments {
        flags: query_flags(coherent),
        feature_mask: sys::RTCFeatureFlags::RTC_FEATURE_FLAG_ALL,
        context: null_mut(),
        filter: None,
        occluded: None,
    };
    QueryArgs { inner, abi_tail: [0; 8] }
}

/// Embree's packet activity mask: -1 active, 0 inactive; must be 32-byte aligned.
#[repr(C, align(32))]
struct Valid8([i32; 8]);

impl Valid8 {
    fn first(n: usize) -> Valid8 {
        Valid8(std::array::from_fn(|i| if i < n { -1 } else { 0 }))
    }
}

const INVALID_ID: u32 = u32::MAX;

fn ray1(r: &Ray) -> sys::RTCRay {
    sys::RTCRay {
        org_x: r.origin.x,
        org_y: r.origin.y,
        org_z: r.origin.z,
        tnear: r.t_min,
        dir_x: r.dir.x,
        dir_y: r.dir.y,
        dir_z: r.dir.z,
        time: 0.0,
        tfar: r.t_max,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

fn empty_hit1() -> sys::RTCHit {
    sys::RTCHit { Ng_x: 0.0, Ng_y: 0.0, Ng_z: 0.0, u: 0.0, v: 0.0, primID: INVALID_ID, geomID: INVALID_ID, instID: [INVALID_ID] }
}

fn fill_ray8(dst: &mut sys::RTCRay8, rays: &[Ray]) {
    for (i, r) in rays.iter().enumerate() {
        dst.org_x[i] = r.origin.x;
        dst.org_y[i] = r.origin.y;
        dst.org_z[i] = r.origin.z;
        dst.tnear[i] = r.t_min;
        dst.dir_x[i] = r.dir.x;
        dst.dir_y[i] = r.dir.y;
        dst.dir_z[i] = r.dir.z;
        dst.tfar[i] = r.t_max;
        dst.mask[i] = u32::MAX;
    }
}

fn zeroed_ray8() -> sys::RTCRay8 {
    sys::RTCRay8 {
        org_x: [0.0; 8],
        org_y: [0.0; 8],
        org_z: [0.0; 8],
        tnear: [0.0; 8],
        dir_x: [0.0; 8],
        dir_y: [0.0; 8],
        dir_z: [0.0; 8],
        time: [0.0; 8],
        tfar: [0.0; 8],
        mask: [0; 8],
        id: [0; 8],
        flags: [0; 8],
    }
}

fn new_rayhit8(rays: &[Ray]) -> RayHit8 {
    let mut ray = zeroed_ray8();
    fill_ray8(&mut ray, rays);
    let hit = sys::RTCHit8 {
        Ng_x: [0.0; 8],
        Ng_y: [0.0; 8],
        Ng_z: [0.0; 8],
        u: [0.0; 8],
        v: [0.0; 8],
        primID: [INVALID_ID; 8],
        geomID: [INVALID_ID; 8],
        instID: [[INVALID_ID; 8]],
    };
    RayHit8 { inner: sys::RTCRayHit8 { ray, hit }, abi_tail: [0; 16] }
}

fn hit_from(t: f32, geom: u32, prim: u32, u: f32, v: f32, ng: Vec3) -> Option<Hit> {
    (geom != INVALID_ID).then(|| Hit { t, triangle: prim, u, v, normal: ng.normalize_or_zero() })
}

/// A committed Embree scene of triangles. Queries are thread-safe.
pub struct RayScene {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    triangle_count: usize,
}

// SAFETY: Embree documents committed scenes as safe to query from any number of
// threads at once, and this type never mutates the scene after commit.
unsafe impl Send for RayScene {}
// SAFETY: as above.
unsafe impl Sync for RayScene {}

impl Drop for RayScene {
    fn drop(&mut self) {
        // SAFETY: both handles were created by `new` and are released once.
        unsafe {
            sys::rtcReleaseScene(self.scene);
            sys::rtcReleaseDevice(self.device);
        }
    }
}

impl RayScene {
    /// Builds the acceleration structure. Indices must be in range of `positions`
    /// (the `Scene` invariants guarantee it); `threads` caps Embree's build threads (0: all).
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]], threads: usize) -> Result<RayScene, RaycastError> {
        if triangles.len() >= INVALID_ID as usize {
            return Err(RaycastError::TooLarge(triangles.len()));
        }
        assert!(triangles.iter().flatten().all(|&i| (i as usize) < positions.len()), "triangle index out of range");
        let config = std::ffi::CString::new(format!("threads={threads},verbose=0")).expect("no NUL in config");
        // SAFETY: plain FFI calls on handles created here; buffers returned by
        // rtcSetNewGeometryBuffer are Embree-owned, sized for exactly the counts
        // passed, and filled before commit.
        unsafe {
            let device = sys::rtcNewDevice(config.as_ptr());
            if device.is_null() {
                return Err(RaycastError::Device(sys::rtcGetDeviceError(null_mut())));
            }
            let scene = sys::rtcNewScene(device);
            let geometry = sys::rtcNewGeometry(device, sys::RTCGeometryType::TRIANGLE);
            let vertex_ptr =
                sys::rtcSetNewGeometryBuffer(geometry, sys::RTCBufferType::VERTEX, 0, sys::RTCFormat::FLOAT3, 12, positions.len()) as *mut f32;
            let index_ptr =
                sys::rtcSetNewGeometryBuffer(geometry, sys::RTCBufferType::INDEX, 0, sys::RTCFormat::UINT3, 12, triangles.len()) as *mut u32;
            let built = !vertex_ptr.is_null() && !index_ptr.is_null();
            if built {
                let vertices = std::slice::from_raw_parts_mut(vertex_ptr, positions.len() * 3);
                for (dst, p) in vertices.chunks_exact_mut(3).zip(positions) {
                    dst.copy_from_slice(&p.to_array());
                }
                let indices = std::slice::from_raw_parts_mut(index_ptr, triangles.len() * 3);
                for (dst, t) in indices.chunks_exact_mut(3).zip(triangles) {
                    dst.copy_from_slice(t);
                }
                sys::rtcCommitGeometry(geometry);
                sys::rtcAttachGeometry(scene, geometry);
            }
            sys::rtcReleaseGeometry(geometry);
            sys::rtcSetSceneBuildQuality(scene, sys::RTCBuildQuality::MEDIUM);
            sys::rtcCommitScene(scene);
            let error = sys::rtcGetDeviceError(device);
            let result = RayScene { device, scene, triangle_count: triangles.len() };
            if !built || error != sys::RTCError::NONE {
                return Err(RaycastError::Build(error));
            }
            Ok(result)
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Embree's version as a number, e.g. 40400 for 4.4.0.
    pub fn embree_version(&self) -> i64 {
        // SAFETY: valid device handle.
        unsafe { sys::rtcGetDeviceProperty(self.device, sys::RTCDeviceProperty::VERSION) as i64 }
    }

    fn intersect1_raw(&self, rh: &mut RayHit1) {
        // SAFETY: the pointer covers the whole RayHit1, which has room for what
        // Embree 4.4 writes; NULL arguments select the defaults.
        unsafe { sys::rtcIntersect1(self.scene, rh as *mut RayHit1 as *mut sys::RTCRayHit, null_mut()) }
    }

    fn intersect8_raw(&self, valid: &Valid8, rh: &mut RayHit8, coherent: bool) {
        let mut args = intersect_args(coherent);
        let args = &mut args as *mut QueryArgs<_> as *mut sys::RTCIntersectArguments;
        // SAFETY: as in intersect1_raw; `valid` is 32-byte aligned as Embree requires;
        // `args` covers the padded arguments, with a NULL context (the default).
        unsafe { sys::rtcIntersect8(valid.0.as_ptr(), self.scene, rh as *mut RayHit8 as *mut sys::RTCRayHit8, args) }
    }

    /// Closest hit along one ray.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut rh = RayHit1 { inner: sys::RTCRayHit { ray: ray1(ray), hit: empty_hit1() }, abi_tail: [0; 8] };
        self.intersect1_raw(&mut rh);
        let (r, h) = (&rh.inner.ray, &rh.inner.hit);
        hit_from(r.tfar, h.geomID, h.primID, h.u, h.v, Vec3::new(h.Ng_x, h.Ng_y, h.Ng_z))
    }

    /// Whether anything blocks the ray between `t_min` and `t_max`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut r = ray1(ray);
        // SAFETY: RTCRay's layout did not change in Embree 4.3/4.4; NULL arguments.
        unsafe { sys::rtcOccluded1(self.scene, &mut r, null_mut()) };
        r.tfar == f32::NEG_INFINITY
    }

    /// Closest hits of up to 8 rays traced as one packet; `out[i]` answers `rays[i]`.
    /// `coherent`: the rays share an origin and nearly a direction (a pixel tile).
    pub fn intersect8(&self, rays: &[Ray], out: &mut [Option<Hit>], coherent: bool) {
        assert!(rays.len() <= 8 && out.len() >= rays.len());
        let valid = Valid8::first(rays.len());
        let mut rh = new_rayhit8(rays);
        self.intersect8_raw(&valid, &mut rh, coherent);
        let (r, h) = (&rh.inner.ray, &rh.inner.hit);
        for (i, o) in out.iter_mut().enumerate().take(rays.len()) {
            *o = hit_from(r.tfar[i], h.geomID[i], h.primID[i], h.u[i], h.v[i], Vec3::new(h.Ng_x[i], h.Ng_y[i], h.Ng_z[i]));
        }
    }

    /// Occlusion of up to 8 rays traced as one packet; `out[i]` answers `rays[i]`.
    pub fn occluded8(&self, rays: &[Ray], out: &mut [bool], coherent: bool) {
        assert!(rays.len() <= 8 && out.len() >= rays.len());
        let valid = Valid8::first(rays.len());
        let mut r = zeroed_ray8();
        fill_ray8(&mut r, rays);
        let mut args = occluded_args(coherent);
        let args = &mut args as *mut QueryArgs<_> as *mut sys::RTCOccludedArguments;
        // SAFETY: RTCRay8 is unchanged in 4.4 (Embree writes only tfar); aligned mask; padded arguments.
        unsafe { sys::rtcOccluded8(valid.0.as_ptr(), self.scene, &mut r, args) };
        for (i, o) in out.iter_mut().enumerate().take(rays.len()) {
            *o = r.tfar[i] == f32::NEG_INFINITY;
        }
    }

    /// Closest hits of many rays, spread over rayon's threads.
    pub fn intersect_batch(&self, rays: &[Ray], packing: Packing) -> Vec<Option<Hit>> {
        let mut out = vec![None; rays.len()];
        self.intersect_into(rays, &mut out, packing);
        out
    }

    /// Occlusion of many rays, spread over rayon's threads.
    pub fn occluded_batch(&self, rays: &[Ray], packing: Packing) -> Vec<bool> {
        let mut out = vec![false; rays.len()];
        self.occluded_into(rays, &mut out, packing);
        out
    }

    /// Closest hits of `rays` written to `out` (same length). Hot loops call this
    /// with a reused buffer: a fresh one costs page faults comparable to the tracing.
    pub fn intersect_into(&self, rays: &[Ray], out: &mut [Option<Hit>], packing: Packing) {
        let coherent = packing == Packing::Coherent8;
        batched(rays, out, packing, |r| self.intersect(r), |r8, o8| self.intersect8(r8, o8, coherent));
    }

    /// Occlusion of `rays` written to `out` (same length).
    pub fn occluded_into(&self, rays: &[Ray], out: &mut [bool], packing: Packing) {
        let coherent = packing == Packing::Coherent8;
        batched(rays, out, packing, |r| self.occluded(r), |r8, o8| self.occluded8(r8, o8, coherent));
    }
}

/// Spreads rays over rayon's threads in chunks of [`BATCH`], each answered one
/// ray at a time or in packets of 8, with denormals flushed while tracing.
fn batched<O: Send>(rays: &[Ray], out: &mut [O], packing: Packing, one: impl Fn(&Ray) -> O + Sync, eight: impl Fn(&[Ray], &mut [O]) + Sync) {
    assert_eq!(rays.len(), out.len());
    out.par_chunks_mut(BATCH).zip(rays.par_chunks(BATCH)).for_each(|(o, r)| {
        let _mode = FlushDenormals::new();
        match packing {
            Packing::Single => o.iter_mut().zip(r).for_each(|(o1, r1)| *o1 = one(r1)),
            Packing::Packets8 | Packing::Coherent8 => o.chunks_mut(8).zip(r.chunks(8)).for_each(|(o8, r8)| eight(r8, o8)),
        }
    });
}

/// How batches hand rays to Embree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Packing {
    /// One `rtcIntersect1`/`rtcOccluded1` call per ray: best for incoherent rays.
    Single,
    /// 8-wide packets (native width on AVX2), traced ray by ray inside Embree.
    Packets8,
    /// 8-wide packets whose rays share an origin and nearly a direction (4×2
    /// pixel tiles of a camera or cube-map face), traced as one frustum.
    Coherent8,
}

/// Sets the CPU's flush-to-zero and denormals-are-zero modes while alive, as
/// Embree asks of every thread that traces (denormals slow traversal badly), and
/// restores the previous mode on drop so code outside ray casting is unaffected.
pub(crate) struct FlushDenormals {
    #[cfg(target_arch = "x86_64")]
    saved: u32,
}

impl FlushDenormals {
    pub(crate) fn new() -> FlushDenormals {
        #[cfg(target_arch = "x86_64")]
        {
            let mut saved: u32 = 0;
            // SAFETY: stmxcsr/ldmxcsr only read and write the SSE control register;
            // bits 15 (FTZ) and 6 (DAZ) exist on every x86_64 CPU.
            unsafe {
                std::arch::asm!("stmxcsr [{}]", in(reg) &mut saved, options(nostack));
                let flushed = saved | (1 << 15) | (1 << 6);
                std::arch::asm!("ldmxcsr [{}]", in(reg) &flushed, options(nostack, readonly));
            }
            FlushDenormals { saved }
        }
        #[cfg(not(target_arch = "x86_64"))]
        FlushDenormals {}
    }
}

impl Drop for FlushDenormals {
    fn drop(&mut self) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: restores the value read in `new`.
        unsafe {
            std::arch::asm!("ldmxcsr [{}]", in(reg) &self.saved, options(nostack, readonly));
        }
    }
}

/// Rays per rayon work item: large enough to amortize scheduling, small enough to balance.
const BATCH: usize = 512;

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Unit square in the z = 0 plane, two triangles facing +z.
    fn square() -> RayScene {
        let p = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        RayScene::new(&p, &[[0, 1, 2], [0, 2, 3]], 0).unwrap()
    }

    #[test]
    fn embree_is_version_4() {
        let v = square().embree_version();
        assert!((40000..50000).contains(&v), "Embree version {v}");
    }

    #[test]
    fn exact_hit_distance_triangle_and_barycentrics() {
        let scene = square();
        // (0.75, 0.25) lies in triangle 0 (0,0)-(1,0)-(1,1): u = 0.5, v = 0.25.
        let hit = scene.intersect(&Ray::new(Vec3::new(0.75, 0.25, 2.0), Vec3::new(0.0, 0.0, -1.0))).unwrap();
        assert_eq!(hit.triangle, 0);
        assert!((hit.t - 2.0).abs() < 1e-6);
        assert!((hit.u - 0.5).abs() < 1e-6 && (hit.v - 0.25).abs() < 1e-6, "{hit:?}");
        assert!((hit.normal - Vec3::Z).length() < 1e-6);
        // (0.25, 0.75) lies in triangle 1 (0,0)-(1,1)-(0,1): u = 0.25, v = 0.5.
        let hit = scene.intersect(&Ray::new(Vec3::new(0.25, 0.75, -3.0), Vec3::new(0.0, 0.0, 2.0))).unwrap();
        assert_eq!(hit.triangle, 1);
        assert!((hit.t - 1.5).abs() < 1e-6);
        assert!((hit.u - 0.25).abs() < 1e-6 && (hit.v - 0.5).abs() < 1e-6, "{hit:?}");
        // Misses: beside the square, pointing away, and stopped short by t_max.
        assert!(scene.intersect(&Ray::new(Vec3::new(1.5, 0.5, 1.0), -Vec3::Z)).is_none());
        assert!(scene.intersect(&Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::Z)).is_none());
        assert!(scene.intersect(&Ray { t_max: 0.9, ..Ray::new(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z) }).is_none());
        assert!(scene.occluded(&Ray::segment(Vec3::new(0.5, 0.5, 1.0), Vec3::new(0.5, 0.5, -1.0))));
        assert!(!scene.occluded(&Ray::segment(Vec3::new(0.5, 0.5, 1.0), Vec3::new(0.5, 0.5, 0.1))));
    }

    #[test]
    fn canary_bytes_after_hit_structs_survive() {
        const CANARY: u8 = 0xA5;
        #[repr(C)]
        struct Guarded<T> {
            value: T,
            canary: [u8; 128],
        }
        let scene = square();
        let ray = Ray::new(Vec3::new(0.3, 0.2, 1.0), -Vec3::Z);
        let mut one =
            Guarded { value: RayHit1 { inner: sys::RTCRayHit { ray: ray1(&ray), hit: empty_hit1() }, abi_tail: [0; 8] }, canary: [CANARY; 128] };
        scene.intersect1_raw(&mut one.value);
        assert_eq!(one.value.inner.hit.primID, 0, "the guarded ray must really hit");
        assert!(one.canary.iter().all(|&b| b == CANARY), "Embree wrote past RayHit1");
        let rays = [ray; 8];
        let mut eight = Guarded { value: new_rayhit8(&rays), canary: [CANARY; 128] };
        scene.intersect8_raw(&Valid8::first(8), &mut eight.value, true);
        assert!(eight.value.inner.hit.primID.iter().all(|&p| p == 0));
        assert!(eight.canary.iter().all(|&b| b == CANARY), "Embree wrote past RayHit8");
    }

    #[test]
    fn packets_agree_with_single_rays_on_100k_random_rays() {
        let scene_data = exploremaps_scenes::BuiltIn::Pillars.generate(7);
        let scene = RayScene::new(&scene_data.positions, &scene_data.triangles, 0).unwrap();
        let bounds = scene_data.bounds();
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        let rays: Vec<Ray> = (0..100_000)
            .map(|_| {
                let o = bounds.min + Vec3::new(rng.random(), rng.random(), rng.random()) * bounds.extent();
                let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                Ray { t_max: if rng.random_bool(0.5) { f32::INFINITY } else { rng.random_range(0.1..10.0) }, ..Ray::new(o, d) }
            })
            .collect();
        let mut singles = vec![None; rays.len()];
        scene.intersect_into(&rays, &mut singles, Packing::Single);
        let hits = singles.iter().filter(|h| h.is_some()).count();
        assert!(hits > 30_000 && hits < 100_000, "the rays should both hit and miss: {hits}");
        let mut occluded_singles = vec![false; rays.len()];
        scene.occluded_into(&rays, &mut occluded_singles, Packing::Single);
        // Occlusion agrees with closest hits.
        for (o, h) in occluded_singles.iter().zip(&singles) {
            assert_eq!(*o, h.is_some());
        }
        // Packets, flagged coherent or not, agree with single rays (random rays are
        // the hard case for the coherent frustum traversal).
        for packing in [Packing::Packets8, Packing::Coherent8] {
            let packets = scene.intersect_batch(&rays, packing);
            // The pillars' bottom caps lie on the floor: coincident faces give equal
            // distances with either triangle, so a different triangle at the same
            // distance is a tie, not an error; ties must stay rare.
            let (mut mismatches, mut ties) = (0, 0);
            for (a, b) in packets.iter().zip(&singles) {
                match (a, b) {
                    (Some(a), Some(b)) if (a.t - b.t).abs() <= 1e-5 * a.t.max(1.0) => ties += (a.triangle != b.triangle) as usize,
                    (None, None) => {}
                    _ => mismatches += 1,
                }
            }
            assert_eq!(mismatches, 0, "{packing:?}");
            assert!(ties < rays.len() / 100, "{packing:?}: {ties} ties");
            assert_eq!(scene.occluded_batch(&rays, packing), occluded_singles, "{packing:?}");
        }
    }

    #[test]
    fn coherent_camera_packets_agree_with_single_rays() {
        let scene_data = exploremaps_scenes::BuiltIn::Gallery.generate(2);
        let scene = RayScene::new(&scene_data.positions, &scene_data.triangles, 0).unwrap();
        // 4×2 pixel tiles of a 256² 90° view from the pillared hall toward the statues.
        let eye = Vec3::new(28.0, 1.6, 10.0);
        let mut rays = Vec::new();
        for ty in (0..256).step_by(2) {
            for tx in (0..256).step_by(4) {
                for y in ty..ty + 2 {
                    for x in tx..tx + 4 {
                        let (sx, sy) = ((x as f32 + 0.5) / 128.0 - 1.0, 1.0 - (y as f32 + 0.5) / 128.0);
                        rays.push(Ray::new(eye, Vec3::new(sx, sy, 1.0)));
                    }
                }
            }
        }
        let singles = scene.intersect_batch(&rays, Packing::Single);
        let coherent = scene.intersect_batch(&rays, Packing::Coherent8);
        let same = singles.iter().zip(&coherent).filter(|(a, b)| a.map(|h| h.triangle) == b.map(|h| h.triangle)).count();
        assert_eq!(same, rays.len());
        assert!(singles.iter().all(|h| h.is_some()), "an indoor view hits everywhere");
    }

    #[test]
    fn partial_packets_leave_inactive_lanes_alone() {
        let scene = square();
        let rays = [Ray::new(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z); 3];
        for coherent in [false, true] {
            let mut out = [None; 8];
            scene.intersect8(&rays, &mut out, coherent);
            assert!(out[..3].iter().all(|h| h.is_some()));
            assert!(out[3..].iter().all(|h| h.is_none()));
        }
    }
}
