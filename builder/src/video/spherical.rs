//! Google's Spherical Video V2 metadata in an MP4: the boxes by which
//! players (VLC, YouTube, phone galleries, headsets) know a video is 360°,
//! equirectangular and mono. ffmpeg 5 cannot write them from its command
//! line and the openh264 path's muxer has none, so they are added to the
//! finished file: `st3d` (stereo mode: mono) and `sv3d` (a source name,
//! then `proj` with a zero pose `prhd` and an uncropped `equi`) at the end
//! of the video track's sample entry. The boxes around it grow by as much,
//! and with the movie header before the media data (fast start), every
//! chunk offset moves on by as much too.

/// Box types from a track down to its video sample entry.
const TO_ENTRY: [&[u8; 4]; 5] = [b"mdia", b"minf", b"stbl", b"stsd", b"avc1"];
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
fn box_at(data: &[u8], start: usize, limit: usize) -> Option<Bx> {
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
fn children(data: &[u8], from: usize, to: usize) -> Vec<Bx> {
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

/// A box: type, start, end, header size.
type Bx = ([u8; 4], usize, usize, usize);

/// Where a box's children are (after the entry count, in a `stsd`).
fn inside(&(kind, start, end, header): &Bx) -> (usize, usize) {
    let skip = if &kind == b"stsd" { 8 } else { 0 };
    (start + header + skip, end)
}

/// The boxes of `kinds` nested one in the next, from `scope` down (the first of each kind).
fn descend(data: &[u8], mut scope: (usize, usize), kinds: &[&[u8; 4]]) -> Option<Vec<Bx>> {
    let mut chain = Vec::with_capacity(kinds.len());
    for kind in kinds {
        let found = children(data, scope.0, scope.1).into_iter().find(|b| &b.0 == *kind)?;
        scope = inside(&found);
        chain.push(found);
    }
    Some(chain)
}

/// The file's movie header box.
fn movie_header(data: &[u8]) -> Result<Bx, SphericalError> {
    children(data, 0, data.len()).into_iter().find(|b| &b.0 == b"moov").ok_or(SphericalError::Layout("no movie header"))
}

/// The MP4 with the metadata in its video track (unchanged if it has it already).
pub fn tag(mut mp4: Vec<u8>) -> Result<Vec<u8>, SphericalError> {
    let moov = movie_header(&mp4)?;
    // The boxes from the movie header down to the video's sample entry (avc1), whose sizes grow.
    let (scope_start, scope_end) = inside(&moov);
    let chain = children(&mp4, scope_start, scope_end)
        .into_iter()
        .filter(|b| &b.0 == b"trak")
        .find_map(|trak| descend(&mp4, inside(&trak), &TO_ENTRY).map(|rest| [vec![moov, trak], rest].concat()))
        .ok_or(SphericalError::Layout("no video track"))?;
    let (_, avc1_start, avc1_end, avc1_header) = *chain.last().expect("the sample entry");
    if children(&mp4, avc1_start + avc1_header + VISUAL_ENTRY_FIELDS, avc1_end).iter().any(|b| &b.0 == b"sv3d") {
        return Ok(mp4);
    }
    let added = metadata();
    let delta = added.len();
    for &(_, start, _, header) in &chain {
        grow(&mut mp4, start, header, delta)?;
    }
    mp4.splice(avc1_end..avc1_end, added);
    shift_chunk_offsets(&mut mp4, avc1_end, delta)?;
    Ok(mp4)
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
    let moov = movie_header(data)?;
    let (from, to) = inside(&moov);
    let mut tables = Vec::new();
    for trak in children(data, from, to).into_iter().filter(|b| &b.0 == b"trak") {
        if let Some(stbl) = descend(data, inside(&trak), &TO_ENTRY[..3]).and_then(|c| c.last().copied()) {
            let (from, to) = inside(&stbl);
            tables.extend(children(data, from, to).into_iter().filter(|b| &b.0 == b"stco" || &b.0 == b"co64"));
        }
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
