//! Denoising with Intel Open Image Denoise's ray-tracing filter, guided by
//! the first hit's albedo and normal (the `oidn` crate; scripts/setup.sh
//! fetches the library).

use super::Frame;
use glam::Vec3;

fn flat(v: &[Vec3]) -> Vec<f32> {
    v.iter().flat_map(|c| c.to_array()).collect()
}

/// What went wrong in the library (its errors carry only a debug text).
#[derive(Debug, thiserror::Error)]
pub enum DenoiseError {
    #[error("Open Image Denoise: no CPU device ({0}); run scripts/setup.sh, which fetches the library")]
    NoDevice(String),
    #[error("Open Image Denoise: no ray-tracing filter ({0})")]
    NoFilter(String),
    #[error("Open Image Denoise: {0}")]
    Filter(String),
}

/// Replaces a frame's radiance with its denoised version.
pub fn denoise(frame: &mut Frame) -> Result<(), DenoiseError> {
    let device = oidn::Device::cpu().map_err(|e| DenoiseError::NoDevice(format!("{e:?}")))?;
    let (albedo, normal) = (flat(&frame.albedo), flat(&frame.normal));
    let mut color = flat(&frame.color);
    oidn::RayTracing::try_new(&device)
        .map_err(|e| DenoiseError::NoFilter(format!("{e:?}")))?
        .hdr(true)
        .albedo_normal(&albedo, &normal)
        .image_dimensions(frame.width as usize, frame.height as usize)
        .filter_in_place(&mut color)
        .map_err(|e| DenoiseError::Filter(format!("{e:?}")))?;
    device.get_error().map_err(|e| DenoiseError::Filter(format!("{e:?}")))?;
    frame.color = color.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    Ok(())
}
