#!/usr/bin/env bash
# The cavity benchmark of shared/cavity, code to code: Debian's LAMMPS runs
# in.expand on a settled bed, then `host-sim cavity` runs the same problem
# and sets its p_e beside LAMMPS' at rest and every 10 % of the expansion.
#
# Usage: scripts/cavity-lammps.sh [BED] [EXPANSION_S] [OUT]
#   BED          h40 (default), h70 or h40s7: shared/cavity/bed_BED.csv
#   EXPANSION_S  1 (default) or 2
#   OUT          results folder (default out/cavity/BED_T<EXPANSION_S>)
# Needs: cargo; lmp and mpirun (`apt-get install -y lammps`), else ours only.
# Two MPI ranks, as in.expand's `processors 2 1 1` asks.
set -euo pipefail

bed="${1:-h40}"
texp="${2:-1}"
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="${3:-$repo/out/cavity/${bed}_T${texp}}"
cavity_dir="${CAVITY_DIR:-$repo/../shared/cavity}"
[ -f "$cavity_dir/in.expand" ] || cavity_dir=/work/shared/cavity
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$repo/target}"
mkdir -p "$out"

echo "== building host-sim (profile sim) =="
(cd "$repo" && cargo build --profile sim -p host-sim --target host-tuple --quiet)
bin="$CARGO_TARGET_DIR/$(rustc -vV | sed -n 's/^host: //p')/sim/host-sim"

peer=()
if command -v lmp >/dev/null && command -v mpirun >/dev/null; then
    run="$out/lammps"
    mkdir -p "$run"
    cp "$cavity_dir/in.expand" "$run/"
    zcat "$cavity_dir/data.bed_$bed.gz" >"$run/data.bed_$bed"
    # The bed's measured surface height, from its .json.
    zs=$(sed -n 's/.*"z_surface": *\([0-9.eE+-]*\).*/\1/p' "$cavity_dir/bed_$bed.json")
    tag="${bed}_T${texp}"
    echo "== LAMMPS: $tag (surface at z = $zs m) =="
    start=$(date +%s.%N)
    (cd "$run" && mpirun --allow-run-as-root --oversubscribe -np 2 lmp -in in.expand \
        -var tag "$tag" -var datain "data.bed_$bed" -var zs "$zs" -var Texp "$texp" \
        -var seg 1 -var upto 999999999 -log "log.$tag" >"out.$tag" 2>&1)
    end=$(date +%s.%N)
    printf 'LAMMPS: %.1f s wall\n' "$(awk -v a="$start" -v b="$end" 'BEGIN{print b-a}')"
    peer=(--peer-avg "$run/avg_${tag}_seg1.dat")
else
    echo "lmp not installed (apt-get install -y lammps): ours only"
fi

echo "== this DEM: $bed, expansion $texp s =="
"$bin" cavity --bed "$cavity_dir/bed_$bed.csv" --expansion-s "$texp" --out "$out" "${peer[@]}"
