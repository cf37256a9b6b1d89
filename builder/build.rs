//! Finds the Embree 4 shared library, or fetches it, and tells the linker where it is.
//!
//! Order: `EMBREE_DIR` (a folder holding `libembree4.so`, or its `lib/`), then a system
//! Embree >= 4 through pkg-config, then the `embreex` wheel from PyPI (Debian 12 only
//! packages Embree 3). The wheel is pinned by hash and fetched with pip, so no host
//! name appears here. Its libraries carry `$ORIGIN` rpaths, so TBB is found beside Embree.

use std::env;
use std::path::{Path, PathBuf};
use std::process::Command;

const WHEEL_REQUIREMENT: &str = "embreex==4.4.0.post1 \
    --hash=sha256:2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f";

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    let lib_dir = match find_library() {
        Ok(dir) => dir,
        Err(message) => {
            // A build script's panic is the only way to stop the build; say what to do.
            panic!("\n\nexploremaps-builder needs the Embree 4 library.\n{message}\n\n");
        }
    };
    println!("cargo:rustc-link-search=native={}", lib_dir.display());
    // rpath covers this crate's tests and benches; dependents add their own from DEP_EMBREE4_LIBDIR.
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
    println!("cargo:libdir={}", lib_dir.display());
    // Open Image Denoise (scripts/setup.sh fetches it; .cargo/config.toml sets OIDN_DIR).
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if let Some(dir) = env::var_os("OIDN_DIR") {
        let lib = Path::new(&dir).join("lib");
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
        println!("cargo:oidn_libdir={}", lib.display());
    }
}

fn find_library() -> Result<PathBuf, String> {
    if let Some(dir) = env::var_os("EMBREE_DIR") {
        let dir = PathBuf::from(dir);
        for candidate in [dir.join("lib"), dir.join("lib64"), dir.clone()] {
            if candidate.join("libembree4.so").exists() {
                return Ok(candidate);
            }
        }
        return Err(format!(
            "EMBREE_DIR={} holds no libembree4.so (looked in it, lib/ and lib64/). \
             Point it at an Embree 4 install, or unset it to fetch Embree automatically.",
            dir.display()
        ));
    }
    if let Some(dir) = system_embree() {
        return Ok(dir);
    }
    fetch_wheel()
}

fn system_embree() -> Option<PathBuf> {
    let out = Command::new("pkg-config").args(["--atleast-version=4.0", "--variable=libdir", "embree4"]).output().ok()?;
    let dir = PathBuf::from(String::from_utf8(out.stdout).ok()?.trim());
    (out.status.success() && dir.join("libembree4.so").exists()).then_some(dir)
}

fn fetch_wheel() -> Result<PathBuf, String> {
    let out_dir = PathBuf::from(env::var("OUT_DIR").map_err(|e| e.to_string())?);
    let lib_dir = out_dir.join("embree");
    if lib_dir.join("libembree4.so").exists() {
        return Ok(lib_dir);
    }
    let wheel_dir = out_dir.join("wheel");
    std::fs::create_dir_all(&wheel_dir).map_err(|e| e.to_string())?;
    let requirements = wheel_dir.join("requirements.txt");
    std::fs::write(&requirements, format!("{WHEEL_REQUIREMENT}\n")).map_err(|e| e.to_string())?;
    let python = env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let pip_failed = |detail: String| {
        format!(
            "Fetching the embreex 4.4.0.post1 wheel from PyPI with `{python} -m pip download` failed:\n{detail}\n\
             Either allow access to PyPI, or install Embree >= 4 and set EMBREE_DIR to its folder."
        )
    };
    let status = Command::new(&python)
        .args(["-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:"])
        .args(["--require-hashes", "--python-version", "3.11"])
        .args(["--platform", "manylinux_2_28_x86_64", "-d"])
        .arg(&wheel_dir)
        .arg("-r")
        .arg(&requirements)
        .status()
        .map_err(|e| pip_failed(e.to_string()))?;
    if !status.success() {
        return Err(pip_failed(format!("pip exited with {status}")));
    }
    unpack_libraries(&wheel_dir, &lib_dir, &python)?;
    Ok(lib_dir)
}

/// Extracts `embreex.libs/*` flat into `lib_dir` and adds the `libembree4.so` link name.
fn unpack_libraries(wheel_dir: &Path, lib_dir: &Path, python: &str) -> Result<(), String> {
    let script = r#"
import glob, os, sys, zipfile
wheel_dir, lib_dir = sys.argv[1], sys.argv[2]
wheel = sorted(glob.glob(os.path.join(wheel_dir, "embreex-*.whl")))[0]
os.makedirs(lib_dir, exist_ok=True)
embree = None
with zipfile.ZipFile(wheel) as z:
    for name in z.namelist():
        if name.startswith("embreex.libs/") and not name.endswith("/"):
            target = os.path.join(lib_dir, os.path.basename(name))
            with z.open(name) as src, open(target + ".part", "wb") as dst:
                dst.write(src.read())
            os.rename(target + ".part", target)
            if os.path.basename(name).startswith("libembree4"):
                embree = os.path.basename(name)
if embree is None:
    sys.exit("the wheel holds no libembree4")
link = os.path.join(lib_dir, "libembree4.so")
if os.path.lexists(link):
    os.remove(link)
os.symlink(embree, link)
"#;
    let status = Command::new(python)
        .arg("-c")
        .arg(script)
        .arg(wheel_dir)
        .arg(lib_dir)
        .status()
        .map_err(|e| format!("running {python} to unpack the wheel failed: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("unpacking the embreex wheel in {} failed ({status})", wheel_dir.display()))
    }
}
