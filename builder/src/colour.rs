//! sRGB's transfer function, both ways: scene files and textures carry
//! sRGB-encoded colours, lighting works in linear light, and pictures are
//! written encoded again.

/// sRGB-encoded byte to linear, by table (powf per texel was a fifth of render time).
pub fn srgb_to_linear(c: u8) -> f32 {
    srgb_table()[c as usize]
}

/// sRGB's transfer function, decoded: an encoded value in [0, 1] to linear.
pub fn srgb_decode(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

pub(crate) fn srgb_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_decode(i as f32 / 255.0)))
}

/// sRGB encoding of a linear value in 0..=1 (clamped), by a table of 8,192
/// steps: the inverse of [`srgb_to_linear`] within a level wherever a byte
/// can tell (the table is finer than a byte everywhere but the darkest
/// 1/8,192).
pub fn linear_to_srgb(x: f32) -> u8 {
    const STEPS: usize = 8192;
    static TABLE: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..=STEPS)
            .map(|i| {
                let c = i as f32 / STEPS as f32;
                let e = if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
                (e * 255.0).round().clamp(0.0, 255.0) as u8
            })
            .collect()
    });
    table[(x.clamp(0.0, 1.0) * STEPS as f32 + 0.5) as usize]
}
