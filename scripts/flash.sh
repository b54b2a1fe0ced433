#!/usr/bin/env bash
# The board's cargo runner (`cargo run --release`): flashes the firmware
# over the NUCLEO's ST-LINK and streams its defmt log with probe-rs. Says
# how to get probe-rs when it is missing.
set -euo pipefail

CHIP=STM32F446RETx

if ! command -v probe-rs >/dev/null 2>&1; then
  cat >&2 <<'MSG'
flash: probe-rs is not installed, so the firmware cannot be flashed.
  Install it once (about 10 minutes on 2 cores):
      cargo install probe-rs-tools --locked
  or with the installer from the probe-rs documentation (probe.rs).
  The firmware was built; `cargo build --release` alone only cross-builds.
  No board? `cargo demo` runs everything on this computer, and
  `cargo sim virtual-board` runs the firmware's tasks here against a
  simulated plant (drive it with `cargo sim board --port PATH ...`).
MSG
  exit 127
fi

exec probe-rs run --chip "$CHIP" "$@"
