//! Linker set-up for the board build only: host builds (tests, host-sim)
//! must not see `-Tlink.x`, so it is added here under `target_os = "none"`
//! instead of in `.cargo/config.toml`, whose rustflags leak into host crates.
use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=src/board/memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    // The board binary only: the QEMU test crate links the library alone
    // with its own memory.x (the whole flash, for its recorded replays),
    // and a search path from here would shadow it.
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none")
        || env::var_os("CARGO_FEATURE_BOARD").is_none()
    {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    // Not at the repository root: the linker also looks in its working
    // directory, where it would shadow the QEMU crate's own memory.x.
    fs::write(out.join("memory.x"), include_bytes!("src/board/memory.x"))
        .expect("write memory.x to OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
