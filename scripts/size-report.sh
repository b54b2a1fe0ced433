#!/usr/bin/env bash
# Cross-builds the release firmware (thumbv7em-none-eabihf, feature "board")
# and reports flash (text + data) and static RAM (data + bss) with
# arm-none-eabi-size. Fails when either is over budget.
# Budget: 64 KiB flash, 16 KiB static RAM (issue 2; figures in BENCHMARKS.md).
set -euo pipefail
cd "$(dirname "$0")/.."

TARGET=thumbv7em-none-eabihf
FLASH_BUDGET=$((64 * 1024))
RAM_BUDGET=$((16 * 1024))

command -v arm-none-eabi-size >/dev/null || { echo "size-report: arm-none-eabi-size not found (run scripts/setup.sh)" >&2; exit 2; }

elf=$(cargo build --release --target "$TARGET" -p urechis --bin urechis --message-format=json-render-diagnostics \
  | sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)
[ -n "$elf" ] && [ -f "$elf" ] || { echo "size-report: build produced no executable" >&2; exit 2; }

# Berkeley format: text data bss dec hex filename. `text` already holds the
# vector table and .rodata; `data` is stored in flash and copied to RAM.
read -r text data bss _ < <(arm-none-eabi-size -B "$elf" | tail -n 1)
flash=$((text + data))
ram=$((data + bss))

status=ok
[ "$flash" -le "$FLASH_BUDGET" ] || status="OVER BUDGET"
[ "$ram" -le "$RAM_BUDGET" ] || status="OVER BUDGET"
awk -v f="$flash" -v fb="$FLASH_BUDGET" -v r="$ram" -v rb="$RAM_BUDGET" -v s="$status" 'BEGIN {
  printf "size-report: flash %d B (%.1f of %d KiB), static RAM %d B (%.1f of %d KiB): %s\n", f, f / 1024, fb / 1024, r, r / 1024, rb / 1024, s
}'
[ "$status" = ok ]
