//! Google's Spherical Video V2 metadata in an MP4: the boxes by which
//! players (VLC, YouTube, phone galleries, headsets) know a video is 360°,
//! equirectangular and mono. ffmpeg 5 cannot write them from its command
//! line and the openh264 path's muxer has none, so they are added to the
//! finished file: `st3d` (stereo mode: mono) and `sv3d` (a source name,
//! then `proj` with a zero pose `prhd` and an uncropped `equi`) at the end
//! of the video track's sample entry. The boxes around it grow by as much,
//! and with the movie header before the media data (fast start), every
//! chunk offset moves on by as much too.

/// Box types that hold boxes, on the way from the file to the sample entry.
const PATH: [&[u8; 4]; 6] = [b"moov", b"trak", b"mdia", b"minf", b"stbl", b"stsd"];
/// Bytes of a visual sample entry before its child boxes (ISO/IEC 14496-12).
const VISUAL_ENTRY_FIELDS: usize = 78;
/// Named in `svhd` as the metadata's source.
const SOURCE: &str = "ExploreMaps";

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SphericalError {
    #[error("not an MP4 with a video track ({0})")]
    Layout(&'static str),
}

/// A box at `start` in `data`: (type, start, end, header size).
fn box_at(data: &[u8], start: usize, limit: usize) -> Option<([u8; 4], usize, usize, usize)> {
    let head = data.get(start..start + 8)?;
    let size32 = u32::from_be_bytes(head[..4].try_into().ok()?) as usize;
    let kind: [u8; 4] = head[4..8].try_into().ok()?;
    let (size, header) = match size32 {
        0 => (limit - start, 8),
        1 => (u64::from_be_bytes(data.get(start + 8..start + 16)?.try_into().ok()?) as usize, 16),
        s => (s, 8),
    };
    (size >= header && start + size <= limit).then_some((kind, start, start + size, header))
}

/// The child boxes in `data[from..to]`.
fn children(data: &[u8], from: usize, to: usize) -> Vec<([u8; 4], usize, usize, usize)> {
    let mut out = Vec::new();
    let mut at = from;
    while let Some(b) = box_at(data, at, to) {
        at = b.2;
        out.push(b);
        if at >= to {
            break;
        }
    }
    out
}

/// A full box (version 0, no flags) of `kind` around `body`.
fn full_box(kind: &[u8; 4], body: &[u8]) -> Vec<u8> {
    let mut out = ((12 + body.len()) as u32).to_be_bytes().to_vec();
    out.extend_from_slice(kind);
    out.extend_from_slice(&[0; 4]);
    out.extend_from_slice(body);
    out
}

/// A plain box of `kind` around `body`.
fn plain_box(kind: &[u8; 4], body: &[u8]) -> Vec<u8> {
    let mut out = ((8 + body.len()) as u32).to_be_bytes().to_vec();
    out.extend_from_slice(kind);
    out.extend_from_slice(body);
    out
}

/// `st3d` (mono) and `sv3d` (equirectangular, no pose, no crop).
fn metadata() -> Vec<u8> {
    let mut source = SOURCE.as_bytes().to_vec();
    source.push(0);
    let proj = plain_box(b"proj", &[full_box(b"prhd", &[0; 12]), full_box(b"equi", &[0; 16])].concat());
    let sv3d = plain_box(b"sv3d", &[full_box(b"svhd", &source), proj].concat());
    [full_box(b"st3d", &[0]), sv3d].concat()
}

/// The MP4 with the metadata in its video track (unchanged if it has it already).
pub fn tag(mut mp4: Vec<u8>) -> Result<Vec<u8>, SphericalError> {
    // The boxes from the file down to the video's sample entry, whose sizes grow.
    let mut ancestors = Vec::new();
    let mut scope = (0, mp4.len());
    let mut entry = None;
    for (depth, kind) in PATH.iter().enumerate() {
        let boxes = children(&mp4, scope.0, scope.1);
        let found = if *kind == b"trak" {
            // The track whose sample entry is a video's (avc1).
            boxes.iter().filter(|b| &b.0 == *kind).find_map(|&t| video_entry(&mp4, t).map(|e| (t, Some(e))))
        } else {
            boxes.iter().find(|b| &b.0 == *kind).map(|&b| (b, None))
        };
        let ((_, start, end, header), avc1) = found.ok_or(SphericalError::Layout(match depth {
            0 => "no movie header",
            1 => "no video track",
            _ => "no sample description",
        }))?;
        ancestors.push((start, header));
        entry = entry.or(avc1);
        // stsd is a full box with an entry count before its entries.
        scope = if *kind == b"stsd" { (start + header + 8, end) } else { (start + header, end) };
    }
    let (_, avc1_start, avc1_end, avc1_header) = entry.ok_or(SphericalError::Layout("no video sample entry"))?;
    let inner = avc1_start + avc1_header + VISUAL_ENTRY_FIELDS;
    if children(&mp4, inner, avc1_end).iter().any(|b| &b.0 == b"sv3d") {
        return Ok(mp4);
    }
    ancestors.push((avc1_start, avc1_header));
    let added = metadata();
    let delta = added.len();
    for &(start, header) in &ancestors {
        grow(&mut mp4, start, header, delta)?;
    }
    mp4.splice(avc1_end..avc1_end, added);
    shift_chunk_offsets(&mut mp4, avc1_end, delta)?;
    Ok(mp4)
}

/// The avc1 sample entry of track `trak`, if it is a video track's.
fn video_entry(data: &[u8], (_, start, end, header): ([u8; 4], usize, usize, usize)) -> Option<([u8; 4], usize, usize, usize)> {
    let mut scope = (start + header, end);
    for kind in &PATH[2..] {
        let &(_, s, e, h) = children(data, scope.0, scope.1).iter().find(|b| &b.0 == *kind)?;
        scope = if *kind == b"stsd" { (s + h + 8, e) } else { (s + h, e) };
    }
    children(data, scope.0, scope.1).into_iter().find(|b| &b.0 == b"avc1")
}

/// Adds `delta` to the size of the box at `start`.
fn grow(data: &mut [u8], start: usize, header: usize, delta: usize) -> Result<(), SphericalError> {
    if header == 16 {
        let size = u64::from_be_bytes(data[start + 8..start + 16].try_into().expect("8 bytes")) + delta as u64;
        data[start + 8..start + 16].copy_from_slice(&size.to_be_bytes());
    } else {
        let size = u32::from_be_bytes(data[start..start + 4].try_into().expect("4 bytes")) as usize + delta;
        let size = u32::try_from(size).map_err(|_| SphericalError::Layout("a box too large"))?;
        data[start..start + 4].copy_from_slice(&size.to_be_bytes());
    }
    Ok(())
}

/// Moves every chunk offset (`stco`, `co64`) past `at` on by `delta`.
fn shift_chunk_offsets(data: &mut [u8], at: usize, delta: usize) -> Result<(), SphericalError> {
    let Some(&(_, moov, moov_end, header)) = children(data, 0, data.len()).iter().find(|b| &b.0 == b"moov") else {
        return Err(SphericalError::Layout("no movie header"));
    };
    let mut tables = Vec::new();
    for trak in children(data, moov + header, moov_end).into_iter().filter(|b| &b.0 == b"trak") {
        let mut scope = (trak.1 + trak.3, trak.2);
        for kind in [b"mdia", b"minf", b"stbl"] {
            let Some(&(_, s, e, h)) = children(data, scope.0, scope.1).iter().find(|b| &b.0 == kind) else { break };
            scope = (s + h, e);
        }
        tables.extend(children(data, scope.0, scope.1).into_iter().filter(|b| &b.0 == b"stco" || &b.0 == b"co64"));
    }
    for (kind, start, end, header) in tables {
        let body = start + header + 4;
        let count =
            u32::from_be_bytes(data.get(body..body + 4).ok_or(SphericalError::Layout("a short chunk table"))?.try_into().expect("4")) as usize;
        let width = if &kind == b"co64" { 8 } else { 4 };
        if body + 4 + count * width > end {
            return Err(SphericalError::Layout("a short chunk table"));
        }
        for i in 0..count {
            let at_entry = body + 4 + i * width;
            if width == 4 {
                let offset = u32::from_be_bytes(data[at_entry..at_entry + 4].try_into().expect("4")) as usize;
                if offset >= at {
                    let moved = u32::try_from(offset + delta).map_err(|_| SphericalError::Layout("a chunk offset too large"))?;
                    data[at_entry..at_entry + 4].copy_from_slice(&moved.to_be_bytes());
                }
            } else {
                let offset = u64::from_be_bytes(data[at_entry..at_entry + 8].try_into().expect("8"));
                if offset >= at as u64 {
                    data[at_entry..at_entry + 8].copy_from_slice(&(offset + delta as u64).to_be_bytes());
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_is_not_an_mp4_with_a_video_track_is_refused() {
        assert_eq!(tag(b"not an mp4 at all".to_vec()), Err(SphericalError::Layout("no movie header")));
        // A movie header holding no track.
        let empty_movie = plain_box(b"moov", &full_box(b"mvhd", &[0; 96]));
        assert_eq!(tag(empty_movie), Err(SphericalError::Layout("no video track")));
    }

    #[test]
    fn the_boxes_are_as_the_specification_lays_them_out() {
        let m = metadata();
        // st3d: 13 bytes, mono; sv3d: svhd with the source, proj with prhd and equi.
        assert_eq!(&m[..13], &[0, 0, 0, 13, b's', b't', b'3', b'd', 0, 0, 0, 0, 0]);
        let sv3d = box_at(&m, 13, m.len()).unwrap();
        assert_eq!((&sv3d.0, sv3d.2), (b"sv3d", m.len()));
        let kinds: Vec<[u8; 4]> = children(&m, 13 + 8, m.len()).iter().map(|b| b.0).collect();
        assert_eq!(kinds, [*b"svhd", *b"proj"]);
        let proj = children(&m, 21, m.len())[1];
        let inner: Vec<([u8; 4], usize)> = children(&m, proj.1 + 8, proj.2).iter().map(|b| (b.0, b.2 - b.1)).collect();
        assert_eq!(inner, [(*b"prhd", 24), (*b"equi", 28)]);
    }
}
