//! Reads a bundle's transition videos (H.264 in MP4, no B-frames) frame by
//! frame: the native viewer plays them and the builder's tests check them.
//! Only with the `video` feature; the web viewer lets the browser decode.

/// One decoded frame, RGB8, row-major.
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error("not a readable MP4: {0}")]
    Container(String),
    #[error("the MP4 has no H.264 video track")]
    NoVideo,
    #[error("H.264 decoding failed: {0}")]
    Codec(String),
}

/// Decodes samples one at a time, so a long path never sits in memory whole.
///
/// The container is read by Mozilla's `mp4parse` (Firefox's MP4 reader,
/// fuzzed continuously upstream): the `mp4` crate it replaced looped forever
/// on some hostile files (found by this project's fuzzing).
pub struct Mp4Decoder {
    bytes: Vec<u8>,
    /// Each sample's byte range in `bytes` (checked when it is read).
    samples: Vec<(u64, u64)>,
    /// Bytes of the length before each NAL unit (1, 2 or 4).
    length_size: usize,
    next_sample: usize,
    decoder: openh264::decoder::Decoder,
    /// The stream's parameter sets (Annex B), and what of them is still to
    /// be sent before the next sample.
    parameter_sets: Vec<u8>,
    header: Vec<u8>,
    flushed: std::collections::VecDeque<Frame>,
    done: bool,
    /// Frames per second from the track's timing.
    pub fps: f32,
    /// Frames decoding can start from (0-based, ascending).
    key_frames: Vec<u32>,
}

fn frame(yuv: &openh264::decoder::DecodedYUV) -> Frame {
    use openh264::formats::YUVSource;
    let (w, h) = yuv.dimensions();
    let mut rgb = vec![0; w * h * 3];
    yuv.write_rgb8(&mut rgb);
    Frame { width: w as u32, height: h as u32, rgb }
}

/// Checks box sizes and the entry counts of the sample tables before the
/// container is parsed: a box must fit in its parent, and a table's count
/// must fit in its box, so a small hostile file cannot make the parser
/// reserve gigabytes for entries that are not there. Containers are entered
/// past the fields that come before their children.
fn check_boxes(data: &[u8], depth: u32, file: usize) -> Result<(), String> {
    if depth > 16 {
        return Err("boxes nested deeper than 16 levels".into());
    }
    let mut at = 0;
    while data.len() - at >= 8 {
        let word = |i: usize| u32::from_be_bytes(data[i..i + 4].try_into().unwrap());
        let name = &data[at + 4..at + 8];
        let (size, header) = match word(at) {
            1 if data.len() - at >= 16 => ((u64::from(word(at + 8)) << 32) | u64::from(word(at + 12)), 16),
            1 => return Err(format!("box at byte {at} is cut off")),
            s => (u64::from(s), 8),
        };
        let name_text = String::from_utf8_lossy(name);
        if size < header as u64 || size > (data.len() - at) as u64 {
            return Err(format!("box '{name_text}' at byte {at} claims {size} bytes, with {} left", data.len() - at));
        }
        let body = &data[at + header..at + size as usize];
        check_table(name, body, file).map_err(|m| format!("box '{name_text}' at byte {at} {m}"))?;
        let skip = match name {
            b"moov" | b"trak" | b"mdia" | b"minf" | b"dinf" | b"edts" | b"mvex" | b"udta" | b"stbl" | b"moof" | b"traf" | b"ilst" => Some(0),
            // A full box, though some files leave out its version and flags.
            b"meta" => Some(if body.get(4..8) == Some(b"hdlr") { 0 } else { 4 }),
            b"stsd" => Some(8),
            b"avc1" | b"avc3" => Some(78),
            _ => None,
        };
        if let Some(skip) = skip.filter(|&k| k <= body.len()) {
            check_boxes(&body[skip..], depth + 1, file)?;
        }
        at += size as usize;
    }
    Ok(())
}

/// A sample table's entry count against the bytes its box holds (after the
/// version, flags and count); a constant sample size's count against the
/// file (every sample takes at least a byte).
fn check_table(name: &[u8], body: &[u8], file: usize) -> Result<(), String> {
    let word = |i: usize| body.get(i..i + 4).map(|w| u64::from(u32::from_be_bytes(w.try_into().unwrap())));
    let (count, entry, after) = match name {
        b"stts" | b"ctts" | b"co64" => (word(4), 8, 8),
        b"stss" | b"stco" => (word(4), 4, 8),
        b"stsc" => (word(4), 12, 8),
        b"stsz" => match (word(4), word(8)) {
            (Some(0), count) => (count, 4, 12),
            (Some(_), Some(count)) if count > file as u64 => return Err(format!("claims {count} frames in {file} bytes")),
            _ => return Ok(()),
        },
        _ => return Ok(()),
    };
    match count {
        Some(n) if n * entry > (body.len() as u64).saturating_sub(after) => Err(format!("claims {n} entries in {} bytes", body.len())),
        _ => Ok(()),
    }
}

/// The NAL length size and the parameter sets (SPS, then PPS, as Annex B)
/// of an `avcC` record (ISO/IEC 14496-15, 5.3.3.1).
fn avc_config(avcc: &[u8]) -> Result<(usize, Vec<u8>), DecodeError> {
    let bad = || DecodeError::Container("its H.264 configuration (avcC) is cut off".into());
    let length_size = usize::from(avcc.get(4).ok_or_else(bad)? & 3) + 1;
    if length_size == 3 {
        return Err(DecodeError::Container("its H.264 NAL units have 3-byte lengths, which the format does not allow".into()));
    }
    let mut at = 5;
    let mut header = Vec::new();
    for mask in [0x1f, 0xff] {
        let count = avcc.get(at).ok_or_else(bad)? & mask;
        at += 1;
        for _ in 0..count {
            let n = usize::from(u16::from_be_bytes(avcc.get(at..at + 2).ok_or_else(bad)?.try_into().unwrap()));
            header.extend_from_slice(&[0, 0, 0, 1]);
            header.extend_from_slice(avcc.get(at + 2..at + 2 + n).ok_or_else(bad)?);
            at += 2 + n;
        }
    }
    Ok((length_size, header))
}

impl Mp4Decoder {
    pub fn new(bytes: Vec<u8>) -> Result<Mp4Decoder, DecodeError> {
        let container = |m: String| DecodeError::Container(m);
        check_boxes(&bytes, 0, bytes.len()).map_err(container)?;
        let context = mp4parse::read_mp4(&mut std::io::Cursor::new(&bytes)).map_err(|e| container(format!("{e:?}")))?;
        // The first H.264 track and its avcC record.
        let (track, avcc) = context
            .tracks
            .iter()
            .find_map(|t| match t.stsd.as_ref()?.descriptions.first()? {
                mp4parse::SampleEntry::Video(v) if v.codec_type == mp4parse::CodecType::H264 => match &v.codec_specific {
                    mp4parse::VideoCodecSpecific::AVCConfig(avcc) => Some((t, avcc.as_slice())),
                    _ => None,
                },
                _ => None,
            })
            .ok_or(DecodeError::NoVideo)?;
        let (length_size, header) = avc_config(avcc)?;
        // The samples the chunk tables add up to, counted before a table of them is made.
        let chunks = track.stco.as_ref().map_or(0, |c| c.offsets.len() as u64);
        let runs = track.stsc.as_ref().map_or(&[][..], |s| s.samples.as_slice());
        let mut claimed = 0u64;
        for (i, run) in runs.iter().enumerate() {
            let end = runs.get(i + 1).map_or(chunks + 1, |next| u64::from(next.first_chunk)).min(chunks + 1);
            claimed = claimed.saturating_add(end.saturating_sub(u64::from(run.first_chunk)).saturating_mul(u64::from(run.samples_per_chunk)));
        }
        if claimed > bytes.len() as u64 {
            return Err(container(format!("it claims {claimed} frames in {} bytes", bytes.len())));
        }
        let table = mp4parse::unstable::create_sample_table(track, 0.into()).ok_or_else(|| container("its sample tables are inconsistent".into()))?;
        let samples: Vec<(u64, u64)> = table.iter().map(|s| (s.start_offset.0, s.end_offset.0)).collect();
        let key_frames = table.iter().enumerate().filter(|(_, s)| s.sync).map(|(i, _)| i as u32).collect();
        let (timescale, duration) = (track.timescale.map_or(0, |t| t.0), track.duration.map_or(0, |d| d.0));
        let fps = if timescale > 0 && duration > 0 { (samples.len() as f64 * timescale as f64 / duration as f64) as f32 } else { 0.0 };
        let decoder = openh264::decoder::Decoder::new().map_err(|e| DecodeError::Codec(e.to_string()))?;
        Ok(Mp4Decoder {
            bytes,
            samples,
            length_size,
            next_sample: 0,
            decoder,
            parameter_sets: header.clone(),
            header,
            flushed: Default::default(),
            done: false,
            fps: if fps.is_finite() && fps > 0.0 { fps } else { 25.0 },
            key_frames,
        })
    }

    /// Frames decoding can start from (0-based, ascending): `seek` targets.
    pub fn key_frames(&self) -> &[u32] {
        &self.key_frames
    }

    /// Restarts decoding at key frame `frame`, so a video can be played
    /// backwards a key-frame interval at a time.
    pub fn seek(&mut self, frame: u32) -> Result<(), DecodeError> {
        if self.key_frames.binary_search(&frame).is_err() {
            return Err(DecodeError::Container(format!("frame {frame} is not a key frame")));
        }
        self.decoder = openh264::decoder::Decoder::new().map_err(|e| DecodeError::Codec(e.to_string()))?;
        self.header = self.parameter_sets.clone();
        self.next_sample = frame as usize;
        self.flushed.clear();
        self.done = false;
        Ok(())
    }

    /// The number of frames the track holds.
    pub fn frame_count(&self) -> u32 {
        self.samples.len() as u32
    }

    /// The next frame, `None` at the end.
    pub fn next_frame(&mut self) -> Result<Option<Frame>, DecodeError> {
        let codec = |e: openh264::Error| DecodeError::Codec(e.to_string());
        while let Some(&(start, end)) = self.samples.get(self.next_sample) {
            let sample = self.next_sample;
            self.next_sample += 1;
            let Some(mut data) = usize::try_from(start).ok().zip(usize::try_from(end).ok()).and_then(|(a, b)| self.bytes.get(a..b)) else {
                self.next_sample = self.samples.len();
                return Err(DecodeError::Container(format!("sample {sample} lies outside the file")));
            };
            // MP4 stores NAL units after their lengths; the decoder wants start codes.
            let mut annex_b = std::mem::take(&mut self.header);
            let k = self.length_size;
            while data.len() >= k {
                let n = data[..k].iter().fold(0usize, |n, &b| n << 8 | usize::from(b));
                let nal = data.get(k..k + n).ok_or_else(|| DecodeError::Container(format!("sample {sample} is truncated")))?;
                annex_b.extend_from_slice(&[0, 0, 0, 1]);
                annex_b.extend_from_slice(nal);
                data = &data[k + n..];
            }
            if let Some(yuv) = self.decoder.decode(&annex_b).map_err(codec)? {
                return Ok(Some(frame(&yuv)));
            }
        }
        if !self.done {
            self.done = true;
            self.flushed = self.decoder.flush_remaining().map_err(codec)?.iter().map(frame).collect();
        }
        Ok(self.flushed.pop_front())
    }
}

/// Decodes every frame (for checks on short videos).
pub fn decode_mp4(bytes: Vec<u8>) -> Result<Vec<Frame>, DecodeError> {
    let mut decoder = Mp4Decoder::new(bytes)?;
    let mut frames = Vec::new();
    while let Some(f) = decoder.next_frame()? {
        frames.push(f);
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_smaller_than_their_header_are_refused_not_looped_on() {
        // Found by fuzzing: mp4 0.14 sought back to the start of such a box forever.
        let boxed = |name: &[u8], size: u32, body: &[u8]| [&size.to_be_bytes()[..], name, body].concat();
        let files = [
            boxed(b"moov", 16, &boxed(b"free", 0, &[])),
            boxed(b"moov", 8, &[]).into_iter().chain(boxed(b"free", 4, &[])).collect(),
            boxed(b"ftyp", 0, b"isom"),
            boxed(b"moov", 40, &boxed(b"trak", 32, &boxed(b"mdia", 24, &boxed(b"minf", 16, &boxed(b"stbl", 8, &[])))))
                .into_iter()
                .chain(boxed(b"mdat", 99, &[]))
                .collect(),
        ];
        for (i, bytes) in files.into_iter().enumerate() {
            match Mp4Decoder::new(bytes) {
                Err(DecodeError::Container(m)) => assert!(m.contains("claims"), "file {i}: {m}"),
                Err(e) => panic!("file {i}: {e}"),
                Ok(_) => panic!("file {i} opened"),
            }
        }
    }

    #[test]
    fn a_zero_timescale_is_an_error_or_a_default_rate_not_a_panic() {
        // mp4 0.14's `frame_rate` divided by the media timescale (found by fuzzing).
        let mut bytes = include_bytes!("../../fuzz/seeds/mp4/maze.mp4").to_vec();
        assert_eq!(Mp4Decoder::new(bytes.clone()).unwrap().fps, 25.0);
        let mdhd = bytes.windows(4).position(|w| w == b"mdhd").unwrap();
        bytes[mdhd + 16..mdhd + 20].copy_from_slice(&[0; 4]); // version 0: timescale after two times
        if let Ok(mut video) = Mp4Decoder::new(bytes) {
            assert_eq!(video.fps, 25.0);
            while let Ok(Some(_)) = video.next_frame() {}
        }
    }

    #[test]
    fn a_frame_count_larger_than_the_file_is_refused_before_allocating() {
        // A constant sample size lets a tiny file claim 4 billion frames (found by fuzzing).
        let mut bytes = include_bytes!("../../fuzz/seeds/mp4/maze.mp4").to_vec();
        let stsz = bytes.windows(4).position(|w| w == b"stsz").unwrap();
        bytes[stsz + 8..stsz + 16].copy_from_slice(&[0, 0, 0, 1, 0xff, 0xff, 0xff, 0xf0]);
        match Mp4Decoder::new(bytes) {
            Err(DecodeError::Container(m)) => assert!(m.contains("4294967280 frames"), "{m}"),
            other => panic!("{:?}", other.err()),
        }
    }

    #[test]
    fn tables_claiming_more_entries_than_their_box_holds_are_refused_and_samples_outside_the_file_are_errors() {
        let seed = include_bytes!("../../fuzz/seeds/mp4/maze.mp4").to_vec();
        for table in [&b"stts"[..], b"stsc", b"stco", b"stss"] {
            let mut bytes = seed.clone();
            let at = bytes.windows(4).position(|w| w == table).unwrap();
            bytes[at + 8..at + 12].copy_from_slice(&0x7fff_ffffu32.to_be_bytes());
            match Mp4Decoder::new(bytes) {
                Err(DecodeError::Container(m)) => assert!(m.contains("2147483647 entries"), "{m}"),
                other => panic!("{}: {:?}", String::from_utf8_lossy(table), other.err()),
            }
        }
        // The first chunk moved past the end: the file opens, reading its frames is an error.
        let mut bytes = seed.clone();
        let stco = bytes.windows(4).position(|w| w == b"stco").unwrap();
        bytes[stco + 12..stco + 16].copy_from_slice(&0xffff_0000u32.to_be_bytes());
        let mut video = Mp4Decoder::new(bytes).unwrap();
        assert!(matches!(video.next_frame(), Err(DecodeError::Container(m)) if m.contains("outside the file")));
        assert!(matches!(video.next_frame(), Ok(None) | Err(_)));
    }

    #[test]
    fn fragment_and_metadata_boxes_are_checked_too() {
        // A `moof` holding a box smaller than its header looped mp4 0.14 (found by fuzzing).
        let boxed = |name: &[u8], size: u32, body: &[u8]| [&size.to_be_bytes()[..], name, body].concat();
        let files = [
            boxed(b"moof", 16, &boxed(b"traf", 0, &[])),
            boxed(b"moov", 36, &boxed(b"udta", 28, &boxed(b"meta", 20, &[0, 0, 0, 0, 0, 0, 0, 3, b'x', b'y', b'z', b'w']))),
        ];
        for (i, bytes) in files.into_iter().enumerate() {
            assert!(matches!(Mp4Decoder::new(bytes), Err(DecodeError::Container(m)) if m.contains("claims")), "file {i}");
        }
    }

    #[test]
    fn a_meta_box_found_by_fuzzing_does_not_hang_the_reader() {
        let bytes = include_bytes!("../../fuzz/regressions/mp4-meta-hang").to_vec();
        let (done, wait) = std::sync::mpsc::channel();
        std::thread::spawn(move || done.send(Mp4Decoder::new(bytes).is_ok()).unwrap());
        assert!(wait.recv_timeout(std::time::Duration::from_secs(5)).is_ok(), "the reader is still looping after 5 s");
    }
}
