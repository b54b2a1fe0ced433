//! Which worker evaluates which particles' pairs in the pair pass.
//!
//! The particles are cut into units of [`UNIT`] consecutive indices, and a
//! step's pass into runs of consecutive units, each evaluated in order by
//! one worker. Each worker starts with one run, where the last steps'
//! shares put its start ([`Shares`]); a worker whose run is done splits
//! the run with the most units left in two, taking the upper part. The
//! split between workers so moves within the step, and one CPU's stall is
//! made up by the other instead of waited out (measured on the 2-core VM
//! with one fixed split per list build: the two halves' times differed by
//! 9.4 % on average from step to step, little of it systematic).
//!
//! A run adds each pair to its first particle and, if it holds it, to its
//! second; a particle's sum so sees the same terms in the same order as if
//! the pairs were taken one by one, whatever the runs. A split hands over
//! at a unit boundary: the run being split answers the request before its
//! next unit, so the particles above the split already hold every pair
//! from below that boundary, in order. The new run then evaluates the
//! pairs from the rest of the units below the split itself (their first
//! particles' run evaluates them too, each adding its own particle's
//! share), from a copy of their histories taken before the run below
//! changes them: that run waits for [`Run::copied`] first.
//!
//! A run waits only for the next run's copy, so no run may be reached
//! past the next by the pairs of the one before it: the workers' first
//! runs are at least the pairs' reach long, or only two ([`Runs::new`]),
//! and a run split off another counts its copy done only once the run
//! after it has copied (a split can leave the run below shorter than the
//! reach; its pairs reaching past the new run were copied by the run
//! after, taken before any split).

use crate::team::Patience;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

/// Particles in a unit.
pub(crate) const UNIT: usize = 128;

/// Runs one pass may have (the workers' first ones and the splits).
const MAX_RUNS: usize = 64;

/// A run with fewer units left is not split: the pairs crossing into the
/// new run, evaluated twice, would cost more than the wait it saves.
const MIN_SPLIT_UNITS: usize = 4;

/// No run (in a [`Limit`]).
pub(crate) const NONE_RUN: usize = u32::MAX as usize;

/// [`Run::split`] states (bits 62–63; the rest is a unit).
const ASKED: u64 = 1 << 62;
const ANSWERED: u64 = 2 << 62;
const REFUSED: u64 = 3 << 62;
const TAG: u64 = 3 << 62;

/// The end of a run: the first unit not its own, and the run that starts
/// there ([`NONE_RUN`] at the last unit and at a worker's first run's end).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Limit {
    /// First unit not the run's own.
    pub unit: usize,
    /// The run that starts at `unit`, whose copy of the pairs crossing
    /// into it the run must wait for before it reaches them.
    pub run: usize,
}

impl Limit {
    fn pack(self) -> u64 {
        (self.unit as u64) << 32 | self.run as u64
    }
    fn unpack(v: u64) -> Limit {
        Limit {
            unit: (v >> 32) as usize,
            run: (v & 0xffff_ffff) as usize,
        }
    }
}

/// One run of a pass.
#[derive(Default)]
pub(crate) struct Run {
    /// Its first unit.
    first: AtomicUsize,
    /// Its [`Limit`], packed; lowered by each split.
    limit: AtomicU64,
    /// Set by the worker that runs it.
    taken: AtomicBool,
    /// The unit it starts next (for thieves to size a split).
    next: AtomicUsize,
    /// A split's handshake: 0 idle; `ASKED | at` a thief asks for the
    /// units from `at` on; `ANSWERED | u` the run gave them, having done
    /// its pairs below unit u; `REFUSED`. Only the run moves it from
    /// `ASKED` but to cancel, only the thief back to 0.
    split: AtomicU64,
    /// Set when it has no more units to run (it answers no more).
    finished: AtomicBool,
    /// Set once it has copied the pairs crossing into it.
    copied: AtomicBool,
}

impl Run {
    /// Its first unit.
    pub(crate) fn first(&self) -> usize {
        self.first.load(Ordering::Acquire)
    }

    /// Its current limit.
    pub(crate) fn limit(&self) -> Limit {
        Limit::unpack(self.limit.load(Ordering::Acquire))
    }

    /// Marks the pairs crossing into the run copied.
    pub(crate) fn set_copied(&self) {
        self.copied.store(true, Ordering::Release);
    }

    /// Called by the run's worker before each unit `u`: answers a pending
    /// split request and returns the limit to keep to.
    pub(crate) fn before_unit(&self, u: usize, runs: &Runs) -> Limit {
        self.next.store(u, Ordering::Relaxed);
        let asked = self.split.load(Ordering::Acquire);
        if asked & TAG == ASKED {
            let at = (asked & !TAG) as usize;
            let old = self.limit();
            let r = runs.pending.load(Ordering::Acquire);
            let answer = if at > u && at < old.unit && r < MAX_RUNS {
                // The thief's run: units at..old, where this one ended.
                runs.runs[r].limit.store(old.pack(), Ordering::Relaxed);
                ANSWERED | u as u64
            } else {
                REFUSED
            };
            let answered = self
                .split
                .compare_exchange(asked, answer, Ordering::AcqRel, Ordering::Acquire)
                .is_ok();
            if answered && answer != REFUSED {
                let new = Limit { unit: at, run: r };
                self.limit.store(new.pack(), Ordering::Release);
            }
        }
        self.limit()
    }

    /// Called by the run's worker when it has run its last unit.
    pub(crate) fn finish(&self) {
        self.finished.store(true, Ordering::Release);
    }
}

/// The runs of one pass.
pub(crate) struct Runs {
    runs: Vec<Run>,
    /// Runs handed out.
    used: AtomicUsize,
    /// The run a thief is creating (set while its request is pending).
    pending: AtomicUsize,
    /// The workers' first runs (the first in `runs`).
    firsts: usize,
    /// Set when a run panicked, so that none waits for it.
    abort: AtomicBool,
}

/// A run taken by a worker: whole (a worker's first run, or one whose
/// worker had not come: [`Runs::is_first`]), or split off another.
pub(crate) struct Taken {
    /// Its index.
    pub run: usize,
    /// The unit below which the particles from its first unit on already
    /// hold every pair: the pairs crossing into it from units `done..first`
    /// are the run's to evaluate (`done` = 0: all from below).
    pub done: usize,
}

impl Runs {
    /// Runs for a pass over `n` particles whose workers start at units
    /// `starts` (ascending, the first 0), for pairs (i, j) with
    /// j − i ≤ `reach` particles.
    pub(crate) fn new(n: usize, starts: &[usize], reach: usize) -> Runs {
        let units = n.div_ceil(UNIT);
        let runs: Vec<Run> = (0..MAX_RUNS).map(|_| Run::default()).collect();
        let mut kept: Vec<usize> = Vec::with_capacity(starts.len());
        // A run waits for the next one's copy only: each first run is at
        // least `reach` long, so that the pairs of the run before it end
        // inside it (empty first runs are so left out too).
        let least = reach.div_ceil(UNIT).max(1);
        for &s in starts {
            if s < units && kept.last().is_none_or(|&l| s >= l + least) {
                kept.push(s);
            }
        }
        // Two runs are safe whatever their lengths: the first one's pairs
        // end in the second or past the last particle. A bed whose pairs
        // reach across it (a periodic one's wrap around) so keeps two.
        if kept.len() < 2 {
            let middle = starts.get(starts.len() / 2).copied();
            if let (Some(&first), Some(s)) = (kept.first(), middle) {
                if s > first && s < units {
                    kept.push(s);
                }
            }
        }
        // Half the slots at most, the rest for splits: more workers share
        // the first runs' units through splits.
        kept.truncate(MAX_RUNS / 2);
        for (w, &s) in kept.iter().enumerate() {
            let (end, next) = match kept.get(w + 1) {
                Some(&e) => (e, w + 1),
                None => (units, NONE_RUN),
            };
            runs[w].first.store(s, Ordering::Relaxed);
            runs[w].next.store(s, Ordering::Relaxed);
            let limit = Limit {
                unit: end,
                run: next,
            };
            runs[w].limit.store(limit.pack(), Ordering::Relaxed);
        }
        Runs {
            runs,
            used: AtomicUsize::new(kept.len()),
            firsts: kept.len(),
            pending: AtomicUsize::new(NONE_RUN),
            abort: AtomicBool::new(false),
        }
    }

    /// Runs split off others.
    pub(crate) fn splits(&self) -> usize {
        self.used.load(Ordering::Acquire) - self.firsts
    }

    /// Run `r`.
    pub(crate) fn get(&self, r: usize) -> &Run {
        &self.runs[r]
    }

    /// Whether run `r` is a worker's first run (whose particles' sums are
    /// not begun when it is taken), not one split off another.
    pub(crate) fn is_first(&self, r: usize) -> bool {
        r < self.firsts
    }

    /// Takes worker `w`'s first run, unless someone took it first (every
    /// first run holds at least one unit: [`Runs::new`]).
    pub(crate) fn take_first(&self, w: usize) -> Option<Taken> {
        let run = self.runs[..self.firsts].get(w)?;
        if run.taken.load(Ordering::Acquire) || run.taken.swap(true, Ordering::AcqRel) {
            return None;
        }
        Some(Taken { run: w, done: 0 })
    }

    /// Takes a run for an idle worker: a first run no worker has begun, or
    /// the upper part of the run with the most units left (waiting for it
    /// to answer); `None` if none is worth it.
    pub(crate) fn steal(&self) -> Option<Taken> {
        if let Some(whole) = (0..self.firsts).find_map(|w| self.take_first(w)) {
            return Some(whole);
        }
        let used = self.used.load(Ordering::Acquire).min(MAX_RUNS);
        let (mut victim, mut most) = (NONE_RUN, 0);
        for (r, run) in self.runs[..used].iter().enumerate() {
            if run.finished.load(Ordering::Acquire) || !run.taken.load(Ordering::Acquire) {
                continue;
            }
            let left = run
                .limit()
                .unit
                .saturating_sub(run.next.load(Ordering::Relaxed));
            if left > most {
                (victim, most) = (r, left);
            }
        }
        if victim == NONE_RUN || most < MIN_SPLIT_UNITS {
            return None;
        }
        let v = &self.runs[victim];
        let at = v.next.load(Ordering::Relaxed) + most / 2;
        // One thief at a time: the new run's slot is claimed with the request.
        if self
            .pending
            .compare_exchange(
                NONE_RUN,
                usize::MAX - 1,
                Ordering::AcqRel,
                Ordering::Acquire,
            )
            .is_err()
        {
            return None;
        }
        let r = self.used.load(Ordering::Acquire);
        if r >= MAX_RUNS {
            self.pending.store(NONE_RUN, Ordering::Release);
            return None;
        }
        // Taken before it is named as the victim's limit, so that the
        // victim cannot take it over (`absorb`) meanwhile.
        self.runs[r].taken.store(true, Ordering::Release);
        self.pending.store(r, Ordering::Release);
        let asked = ASKED | at as u64;
        if (v.split)
            .compare_exchange(0, asked, Ordering::AcqRel, Ordering::Acquire)
            .is_err()
        {
            self.pending.store(NONE_RUN, Ordering::Release);
            return None;
        }
        let mut patience = Patience::new();
        let answer = loop {
            let a = v.split.load(Ordering::Acquire);
            if a != asked {
                break a;
            }
            if v.finished.load(Ordering::Acquire)
                && (v.split)
                    .compare_exchange(asked, 0, Ordering::AcqRel, Ordering::Acquire)
                    .is_ok()
            {
                // It ran out of units before it saw the request.
                break REFUSED;
            }
            if self.abort.load(Ordering::Relaxed) {
                panic!("a run of the pair pass panicked on another thread");
            }
            patience.pause();
        };
        v.split.store(0, Ordering::Release);
        let split = answer & TAG == ANSWERED;
        if split {
            let run = &self.runs[r];
            run.first.store(at, Ordering::Relaxed);
            run.next.store(at, Ordering::Relaxed);
            self.used.store(r + 1, Ordering::Release);
        }
        self.pending.store(NONE_RUN, Ordering::Release);
        split.then_some(Taken {
            run: r,
            done: (answer & !TAG) as usize,
        })
    }

    /// Lets run `r` take over the next run, `next`, if no worker has begun
    /// it (its worker has not come): its units become `r`'s, and no pair
    /// between the two is evaluated twice. Returns the units taken over.
    pub(crate) fn absorb(&self, r: usize, next: usize) -> Option<std::ops::Range<usize>> {
        // Only a worker's first run can be one no worker has begun.
        let n = self.runs[..self.firsts].get(next)?;
        if n.taken.load(Ordering::Acquire) || n.taken.swap(true, Ordering::AcqRel) {
            return None;
        }
        n.finished.store(true, Ordering::Release);
        let units = n.first()..n.limit().unit;
        // Only its own worker changes a run's limit.
        self.runs[r]
            .limit
            .store(n.limit.load(Ordering::Acquire), Ordering::Release);
        Some(units)
    }

    /// Waits until run `r` has copied the pairs crossing into it.
    pub(crate) fn wait_copied(&self, r: usize) {
        let Some(run) = self.runs.get(r) else {
            return;
        };
        let mut patience = Patience::new();
        while !run.copied.load(Ordering::Acquire) {
            if self.abort.load(Ordering::Relaxed) {
                panic!("a run of the pair pass panicked on another thread");
            }
            patience.pause();
        }
    }

    /// Tells the other runs to stop waiting (a run panicked).
    pub(crate) fn abort(&self) {
        self.abort.store(true, Ordering::Relaxed);
    }
}

/// How far the workers' first runs move towards the last step's shares.
const LEARN_RATE: f64 = 0.125;

/// Where each worker's first run starts, learnt from the work each did in
/// the last steps.
#[derive(Clone, Debug, Default)]
pub(crate) struct Shares {
    /// Cumulative share of the work before worker w's first run
    /// (`bounds[0]` = 0), smoothed over steps.
    bounds: Vec<f64>,
}

impl Shares {
    /// The first unit of each of `workers` workers' first runs, for
    /// particles of cumulative estimated work `work` (len n + 1).
    pub(crate) fn starts(&mut self, workers: usize, work: &[f64]) -> Vec<usize> {
        if self.bounds.len() != workers {
            self.bounds = (0..workers).map(|w| w as f64 / workers as f64).collect();
        }
        let total = work.last().copied().unwrap_or(0.0);
        let n = work.len().saturating_sub(1);
        let mut starts: Vec<usize> = (self.bounds.iter())
            .map(|&b| {
                let at = work[..n.max(1)].partition_point(|&w| w < b * total);
                (at + UNIT / 2) / UNIT
            })
            .collect();
        if let Some(s) = starts.first_mut() {
            *s = 0;
        }
        starts
    }

    /// Learns from one step in which worker w did work `done[w].0` in
    /// `done[w].1` ns: the bounds move [`LEARN_RATE`] of the way towards
    /// the shares that the workers' speeds in that step would have
    /// balanced (the speeds are noisy from step to step, and the splits
    /// within the step make up for that noise; each split costs the pairs
    /// crossing it twice). A step in which a worker did nothing (it came
    /// late, or not at all) says nothing about its speed.
    pub(crate) fn learn(&mut self, done: &[(f64, u64)]) {
        if done.len() != self.bounds.len() || done.iter().any(|&(w, t)| w <= 0.0 || t == 0) {
            return;
        }
        let speed: Vec<f64> = done.iter().map(|&(w, t)| w / t as f64).collect();
        let total: f64 = speed.iter().sum();
        let mut cum = 0.0;
        for (b, s) in self.bounds.iter_mut().zip(&speed) {
            *b += LEARN_RATE * (cum / total - *b);
            cum += s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_first_run_is_taken_once() {
        let runs = Runs::new(UNIT * 10, &[0, 6], UNIT);
        assert_eq!(runs.get(0).limit(), Limit { unit: 6, run: 1 });
        assert_eq!(
            runs.get(1).limit(),
            Limit {
                unit: 10,
                run: NONE_RUN
            }
        );
        assert_eq!(runs.take_first(1).map(|t| t.run), Some(1));
        assert!(runs.take_first(1).is_none());
        // Worker 0 has not come: a thief takes its run whole.
        let t = runs.steal().map(|t| (t.run, runs.is_first(t.run)));
        assert_eq!(t, Some((0, true)));
        assert!(runs.take_first(0).is_none());
    }

    #[test]
    fn first_runs_are_at_least_the_pairs_reach_long() {
        // Pairs reach 300 particles on (three units): the runs from units
        // 2 and 4 are merged into the ones before them.
        let runs = Runs::new(UNIT * 20, &[0, 2, 3, 4, 7, 8], 300);
        assert_eq!(runs.firsts, 3);
        let ends: Vec<Limit> = (0..3).map(|r| runs.get(r).limit()).collect();
        let firsts: Vec<usize> = (0..3).map(|r| runs.get(r).first()).collect();
        assert_eq!(firsts, vec![0, 3, 7]);
        assert_eq!(ends[0], Limit { unit: 3, run: 1 });
        assert_eq!(ends[1], Limit { unit: 7, run: 2 });
        assert_eq!(
            ends[2],
            Limit {
                unit: 20,
                run: NONE_RUN
            }
        );
    }

    #[test]
    fn pairs_reaching_across_the_bed_leave_two_first_runs() {
        // Three workers, pairs reaching the whole bed (a periodic one):
        // two runs, split at the middle worker's start.
        let runs = Runs::new(UNIT * 30, &[0, 10, 20], UNIT * 30);
        assert_eq!(runs.firsts, 2);
        assert_eq!(runs.get(0).limit(), Limit { unit: 10, run: 1 });
        // Two workers: their runs as they were.
        let runs = Runs::new(UNIT * 30, &[0, 16], UNIT * 30);
        assert_eq!(runs.firsts, 2);
        assert_eq!(runs.get(1).first(), 16);
        // One worker: one run.
        let runs = Runs::new(UNIT * 30, &[0], UNIT * 30);
        assert_eq!(runs.firsts, 1);
    }

    #[test]
    fn more_workers_than_run_slots_share_half_the_slots() {
        let starts: Vec<usize> = (0..200).collect();
        let runs = Runs::new(UNIT * 200, &starts, 1);
        assert_eq!(runs.firsts, MAX_RUNS / 2);
        let last = runs.get(MAX_RUNS / 2 - 1).limit();
        assert_eq!(
            last,
            Limit {
                unit: 200,
                run: NONE_RUN
            }
        );
        assert!(runs.take_first(MAX_RUNS / 2).is_none());
        assert!(runs.take_first(MAX_RUNS / 2 - 1).is_some());
    }

    #[test]
    fn a_run_takes_over_the_next_if_no_worker_began_it() {
        let runs = Runs::new(UNIT * 10, &[0, 6], UNIT);
        assert!(runs.take_first(0).is_some());
        assert_eq!(runs.absorb(0, 1), Some(6..10));
        assert_eq!(
            runs.get(0).limit(),
            Limit {
                unit: 10,
                run: NONE_RUN
            }
        );
        assert!(runs.take_first(1).is_none());
        let runs = Runs::new(UNIT * 10, &[0, 6], UNIT);
        assert!(runs.take_first(1).is_some());
        assert_eq!(runs.absorb(0, 1), None);
    }

    #[test]
    fn a_split_hands_over_the_upper_half_at_a_unit_boundary() {
        let runs = Runs::new(UNIT * 20, &[0], UNIT);
        assert!(runs.take_first(0).is_some());
        // The run is before its unit 4: 16 units left.
        let run = runs.get(0);
        assert_eq!(run.before_unit(4, &runs).unit, 20);
        std::thread::scope(|s| {
            let thief = s.spawn(|| runs.steal().map(|t| (t.run, runs.is_first(t.run), t.done)));
            // It answers before the same unit.
            while run.before_unit(4, &runs).unit == 20 {
                std::hint::spin_loop();
            }
            assert_eq!(run.limit(), Limit { unit: 12, run: 1 });
            // The thief's run: units 12..20, the pairs from units 4..12
            // still to come to it.
            assert_eq!(thief.join().unwrap(), Some((1, false, 4)));
        });
        assert_eq!(runs.get(1).first(), 12);
        assert_eq!(
            runs.get(1).limit(),
            Limit {
                unit: 20,
                run: NONE_RUN
            }
        );
    }

    #[test]
    fn a_finished_run_is_not_split() {
        let runs = Runs::new(UNIT * 20, &[0], UNIT);
        assert!(runs.take_first(0).is_some());
        runs.get(0).finish();
        assert!(runs.steal().is_none());
    }

    #[test]
    fn shares_move_towards_the_work_done() {
        let mut s = Shares::default();
        let work: Vec<f64> = (0..=1000).map(|i| i as f64).collect();
        assert_eq!(s.starts(2, &work), vec![0, 4]);
        // Worker 0 did three times worker 1's work in the same time: the
        // bound moves from 0.5 an eighth of the way to 0.75.
        s.learn(&[(3.0, 10), (1.0, 10)]);
        assert_eq!(s.bounds, vec![0.0, 0.53125]);
        // Worker 1 did half its work in half the time: as fast as
        // worker 0, an even share.
        s.learn(&[(3.0, 10), (1.5, 5)]);
        let b = 0.53125 + 0.125 * (0.5 - 0.53125);
        assert_eq!(s.bounds, vec![0.0, b]);
        // Worker 1 did nothing: no change.
        s.learn(&[(3.0, 10), (0.0, 0)]);
        assert_eq!(s.bounds[1], b);
        assert_eq!(s.starts(2, &work), vec![0, 4]);
    }
}
