//! The runs of an ensemble command, case by case: all on one machine
//! ([`Part::Whole`]), the cases of one part of N ([`Part::Shard`]), or
//! none, their records read back from the parts' assembled folders
//! ([`Part::Merge`], after [`shard::assemble`]).
//!
//! Every run with a folder leaves its [`RECORD`] there: what the run
//! produced, with the case it ran, and its [`TIMING`]. A merge rebuilds
//! each [`Report`] from them and the case (and the free curve, which the
//! merge computes as a single machine would), so the aggregation
//! downstream sees the same numbers bit for bit (`serde_json`'s
//! `float_roundtrip`). The results of a run repeated elsewhere are the
//! same bits; only the timing files differ.

use std::cell::{Cell, RefCell};
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use serde::{Deserialize, Serialize};
pub use shard::{Part, Shard};

use crate::coupling::Sample;
use crate::{simulate_with, FreeCurve, Options, PhaseTimes, Report, Settled};

/// The file each run writes into its folder: its results.
pub const RECORD: &str = "record.json";

/// The file each run writes beside its [`RECORD`]: its wall times, which a
/// repeat of the run does not reproduce.
pub const TIMING: &str = "timing.json";

/// Where a run's wall time went.
#[derive(Debug, Serialize, Deserialize)]
struct Timing {
    wall_s: f64,
    phases: PhaseTimes,
}

/// What one run produced, beside the case it ran.
#[derive(Debug, Serialize, Deserialize)]
struct Record {
    /// The case (`{:?}` of its [`crate::ScenarioSpec`]): a merge checks it
    /// ran exactly the case the command asks for.
    case: String,
    grains: (usize, usize),
    surcharge_pa: f64,
    settled: Settled,
    samples: Vec<Sample>,
    skin_steps_per_dem_step: f64,
    skin_added_mass: f64,
}

impl Record {
    fn of(report: &Report) -> Record {
        Record {
            case: format!("{:?}", report.spec),
            grains: report.grains,
            surcharge_pa: report.surcharge_pa,
            settled: report.settled,
            samples: report.samples.clone(),
            skin_steps_per_dem_step: report.skin_steps_per_dem_step,
            skin_added_mass: report.skin_added_mass,
        }
    }

    fn write(&self, dir: &Path) -> Result<()> {
        let text = serde_json::to_string(self).context("encoding a run's record")?;
        // JSON has no NaN or infinity (serde_json writes null): a record a
        // merge could not read back is refused here, where the run that
        // made it is still known.
        serde_json::from_str::<Record>(&text).with_context(|| {
            format!(
                "{}: the run produced a value that is not a finite number, which its record cannot hold",
                dir.display()
            )
        })?;
        datafile::write_atomic(&dir.join(RECORD), text.as_bytes())
    }
}

impl Timing {
    fn write(&self, dir: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).context("encoding a run's timing")?;
        datafile::write_atomic(&dir.join(TIMING), text.as_bytes())
    }
}

/// Reads `dir/name` as a `T`.
fn read<T: serde::de::DeserializeOwned>(dir: &Path, name: &str) -> Result<T> {
    let path = dir.join(name);
    let text = std::fs::read_to_string(&path).with_context(|| {
        format!(
            "reading {}: no record of this case (were all parts merged?)",
            path.display()
        )
    })?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a run's {name}", path.display()))
}

/// Runs, skips or reads back the cases of one ensemble command, in the
/// command's order.
#[derive(Debug)]
pub struct Runner {
    part: Part,
    root: Option<PathBuf>,
    command: Vec<String>,
    next: Cell<usize>,
    ran: RefCell<Vec<PathBuf>>,
}

impl Runner {
    /// Every case here.
    pub fn whole() -> Runner {
        Runner {
            part: Part::Whole,
            root: None,
            command: Vec::new(),
            next: Cell::new(0),
            ran: RefCell::new(Vec::new()),
        }
    }

    /// `part` of the command `command` (its arguments, for the shard's
    /// manifest), whose cases' folders lie under `root`: a shard and a
    /// merge need one.
    pub fn new(part: Part, root: Option<&Path>, command: Vec<String>) -> Result<Runner> {
        ensure!(
            part == Part::Whole || root.is_some(),
            "a shard or a merge needs an output folder: each case's record lives in it"
        );
        Ok(Runner {
            part,
            root: root.map(Path::to_path_buf),
            command,
            ..Runner::whole()
        })
    }

    /// Which part this is.
    pub fn part(&self) -> Part {
        self.part
    }

    /// The next case, `opts` (its folder `opts.out`), with the zone's free
    /// curve `free`: run here, or read back from its record, or `None`
    /// when another part runs it.
    pub fn run(&self, opts: &Options, free: &FreeCurve) -> Result<Option<Report>> {
        let k = self.next.get();
        self.next.set(k + 1);
        if self.part == Part::Merge {
            let dir = opts
                .out
                .as_deref()
                .context("a merged case needs its folder")?;
            let record: Record = read(dir, RECORD)?;
            let timing: Timing = read(dir, TIMING)?;
            ensure!(
                record.case == format!("{:?}", opts.spec),
                "{}: this record is of another case than the command's (run with other options?)",
                dir.join(RECORD).display()
            );
            return Ok(Some(Report {
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
            }));
        }
        if !self.part.runs(k) {
            return Ok(None);
        }
        let report = simulate_with(opts, free.clone(), 0.0)?;
        if let Some(dir) = &opts.out {
            Record::of(&report).write(dir)?;
            Timing {
                wall_s: report.wall_s,
                phases: report.phases,
            }
            .write(dir)?;
            if let (Part::Shard(_), Some(root)) = (self.part, &self.root) {
                let rel = dir.strip_prefix(root).with_context(|| {
                    format!(
                        "the case folder {} is not under the shard's folder {}",
                        dir.display(),
                        root.display()
                    )
                })?;
                self.ran.borrow_mut().push(rel.to_path_buf());
            }
        }
        Ok(Some(report))
    }

    /// After the command's last case: a shard writes its manifest and
    /// says what it ran; other parts return `None`.
    pub fn finish(&self) -> Result<Option<String>> {
        let (Part::Shard(shard), Some(root)) = (self.part, &self.root) else {
            return Ok(None);
        };
        let manifest = shard::Manifest {
            command: self.command.clone(),
            shard,
            cases_total: self.next.get(),
            cases: self.ran.borrow().clone(),
        };
        manifest.write(root)?;
        Ok(Some(format!(
            "part {shard}: ran {} of the ensemble's {} cases into {}; when every part is done: host-sim merge --out DIR PART_FOLDER...",
            manifest.cases.len(),
            manifest.cases_total,
            root.display()
        )))
    }
}
