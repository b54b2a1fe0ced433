//! The error of every data file.

use std::fmt;

/// A bad data file: which file, which line (1-based, where one can be
/// named), which key (a TOML dotted key or a CSV column, where one is at
/// fault) and what is wrong.
///
/// Shown as `{file}:{line}: {key}: {message}`, the parts that are `None`
/// left out: `runs.csv:3: pressure_kpa: `abc` is not a number`,
/// `rig.toml: actuator.initial_diameter_mm: missing key`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}: {message}", Location(self))]
pub struct DataError {
    /// The file, as the reader was given it (a name or a path).
    pub file: String,
    /// 1-based line, where the problem sits on one.
    pub line: Option<u64>,
    /// TOML dotted key or CSV column at fault, where there is one.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
}

/// `file[:line][: key]`.
struct Location<'e>(&'e DataError);

impl fmt::Display for Location<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = self.0;
        f.write_str(&e.file)?;
        if let Some(line) = e.line {
            write!(f, ":{line}")?;
        }
        if let Some(key) = &e.key {
            write!(f, ": {key}")?;
        }
        Ok(())
    }
}

impl DataError {
    /// An error about `file` as a whole (no line, no key).
    pub fn new(file: impl Into<String>, message: impl Into<String>) -> DataError {
        DataError {
            file: file.into(),
            line: None,
            key: None,
            message: message.into(),
        }
    }

    /// The same error, placed at 1-based `line`.
    #[must_use]
    pub fn with_line(mut self, line: u64) -> DataError {
        self.line = Some(line);
        self
    }

    /// The same error, naming `key` (TOML dotted key or CSV column).
    #[must_use]
    pub fn with_key(mut self, key: impl Into<String>) -> DataError {
        self.key = Some(key.into());
        self
    }
}

/// `bytes` as text, or "not valid UTF-8" at the line of the first bad byte.
pub fn decode_utf8(file: &str, bytes: Vec<u8>) -> Result<String, DataError> {
    String::from_utf8(bytes).map_err(|e| {
        let valid = e.utf8_error().valid_up_to();
        let before = e.as_bytes().get(..valid).unwrap_or_default();
        DataError::new(file, "not valid UTF-8").with_line(count_newlines(before) + 1)
    })
}

/// Number of `\n` in `bytes`.
pub(crate) fn count_newlines(bytes: &[u8]) -> u64 {
    bytes.iter().filter(|&&b| b == b'\n').count() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_leaves_out_what_is_not_known() {
        let e = DataError::new("rig.toml", "missing key").with_key("actuator.initial_diameter_mm");
        assert_eq!(
            e.to_string(),
            "rig.toml: actuator.initial_diameter_mm: missing key"
        );
        let e = DataError::new("runs.csv", "`abc` is not a number")
            .with_line(3)
            .with_key("pressure_kpa");
        assert_eq!(
            e.to_string(),
            "runs.csv:3: pressure_kpa: `abc` is not a number"
        );
        let e = DataError::new("runs.csv", "4 fields, but the header has 5").with_line(3);
        assert_eq!(e.to_string(), "runs.csv:3: 4 fields, but the header has 5");
        let e = DataError::new("*.csv", "no samples");
        assert_eq!(e.to_string(), "*.csv: no samples");
        assert_eq!(
            (e.file.as_str(), e.line, e.key, e.message.as_str()),
            ("*.csv", None, None, "no samples")
        );
    }

    #[test]
    fn bad_utf8_names_its_line() {
        assert_eq!(decode_utf8("a.csv", b"x\ny".to_vec()).unwrap(), "x\ny");
        let e = decode_utf8("a.csv", b"a,b\r\n1,2\r\n3,\xff\n".to_vec()).unwrap_err();
        assert_eq!(e.to_string(), "a.csv:3: not valid UTF-8");
    }
}
