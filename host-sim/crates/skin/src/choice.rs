//! The command line's skin options, parsed here so every command reads
//! them alike: `--skin-fit FILE [--skin-law NAME]` (a law from
//! `fit-skin`'s JSON report, replacing `rig.toml`'s `[skin]`), and
//! `fit-skin`'s own `--fit-modes` and `--inflation-law`.
//!
//! Which law of a report, when `--skin-law` is not given: the inflation
//! fit if the report has one (it measured the tube's own state, with its
//! ends and wall: the skin README's first choice); otherwise the name is
//! required. The report's criterion (summed per-mode R² of the coupon
//! curves) does not rank the laws for the tube: on Treloar's uniaxial
//! test Ogden-2 fits better than Yeoh (R² 0.9986 against 0.9973) yet
//! misses the joint fit's tube pressure by 28 % against Yeoh's 9 % (skin
//! README, "Which law to trust").

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use serde::Deserialize;

use super::coupon::Mode;
use super::law::{check_inflatable, SkinLaw};
use super::LawSpec;

/// `--skin-law`'s name for the report's inflation fit.
pub const INFLATION: &str = "inflation";

/// `--skin-fit FILE [--skin-law NAME]`, as given.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SkinFitChoice {
    /// `fit-skin`'s JSON report.
    pub file: PathBuf,
    /// A law's name as the report prints it, or [`INFLATION`]; `None`:
    /// the inflation fit, which the report must then hold.
    pub law: Option<String>,
}

/// A law read from a report.
#[derive(Clone, Debug, PartialEq)]
pub struct ChosenLaw {
    /// The law.
    pub law: SkinLaw,
    /// Where it came from, for notes, warnings and file headers: e.g.
    /// `the Gent coupon fit (uniaxial + planar) of out/skin-fit.json`.
    pub source: String,
    /// What the report says against it (unstable over its data).
    pub warnings: Vec<String>,
}

/// The parts of a report this reads.
#[derive(Deserialize)]
struct StoredReport {
    fits: Vec<StoredFit>,
    #[serde(default)]
    inflation: Option<StoredInflation>,
}

#[derive(Deserialize)]
struct StoredFit {
    law: String,
    parameters: Vec<f64>,
    #[serde(default)]
    modes: Vec<StoredMode>,
    #[serde(default)]
    stability: Option<StoredStability>,
}

#[derive(Deserialize)]
struct StoredMode {
    mode: String,
    fitted: bool,
    r_squared: Option<f64>,
}

#[derive(Deserialize)]
struct StoredStability {
    stable_over_data: bool,
}

#[derive(Deserialize)]
struct StoredInflation {
    folder: PathBuf,
    fit: StoredInflationFit,
}

#[derive(Deserialize)]
struct StoredInflationFit {
    law: String,
    parameters: Vec<f64>,
}

impl SkinFitChoice {
    /// Reads the report and builds the chosen law; errors name the file
    /// (and, for JSON errors, its line and column) and list the laws the
    /// report holds when the name is missing or unknown.
    pub fn read(&self) -> Result<ChosenLaw> {
        let f = self.file.display();
        let text = std::fs::read_to_string(&self.file)
            .with_context(|| format!("--skin-fit {f}: cannot read it"))?;
        let report: StoredReport = serde_json::from_str(&text)
            .with_context(|| format!("--skin-fit {f}: not a fit-skin JSON report"))?;
        let listing = || {
            let mut l: Vec<String> = report
                .fits
                .iter()
                .map(|fit| {
                    let r2: Vec<String> = fit
                        .modes
                        .iter()
                        .filter(|m| m.fitted)
                        .map(|m| {
                            format!(
                                "{} R² {}",
                                m.mode,
                                m.r_squared.map_or("n/a".into(), |r| format!("{r:.4}"))
                            )
                        })
                        .collect();
                    format!("{} ({})", fit.law, r2.join(", "))
                })
                .collect();
            if let Some(i) = &report.inflation {
                l.push(format!(
                    "{INFLATION} ({} fit to the free inflation)",
                    i.fit.law
                ));
            }
            l.join("; ")
        };
        let wanted = match (&self.law, &report.inflation) {
            (Some(name), _) => name.as_str(),
            (None, Some(_)) => INFLATION,
            (None, None) => bail!(
                "--skin-fit {f}: say which law with --skin-law (the report's R² ranks the coupon curves, not the tube: host-sim/crates/skin/README.md, \"Which law to trust\"); it holds {}",
                listing()
            ),
        };
        let chosen = if wanted == INFLATION {
            let Some(i) = &report.inflation else {
                bail!(
                    "--skin-fit {f}: --skin-law {INFLATION}: the report has no inflation fit (fit-skin --inflation); it holds {}",
                    listing()
                );
            };
            ChosenLaw {
                law: SkinLaw::new(&i.fit.law, &i.fit.parameters)
                    .with_context(|| format!("--skin-fit {f}: inflation.fit"))?,
                source: format!(
                    "the {} inflation fit (to {}) of {f}",
                    i.fit.law,
                    i.folder.display()
                ),
                warnings: Vec::new(),
            }
        } else {
            let Some(fit) = report.fits.iter().find(|fit| fit.law == wanted) else {
                bail!(
                    "--skin-fit {f}: --skin-law {wanted}: the report has no fit of that law; it holds {}",
                    listing()
                );
            };
            let modes: Vec<&str> = fit
                .modes
                .iter()
                .filter(|m| m.fitted)
                .map(|m| m.mode.as_str())
                .collect();
            let source = format!("the {} coupon fit ({}) of {f}", fit.law, modes.join(" + "));
            let mut warnings = Vec::new();
            if fit.stability.as_ref().is_some_and(|s| !s.stable_over_data) {
                warnings.push(format!(
                    "{source} is not Drucker-stable over its own data (fit-skin's stability column)"
                ));
            }
            ChosenLaw {
                law: SkinLaw::new(&fit.law, &fit.parameters)
                    .with_context(|| format!("--skin-fit {f}: the fit of {}", fit.law))?,
                source,
                warnings,
            }
        };
        check_inflatable(&chosen.law, &format!("--skin-fit {f}"))?;
        Ok(chosen)
    }

    /// The options as a command line gives them (for a file header's
    /// regenerating command).
    pub fn args(&self) -> String {
        let mut s = format!("--skin-fit {}", self.file.display());
        if let Some(l) = &self.law {
            s.push_str(&format!(" --skin-law {l}"));
        }
        s
    }
}

/// `--fit-modes`: each name a test mode, or an error naming the option
/// and the modes there are.
pub fn parse_fit_modes(names: &[String]) -> Result<Vec<Mode>> {
    names
        .iter()
        .map(|n| {
            Mode::parse(n).ok_or_else(|| {
                anyhow::anyhow!(
                    "--fit-modes: `{n}` is not a test mode (uniaxial, equibiaxial or planar)"
                )
            })
        })
        .collect()
}

/// `--inflation-law`: a registered law, or an error listing them.
pub fn parse_inflation_law(name: &str) -> Result<&'static LawSpec> {
    LawSpec::named(name, "--inflation-law")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::StrainEnergy;

    /// A report as fit-skin writes it, cut to what is read: a stable Gent
    /// fit, a Mooney–Rivlin fit unstable at rest, and, when asked for, an
    /// inflation fit of Yeoh.
    fn report(dir: &std::path::Path, inflation: bool) -> PathBuf {
        let fits = r#""fits": [
            {"law": "Gent", "parameters": [8.0, 23.0], "modes": [{"mode": "uniaxial", "fitted": true, "r_squared": 0.96}],
             "stability": {"stable_over_data": true}},
            {"law": "Mooney-Rivlin", "parameters": [23.4, -47.0], "modes": [{"mode": "uniaxial", "fitted": true, "r_squared": 0.81}],
             "stability": {"stable_over_data": false}}
        ]"#;
        let infl = if inflation {
            r#", "inflation": {"folder": "exp", "fit": {"law": "Yeoh", "parameters": [2.0, 0.0, 0.02]}}"#
        } else {
            ""
        };
        let path = dir.join(if inflation {
            "with.json"
        } else {
            "without.json"
        });
        std::fs::write(&path, format!("{{{fits}{infl}}}")).unwrap();
        path
    }

    fn choose(file: &std::path::Path, law: Option<&str>) -> Result<ChosenLaw> {
        SkinFitChoice {
            file: file.to_path_buf(),
            law: law.map(str::to_owned),
        }
        .read()
    }

    #[test]
    fn the_inflation_fit_is_the_default_and_a_name_picks_a_coupon_fit() {
        let dir = tempfile::tempdir().unwrap();
        let with = report(dir.path(), true);
        let c = choose(&with, None).unwrap();
        assert_eq!(c.law.name(), "Yeoh");
        assert!(c.source.contains("inflation fit (to exp)"), "{}", c.source);
        let c = choose(&with, Some("Gent")).unwrap();
        assert_eq!(c.law.parameters(), vec![8.0, 23.0]);
        assert!(c.source.contains("Gent coupon fit (uniaxial)"));
        assert!(c.warnings.is_empty());
    }

    #[test]
    fn a_missing_name_a_missing_law_and_an_unstable_one_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let without = report(dir.path(), false);
        let e = format!("{:#}", choose(&without, None).unwrap_err());
        assert!(
            e.contains("say which law with --skin-law")
                && e.contains("Gent (uniaxial R² 0.9600)")
                && e.contains("without.json"),
            "{e}"
        );
        let e = format!("{:#}", choose(&without, Some(INFLATION)).unwrap_err());
        assert!(e.contains("the report has no inflation fit"), "{e}");
        let e = format!("{:#}", choose(&without, Some("Ogden-3")).unwrap_err());
        assert!(
            e.contains("--skin-law Ogden-3: the report has no fit of that law"),
            "{e}"
        );
        // μ = 2(C10 + C01) < 0: no tube.
        let e = format!("{:#}", choose(&without, Some("Mooney-Rivlin")).unwrap_err());
        assert!(e.contains("unstable") && e.contains("no skin tube"), "{e}");
        // Not a report: the file, line and column.
        let bad = dir.path().join("bad.json");
        std::fs::write(&bad, "{\n \"fits\": 3\n}").unwrap();
        let e = format!("{:#}", choose(&bad, Some("Gent")).unwrap_err());
        assert!(
            e.contains("bad.json: not a fit-skin JSON report") && e.contains("line 2"),
            "{e}"
        );
    }
}
