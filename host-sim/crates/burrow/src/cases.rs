//! The runs of an ensemble command, case by case ([`shard::Cases`]): all
//! on one machine ([`Part::Whole`]), the cases of one part of N
//! ([`Part::Shard`]), or none, their records read back from the parts'
//! assembled folders ([`Part::Merge`], after [`shard::assemble`]).
//!
//! Every run with a folder leaves its [`RECORD`] there (what it produced,
//! with the case it ran) and its [`TIMING`]. A report is always rebuilt
//! from them, the case and the free curve (which a merge computes as a
//! single machine would), so the aggregation downstream sees the same
//! numbers bit for bit wherever the run was made; only the timing files
//! of a run repeated elsewhere differ.

use std::cell::Cell;
use std::path::Path;

use anyhow::{ensure, Context, Result};
use serde::{Deserialize, Serialize};
pub use shard::{Part, Shard};

use crate::coupling::Sample;
use crate::{simulate_with, FreeCurve, Options, PhaseTimes, Report, ScenarioSpec, Settled};

/// The file each run writes into its folder: its results.
pub const RECORD: &str = "record.json";

/// The file each run writes beside its [`RECORD`]: its wall times, which a
/// repeat of the run does not reproduce.
pub const TIMING: &str = "timing.json";

/// What one run produced, beside the case it ran.
#[derive(Debug, Serialize, Deserialize)]
struct Record {
    /// The case (`{:?}` of its [`ScenarioSpec`]): a merge checks it ran
    /// exactly the case the command asks for.
    case: String,
    grains: (usize, usize),
    surcharge_pa: f64,
    settled: Settled,
    samples: Vec<Sample>,
    skin_steps_per_dem_step: f64,
    skin_added_mass: f64,
}

/// Where a run's wall time went.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
struct Timing {
    wall_s: f64,
    phases: PhaseTimes,
}

/// Runs, skips or reads back the cases of one ensemble command.
#[derive(Debug)]
pub struct Runner {
    cases: shard::Cases,
}

impl Runner {
    /// Every case here.
    pub fn whole() -> Runner {
        Runner {
            cases: shard::Cases::whole(),
        }
    }

    /// `part` of the command `command` (its part-independent arguments),
    /// whose cases' folders lie under `root`: a shard and a merge need one.
    pub fn new(part: Part, root: Option<&Path>, command: Vec<String>) -> Result<Runner> {
        Ok(Runner {
            cases: shard::Cases::new(part, root, command)?,
        })
    }

    /// Which part this is.
    pub fn part(&self) -> Part {
        self.cases.part()
    }

    /// The next case, `opts` (its folder `opts.out`), with the zone's free
    /// curve `free`: run here, or read back from its record, or `None`
    /// when another part runs it.
    pub fn run(&self, opts: &Options, free: &FreeCurve) -> Result<Option<Report>> {
        let dir = opts.out.as_deref();
        let timing = Cell::new(None);
        let record = self.cases.case(dir, RECORD, || {
            let r = simulate_with(opts, free.clone(), 0.0)?;
            timing.set(Some(Timing {
                wall_s: r.wall_s,
                phases: r.phases,
            }));
            Ok(Record {
                case: case_key(&r.spec),
                grains: r.grains,
                surcharge_pa: r.surcharge_pa,
                settled: r.settled,
                samples: r.samples,
                skin_steps_per_dem_step: r.skin_steps_per_dem_step,
                skin_added_mass: r.skin_added_mass,
            })
        })?;
        let Some(record) = record else {
            return Ok(None);
        };
        let timing = match (timing.get(), dir) {
            (Some(t), Some(dir)) => {
                shard::write_json(dir, TIMING, &t)?;
                t
            }
            (Some(t), None) => t,
            (None, dir) => {
                shard::read_json(dir.context("a merged case needs its folder")?, TIMING)?
            }
        };
        if let Some(dir) = dir {
            ensure!(
                record.case == case_key(&opts.spec),
                "{}: this record is of another case than the command's (run with other options?)",
                dir.join(RECORD).display()
            );
        }
        Ok(Some(Report {
            spec: opts.spec.clone(),
            grains: record.grains,
            surcharge_pa: record.surcharge_pa,
            settled: record.settled,
            samples: record.samples,
            free: free.clone(),
            wall_s: timing.wall_s,
            phases: timing.phases,
            skin_steps_per_dem_step: record.skin_steps_per_dem_step,
            skin_added_mass: record.skin_added_mass,
        }))
    }

    /// After the command's last case: a shard writes its manifest and
    /// says what it ran; other parts return `None`.
    pub fn finish(&self) -> Result<Option<String>> {
        self.cases.finish()
    }
}

/// A case's identity in its record: every setting, each number exact.
fn case_key(spec: &ScenarioSpec) -> String {
    format!("{spec:?}")
}
