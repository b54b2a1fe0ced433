//! Ensembles a cluster can run: an ensemble command's cases are
//! independent, so `--shard I/N` runs every N-th of them (the I-th part)
//! into the part's own folder, and [`assemble`] gathers the parts' folders
//! into one, from which the command, run again in [`Part::Merge`] mode,
//! reads each case's record instead of running it. The aggregation is then
//! the same code over the same numbers as on one machine: the same bits.
//!
//! The scheduling is the cluster's (a Slurm job array, GNU parallel): this
//! crate only says which cases a part holds and checks that the parts
//! fit together (same command, every part once, every case once).

use std::cell::{Cell, RefCell};
use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use anyhow::{bail, ensure, Context, Result};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// The manifest each part writes at the root of its folder.
pub const MANIFEST: &str = "shard.json";

/// One part of N: the cases whose index k (0-based, in the command's
/// order) has k mod N = I − 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    index: usize,
    count: usize,
}

impl Shard {
    /// The `index`-th (1-based) of `count` parts.
    pub fn new(index: usize, count: usize) -> Result<Shard> {
        ensure!(
            count >= 1,
            "a shard's part count must be at least 1, not {count}"
        );
        ensure!(
            (1..=count).contains(&index),
            "shard {index}/{count}: the part must be between 1 and {count}"
        );
        Ok(Shard { index, count })
    }

    /// The part's number, 1..=[`Shard::count`].
    pub fn index(self) -> usize {
        self.index
    }

    /// How many parts the cases are split into.
    pub fn count(self) -> usize {
        self.count
    }

    /// Whether the case with 0-based index `case` belongs to this part.
    pub fn holds(self, case: usize) -> bool {
        case % self.count == self.index - 1
    }
}

impl FromStr for Shard {
    type Err = anyhow::Error;

    /// `I/N`, e.g. `2/8` (Slurm: `--shard $SLURM_ARRAY_TASK_ID/8` with
    /// `--array=1-8`).
    fn from_str(s: &str) -> Result<Shard> {
        let (i, n) = s
            .split_once('/')
            .with_context(|| format!("shard `{s}`: expected I/N, e.g. 2/8"))?;
        let parse = |v: &str, what: &str| {
            v.trim()
                .parse::<usize>()
                .with_context(|| format!("shard `{s}`: the {what} `{v}` is not a whole number"))
        };
        Shard::new(parse(i, "part")?, parse(n, "part count")?)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// How an ensemble command obtains its cases.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Part {
    /// Run every case here, then aggregate (one machine).
    #[default]
    Whole,
    /// Run only this part's cases and record them; no aggregation.
    Shard(Shard),
    /// Run nothing: read every case's record from the output folder
    /// (assembled by [`assemble`]) and aggregate.
    Merge,
}

impl Part {
    /// Whether the case with 0-based index `case` is run here.
    pub fn runs(self, case: usize) -> bool {
        match self {
            Part::Whole => true,
            Part::Shard(s) => s.holds(case),
            Part::Merge => false,
        }
    }
}

/// Runs, skips or reads back the cases of one command, in the command's
/// order: each case is a closure giving its results, kept as JSON in the
/// case's folder, from which a merge reads them back bit for bit
/// (`serde_json`'s `float_roundtrip`).
#[derive(Debug)]
pub struct Cases {
    part: Part,
    root: Option<PathBuf>,
    command: Vec<String>,
    next: Cell<usize>,
    ran: RefCell<Vec<PathBuf>>,
}

impl Cases {
    /// Every case here.
    pub fn whole() -> Cases {
        Cases {
            part: Part::Whole,
            root: None,
            command: Vec::new(),
            next: Cell::new(0),
            ran: RefCell::new(Vec::new()),
        }
    }

    /// `part` of the command `command` (its part-independent arguments,
    /// [`Manifest::command`]), whose cases' folders lie under `root`: a
    /// shard and a merge need one.
    pub fn new(part: Part, root: Option<&Path>, command: Vec<String>) -> Result<Cases> {
        ensure!(
            part == Part::Whole || root.is_some(),
            "a shard or a merge needs an output folder: each case's record lives in it"
        );
        Ok(Cases {
            part,
            root: root.map(Path::to_path_buf),
            command,
            ..Cases::whole()
        })
    }

    /// Which part this is.
    pub fn part(&self) -> Part {
        self.part
    }

    /// The next case, whose folder is `dir` (`None`: nothing kept) and
    /// whose results `run` gives: run here and kept in `dir/file`, or read
    /// back from there ([`Part::Merge`]), or `None` when another part runs
    /// it.
    pub fn case<T: Serialize + DeserializeOwned>(
        &self,
        dir: Option<&Path>,
        file: &str,
        run: impl FnOnce() -> Result<T>,
    ) -> Result<Option<T>> {
        let k = self.next.get();
        self.next.set(k + 1);
        if self.part == Part::Merge {
            let dir = dir.context("a merged case needs its folder")?;
            return read_json(dir, file).map(Some);
        }
        if !self.part.runs(k) {
            return Ok(None);
        }
        let results = run()?;
        if let Some(dir) = dir {
            write_json(dir, file, &results)?;
            if let (Part::Shard(_), Some(root)) = (self.part, &self.root) {
                let rel = dir.strip_prefix(root).with_context(|| {
                    format!(
                        "the case folder {} is not under the part's folder {}",
                        dir.display(),
                        root.display()
                    )
                })?;
                self.ran.borrow_mut().push(rel.to_path_buf());
            }
        }
        Ok(Some(results))
    }

    /// After the command's last case: a shard writes its manifest and
    /// says what it ran; other parts return `None`.
    pub fn finish(&self) -> Result<Option<String>> {
        let (Part::Shard(shard), Some(root)) = (self.part, &self.root) else {
            return Ok(None);
        };
        let manifest = Manifest {
            command: self.command.clone(),
            shard,
            cases_total: self.next.get(),
            cases: self.ran.borrow().clone(),
        };
        manifest.write(root)?;
        Ok(Some(format!(
            "part {shard}: ran {} of the command's {} cases into {}; when every part is done: host-sim merge --out DIR PART_FOLDER...",
            manifest.cases.len(),
            manifest.cases_total,
            root.display()
        )))
    }
}

/// Writes `value` as JSON to `dir/file` (atomically), after checking that
/// it reads back: JSON has no NaN or infinity (serde_json writes null), and
/// a file a merge could not read is refused here, where the run that made
/// it is still known.
pub fn write_json<T: Serialize + DeserializeOwned>(
    dir: &Path,
    file: &str,
    value: &T,
) -> Result<()> {
    let path = dir.join(file);
    let text =
        serde_json::to_string(value).with_context(|| format!("encoding {}", path.display()))?;
    serde_json::from_str::<T>(&text).with_context(|| {
        format!(
            "{}: the case produced a value that is not a finite number, which JSON cannot hold",
            path.display()
        )
    })?;
    datafile::write_atomic(&path, text.as_bytes())
}

/// Reads `dir/file` as JSON.
pub fn read_json<T: DeserializeOwned>(dir: &Path, file: &str) -> Result<T> {
    let path = dir.join(file);
    let text = fs::read_to_string(&path).with_context(|| {
        format!(
            "reading {}: no record of this case (were all parts merged?)",
            path.display()
        )
    })?;
    serde_json::from_str(&text)
        .with_context(|| format!("{}: not what this command wrote", path.display()))
}

/// What a part ran: written by the part, read by [`assemble`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// The command line that ran the part, without the program's name,
    /// its part and its folder ([`without_options`]): every part of one
    /// ensemble must have run the same one, and the merge runs it again
    /// in [`Part::Merge`] mode, with the merged folder.
    pub command: Vec<String>,
    /// Which part.
    pub shard: Shard,
    /// Cases in the whole ensemble.
    pub cases_total: usize,
    /// The folders of the cases this part ran, relative to its folder.
    pub cases: Vec<PathBuf>,
}

impl Manifest {
    /// Writes the manifest to `dir/shard.json` (atomically).
    pub fn write(&self, dir: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).context("encoding the shard manifest")?;
        datafile::write_atomic(&dir.join(MANIFEST), text.as_bytes())
    }

    /// Reads `dir/shard.json`.
    pub fn read(dir: &Path) -> Result<Manifest> {
        let path = dir.join(MANIFEST);
        let text = fs::read_to_string(&path).with_context(|| {
            format!(
                "reading {}: is {} the folder of a part run with --shard I/N?",
                path.display(),
                dir.display()
            )
        })?;
        serde_json::from_str(&text)
            .with_context(|| format!("{}: not a shard manifest", path.display()))
    }
}

/// `args` without the options `names` (each spelled `--name VALUE` or
/// `--name=VALUE`): what remains of a part's command line once its part
/// (`--shard`) and its own folder are taken out, which every part of one
/// ensemble shares.
pub fn without_options(args: &[String], names: &[&str]) -> Vec<String> {
    let mut out = Vec::with_capacity(args.len());
    let mut skip = false;
    for a in args {
        let named = |n: &&str| a == n || a.strip_prefix(n).is_some_and(|v| v.starts_with('='));
        if skip {
            skip = false;
        } else if names.iter().any(|n| a == n) {
            skip = true;
        } else if !names.iter().any(named) {
            out.push(a.clone());
        }
    }
    out
}

/// Checks that `parts` are every part of one ensemble, once each, and
/// copies their case folders into `out` (which must not exist yet, or be
/// empty). Returns the command the parts ran ([`Manifest::command`]), to
/// be run again in [`Part::Merge`] mode with its output folder set to
/// `out`.
pub fn assemble(parts: &[PathBuf], out: &Path) -> Result<Vec<String>> {
    ensure!(!parts.is_empty(), "merge: no part folders given");
    let manifests = parts
        .iter()
        .map(|p| Manifest::read(p))
        .collect::<Result<Vec<_>>>()?;
    let first = &manifests[0];
    let command = first.command.clone();
    let count = first.shard.count();
    let mut seen = vec![None::<&Path>; count];
    for (m, dir) in manifests.iter().zip(parts) {
        ensure!(
            m.command == command,
            "merge: {} ran `{}`, but {} ran `{}`: parts of different ensembles",
            dir.display(),
            m.command.join(" "),
            parts[0].display(),
            first.command.join(" ")
        );
        ensure!(
            m.shard.count() == count && m.cases_total == first.cases_total,
            "merge: {} is part {} of an ensemble of {} cases, {} part {} of {}",
            dir.display(),
            m.shard,
            m.cases_total,
            parts[0].display(),
            first.shard,
            first.cases_total
        );
        let slot = &mut seen[m.shard.index() - 1];
        if let Some(other) = slot {
            bail!(
                "merge: part {} given twice ({} and {})",
                m.shard,
                other.display(),
                dir.display()
            );
        }
        *slot = Some(dir);
    }
    let missing: Vec<String> = seen
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_none())
        .map(|(k, _)| format!("{}/{count}", k + 1))
        .collect();
    ensure!(
        missing.is_empty(),
        "merge: part(s) {} missing (every part of the ensemble is needed)",
        missing.join(", ")
    );
    let listed: usize = manifests.iter().map(|m| m.cases.len()).sum();
    ensure!(
        listed == first.cases_total,
        "merge: the parts ran {listed} cases, the ensemble has {}",
        first.cases_total
    );
    if out.exists() {
        let empty = fs::read_dir(out)
            .with_context(|| format!("reading {}", out.display()))?
            .next()
            .is_none();
        ensure!(
            empty,
            "merge: {} exists and is not empty; merge into a new folder",
            out.display()
        );
    }
    for (m, dir) in manifests.iter().zip(parts) {
        for case in &m.cases {
            ensure!(
                case.is_relative()
                    && case
                        .components()
                        .all(|c| matches!(c, std::path::Component::Normal(_))),
                "{}: case folder `{}` is not inside the part",
                dir.join(MANIFEST).display(),
                case.display()
            );
            let to = out.join(case);
            ensure!(
                !to.exists(),
                "merge: case {} comes from two parts",
                case.display()
            );
            copy_dir(&dir.join(case), &to)?;
        }
    }
    Ok(command)
}

/// Copies the folder `from` into the new folder `to`, recursively.
fn copy_dir(from: &Path, to: &Path) -> Result<()> {
    fs::create_dir_all(to).with_context(|| format!("creating {}", to.display()))?;
    let entries = fs::read_dir(from).with_context(|| format!("reading {}", from.display()))?;
    for entry in entries {
        let entry = entry.with_context(|| format!("reading {}", from.display()))?;
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        let kind = entry
            .file_type()
            .with_context(|| format!("reading {}", src.display()))?;
        if kind.is_dir() {
            copy_dir(&src, &dst)?;
        } else {
            fs::copy(&src, &dst)
                .with_context(|| format!("copying {} to {}", src.display(), dst.display()))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_split_the_cases_once_each() {
        for count in 1..=5 {
            let parts: Vec<Shard> = (1..=count).map(|i| Shard::new(i, count).unwrap()).collect();
            for case in 0..17 {
                let holders = parts.iter().filter(|s| s.holds(case)).count();
                assert_eq!(holders, 1, "case {case} of {count} parts");
            }
        }
        let s: Shard = "2/3".parse().unwrap();
        assert_eq!((s.index(), s.count(), s.to_string()), (2, 3, "2/3".into()));
        assert!(s.holds(1) && s.holds(4) && !s.holds(0));
    }

    #[test]
    fn bad_shards_are_refused_in_words() {
        for (text, says) in [
            ("0/3", "between 1 and 3"),
            ("4/3", "between 1 and 3"),
            ("1/0", "at least 1"),
            ("2", "expected I/N"),
            ("a/3", "part `a`"),
            ("1/x", "part count `x`"),
        ] {
            let e = text.parse::<Shard>().unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn the_parts_options_are_stripped_in_both_spellings() {
        let args: Vec<String> = [
            "balloon",
            "--shard",
            "1/2",
            "--seeds",
            "3",
            "--out=p1",
            "--shard=2/2",
            "--outer",
            "x",
        ]
        .map(String::from)
        .to_vec();
        assert_eq!(
            without_options(&args, &["--shard", "--out"]),
            ["balloon", "--seeds", "3", "--outer", "x"]
        );
    }

    fn part(root: &Path, name: &str, shard: &str, cases: &[&str], total: usize) -> PathBuf {
        let dir = root.join(name);
        for c in cases {
            fs::create_dir_all(dir.join(c)).unwrap();
            fs::write(dir.join(c).join("record.json"), c.as_bytes()).unwrap();
        }
        Manifest {
            command: ["balloon", "--seeds", "2"].map(String::from).to_vec(),
            shard: shard.parse().unwrap(),
            cases_total: total,
            cases: cases.iter().map(PathBuf::from).collect(),
        }
        .write(&dir)
        .unwrap();
        dir
    }

    #[test]
    fn parts_are_assembled_and_checked() {
        let tmp = tempfile::tempdir().unwrap();
        let a = part(tmp.path(), "a", "1/2", &["h40mm/seed-1", "h50mm/seed-1"], 3);
        let b = part(tmp.path(), "b", "2/2", &["h40mm/seed-2"], 3);
        let out = tmp.path().join("merged");
        let command = assemble(&[a.clone(), b.clone()], &out).unwrap();
        assert_eq!(command, ["balloon", "--seeds", "2"]);
        let read = |c: &str| fs::read_to_string(out.join(c).join("record.json")).unwrap();
        assert_eq!(read("h40mm/seed-2"), "h40mm/seed-2");
        assert_eq!(read("h50mm/seed-1"), "h50mm/seed-1");

        // Into a folder that is not empty; a part missing; a part twice.
        let e = assemble(&[a.clone(), b.clone()], &out)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not empty"), "{e}");
        let fresh = tmp.path().join("m2");
        let e = assemble(std::slice::from_ref(&a), &fresh)
            .unwrap_err()
            .to_string();
        assert!(e.contains("part(s) 2/2 missing"), "{e}");
        let e = assemble(&[a.clone(), a.clone()], &fresh)
            .unwrap_err()
            .to_string();
        assert!(e.contains("given twice"), "{e}");
        // A part of another ensemble.
        let c = part(tmp.path(), "c", "2/2", &["h40mm/seed-2"], 4);
        let e = assemble(&[a.clone(), c], &fresh).unwrap_err().to_string();
        assert!(e.contains("ensemble of 4 cases"), "{e}");
        // A folder that is not a part.
        let e = assemble(&[tmp.path().join("none")], &fresh)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--shard I/N"), "{e}");
    }

    #[test]
    fn cases_run_skip_and_read_back_exactly() {
        let tmp = tempfile::tempdir().unwrap();
        let values = [0.1_f64, 1.0 / 3.0, 2f64.sqrt()];
        let run_all = |cases: &Cases, root: &Path| -> Vec<Option<Vec<f64>>> {
            (0..3)
                .map(|k| {
                    let dir = root.join(format!("case-{k}"));
                    cases
                        .case(Some(&dir), "r.json", || Ok(vec![values[k], -values[k]]))
                        .unwrap()
                })
                .collect()
        };
        let root = tmp.path().join("p2");
        let part = Cases::new(
            Part::Shard(Shard::new(2, 2).unwrap()),
            Some(&root),
            vec!["x".into()],
        )
        .unwrap();
        let got = run_all(&part, &root);
        assert!(got[0].is_none() && got[2].is_none());
        assert_eq!(got[1].as_deref(), Some(&[values[1], -values[1]][..]));
        assert!(part
            .finish()
            .unwrap()
            .unwrap()
            .contains("ran 1 of the command's 3 cases"));
        let root1 = tmp.path().join("p1");
        let part1 = Cases::new(
            Part::Shard(Shard::new(1, 2).unwrap()),
            Some(&root1),
            vec!["x".into()],
        )
        .unwrap();
        run_all(&part1, &root1);
        part1.finish().unwrap();
        let merged = tmp.path().join("m");
        assemble(&[root, root1], &merged).unwrap();
        let merge = Cases::new(Part::Merge, Some(&merged), Vec::new()).unwrap();
        let back: Vec<Vec<f64>> = (0..3)
            .map(|k| {
                merge
                    .case(
                        Some(&merged.join(format!("case-{k}"))),
                        "r.json",
                        || -> Result<Vec<f64>> { panic!("a merge runs nothing") },
                    )
                    .unwrap()
                    .unwrap()
            })
            .collect();
        for (k, v) in back.iter().enumerate() {
            assert_eq!(v[0].to_bits(), values[k].to_bits());
        }
        // A merge or a shard needs a folder; a NaN cannot be kept.
        assert!(Cases::new(Part::Merge, None, Vec::new()).is_err());
        let whole = Cases::whole();
        let e = whole
            .case(Some(&tmp.path().join("nan")), "r.json", || Ok(f64::NAN))
            .unwrap_err();
        assert!(format!("{e:#}").contains("not a finite number"), "{e:#}");
    }
}
