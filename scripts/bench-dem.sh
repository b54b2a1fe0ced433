#!/usr/bin/env bash
# DEM throughput, ours against Debian's LIGGGHTS, on the problem of
# shared/bench (20,000 spheres settling in a box), at 1 and 2 workers, in one
# run so both see the same machine. Prints particle-steps/s side by side.
#
# Usage: scripts/bench-dem.sh [steps-scale]   (default 1 = the full problem)
# Needs: cargo; python3 (gen_lattice.py, the peer's input); liggghts and
# mpirun (`apt-get install -y liggghts`; run as root, the script installs
# them), else only ours is measured.
set -euo pipefail

scale="${1:-1}"
repo="$(cd "$(dirname "$0")/.." && pwd)"
bench_dir="${BENCH_DIR:-$repo/../shared/bench}"
[ -f "$bench_dir/in.liggghts" ] || bench_dir=/work/shared/bench
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$repo/target}"

echo "== building host-sim (profile sim, generic x86-64) =="
(cd "$repo" && cargo build --profile sim -p host-sim --target host-tuple --quiet)
bin="$CARGO_TARGET_DIR/$(rustc -vV | sed -n 's/^host: //p')/sim/host-sim"

steps() { python3 -c "print(max(1, round($1 * $scale)))"; }
nwarm=$(steps 1000)
nbench=$(steps 20000)
npack=$(steps 10000)
total=$((nwarm + nbench + npack))

declare -A ours peer
for w in 1 2; do
    echo "== ours, $w worker(s) =="
    out=$("$bin" bench dem --workers "$w" --steps-scale "$scale")
    echo "$out"
    ours[$w]=$(sed -n 's/.*overall_psps=\([0-9.]*\).*/\1/p' <<<"$out")
done

# The peer comes from Debian's package; install it where this script may.
if ! command -v liggghts >/dev/null && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "== installing Debian's liggghts =="
    apt-get install -y -q liggghts >/dev/null || true
fi

if command -v liggghts >/dev/null; then
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
    cp "$bench_dir/in.liggghts" "$bench_dir/gen_lattice.py" "$tmp/"
    (cd "$tmp" && python3 gen_lattice.py >/dev/null)
    for w in 1 2; do
        echo "== LIGGGHTS, $w process(es) =="
        if [ "$w" = 1 ]; then
            cmd=(liggghts)
        else
            cmd=(mpirun --allow-run-as-root --oversubscribe -np "$w" liggghts)
        fi
        start=$(date +%s.%N)
        (cd "$tmp" && "${cmd[@]}" -in in.liggghts -var nwarm "$nwarm" -var nbench "$nbench" \
            -var npack "$npack" -log "log.$w" >"out.$w" 2>&1)
        end=$(date +%s.%N)
        # Wall time of the three timed runs from LIGGGHTS' own "Loop time"
        # lines (the 1-step time-step check and the final run 0 excluded).
        loops=$(grep -o 'Loop time of [0-9.e+-]*' "$tmp/out.$w" | awk '{print $4}')
        t=$(awk 'NR==1||NR==3||NR==4{s+=$1} END{print s}' <<<"$loops")
        peer[$w]=$(python3 -c "print(20000 * $total / $t)")
        grep -E "FINAL|TIMESTEP CHECK" "$tmp/out.$w" || true
        printf 'LIGGGHTS %d: timed loops %.2f s (whole process %.2f s): %.2f M particle-steps/s\n' \
            "$w" "$t" "$(python3 -c "print($end - $start)")" "$(python3 -c "print(${peer[$w]} / 1e6)")"
    done
else
    echo "liggghts not installed (apt-get install -y liggghts): ours only"
fi

echo
echo "== DEM throughput, M particle-steps/s ($total steps x 20,000 particles) =="
printf '%-8s %10s %10s %8s\n' workers ours LIGGGHTS ratio
for w in 1 2; do
    o=${ours[$w]}
    p=${peer[$w]:-}
    if [ -n "$p" ]; then
        printf '%-8s %10.2f %10.2f %7.2fx\n' "$w" "$(python3 -c "print($o/1e6)")" \
            "$(python3 -c "print($p/1e6)")" "$(python3 -c "print($o/$p)")"
    else
        printf '%-8s %10.2f %10s %8s\n' "$w" "$(python3 -c "print($o/1e6)")" - -
    fi
done
