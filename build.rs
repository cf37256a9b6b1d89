//! The CLI's binaries and tests load Embree at run time: give them an rpath to the
//! folder that exploremaps-builder's build script found or fetched.
fn main() {
    if let Ok(dir) = std::env::var("DEP_EMBREE4_LIBDIR") {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{dir}");
    }
}
