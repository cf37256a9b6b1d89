//! Procedural textures for the built-in scenes, so walls and floors carry detail
//! that the renderer's filtering and the viewer's compression must preserve.

use crate::scene::Texture;
use image::{Rgba, RgbaImage};

const SIZE: u32 = 256;

/// Integer hash to [0, 1): deterministic value noise without a random generator.
fn hash01(x: u32, y: u32, seed: u32) -> f32 {
    let mut h = x.wrapping_mul(0x8da6_b343) ^ y.wrapping_mul(0xd816_3841) ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h & 0x00ff_ffff) as f32 / 16_777_216.0
}

/// Smooth tileable value noise with period `cells` over the texture.
fn noise(x: u32, y: u32, cells: u32, seed: u32) -> f32 {
    let f = cells as f32 / SIZE as f32;
    let (fx, fy) = (x as f32 * f, y as f32 * f);
    let (x0, y0) = (fx.floor() as u32, fy.floor() as u32);
    let (tx, ty) = (fx.fract(), fy.fract());
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let v = |i: u32, j: u32| hash01((x0 + i) % cells, (y0 + j) % cells, seed);
    let top = v(0, 0) + (v(1, 0) - v(0, 0)) * sx;
    let bottom = v(0, 1) + (v(1, 1) - v(0, 1)) * sx;
    top + (bottom - top) * sy
}

fn make(name: &str, f: impl Fn(u32, u32) -> [f32; 3]) -> Texture {
    let image = RgbaImage::from_fn(SIZE, SIZE, |x, y| {
        let c = f(x, y).map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
        Rgba([c[0], c[1], c[2], 255])
    });
    Texture { name: format!("procedural:{name}"), image }
}

/// Tinted plaster with soft blotches.
pub fn plaster(tint: [f32; 3], seed: u32) -> Texture {
    make("plaster", |x, y| {
        let n = 0.8 * noise(x, y, 8, seed) + 0.2 * noise(x, y, 32, seed + 1);
        tint.map(|c| c * (0.85 + 0.3 * n))
    })
}

/// Running-bond brick with mortar lines.
pub fn bricks(seed: u32) -> Texture {
    make("bricks", |x, y| {
        let row = y / 32;
        let shifted = x + if row % 2 == 1 { 32 } else { 0 };
        let (bx, by) = (shifted % 64, y % 32);
        if bx < 3 || by < 3 {
            return [0.75, 0.72, 0.66];
        }
        let brick = hash01(shifted / 64, row, seed);
        let grain = noise(x, y, 64, seed + 7);
        [0.55 + 0.15 * brick + 0.1 * grain, 0.27 + 0.08 * brick, 0.2 + 0.05 * grain]
    })
}

/// Two-tone marble checkerboard.
pub fn checker_marble(seed: u32) -> Texture {
    make("checker_marble", |x, y| {
        let dark = ((x / 64) + (y / 64)) % 2 == 1;
        let vein = (noise(x, y, 16, seed) * 12.0).sin().abs();
        let base = if dark { 0.25 } else { 0.85 };
        let v = base - 0.12 * (1.0 - vein);
        [v, v * 0.98, v * 0.95]
    })
}

/// Wood planks along u.
pub fn planks(seed: u32) -> Texture {
    make("planks", |x, y| {
        let plank = y / 32;
        let grain = (x as f32 * 0.05 + 6.0 * noise(x, y, 8, seed + plank)).sin() * 0.5 + 0.5;
        let tone = 0.8 + 0.2 * hash01(plank, 0, seed);
        if y % 32 < 2 {
            [0.2, 0.12, 0.07]
        } else {
            [tone * (0.45 + 0.1 * grain), tone * (0.3 + 0.06 * grain), tone * (0.17 + 0.04 * grain)]
        }
    })
}
