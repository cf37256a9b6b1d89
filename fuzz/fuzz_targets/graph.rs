//! A bundle's graph.json: parsing, then the validation every reader runs.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(graph) = exploremaps_format::Graph::from_json(text) {
            let _ = graph.validate();
        }
    }
});
