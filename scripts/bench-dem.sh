#!/usr/bin/env bash
# DEM throughput, ours against Debian's LIGGGHTS, on the problem of
# shared/bench (20,000 spheres settling in a box), at 1 and 2 workers, in one
# run so both see the same machine. Prints particle-steps/s side by side.
#
# Usage: scripts/bench-dem.sh [steps-scale] [rounds]
#   steps-scale  multiplies the three phases' steps (default 1 = the full
#                problem; 0.05 is a smoke test)
#   rounds       how many times each code runs at each worker count, the two
#                codes alternating (default 1). A shared VM drifts by 10 % and
#                more from minute to minute: with several rounds each ratio is
#                taken within one round, and the median ratio is reported.
# Needs: cargo, awk; for the peer python3 (the benchmark's own gen_lattice.py
# writes its input), liggghts and mpirun (`apt-get install -y liggghts`; run
# as root, the script installs them), else only ours is measured.
set -euo pipefail

scale="${1:-1}"
rounds="${2:-1}"
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "rounds must be a positive integer, not '$rounds'" >&2; exit 2; }
awk -v s="$scale" 'BEGIN { exit !(s + 0 > 0) }' || { echo "steps-scale must be positive, not '$scale'" >&2; exit 2; }
repo="$(cd "$(dirname "$0")/.." && pwd)"
bench_dir="${BENCH_DIR:-$repo/../shared/bench}"
[ -f "$bench_dir/in.liggghts" ] || bench_dir=/work/shared/bench
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$repo/target}"

echo "== building host-sim (profile sim, generic x86-64) =="
(cd "$repo" && cargo build --profile sim -p host-sim --target host-tuple --quiet)
bin="$CARGO_TARGET_DIR/$(rustc -vV | sed -n 's/^host: //p')/sim/host-sim"

# Floating-point arithmetic: calc FORMAT EXPRESSION (awk, no other tool).
calc() { awk "BEGIN { printf \"$1\", $2 }"; }
steps() { calc '%d' "int($1 * $scale + 0.5) < 1 ? 1 : int($1 * $scale + 0.5)"; }
nwarm=$(steps 1000)
nbench=$(steps 20000)
npack=$(steps 10000)
total=$((nwarm + nbench + npack))
particles=20000 # the benchmark's bed (shared/bench), for both codes

# The peer comes from Debian's package; install it where this script may.
if ! command -v liggghts >/dev/null && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "== installing Debian's liggghts =="
    apt-get install -y -q liggghts >/dev/null || true
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
peer_ok=no
if ! command -v liggghts >/dev/null; then
    echo "liggghts not installed (apt-get install -y liggghts): ours only"
elif ! command -v python3 >/dev/null; then
    echo "python3 not installed (the peer's input generator needs it): ours only"
else
    cp "$bench_dir/in.liggghts" "$bench_dir/gen_lattice.py" "$tmp/"
    (cd "$tmp" && python3 gen_lattice.py >/dev/null)
    peer_ok=yes
fi

# ours W: prints our run; sets $whole to its particle-steps/s over the whole
# process and $timed to them over its three timed phases.
ours() {
    echo "== ours, $1 worker(s) =="
    local out start end
    start=$(date +%s.%N)
    out=$("$bin" bench dem --workers "$1" --steps-scale "$scale")
    end=$(date +%s.%N)
    echo "$out"
    timed=$(sed -n 's/.*overall_psps=\([0-9.]*\).*/\1/p' <<<"$out")
    whole=$(calc '%.0f' "$particles * $total / ($end - $start)")
    printf 'ours %d: whole process %s s: %s M particle-steps/s\n' \
        "$1" "$(calc '%.2f' "$end - $start")" "$(calc '%.2f' "$whole / 1e6")"
}

# peer W: prints LIGGGHTS' run; sets $whole and $timed as ours does.
peer() {
    echo "== LIGGGHTS, $1 process(es) =="
    local cmd start end loops t
    if [ "$1" = 1 ]; then
        cmd=(liggghts)
    else
        cmd=(mpirun --allow-run-as-root --oversubscribe -np "$1" liggghts)
    fi
    start=$(date +%s.%N)
    (cd "$tmp" && "${cmd[@]}" -in in.liggghts -var nwarm "$nwarm" -var nbench "$nbench" \
        -var npack "$npack" -log "log.$1" >"out.$1" 2>&1)
    end=$(date +%s.%N)
    # Wall time of the three timed runs from LIGGGHTS' own "Loop time"
    # lines (the 1-step time-step check and the final run 0 excluded).
    loops=$(grep -o 'Loop time of [0-9.e+-]*' "$tmp/out.$1" | awk '{print $4}')
    t=$(awk 'NR==1||NR==3||NR==4{s+=$1} END{print s}' <<<"$loops")
    timed=$(calc '%.0f' "$particles * $total / $t")
    whole=$(calc '%.0f' "$particles * $total / ($end - $start)")
    grep -E "FINAL|TIMESTEP CHECK" "$tmp/out.$1" || true
    printf 'LIGGGHTS %d: whole process %s s: %s M particle-steps/s (timed loops %.2f s)\n' \
        "$1" "$(calc '%.2f' "$end - $start")" "$(calc '%.2f' "$whole / 1e6")" "$t"
}

# rows: "round workers ours peer ours-timed peer-timed" per run.
rows=""
for r in $(seq "$rounds"); do
    [ "$rounds" = 1 ] || echo "== round $r of $rounds =="
    for w in 1 2; do
        ours "$w"
        ours_whole=$whole ours_timed=$timed peer_whole=- peer_timed=-
        if [ "$peer_ok" = yes ]; then
            peer "$w"
            peer_whole=$whole peer_timed=$timed
        fi
        rows+="$r $w $ours_whole $peer_whole $ours_timed $peer_timed"$'\n'
    done
done

echo
echo "== DEM throughput, M particle-steps/s ($total steps x $particles particles) =="
echo "(whole process for both; in brackets over the timed phases alone: ours as it"
echo " times them, LIGGGHTS by its Loop times)"
printf '%s' "$rows" | awk -v rounds="$rounds" '
    function median(a, n,   i, j, t) {
        for (i = 2; i <= n; i++) for (j = i; j > 1 && a[j - 1] > a[j]; j--) { t = a[j]; a[j] = a[j - 1]; a[j - 1] = t }
        return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
    }
    BEGIN { printf "%-6s %-8s %10s %10s %8s   %s\n", "round", "workers", "ours", "LIGGGHTS", "ratio", "(timed phases)" }
    NF == 6 {
        if ($4 == "-") {
            printf "%-6s %-8s %10.2f %10s %8s   (%.2f)\n", $1, $2, $3 / 1e6, "-", "-", $5 / 1e6
        } else {
            printf "%-6s %-8s %10.2f %10.2f %7.2fx   (%.2f / %.2f = %.2fx)\n", $1, $2, $3 / 1e6, $4 / 1e6, $3 / $4, $5 / 1e6, $6 / 1e6, $5 / $6
            n[$2]++; ratio[$2, n[$2]] = $3 / $4
        }
    }
    END {
        if (rounds < 2) exit
        for (w = 1; w <= 2; w++) {
            if (!n[w]) continue
            for (i = 1; i <= n[w]; i++) a[i] = ratio[w, i]
            printf "median ratio at %d worker(s) over %d rounds: %.2fx\n", w, n[w], median(a, n[w])
        }
    }'
