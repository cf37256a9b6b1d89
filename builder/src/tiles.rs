//! Cuts a probe's cube faces into the tile pyramid tour viewers load
//! (Pannellum's `multires`, Marzipano's cube geometry, Photo Sphere Viewer's
//! cube-tiles adapter, our own viewer): faces turned to the tour orientation
//! ([`exploremaps_format::Tiles`]), each level cut into square tiles, and one
//! small preview strip of all six faces.

use exploremaps_format::{Tiles, PREVIEW_ORDER, TILE_FACES};
use image::{imageops, RgbImage};

/// A face of the bundle's cube (GPU orientation, [`exploremaps_format::CUBE_FACES`]
/// order) turned to the tour orientation: side faces mirrored left to
/// right, top and bottom upside down ([`Tiles::face_coordinates`]).
pub fn tour_face(face: usize, image: &RgbImage) -> RgbImage {
    if face == 2 || face == 3 {
        imageops::flip_vertical(image)
    } else {
        imageops::flip_horizontal(image)
    }
}

/// Writes the pyramid through `emit(file, tile)`, smallest level first.
/// `levels` holds the faces (bundle orientation, six a level) at whatever
/// sizes were rendered, the largest `tiles.size`; a tile level with no face
/// of its size is resized from the nearest larger one.
pub fn cut<E>(tiles: &Tiles, levels: &[(u32, Vec<RgbImage>)], mut emit: impl FnMut(&str, RgbImage) -> Result<(), E>) -> Result<(), E> {
    let source = |size: u32| levels.iter().filter(|(s, faces)| *s >= size && faces.len() == 6).min_by_key(|(s, _)| *s);
    let Some((largest, _)) = source(tiles.size) else { return Ok(()) };
    debug_assert_eq!(*largest, tiles.size, "the largest level is the pyramid's");
    let resized = |face: &RgbImage, size: u32| {
        if face.width() == size {
            face.clone()
        } else {
            imageops::resize(face, size, size, imageops::FilterType::Triangle)
        }
    };
    for level in 1..=tiles.levels {
        let size = tiles.level_size(level);
        let (_, faces) = source(size).expect("the largest level covers every size");
        for (f, face) in faces.iter().enumerate() {
            let turned = tour_face(f, &resized(face, size));
            let n = tiles.across(level);
            for y in 0..n {
                for x in 0..n {
                    let (x0, y0) = (x * tiles.tile, y * tiles.tile);
                    let tile = imageops::crop_imm(&turned, x0, y0, tiles.tile.min(size - x0), tiles.tile.min(size - y0)).to_image();
                    emit(&tiles.file(level, TILE_FACES[f], x, y), tile)?;
                }
            }
        }
    }
    let (_, smallest) = source(tiles.preview_size).unwrap_or_else(|| levels.iter().min_by_key(|(s, _)| *s).expect("levels is not empty"));
    let p = tiles.preview_size;
    let mut strip = RgbImage::new(p, 6 * p);
    for (row, name) in PREVIEW_ORDER.iter().enumerate() {
        let f = TILE_FACES.iter().position(|c| c == name).expect("the preview names the six faces");
        imageops::replace(&mut strip, &tour_face(f, &resized(&smallest[f], p)), 0, (row as u32 * p).into());
    }
    emit(&tiles.preview, strip)
}

/// Puts a level's tiles back together into six faces (bundle orientation):
/// the inverse of [`cut`] at that level, for checks. `tile(file)` reads one.
pub fn assemble<E>(tiles: &Tiles, level: u32, mut tile: impl FnMut(&str) -> Result<RgbImage, E>) -> Result<Vec<RgbImage>, E> {
    let size = tiles.level_size(level);
    let mut faces = Vec::with_capacity(6);
    for (f, name) in TILE_FACES.iter().enumerate() {
        let mut turned = RgbImage::new(size, size);
        for y in 0..tiles.across(level) {
            for x in 0..tiles.across(level) {
                imageops::replace(&mut turned, &tile(&tiles.file(level, *name, x, y))?, (x * tiles.tile).into(), (y * tiles.tile).into());
            }
        }
        // Each turn is its own inverse.
        faces.push(tour_face(f, &turned));
    }
    Ok(faces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// A face whose every pixel says where it is.
    fn face(size: u32, f: usize) -> RgbImage {
        RgbImage::from_fn(size, size, |x, y| image::Rgb([(x * 255 / size) as u8, (y * 255 / size) as u8, 40 * f as u8]))
    }

    fn jpeg_round_trip(image: &RgbImage) -> RgbImage {
        image::load_from_memory(&crate::files::jpeg(image, 90)).unwrap().to_rgb8()
    }

    #[test]
    fn tiles_reassemble_into_the_faces_within_jpeg_error() {
        // 999 halves unevenly: the edge tiles are cut short.
        let tiles = Tiles::new("probes/0/tiles".into(), 999, 256, 64);
        assert_eq!(tiles.tile, 256);
        let levels = vec![(999, (0..6).map(|f| face(999, f)).collect::<Vec<_>>())];
        let mut written: HashMap<String, RgbImage> = HashMap::new();
        cut(&tiles, &levels, |file, tile| {
            assert!(file == tiles.preview || (tile.width() <= 256 && tile.height() <= 256));
            written.insert(file.to_string(), jpeg_round_trip(&tile));
            Ok::<_, ()>(())
        })
        .unwrap();
        assert_eq!(written.len(), tiles.files().len() + 1, "every tile and the preview");
        assert!(tiles.files().iter().all(|f| written.contains_key(f)));
        let top = tiles.levels;
        let faces = assemble(&tiles, top, |file| written.get(file).cloned().ok_or(())).unwrap();
        for (f, got) in faces.iter().enumerate() {
            let want = &levels[0].1[f];
            let worst = got.pixels().zip(want.pixels()).flat_map(|(a, b)| (0..3).map(move |c| a[c].abs_diff(b[c]))).max().unwrap();
            assert!(worst <= 12, "face {f}: a pixel is off by {worst}");
        }
        // The preview's third face is f (−Z), turned: its top-left pixel is
        // the bundle face's top-right.
        let preview = &written[&tiles.preview];
        assert_eq!(preview.dimensions(), (64, 6 * 64));
        let p = preview.get_pixel(0, 2 * 64 + 32);
        assert!(p[0] > 200 && p[2].abs_diff(200) < 12, "{p:?}");
    }
}
