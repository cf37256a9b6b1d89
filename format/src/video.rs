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

impl Mp4Decoder {
    pub fn new(bytes: Vec<u8>) -> Result<Mp4Decoder, DecodeError> {
        let err = |e: mp4::Error| DecodeError::Container(e.to_string());
        let size = bytes.len() as u64;
        let reader = mp4::Mp4Reader::read_header(std::io::Cursor::new(bytes), size).map_err(err)?;
        let track = reader.tracks().values().find(|t| t.media_type().ok() == Some(mp4::MediaType::H264)).ok_or(DecodeError::NoVideo)?;
        let mut header = Vec::new();
        for ps in [track.sequence_parameter_set().map_err(err)?, track.picture_parameter_set().map_err(err)?] {
            header.extend_from_slice(&[0, 0, 0, 1]);
            header.extend_from_slice(ps);
        }
        let (id, samples) = (track.track_id(), track.sample_count());
        let fps = track.frame_rate() as f32;
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
            let Some(s) = self.reader.read_sample(self.track, sample).map_err(|e| DecodeError::Container(e.to_string()))? else { continue };
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
