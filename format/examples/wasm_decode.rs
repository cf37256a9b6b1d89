//! The proxy decoder as a bare WebAssembly module, for the proxy bench's
//! decoding speed in Node (`builder/benches/wasm_decode.js`). Built with
//! `cargo build --release -p exploremaps-format --example wasm_decode --target wasm32-unknown-unknown`.
//! Exports: `buffer(len) -> ptr` (room for a coded mesh) and `decode(len) ->
//! triangles` (or -1 when the file does not decode).

use std::cell::RefCell;

thread_local! {
    static INPUT: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
}

#[unsafe(no_mangle)]
pub extern "C" fn buffer(len: usize) -> *mut u8 {
    INPUT.with_borrow_mut(|input| {
        input.resize(len, 0);
        input.as_mut_ptr()
    })
}

#[unsafe(no_mangle)]
pub extern "C" fn decode(len: usize) -> i32 {
    INPUT.with_borrow(|input| match exploremaps_format::meshcode::decode(&input[..len.min(input.len())]) {
        Ok(mesh) => mesh.triangles.len() as i32,
        Err(_) => -1,
    })
}
