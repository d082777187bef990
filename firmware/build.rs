//! For bare-metal builds of the firmware's binaries: puts the board's `memory.x` where
//! cortex-m-rt's `link.x` finds it and links with `link.x`. Host builds are untouched.
use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=memory");
    println!("cargo:rerun-if-changed=build.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let board = if env::var_os("CARGO_FEATURE_BOARD_STM32F407").is_some() {
        "stm32f407.x"
    } else {
        "mps2-an386.x"
    };
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy(PathBuf::from("memory").join(board), out.join("memory.x")).expect("memory file");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    // defmt's symbols (its interned strings) have their own linker script.
    if env::var_os("CARGO_FEATURE_DEFMT").is_some() {
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
