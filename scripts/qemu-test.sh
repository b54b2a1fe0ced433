#!/usr/bin/env bash
# Builds the controller's self-test scenarios and the recorded emulator
# runs (replays) for the Cortex-M4 (tests/qemu, package urechis-qemu-tests)
# and runs them under Debian's qemu-system-arm on the netduinoplus2
# machine. The binary reports through semihosting and exits with its own
# exit code, which this script passes on:
# 0 = every scenario passed; anything else (failure, panic, timeout) fails.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGET=thumbv7em-none-eabihf
TIMEOUT_S="${QEMU_TIMEOUT_S:-60}"

command -v qemu-system-arm >/dev/null || { echo "qemu-test: qemu-system-arm not found (run scripts/setup.sh)" >&2; exit 2; }

# QEMU parity: the recorded emulator runs (tests/qemu/replay) must be what
# the host's controller decides now; the Cortex-M4 build below replays them
# and checks it decides the same at every step.
echo "qemu-test: checking the replay recordings against the host controller"
cargo run --quiet --profile sim -p host-sim --target host-tuple -- emulate --export-replay --check

# --message-format lets us ask cargo for the ELF path instead of guessing
# where CARGO_TARGET_DIR puts it.
elf=$(cargo build --release --target "$TARGET" -p urechis-qemu-tests --message-format=json-render-diagnostics \
  | sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)
[ -n "$elf" ] && [ -f "$elf" ] || { echo "qemu-test: build produced no executable" >&2; exit 2; }

echo "qemu-test: running $elf"
set +e
timeout "$TIMEOUT_S" qemu-system-arm -machine netduinoplus2 -cpu cortex-m4 \
  -semihosting-config enable=on,target=native -nographic -monitor none -serial null \
  -kernel "$elf"
rc=$?
set -e
if [ "$rc" -eq 124 ]; then
  echo "qemu-test: timed out after ${TIMEOUT_S} s" >&2
fi
exit "$rc"
