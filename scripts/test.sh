#!/usr/bin/env bash
# Runs every check of the project: formatting, lints, rustdoc, host tests of the
# firmware logic and of host-sim (among them the firmware table's freshness:
# the `tables` crate's `committed_table_matches_a_fresh_generation`), the
# release firmware's size budget, and the controller self-tests on a
# Cortex-M4 under QEMU. `.ci/run` calls exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh

log=$(mktemp)
trap 'rm -f "$log"' EXIT
step() { printf '\n==> %s\n' "$*"; }

step "format"
cargo fmt --all --check

step "lints: firmware logic (host), host-sim, QEMU runner"
cargo clippy --target host-tuple --workspace --all-targets -- -D warnings
step "lints: firmware for the board (thumbv7em, release)"
cargo clippy --release -- -D warnings

step "docs: rustdoc without warnings (firmware logic, host-sim)"
RUSTDOCFLAGS="-D warnings" cargo doc --quiet --no-deps --target host-tuple --workspace

step "host tests: firmware logic and host-sim"
cargo test --target host-tuple --workspace 2>&1 | tee "$log"

step "release firmware size"
bash scripts/size-report.sh

step "controller self-tests on Cortex-M4 (QEMU)"
bash scripts/qemu-test.sh 2>&1 | tee -a "$log"

# One closing line over everything that ran.
awk '
  /^test result: / { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed;?$/) p += $i; if ($(i+1) ~ /^failed;?$/) f += $i } }
  /^[0-9]+ passed, [0-9]+ failed$/ { p += $1; f += $3 }
  END { printf "\ntotal: %d passed, %d failed\n", p, f; exit (f > 0) }
' "$log"
