//! The MP4 / H.264 reader of transition videos: open, seek, decode frames.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(mut video) = exploremaps_format::video::Mp4Decoder::new(data.to_vec()) else { return };
    let last = video.frame_count().saturating_sub(1);
    let _ = video.seek(last / 2);
    for _ in 0..4 {
        match video.next_frame() {
            Ok(Some(_)) => {}
            _ => break,
        }
    }
});
