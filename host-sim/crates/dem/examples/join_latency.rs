//! What a rayon join costs on this machine beyond its longer half: when
//! the caller comes back to the pool after a serial gap, and when its half
//! ends before the other's. Two workers, 2,000 joins of two busy halves per
//! line, µs per join. The last column has the caller wait for the other
//! half by spinning (and running pending jobs) instead of in the join.
//!
//! `cargo run --profile sim --target host-tuple -p dem --example join_latency`

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Keeps a core busy for `us` µs.
fn busy(us: f64) {
    let t = Instant::now();
    while t.elapsed().as_secs_f64() * 1e6 < us {}
}

/// `b` as a job for the pool, `a` on the caller, which then spins until
/// `b` is done.
fn spin_join(a: impl FnOnce() + Send, b: impl FnOnce() + Send) {
    let done = AtomicBool::new(false);
    rayon::scope(|s| {
        s.spawn(|_| {
            b();
            done.store(true, Ordering::Release);
        });
        a();
        while !done.load(Ordering::Acquire) {
            if rayon::yield_local() != Some(rayon::Yield::Executed) {
                std::hint::spin_loop();
            }
        }
    });
}

/// µs per join beyond the longer half and the gap.
fn overhead(mine: f64, other: f64, gap: f64, spin: bool) -> f64 {
    let n = 2000;
    let t = Instant::now();
    for _ in 0..n {
        if spin {
            spin_join(|| busy(mine), || busy(other));
        } else {
            rayon::join(|| busy(mine), || busy(other));
        }
        busy(gap);
    }
    t.elapsed().as_secs_f64() * 1e6 / n as f64 - mine.max(other) - gap
}

fn main() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a pool of two workers");
    println!("caller half  other half  gap  | join  spinning (µs)");
    pool.install(|| {
        for (mine, other) in [(400.0, 400.0), (300.0, 400.0), (400.0, 300.0)] {
            for gap in [0.0, 10.0, 30.0, 100.0, 300.0] {
                let join = overhead(mine, other, gap, false);
                let spin = overhead(mine, other, gap, true);
                println!("{mine:11} {other:11} {gap:4} | {join:5.1} {spin:9.1}");
            }
        }
    });
}
