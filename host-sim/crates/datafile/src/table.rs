//! CSV tables: a header naming the columns, then rows, each row with its
//! true line in the file.

use crate::error::{count_newlines, DataError};

/// The UTF-8 byte-order mark some spreadsheet programs write first.
const BOM: &[u8] = b"\xef\xbb\xbf";

/// A CSV table being read: the header is read on opening, the rows one at
/// a time by [`Table::rows`] (so a bad row is reported where it is met).
///
/// Fields and column names are trimmed; CRLF line ends, a UTF-8 byte-order
/// mark and empty lines are accepted; with [`Table::parse_with_comments`],
/// lines starting with `#` are skipped. Every error is a [`DataError`]
/// naming the file and the line, counting every line of the file
/// (comments and empty ones too).
pub struct Table<'a> {
    file: String,
    columns: Vec<String>,
    header_line: u64,
    reader: csv::Reader<&'a [u8]>,
    lines: Lines<'a>,
}

impl<'a> Table<'a> {
    /// Opens `bytes` as a table without comment lines (a line starting
    /// with `#` is a row like any other); `file` names it in errors.
    pub fn parse(file: impl Into<String>, bytes: &'a [u8]) -> Result<Table<'a>, DataError> {
        Table::open(file.into(), bytes, false)
    }

    /// Opens `bytes` as a table in which lines starting with `#` are
    /// comments (see [`comment_lines`] to read them); `file` names it in
    /// errors.
    pub fn parse_with_comments(
        file: impl Into<String>,
        bytes: &'a [u8],
    ) -> Result<Table<'a>, DataError> {
        Table::open(file.into(), bytes, true)
    }

    fn open(file: String, bytes: &'a [u8], comments: bool) -> Result<Table<'a>, DataError> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(comments.then_some(b'#'))
            .from_reader(bytes);
        let mut lines = Lines {
            bytes,
            comments,
            upto: 0,
            newlines: 0,
        };
        // The header is the first record, wherever the comments and empty
        // lines before it end.
        let header_line = lines.record_line(0);
        let columns = match reader.headers() {
            Ok(header) => header.iter().map(str::to_owned).collect(),
            Err(e) => return Err(lines.csv_error(&file, &[], &e)),
        };
        Ok(Table {
            file,
            columns,
            header_line,
            reader,
            lines,
        })
    }

    /// The file as given to the reader.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The column names, trimmed, in file order.
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// 1-based line of the header.
    pub fn header_line(&self) -> u64 {
        self.header_line
    }

    /// Index of the (first) column called `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// Index of the column called `name`, or an error at the header line
    /// naming it.
    pub fn require(&self, name: &str) -> Result<usize, DataError> {
        self.column(name).ok_or_else(|| {
            self.header_error(if self.columns.is_empty() {
                "missing column (the file has no header)".to_owned()
            } else {
                format!("missing column (header: {})", self.columns.join(", "))
            })
            .with_key(name)
        })
    }

    /// An error at the header line (no key; add one with
    /// [`DataError::with_key`]).
    pub fn header_error(&self, message: impl Into<String>) -> DataError {
        DataError::new(&self.file, message).with_line(self.header_line)
    }

    /// The rows after the header, in file order. A malformed record (a
    /// field count that differs from the header's, invalid UTF-8) is an
    /// error at its line; reading may go on after it.
    pub fn rows(&mut self) -> Rows<'_, 'a> {
        Rows {
            file: &self.file,
            columns: &self.columns,
            reader: &mut self.reader,
            lines: &mut self.lines,
        }
    }
}

/// The rows of a [`Table`], from [`Table::rows`].
pub struct Rows<'t, 'a> {
    file: &'t str,
    columns: &'t [String],
    reader: &'t mut csv::Reader<&'a [u8]>,
    lines: &'t mut Lines<'a>,
}

impl<'t> Iterator for Rows<'t, '_> {
    type Item = Result<Row<'t>, DataError>;

    fn next(&mut self) -> Option<Self::Item> {
        let mut record = csv::StringRecord::new();
        match self.reader.read_record(&mut record) {
            Ok(true) => {
                let line = self
                    .lines
                    .record_line(record.position().map_or(0, |p| p.byte()));
                Some(Ok(Row {
                    file: self.file,
                    columns: self.columns,
                    line,
                    record,
                }))
            }
            Ok(false) => None,
            Err(e) => Some(Err(self.lines.csv_error(self.file, self.columns, &e))),
        }
    }
}

/// One row of a [`Table`]: its fields (trimmed) and its line.
#[derive(Clone, Debug)]
pub struct Row<'t> {
    file: &'t str,
    columns: &'t [String],
    line: u64,
    record: csv::StringRecord,
}

impl Row<'_> {
    /// 1-based line of the row in the file.
    pub fn line(&self) -> u64 {
        self.line
    }

    /// The field in `column` (an index from [`Table::column`] or
    /// [`Table::require`]); empty when the row has none there.
    pub fn get(&self, column: usize) -> &str {
        self.record.get(column).unwrap_or("")
    }

    /// The field in `column` as a finite number; an error naming the file,
    /// the line and the column when it is empty, not a number or not
    /// finite.
    pub fn number(&self, column: usize) -> Result<f64, DataError> {
        let text = self.get(column);
        if text.is_empty() {
            return Err(self.error_in(column, "empty"));
        }
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error_in(column, format!("`{text}` is not a finite number"))),
            Err(_) => Err(self.error_in(column, format!("`{text}` is not a number"))),
        }
    }

    /// An error at this row's line naming `key` (a column).
    pub fn error(&self, key: &str, message: impl Into<String>) -> DataError {
        DataError::new(self.file, message)
            .with_line(self.line)
            .with_key(key)
    }

    /// An error at this row's line naming the column at index `column`.
    pub fn error_in(&self, column: usize, message: impl Into<String>) -> DataError {
        self.error(&column_name(self.columns, column), message)
    }
}

/// The name of column `index`, or `column N` (1-based) where it has none.
fn column_name(columns: &[String], index: usize) -> String {
    match columns.get(index) {
        Some(name) if !name.is_empty() => name.clone(),
        _ => format!("column {}", index + 1),
    }
}

/// The `#` comment lines of `text` as (1-based line, text after the `#`),
/// as [`Table::parse_with_comments`] skips them: lines whose first
/// character is `#` (after a byte-order mark on the first line).
pub fn comment_lines(text: &str) -> impl Iterator<Item = (u64, &str)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.lines()
        .zip(1u64..)
        .filter_map(|(line, number)| Some((number, line.strip_prefix('#')?)))
}

/// Turns the csv reader's record positions into true line numbers.
///
/// The reader places a record where the previous one ended: before the
/// empty and comment lines it skips (and, with CRLF, before the `\n`), and
/// its own line count leaves comment lines out. The true line is that of
/// the record's first byte, found by skipping those forward; lines are
/// counted incrementally, as records come in file order.
struct Lines<'a> {
    bytes: &'a [u8],
    comments: bool,
    /// Bytes counted so far.
    upto: usize,
    /// `\n` in `bytes[..upto]`.
    newlines: u64,
}

impl Lines<'_> {
    /// Line of the record the reader placed at byte `byte`.
    fn record_line(&mut self, byte: u64) -> u64 {
        let bytes = self.bytes;
        let mut at = usize::try_from(byte).unwrap_or(usize::MAX).min(bytes.len());
        if at == 0 && bytes.starts_with(BOM) {
            at = BOM.len();
        }
        loop {
            match bytes.get(at) {
                Some(b'\r' | b'\n') => at += 1,
                Some(b'#') if self.comments => {
                    let rest = bytes.get(at..).unwrap_or_default();
                    at = rest
                        .iter()
                        .position(|&b| b == b'\n')
                        .map_or(bytes.len(), |i| at + i + 1);
                }
                _ => break,
            }
        }
        if at < self.upto {
            (self.upto, self.newlines) = (0, 0);
        }
        self.newlines += count_newlines(bytes.get(self.upto..at).unwrap_or_default());
        self.upto = at;
        self.newlines + 1
    }

    /// The csv reader's error as a [`DataError`] at its record's line.
    fn csv_error(&mut self, file: &str, columns: &[String], e: &csv::Error) -> DataError {
        let mut key = None;
        let message = match e.kind() {
            csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } => format!("{len} fields, but the header has {expected_len}"),
            csv::ErrorKind::Utf8 { err, .. } => {
                if !columns.is_empty() {
                    key = Some(column_name(columns, err.field()));
                }
                "not valid UTF-8".to_owned()
            }
            _ => e.to_string(),
        };
        let mut error = DataError::new(file, message);
        if let Some(p) = e.position() {
            error = error.with_line(self.record_line(p.byte()));
        }
        if let Some(key) = key {
            error = error.with_key(key);
        }
        error
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (line, fields) of every row, or the first error.
    fn rows(table: &mut Table<'_>) -> Result<Vec<(u64, Vec<String>)>, DataError> {
        table
            .rows()
            .map(|r| {
                let r = r?;
                let fields = (0..r.record.len()).map(|i| r.get(i).to_owned()).collect();
                Ok((r.line(), fields))
            })
            .collect()
    }

    fn row(line: u64, fields: &[&str]) -> (u64, Vec<String>) {
        (line, fields.iter().map(|s| s.to_string()).collect())
    }

    #[test]
    fn rows_carry_their_true_line() {
        let text = "# a = 1\n\n# note, with a comma\nx , y\n1, 2\n\n# between\n3,4\n# end\n";
        let mut t = Table::parse_with_comments("c.csv", text.as_bytes()).unwrap();
        assert_eq!(t.columns(), ["x", "y"]);
        assert_eq!(t.header_line(), 4);
        assert_eq!(
            rows(&mut t).unwrap(),
            [row(5, &["1", "2"]), row(8, &["3", "4"])]
        );
        assert_eq!(
            comment_lines(text).collect::<Vec<_>>(),
            [
                (1, " a = 1"),
                (3, " note, with a comma"),
                (7, " between"),
                (9, " end")
            ]
        );
    }

    #[test]
    fn crlf_bom_and_quoted_line_breaks() {
        let text = "\u{feff}x,y\r\n\r\n1,\"two\r\nlines\"\r\n3,4\r\n";
        let mut t = Table::parse("s.csv", text.as_bytes()).unwrap();
        assert_eq!(
            (t.columns(), t.header_line()),
            (&["x".into(), "y".into()][..], 1)
        );
        assert_eq!(
            rows(&mut t).unwrap(),
            [row(3, &["1", "two\r\nlines"]), row(5, &["3", "4"])]
        );
        // A byte-order mark before a comment, with CRLF.
        let text = "\u{feff}# k = v\r\nx\r\n# c\r\n1\r\n";
        let mut t = Table::parse_with_comments("s.csv", text.as_bytes()).unwrap();
        assert_eq!((t.columns(), t.header_line()), (&["x".into()][..], 2));
        assert_eq!(rows(&mut t).unwrap(), [row(4, &["1"])]);
        assert_eq!(
            comment_lines(text).collect::<Vec<_>>(),
            [(1, " k = v"), (3, " c")]
        );
        // Without comments, `#` starts a row.
        let mut t = Table::parse("s.csv", b"x\n#1\n").unwrap();
        assert_eq!(rows(&mut t).unwrap(), [row(2, &["#1"])]);
    }

    #[test]
    fn csv_errors_name_their_line() {
        let text = "# c\nx,y\n# c\n1,2\n# c\n3\n";
        let mut t = Table::parse_with_comments("u.csv", text.as_bytes()).unwrap();
        let e = rows(&mut t).unwrap_err();
        assert_eq!(e.to_string(), "u.csv:6: 1 fields, but the header has 2");
        let mut t = Table::parse("u.csv", b"x,y\r\n1,2\r\n3,\xff\r\n").unwrap();
        let e = rows(&mut t).unwrap_err();
        assert_eq!(
            (e.line, e.key.as_deref(), e.message.as_str()),
            (Some(3), Some("y"), "not valid UTF-8")
        );
        let e = Table::parse("u.csv", b"\n\nx,\xff\n").err().unwrap();
        assert_eq!(e.to_string(), "u.csv:3: not valid UTF-8");
    }

    #[test]
    fn columns_and_numbers_are_named() {
        let text = "a,b\n1,x\n,inf\n";
        let mut t = Table::parse("n.csv", text.as_bytes()).unwrap();
        assert_eq!(t.require("b").unwrap(), 1);
        let e = t.require("c").unwrap_err();
        assert_eq!((e.line, e.key.as_deref()), (Some(1), Some("c")), "{e}");
        assert_eq!(e.to_string(), "n.csv:1: c: missing column (header: a, b)");
        let rows: Vec<Row<'_>> = t.rows().collect::<Result<_, _>>().unwrap();
        assert_eq!(rows[0].number(0), Ok(1.0));
        let bad = |row: &Row<'_>, col| row.number(col).unwrap_err().to_string();
        assert_eq!(bad(&rows[0], 1), "n.csv:2: b: `x` is not a number");
        assert_eq!(bad(&rows[1], 0), "n.csv:3: a: empty");
        assert_eq!(bad(&rows[1], 1), "n.csv:3: b: `inf` is not a finite number");
        assert_eq!(bad(&rows[1], 5), "n.csv:3: column 6: empty");
        let e = Table::parse("e.csv", b"")
            .unwrap()
            .require("a")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "e.csv:1: a: missing column (the file has no header)"
        );
    }
}
