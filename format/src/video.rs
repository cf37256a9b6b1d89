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
pub struct Mp4Decoder {
    reader: mp4::Mp4Reader<std::io::Cursor<Vec<u8>>>,
    track: u32,
    next_sample: u32,
    samples: u32,
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

/// Runs a call into `mp4` 0.14, whose sample tables divide by counts a file
/// may give as zero and index past their ends: such a panic becomes an error.
fn guarded<T>(call: impl FnOnce() -> T + std::panic::UnwindSafe) -> Result<T, DecodeError> {
    std::panic::catch_unwind(call).map_err(|_| DecodeError::Container("its sample tables are inconsistent".into()))
}

/// Checks the sizes of the boxes `mp4` 0.14 walks. It loops forever on a box
/// smaller than its own header (its skip seeks back to the box's start; size
/// 0, "to the end of the file", is such a box to it): those are refused here,
/// as are boxes past their parent's end. Containers are entered as `mp4`
/// enters them, past the fields that come before their children.
fn check_boxes(data: &[u8], depth: u32) -> Result<(), String> {
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
        let skip = match name {
            b"moov" | b"trak" | b"mdia" | b"minf" | b"dinf" | b"edts" | b"mvex" | b"udta" | b"stbl" | b"moof" | b"traf" | b"ilst" => Some(0),
            b"\xa9nam" | b"\xa9day" | b"covr" | b"desc" => Some(0), // metadata items in ilst
            // A full box, though some files leave out its version and flags.
            b"meta" => Some(if body.get(4..8) == Some(b"hdlr") { 0 } else { 4 }),
            b"stsd" => Some(8),
            b"avc1" | b"avc3" | b"hev1" | b"hvc1" | b"vp09" => Some(78),
            b"mp4a" => Some(28),
            b"tx3g" => Some(38),
            _ => None,
        };
        if let Some(skip) = skip.filter(|&k| k <= body.len()) {
            check_boxes(&body[skip..], depth + 1)?;
        }
        at += size as usize;
    }
    Ok(())
}

impl Mp4Decoder {
    pub fn new(bytes: Vec<u8>) -> Result<Mp4Decoder, DecodeError> {
        let err = |e: mp4::Error| DecodeError::Container(e.to_string());
        check_boxes(&bytes, 0).map_err(DecodeError::Container)?;
        let size = bytes.len() as u64;
        let reader = guarded(|| mp4::Mp4Reader::read_header(std::io::Cursor::new(bytes), size))?.map_err(err)?;
        let track = reader.tracks().values().find(|t| t.media_type().ok() == Some(mp4::MediaType::H264)).ok_or(DecodeError::NoVideo)?;
        let mut header = Vec::new();
        for ps in [track.sequence_parameter_set().map_err(err)?, track.picture_parameter_set().map_err(err)?] {
            header.extend_from_slice(&[0, 0, 0, 1]);
            header.extend_from_slice(ps);
        }
        let (id, samples) = (track.track_id(), track.sample_count());
        // Every sample takes at least a byte of the file.
        if samples as u64 > size {
            return Err(DecodeError::Container(format!("it claims {samples} frames in {size} bytes")));
        }
        // Not mp4's `frame_rate`, which divides by a zero timescale.
        let (timescale, duration) = (track.timescale(), track.trak.mdia.mdhd.duration);
        let fps = if timescale > 0 && duration > 0 { (samples as f64 * timescale as f64 / duration as f64) as f32 } else { 0.0 };
        // No sync-sample table means every sample is one.
        let key_frames = match &track.trak.mdia.minf.stbl.stss {
            Some(stss) => stss.entries.iter().filter(|&&s| s >= 1 && s <= samples).map(|s| s - 1).collect(),
            None => (0..samples).collect(),
        };
        let decoder = openh264::decoder::Decoder::new().map_err(|e| DecodeError::Codec(e.to_string()))?;
        Ok(Mp4Decoder { reader, track: id, next_sample: 1, samples, decoder, parameter_sets: header.clone(), header, flushed: Default::default(), done: false, fps: if fps.is_finite() && fps > 0.0 { fps } else { 25.0 }, key_frames })
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
        self.next_sample = frame + 1;
        self.flushed.clear();
        self.done = false;
        Ok(())
    }

    /// The number of frames the track holds.
    pub fn frame_count(&self) -> u32 {
        self.samples
    }

    /// The next frame, `None` at the end.
    pub fn next_frame(&mut self) -> Result<Option<Frame>, DecodeError> {
        let codec = |e: openh264::Error| DecodeError::Codec(e.to_string());
        while self.next_sample <= self.samples {
            let sample = self.next_sample;
            self.next_sample += 1;
            let (reader, track) = (&mut self.reader, self.track);
            let read = guarded(std::panic::AssertUnwindSafe(|| reader.read_sample(track, sample)));
            let read = read.inspect_err(|_| self.next_sample = self.samples + 1)?;
            let Some(s) = read.map_err(|e| DecodeError::Container(e.to_string()))? else { continue };
            // MP4 stores NAL units with 4-byte lengths; the decoder wants start codes.
            let mut annex_b = std::mem::take(&mut self.header);
            let mut data: &[u8] = &s.bytes;
            while data.len() >= 4 {
                let n = u32::from_be_bytes([data[0], data[1], data[2], data[3]]) as usize;
                let nal = data.get(4..4 + n).ok_or_else(|| DecodeError::Container(format!("sample {sample} is truncated")))?;
                annex_b.extend_from_slice(&[0, 0, 0, 1]);
                annex_b.extend_from_slice(nal);
                data = &data[4 + n..];
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
        // Found by fuzzing: mp4 0.14 seeks back to the start of such a box forever.
        let boxed = |name: &[u8], size: u32, body: &[u8]| [&size.to_be_bytes()[..], name, body].concat();
        let files = [
            boxed(b"moov", 16, &boxed(b"free", 0, &[])),
            boxed(b"moov", 8, &[]).into_iter().chain(boxed(b"free", 4, &[])).collect(),
            boxed(b"ftyp", 0, b"isom"),
            boxed(b"moov", 40, &boxed(b"trak", 32, &boxed(b"mdia", 24, &boxed(b"minf", 16, &boxed(b"stbl", 8, &[]))))).into_iter().chain(boxed(b"mdat", 99, &[])).collect(),
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
        // mp4's `frame_rate` divides by the media timescale (found by fuzzing).
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

    /// Known defect, open: a file found by fuzzing (a `meta` box in `udta`)
    /// still makes mp4 0.14 loop in its meta reader. Ignored until fixed;
    /// `cargo test -p exploremaps-format --features video -- --ignored` shows it.
    #[test]
    #[ignore]
    fn a_meta_box_found_by_fuzzing_does_not_hang_the_reader() {
        let bytes = include_bytes!("../../fuzz/regressions/mp4-meta-hang").to_vec();
        let (done, wait) = std::sync::mpsc::channel();
        std::thread::spawn(move || done.send(Mp4Decoder::new(bytes).is_ok()).unwrap());
        assert!(wait.recv_timeout(std::time::Duration::from_secs(5)).is_ok(), "the reader is still looping after 5 s");
    }
}
