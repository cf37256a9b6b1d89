//! Point-to-go's files as the viewer reads them: a proxy level's table of
//! the probe that sees each triangle best, and a probe's depth cube. The first
//! byte picks which; the rest is the file.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, file)) = data.split_first() else { return };
    if which & 1 == 0 {
        if let Ok(best) = exploremaps_format::seen::decode(file, 1000, 16) {
            assert!(best.len() == 1000 && best.iter().all(|&p| p == exploremaps_format::seen::NONE || p < 16));
        }
        let _ = exploremaps_format::seen::decode_runs(file, None);
    } else if let Ok(map) = exploremaps_format::depthmap::DepthMap::decode(file, 16) {
        let texels = 6 * (map.size * map.size) as usize;
        assert!(map.depth.len() == texels && map.best.len() == texels);
        // Every direction looks up within the map.
        let _ = map.look([0.3, -0.2, 0.9]);
        let _ = map.look([0.0, 0.0, 0.0]);
    }
});
