#!/usr/bin/env bash
# Installs what the project needs beyond rustup: the Cortex-M4 target (via
# rust-toolchain.toml), Debian's qemu-system-arm and the ARM binutils.
# Idempotent: a second run does nothing but check.
set -euo pipefail
cd "$(dirname "$0")/.."

need_apt=()
command -v qemu-system-arm >/dev/null 2>&1 || need_apt+=(qemu-system-arm)
command -v arm-none-eabi-size >/dev/null 2>&1 || need_apt+=(binutils-arm-none-eabi)
if [ ${#need_apt[@]} -gt 0 ]; then
  echo "setup: installing ${need_apt[*]} with apt-get"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${need_apt[@]}" >/dev/null
fi

# rustup reads rust-toolchain.toml and installs the toolchain, its
# components and the thumbv7em target on first use.
rustup show active-toolchain >/dev/null
rustup target list --installed | grep -q thumbv7em-none-eabihf || rustup target add thumbv7em-none-eabihf
echo "setup: ok ($(qemu-system-arm --version | head -n1); $(arm-none-eabi-size --version | head -n1))"
