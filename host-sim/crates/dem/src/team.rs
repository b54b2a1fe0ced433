//! The pool's workers held for the steps of one [`crate::advance`]: each
//! step has two parallel phases (first sweep, pair pass; the walls a third
//! after a list build), ≈ 1.5 ms
//! apart at two workers on the benchmark, and a rayon worker that runs out
//! of work sleeps after ≈ 30 µs, to be woken by the next phase (tens to
//! hundreds of µs on a VM: `cargo run --profile sim --target host-tuple -p
//! dem --example join_latency`). A [`Team`] keeps its helpers spinning
//! between phases instead, for as long as phases keep coming.
//!
//! No one waits for a helper to arrive: the caller runs the tasks it can
//! claim and waits only for tasks another thread has claimed, which that
//! thread is running. A helper that finds no task for [`LINGER`] goes back
//! to the pool (where the caller's own rayon work, a list build, finds it),
//! and the next phase sends a new one. So a team cannot deadlock, whether
//! the pool is busy elsewhere or not, and the tasks' results do not depend
//! on who ran them.

use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How long a helper spins without finding a task before it goes back to
/// the pool: well over the gaps between a step's phases (a few µs), well
/// under a list build (milliseconds), whose rayon tasks it then takes.
const LINGER: Duration = Duration::from_micros(200);

/// Spins a waiter makes before it starts giving its CPU away
/// ([`Patience`]): ≈ 0.8 ms of `pause` on the 2-core VM (≈ 25 ns each),
/// far over the usual wait for a running worker (a few µs) and under a
/// scheduler's time slice. Yielding after ≈ 25 µs made the quiet benchmark
/// ≈ 9 % slower at two workers (each yield a system call).
const SPINS_BEFORE_YIELD: u32 = 1 << 15;

/// How a thread waits for another worker of the step: it spins at first
/// (the other is running and nearly done), then yields its CPU at each
/// look. A worker waited on that long has likely been descheduled: the
/// machine has more runnable threads than CPUs (another job, a profiler),
/// and spinning on would burn the time slice that worker needs to come
/// back. When nothing else is runnable a yield returns at once.
pub(crate) struct Patience(u32);

impl Patience {
    /// A new wait.
    pub(crate) fn new() -> Self {
        Patience(0)
    }

    /// One look's pause: a spin, or past [`SPINS_BEFORE_YIELD`] a yield.
    #[inline]
    pub(crate) fn pause(&mut self) {
        if self.0 < SPINS_BEFORE_YIELD {
            self.0 += 1;
            std::hint::spin_loop();
        } else {
            std::thread::yield_now();
        }
    }
}

/// Most tasks in one phase (they are counted in 16 bits of the claim word);
/// a phase with more runs on the caller alone.
const MAX_TASKS: usize = 0xffff;

/// A phase's tasks, as the caller handed them over.
struct Job<'f> {
    run: &'f (dyn Fn(usize) + Sync),
}

/// What a team's threads share.
#[derive(Default)]
struct Crew {
    /// The current phase: its number (bits 32–63) and its unclaimed tasks
    /// `front..back` (bits 16–31 and 0–15), claimed by compare-and-swap:
    /// the caller from the front, helpers from the back, so that with two
    /// workers each takes the same end of the particles in every phase
    /// (what one phase wrote, the next reads from the same core's caches).
    claim: AtomicU64,
    /// The current phase's [`Job`], read only by a thread that has claimed
    /// one of its tasks (the phase cannot end before that task does).
    job: AtomicPtr<()>,
    /// Tasks of the current phase finished.
    done: AtomicUsize,
    /// Helpers sent and not yet gone back to the pool.
    helpers: AtomicUsize,
    /// Set when the caller has no more phases.
    stop: AtomicBool,
    /// Set when a task panicked (the caller then panics too).
    panicked: AtomicBool,
}

/// Runs the tasks of one phase across the pool's workers: the caller and,
/// with more than one worker, helpers kept spinning between phases.
pub(crate) struct Team<'a, 's> {
    /// The shared state and the scope helpers are sent into; `None`: the
    /// caller runs every task, in order.
    crew: Option<(&'s Crew, &'a rayon::Scope<'s>)>,
    /// Workers in the pool.
    workers: usize,
}

/// Calls `body` with a team of the current rayon pool's workers, held until
/// it returns.
pub(crate) fn with_team<R>(body: impl FnOnce(&Team<'_, '_>) -> R) -> R {
    let workers = rayon::current_num_threads();
    if workers < 2 {
        return body(&Team::alone());
    }
    let crew = Crew::default();
    rayon::in_place_scope(|scope| {
        let team = Team {
            crew: Some((&crew, scope)),
            workers,
        };
        let out = body(&team);
        crew.stop.store(true, Ordering::Release);
        out
    })
}

impl Team<'_, '_> {
    /// A team of the caller alone: every task runs on it, in order.
    pub(crate) fn alone() -> Team<'static, 'static> {
        Team {
            crew: None,
            workers: 1,
        }
    }

    /// Workers the team's tasks are shared among (the pool's).
    pub(crate) fn workers(&self) -> usize {
        self.workers
    }

    /// Runs `run(t)` for every task t in `0..tasks` and returns when all
    /// have run. `run` must not use the team itself.
    pub(crate) fn run(&self, tasks: usize, run: &(dyn Fn(usize) + Sync)) {
        let Some((crew, scope)) = self.crew.filter(|_| tasks > 1 && tasks <= MAX_TASKS) else {
            (0..tasks).for_each(run);
            return;
        };
        let job = Job { run };
        crew.done.store(0, Ordering::Relaxed);
        crew.job
            .store((&job as *const Job).cast_mut().cast(), Ordering::Relaxed);
        let phase = (crew.claim.load(Ordering::Relaxed) >> 32).wrapping_add(1);
        // Publishes the job and the reset count with the new phase.
        crew.claim
            .store(phase << 32 | tasks as u64, Ordering::Release);
        while crew.helpers.load(Ordering::Acquire) + 1 < self.workers {
            crew.helpers.fetch_add(1, Ordering::AcqRel);
            scope.spawn(move |_| crew.help());
        }
        // If a task panics on the caller, the job must outlive the tasks
        // helpers are running.
        let _settle = Settle { crew, tasks };
        while crew.take_task(false) {}
        // The rest were claimed by helpers, which are running them.
        let mut patience = Patience::new();
        while crew.done.load(Ordering::Acquire) < tasks {
            patience.pause();
        }
        if crew.panicked.load(Ordering::Relaxed) {
            panic!("a task of the DEM step panicked on another thread");
        }
    }

    /// Runs `f(t, item)` for each item t of `items` and returns the results
    /// in the items' order.
    pub(crate) fn map<T: Send, R: Send>(
        &self,
        items: Vec<T>,
        f: impl Fn(usize, T) -> R + Sync,
    ) -> Vec<R> {
        // Each slot is taken by exactly one task: the locks never wait.
        let slots: Vec<_> = items.into_iter().map(|t| Mutex::new(Some(t))).collect();
        let out: Vec<Mutex<Option<R>>> = slots.iter().map(|_| Mutex::new(None)).collect();
        let take = |m: &Mutex<Option<T>>| m.lock().ok().and_then(|mut s| s.take());
        self.run(slots.len(), &|t| {
            if let Some(item) = take(&slots[t]) {
                let r = f(t, item);
                if let Ok(mut o) = out[t].lock() {
                    *o = Some(r);
                }
            }
        });
        out.into_iter()
            .map(|m| m.into_inner().ok().flatten())
            .collect::<Option<Vec<R>>>()
            .unwrap_or_else(|| panic!("every task of a team phase runs once"))
    }
}

/// Waits, while the caller unwinds from a panicking task, for the tasks
/// helpers claimed to end, after taking the unclaimed ones away: those
/// tasks read the phase's job, which lives in the caller's frame.
struct Settle<'c> {
    crew: &'c Crew,
    tasks: usize,
}

impl Drop for Settle<'_> {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            return;
        }
        let crew = self.crew;
        let mut claim = crew.claim.load(Ordering::Acquire);
        let unclaimed = loop {
            let (front, back) = ((claim >> 16) & 0xffff, claim & 0xffff);
            let closed = claim & !0xffff | front;
            match (crew.claim).compare_exchange_weak(
                claim,
                closed,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => break back.saturating_sub(front) as usize,
                Err(now) => claim = now,
            }
        };
        let mut patience = Patience::new();
        while crew.done.load(Ordering::Acquire) + unclaimed < self.tasks {
            patience.pause();
        }
    }
}

impl Crew {
    /// Claims a task of the current phase, the first left or (`from_back`)
    /// the last, and runs it; false if none was left.
    fn take_task(&self, from_back: bool) -> bool {
        let mut claim = self.claim.load(Ordering::Acquire);
        let task = loop {
            let (front, back) = ((claim >> 16) & 0xffff, claim & 0xffff);
            if front >= back {
                return false;
            }
            let (task, claimed) = if from_back {
                (back - 1, claim - 1)
            } else {
                (front, claim + (1 << 16))
            };
            match self.claim.compare_exchange_weak(
                claim,
                claimed,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => break task,
                Err(now) => claim = now,
            }
        };
        // SAFETY: task `task` of this phase is claimed and not done, so the
        // phase's caller is still waiting in `Team::run`, its `Job` alive;
        // the pointer was stored before the phase was published, and no
        // later phase can store another before this task is done.
        let job = unsafe { &*self.job.load(Ordering::Acquire).cast::<Job>() };
        /// Counts the task done even if it panics, so the caller stops
        /// waiting (and panics in turn).
        struct Done<'c>(&'c Crew);
        impl Drop for Done<'_> {
            fn drop(&mut self) {
                if std::thread::panicking() {
                    self.0.panicked.store(true, Ordering::Relaxed);
                }
                self.0.done.fetch_add(1, Ordering::Release);
            }
        }
        let _done = Done(self);
        (job.run)(task as usize);
        true
    }

    /// A helper's life: runs the tasks it can claim, spinning between
    /// phases, until the caller stops or [`LINGER`] passes with no task.
    fn help(&self) {
        let mut idle_since = Instant::now();
        let mut spins = 0u32;
        // Only spins: it goes back to the pool after `LINGER`, long before
        // a [`Patience`] would yield.
        while !self.stop.load(Ordering::Acquire) {
            if self.take_task(true) {
                idle_since = Instant::now();
                continue;
            }
            std::hint::spin_loop();
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(64) && idle_since.elapsed() > LINGER {
                break;
            }
        }
        self.helpers.fetch_sub(1, Ordering::AcqRel);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn every_task_runs_once_in_every_phase() {
        for threads in [1, 2, 4] {
            pool(threads).install(|| {
                with_team(|team| {
                    assert_eq!(team.workers(), threads);
                    for phase in 0..500usize {
                        let tasks = 1 + phase % 37;
                        let items: Vec<usize> = (0..tasks).collect();
                        let out = team.map(items, |t, item| {
                            assert_eq!(t, item);
                            // Uneven work, so that helpers take some.
                            let mut x = t as u64;
                            for _ in 0..(t * 200) {
                                x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(7));
                            }
                            (t * 3, x)
                        });
                        let ts: Vec<usize> = out.iter().map(|&(t, _)| t / 3).collect();
                        assert_eq!(ts, (0..tasks).collect::<Vec<_>>());
                    }
                })
            });
        }
    }

    #[test]
    fn helpers_go_back_to_the_pool_for_its_own_work() {
        use rayon::prelude::*;
        // A phase, then rayon work on the caller (as a list build), then
        // phases again: the rayon work must finish although helpers were
        // spinning when it began.
        pool(2).install(|| {
            with_team(|team| {
                for round in 0..20u64 {
                    let a = team.map(vec![1u64; 8], |t, x| x + t as u64);
                    assert_eq!(a.iter().sum::<u64>(), 8 + 28);
                    let s: u64 = (0..100_000u64).into_par_iter().map(|x| x ^ round).sum();
                    assert!(s > 0);
                    std::thread::sleep(Duration::from_micros(300 * (round % 3)));
                }
            })
        });
    }

    #[test]
    fn teams_from_many_threads_share_the_pool_without_deadlock() {
        // Four callers outside the pool (the global one): a helper may
        // never come while the others hold the workers; each caller then
        // runs its phases alone.
        std::thread::scope(|s| {
            for caller in 0..4u64 {
                s.spawn(move || {
                    let total = with_team(|team| {
                        (0..300)
                            .map(|_| team.map(vec![caller; 5], |t, x| x * t as u64))
                            .map(|v| v.iter().sum::<u64>())
                            .sum::<u64>()
                    });
                    assert_eq!(total, 300 * caller * 10);
                });
            }
        });
    }

    #[test]
    fn a_panicking_task_panics_the_caller() {
        let result = std::panic::catch_unwind(|| {
            pool(2).install(|| {
                with_team(|team| {
                    team.map((0..16).collect(), |t, _: usize| {
                        if t == 11 {
                            panic!("task 11");
                        }
                        t
                    })
                })
            })
        });
        assert!(result.is_err());
    }
}
