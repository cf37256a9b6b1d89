//! The CLI's binaries and tests load Embree and Open Image Denoise at run time: give
//! them rpaths to the folders exploremaps-builder's build script found or fetched.
fn main() {
    for key in ["DEP_EMBREE4_LIBDIR", "DEP_EMBREE4_OIDN_LIBDIR"] {
        if let Ok(dir) = std::env::var(key) {
            println!("cargo:rustc-link-arg=-Wl,-rpath,{dir}");
        }
    }
}
