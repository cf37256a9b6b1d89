//! Lighting reused along a path's video frames.
//!
//! A transition video moves the eye a few centimetres a frame, and every
//! material is diffuse, so the light arriving at a surface point does not
//! depend on where it is seen from. Key frames (every few frames, and the
//! last) are rendered in full and keep, per pixel, the first hit and the
//! irradiance there (direct and gathered indirect). The frames between trace
//! their own eye rays, so geometry, texture and silhouettes stay exact, and
//! take the irradiance from the two key frames around them: each hit is
//! projected into the key frame's panorama and its 2 × 2 nearest pixels are
//! weighted by likeness (normal and tangent plane, as in the gather's
//! upsampling) and by closeness in space, then the two keys are blended by
//! time, which also fades one key's gather noise into the next instead of
//! changing it every frame. Points neither key saw (disocclusions) are lit
//! as a frame without reuse would light them outside the gather: shadow rays
//! and the cache.
//!
//! A key frame also takes the previous key's gathered indirect light where
//! that key saw the same point (its *history*) and averages it with its own
//! gather, up to [`HISTORY`] keys deep: the same quantity estimated again,
//! so the noise falls as keys go by, and later keys can gather with fewer
//! rays. Direct light stays each key's own (sharp shadow edges).
//!
//! Only single-sample frames keep their hits (a pixel's samples hit
//! different points); a path rendered with more samples renders every frame
//! in full.

use super::gather::NORMAL_POWER;
use super::surface::Surface;
use glam::{Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, PI, TAU};
use std::ops::{Add, Div, Mul};

/// Keys a key frame's gathered light averages over at most (the weight of
/// its own gather is at least 1 / HISTORY): more would keep older, more
/// blurred estimates (each reprojection mixes 2 × 2 pixels) longer.
pub const HISTORY: f32 = 4.0;

/// What a key frame saw at one pixel.
#[derive(Clone, Copy, Debug)]
pub struct Seen {
    pub position: Vec3,
    /// The shading normal.
    pub normal: Vec3,
    /// All of it: direct and indirect.
    pub irradiance: Vec3,
}

/// A key frame's first hits and the irradiance found there.
pub struct Lit {
    pub(super) eye: Vec3,
    pub(super) width: u32,
    pub(super) height: u32,
    /// Per row, every how many pixels it was traced (empty: every pixel);
    /// `None` in `points` for those skipped.
    pub(super) columns: Vec<u32>,
    /// Per pixel; `None` for the sky.
    pub(super) points: Vec<Option<Seen>>,
    /// Per pixel: the gathered indirect light and how many keys' gathers it
    /// averages (apart: frames between keys need only `points`).
    pub(super) history: Vec<Vec4>,
}

/// How a frame reuses light along a path.
#[derive(Clone, Copy)]
pub enum Reuse<'a> {
    /// Lit alone, nothing kept.
    Off,
    /// A key frame: keep what each pixel saw; average its gather with the
    /// previous key's where that saw the same point.
    Key { history: Option<&'a Lit> },
    /// A frame between two keys: their light where they saw the point.
    Between(&'a Between<'a>),
}

/// The key frames around a frame and how far the frame is from the first (0..1).
pub struct Between<'a> {
    pub keys: [&'a Lit; 2],
    pub t: f32,
}

impl Lit {
    /// Where four points fall in this key frame, lane by lane: their pixel
    /// coordinates x and y (pixel centres at whole numbers) and one pixel's
    /// footprint at their distance (the equator's, the largest; a thinned
    /// row's traced pixels are no farther apart); 0 at the eye. Four at
    /// once: a frame between keys projects every pixel's hit into both.
    fn project(&self, p: [Vec3; 4]) -> [Vec4; 3] {
        let d = |f: fn(Vec3) -> f32| Vec4::from_array(p.map(f));
        let (dx, dy, dz) = (d(|p| p.x) - self.eye.x, d(|p| p.y) - self.eye.y, d(|p| p.z) - self.eye.z);
        let across = (dx * dx + dz * dz).sqrt();
        let distance = (across * across + dy * dy).sqrt();
        // The bundle's yaw (0 toward −Z, turning toward +X) and the angle
        // down from straight up, as fractions of a turn and of a half turn
        // (products with the reciprocals: these are long dependent chains).
        let yaw = atan2(dx, -dz) * (0.5 * FRAC_1_PI);
        let yaw = Vec4::select(yaw.cmplt(Vec4::ZERO), yaw + 1.0, yaw);
        let down = atan2(across, dy) * FRAC_1_PI;
        [yaw * self.width as f32 - 0.5, down * self.height as f32 - 0.5, distance * (TAU / self.width as f32)]
    }

    /// The mean of `value` over the pixels (at most four) that saw the point
    /// of `s`, weighted by nearness and likeness; `None` where this key saw
    /// something else there.
    fn blend<T: Copy + Default + Add<Output = T> + Mul<f32, Output = T> + Div<f32, Output = T>>(
        &self,
        s: &Surface,
        (x, y, footprint): (f32, f32, f32),
        value: impl Fn(usize, &Seen) -> T,
    ) -> Option<T> {
        if footprint <= 0.0 {
            return None;
        }
        let (width, height) = (self.width as i32, self.height as i32);
        // x, y ≥ −0.5, so truncating y + 1 (and u + 1 below) floors it (without a libm call).
        let y0 = (y + 1.0) as i32 - 1;
        let fy = y - y0 as f32;
        // The 2 × 2 traced pixels around and their bilinear weights (0 off
        // the image or on the sky): the two rows' pixels on each side.
        let mut index = [0usize; 4];
        let mut bilinear = [0.0f32; 4];
        let mut seen = [&NOWHERE; 4];
        for dy in 0..2 {
            let yy = y0 + dy;
            if yy < 0 || yy >= height {
                continue;
            }
            let columns = self.columns.get(yy as usize).map_or(1, |&c| c as i32);
            // (Columns are powers of two: the product is the quotient exactly.)
            let u = x * (1.0 / columns as f32);
            let u0 = (u + 1.0) as i32 - 1;
            let fx = u - u0 as f32;
            let wy = if dy == 1 { fy } else { 1.0 - fy };
            for dx in 0..2 {
                let xx = (u0 + dx) * columns;
                let xx = if xx < 0 {
                    xx + width
                } else if xx >= width {
                    xx - width
                } else {
                    xx
                };
                let i = (yy * width + xx) as usize;
                if let Some(p) = &self.points[i] {
                    let j = (2 * dy + dx) as usize;
                    index[j] = i;
                    bilinear[j] = (if dx == 1 { fx } else { 1.0 - fx }) * wy;
                    seen[j] = p;
                }
            }
        }
        // The four likenesses side by side in SIMD lanes (this runs twice a
        // pixel of every frame between keys): `gather::geometric_weight`
        // with the power 16, after dropping hits more than two footprints
        // away (another surface: an occluder in front, or beyond an edge).
        let lanes = |f: fn(&Seen) -> f32| Vec4::new(f(seen[0]), f(seen[1]), f(seen[2]), f(seen[3]));
        let (dx, dy, dz) = (lanes(|p| p.position.x) - s.position.x, lanes(|p| p.position.y) - s.position.y, lanes(|p| p.position.z) - s.position.z);
        let m = s.normal;
        let cos = lanes(|p| p.normal.x) * m.x + lanes(|p| p.normal.y) * m.y + lanes(|p| p.normal.z) * m.z;
        let near = (dx * dx + dy * dy + dz * dz).cmple(Vec4::splat(4.0 * footprint * footprint));
        // |Δ · m| ≤ |Δ| ≤ 2 footprints for the hits kept, so the exponent is in [0, 4].
        let plane = (dx * m.x + dy * m.y + dz * m.z) / footprint;
        let c2 = cos * cos;
        let c4 = c2 * c2;
        let c16 = (c4 * c4) * (c4 * c4);
        let w = Vec4::from_array(bilinear) * c16 * exp_minus((plane * plane).min(Vec4::splat(4.0)));
        let w = Vec4::select(near & cos.cmpgt(Vec4::splat(0.5)), w, Vec4::ZERO);
        let weight = w.element_sum();
        if weight < 0.25 {
            return None;
        }
        let mut sum = T::default();
        for j in 0..4 {
            if w[j] > 0.0 {
                sum = sum + value(index[j], seen[j]) * w[j];
            }
        }
        Some(sum / weight)
    }

    /// This key's gathered indirect light at `s` and how many keys it averages.
    pub fn history(&self, s: &Surface) -> Option<Vec4> {
        let [x, y, footprint] = self.project([s.position; 4]);
        self.blend(s, (x.x, y.x, footprint.x), |i, _| self.history[i])
    }
}

impl Between<'_> {
    /// Irradiance at four surface points from the key frames, blended by
    /// time; `None` where neither saw it (and for a point not given).
    pub fn irradiance(&self, s: [Option<&Surface>; 4]) -> [Option<Vec3>; 4] {
        let p = s.map(|s| s.map_or(Vec3::ZERO, |s| s.position));
        let at = self.keys.map(|key| key.project(p));
        std::array::from_fn(|j| {
            let s = s[j]?;
            let [a, b] = [0, 1].map(|k| self.keys[k].blend(s, (at[k][0][j], at[k][1][j], at[k][2][j]), |_, seen| seen.irradiance));
            match (a, b) {
                (Some(a), Some(b)) => Some(a.lerp(b, self.t)),
                (a, b) => a.or(b),
            }
        })
    }
}

// `blend` raises the normals' cosine to this power by squaring four times.
const _: () = assert!(NORMAL_POWER == 16);

/// A stand-in for the sky's and off-image pixels (their weight is 0).
const NOWHERE: Seen = Seen { position: Vec3::ZERO, normal: Vec3::ZERO, irradiance: Vec3::ZERO };

/// e^(−y) for y in [0, 4], lane by lane, within 5e-5 of it relatively:
/// (e^(−y/8))⁸, the inner one by its Taylor series to the sixth power.
fn exp_minus(y: Vec4) -> Vec4 {
    let z = y * -0.125;
    let e = Vec4::ONE + z * (1.0 + z * (0.5 + z * (1.0 / 6.0 + z * (1.0 / 24.0 + z * (1.0 / 120.0 + z * (1.0 / 720.0))))));
    let e2 = e * e;
    let e4 = e2 * e2;
    e4 * e4
}

/// atan2 lane by lane, to within 2e-5 radians (a fiftieth of a pixel of a
/// 4096-wide frame) at a fraction of libm's cost; 0 where x = y = 0.
fn atan2(y: Vec4, x: Vec4) -> Vec4 {
    let (ax, ay) = (x.abs(), y.abs());
    // atan on [0, 1] by an odd minimax polynomial, then the octant.
    let a = ax.min(ay) / ax.max(ay);
    let a = Vec4::select(a.is_nan_mask(), Vec4::ZERO, a);
    let s = a * a;
    let r = a * (0.999_977_26 + s * (-0.332_623_47 + s * (0.193_543_46 + s * (-0.116_432_87 + s * (0.052_653_32 + s * -0.011_721_2)))));
    let r = Vec4::select(ay.cmpgt(ax), FRAC_PI_2 - r, r);
    let r = Vec4::select(x.cmplt(Vec4::ZERO), PI - r, r);
    Vec4::select(y.cmplt(Vec4::ZERO), -r, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::gather::geometric_weight;

    /// `Lit::blend` as it was written before its lanes: one pixel at a time
    /// with `geometric_weight` and libm's exponential.
    /// Also the sum of the weights.
    fn blend_one_by_one(lit: &Lit, s: &Surface) -> (Option<Vec3>, f32) {
        let d = s.position - lit.eye;
        let distance = d.length();
        let yaw = d.x.atan2(-d.z) / TAU;
        let x = yaw.rem_euclid(1.0) * lit.width as f32 - 0.5;
        let y = (d.x * d.x + d.z * d.z).sqrt().atan2(d.y) / PI * lit.height as f32 - 0.5;
        let footprint = TAU / lit.width as f32 * distance;
        let (x0, y0) = (x.floor() as i32, y.floor() as i32);
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
        for (yy, wy) in [(y0, 1.0 - fy), (y0 + 1, fy)] {
            for (xx, wx) in [(x0, 1.0 - fx), (x0 + 1, fx)] {
                if yy < 0 || yy >= lit.height as i32 {
                    continue;
                }
                let i = (yy * lit.width as i32 + xx.rem_euclid(lit.width as i32)) as usize;
                let Some(seen) = &lit.points[i] else { continue };
                if (seen.position - s.position).length_squared() > 4.0 * footprint * footprint {
                    continue;
                }
                let w = wx * wy * geometric_weight(s.position, s.normal, seen.position, seen.normal, footprint, NORMAL_POWER);
                sum += seen.irradiance * w;
                weight += w;
            }
        }
        ((weight >= 0.25).then(|| sum / weight), weight)
    }

    #[test]
    fn lanes_weigh_a_keys_pixels_as_one_by_one() {
        // A key of a bumpy room: every pixel sees a point near a sphere of
        // radius 3 with a tilted normal and its own light; some see the sky.
        let (width, height) = (64u32, 32u32);
        let eye = Vec3::new(0.5, 1.5, -0.25);
        let mut rng = crate::seeds::sampler(3, crate::seeds::Work::Pixels, 0, 0);
        let mut r = || rand::Rng::random::<f32>(&mut rng);
        let mut points = Vec::new();
        for y in 0..height {
            for x in 0..width {
                let (yaw, down) = ((x as f32 + 0.5) / width as f32 * TAU, (y as f32 + 0.5) / height as f32 * PI);
                let dir = Vec3::new(down.sin() * yaw.sin(), down.cos(), -down.sin() * yaw.cos());
                let sky = r() < 0.05;
                let position = eye + dir * (3.0 + 0.05 * r());
                let normal = (-dir + Vec3::new(r(), r(), r()) * 0.6 - 0.3).normalize();
                let irradiance = Vec3::new(r(), r(), r()) * 5.0;
                points.push((!sky).then_some(Seen { position, normal, irradiance }));
            }
        }
        let lit = Lit { eye, width, height, columns: Vec::new(), points, history: vec![Vec4::ZERO; (width * height) as usize] };
        let (mut found, mut compared) = (0, 0);
        for _ in 0..4000 {
            let dir = (Vec3::new(r(), r(), r()) * 2.0 - 1.0).normalize_or(Vec3::X);
            let normal = (-dir + Vec3::new(r(), r(), r()) * 0.6 - 0.3).normalize();
            let s = Surface { position: eye + dir * (3.0 + 0.05 * r()), normal, geometric: normal, albedo: Vec3::ONE, emission: Vec3::ZERO };
            let (lanes, (one_by_one, weight)) =
                (Between { keys: [&lit, &lit], t: 0.0 }.irradiance([None, Some(&s), None, None])[1], blend_one_by_one(&lit, &s));
            // (Within rounding of the threshold either answer is right.)
            if (weight - 0.25).abs() < 1e-3 {
                continue;
            }
            compared += 1;
            match (lanes, one_by_one) {
                (Some(a), Some(b)) => {
                    found += 1;
                    assert!((a - b).abs().max_element() <= 1e-3 * b.max_element().max(1.0), "{a} against {b}");
                }
                (a, b) => assert_eq!(a.is_some(), b.is_some(), "one found light, the other not: {a:?}, {b:?}"),
            }
        }
        assert!(found > compared / 4, "only {found} of {compared} points found a key's light");
    }

    #[test]
    fn lane_exponential_agrees_with_libm() {
        for i in 0..=4000 {
            let y = i as f32 * 0.001;
            let e = super::exp_minus(glam::Vec4::splat(y)).x;
            assert!((e / (-y).exp() - 1.0).abs() < 5e-5, "e^-{y}: {e}");
        }
    }

    #[test]
    fn fast_atan2_agrees_with_libm() {
        for i in 0..3600 {
            let a = i as f32 * 0.1f32.to_radians();
            for r in [1e-3f32, 1.0, 1e3] {
                let (y, x) = (r * a.sin(), r * a.cos());
                let d = (super::atan2(Vec4::splat(y), Vec4::splat(x)).x - y.atan2(x)).abs();
                assert!(d < 2e-5 || (d - std::f32::consts::TAU).abs() < 2e-5, "atan2({y}, {x}): {d}");
            }
        }
    }
}
