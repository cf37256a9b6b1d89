//! The MP4 / H.264 reader of transition videos: open, seek, decode frames.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The reader turns panics of the `mp4` crate into errors: back to the
    // default hook, so only a panic that escapes it aborts.
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| drop(std::panic::take_hook()));
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
