//! The board binary. On the STM32 target it hands over to [`urechis::board`];
//! on any other target it only explains itself, so host builds of the whole
//! workspace (tests, host-sim) stay green.
#![cfg_attr(all(target_os = "none", feature = "board"), no_std)]
#![cfg_attr(all(target_os = "none", feature = "board"), no_main)]

#[cfg(not(all(target_os = "none", feature = "board")))]
fn main() {
    eprintln!(
        "urechis firmware: build for the board with `cargo run --release` \
         (target thumbv7em-none-eabihf); on the host use host-sim (`cargo demo`)."
    );
}
