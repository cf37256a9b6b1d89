//! Atomic file writes: every output is written under a temporary name in the
//! same folder and renamed into place, so a crash or a kill never leaves a
//! half-written file under the real name. A temporary's name says which
//! process wrote it (`.<name>.<host>-<pid>.<random>.tmp`), so the leftovers of
//! a killed run can be told from a running shard's files and removed
//! ([`remove_abandoned`]). Also the bundle's image encoders ([`jpeg`],
//! [`png`]), so every picture is encoded one way.

use std::io::Write;
use std::path::Path;

pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut tmp = tempfile::Builder::new().prefix(&format!(".{file_name}.{}.", writer())).suffix(".tmp").tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    // Temporary files are private; bundles are meant to be served and shared.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file().set_permissions(std::fs::Permissions::from_mode(0o644))?;
    }
    tmp.as_file().sync_data()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// `<host>-<pid>` of this process.
fn writer() -> String {
    format!("{}-{}", host(), std::process::id())
}

fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname").map(|h| h.trim().replace(['.', '/'], "_")).unwrap_or_else(|_| "host".into())
}

/// Removes, under `dir`, the temporaries of writers on this host that are no
/// longer running (a killed render's). Others' are left alone: another
/// shard may be writing them. Returns how many were removed.
pub fn remove_abandoned(dir: &Path) -> usize {
    // Liveness is read from /proc: without it (not Linux), nothing is removed.
    if !Path::new("/proc/self").exists() {
        return 0;
    }
    let ours = format!(".{}-", host());
    let alive = |pid: &str| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()) && Path::new("/proc").join(pid).exists();
    let mut removed = 0;
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if entry.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(path);
                continue;
            }
            if !(name.starts_with('.') && name.ends_with(".tmp")) {
                continue;
            }
            // `.<file>.<host>-<pid>.<random>.tmp`: the pid follows our host's marker.
            let Some(at) = name.rfind(&ours) else { continue };
            let pid = name[at + ours.len()..].split('.').next().unwrap_or("");
            if !alive(pid) && pid != std::process::id().to_string() && std::fs::remove_file(&path).is_ok() {
                removed += 1;
            }
        }
    }
    removed
}

/// JPEG bytes of an image (`quality` 1-100): baseline, 4:4:4 (rendered edges
/// keep their colour), Huffman tables fitted to the image.
pub fn jpeg(image: &image::RgbImage, quality: u8) -> Vec<u8> {
    jpeg_with_app1(image, quality, None)
}

/// [`jpeg`] with an APP1 segment (XMP, Exif) after the start of image.
pub fn jpeg_with_app1(image: &image::RgbImage, quality: u8, app1: Option<&[u8]>) -> Vec<u8> {
    let mut bytes = Vec::new();
    let mut encoder = jpeg_encoder::Encoder::new(&mut bytes, quality);
    encoder.set_sampling_factor(jpeg_encoder::SamplingFactor::R_4_4_4);
    encoder.set_optimized_huffman_tables(true);
    if let Some(data) = app1 {
        encoder.add_app_segment(1, data.to_vec()).expect("an APP1 segment under 64 KiB");
    }
    let (width, height) = (image.width().try_into(), image.height().try_into());
    let (Ok(width), Ok(height)) = (width, height) else { panic!("JPEG sides are at most 65535 pixels") };
    encoder.encode(image.as_raw(), width, height, jpeg_encoder::ColorType::Rgb).expect("JPEG encoding to memory");
    bytes
}

/// PNG bytes of an image.
pub fn png(image: &image::RgbImage) -> Vec<u8> {
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).expect("PNG encoding to memory");
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jpegs_decode_in_the_decoders_we_read_them_with() {
        // Detail in every channel: a decoder that misreads the fitted
        // Huffman tables or the sampling returns noise, not this.
        let image = image::RgbImage::from_fn(200, 120, |x, y| image::Rgb([((x * 7) ^ (y * 3)) as u8, (x * y) as u8, (x + 2 * y) as u8]));
        let back = image::load_from_memory(&jpeg(&image, 90)).unwrap().to_rgb8();
        let psnr = crate::tracer::psnr(&image, &back);
        assert!(psnr > 30.0, "{psnr} dB");
    }

    #[test]
    fn writes_and_replaces_without_leaving_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/out.txt");
        write_atomic(&path, b"one").unwrap();
        write_atomic(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("out.txt")]);
    }

    #[test]
    fn only_the_temporaries_of_dead_writers_on_this_host_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("sub")).unwrap();
        let (host, me) = (host(), std::process::id());
        // A pid no process has (above the kernel's largest), this process, another host.
        let dead = dir.path().join(format!("sub/.a.jpg.{host}-4194304999.x1.tmp"));
        let running = dir.path().join(format!(".b.jpg.{host}-{me}.x2.tmp"));
        let elsewhere = dir.path().join(".c.jpg.otherhost-1.x3.tmp");
        let plain = dir.path().join("d.jpg");
        for p in [&dead, &running, &elsewhere, &plain] {
            std::fs::write(p, b"x").unwrap();
        }
        assert_eq!(remove_abandoned(dir.path()), 1);
        assert!(!dead.exists() && running.exists() && elsewhere.exists() && plain.exists());
    }
}
