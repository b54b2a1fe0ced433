//! TOML documents whose errors name the line of the key at fault.

use toml::de::{DeTable, DeValue};
use toml::Spanned;

use crate::error::{count_newlines, DataError};

/// A parsed TOML document: its values, and where each key sits in the text.
pub struct TomlDoc<'a> {
    file: String,
    text: &'a str,
    values: toml::Table,
    spans: DeTable<'a>,
}

impl<'a> TomlDoc<'a> {
    /// Parses `text`; `file` names it in errors. A syntax error is a
    /// [`DataError`] at its line, the column in the message.
    pub fn parse(file: impl Into<String>, text: &'a str) -> Result<TomlDoc<'a>, DataError> {
        let file = file.into();
        let syntax = |e: toml::de::Error| {
            let mut error = DataError::new(&file, e.message().trim_end());
            if let Some(span) = e.span() {
                let before = text.as_bytes().get(..span.start).unwrap_or_default();
                let line_start = before
                    .iter()
                    .rposition(|&b| b == b'\n')
                    .map_or(0, |i| i + 1);
                let column = text
                    .get(line_start..span.start)
                    .map_or(0, |s| s.chars().count())
                    + 1;
                error.message = format!("{} (column {column})", error.message);
                error = error.with_line(count_newlines(before) + 1);
            }
            error
        };
        let values: toml::Table = text.parse().map_err(syntax)?;
        let spans = DeTable::parse(text).map_err(syntax)?.into_inner();
        Ok(TomlDoc {
            file,
            text,
            values,
            spans,
        })
    }

    /// The file as given to the reader.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The document's values.
    pub fn values(&self) -> &toml::Table {
        &self.values
    }

    /// 1-based line of the key at `path` (`["section", "key"]` for
    /// `section.key`, whether written as a `[section]` header or dotted),
    /// or `None` where there is no such key.
    pub fn line(&self, path: &[&str]) -> Option<u64> {
        let (first, rest) = path.split_first()?;
        let (mut start, mut value) = find(&self.spans, first)?;
        for name in rest {
            let DeValue::Table(table) = value.get_ref() else {
                return None;
            };
            (start, value) = find(table, name)?;
        }
        let before = self.text.as_bytes().get(..start).unwrap_or_default();
        Some(count_newlines(before) + 1)
    }

    /// An error naming the dotted key `path`, at its line where it is in
    /// the document.
    pub fn error(&self, path: &[&str], message: impl Into<String>) -> DataError {
        let error = DataError::new(&self.file, message).with_key(path.join("."));
        match self.line(path) {
            Some(line) => error.with_line(line),
            None => error,
        }
    }
}

/// Where key `name` of `table` starts, and its value.
fn find<'t, 'a>(table: &'t DeTable<'a>, name: &str) -> Option<(usize, &'t Spanned<DeValue<'a>>)> {
    table
        .iter()
        .find(|(k, _)| k.get_ref() == name)
        .map(|(k, v)| (k.span().start, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_found_on_their_line() {
        let text = "top = 1\n\n[a]\nx = 2\nb.y = 3\n\n[c.d]\nz = \"s\"\n";
        let doc = TomlDoc::parse("t.toml", text).unwrap();
        assert_eq!(doc.values()["a"]["x"].as_integer(), Some(2));
        assert_eq!(doc.line(&["top"]), Some(1));
        assert_eq!(doc.line(&["a"]), Some(3));
        assert_eq!(doc.line(&["a", "x"]), Some(4));
        assert_eq!(doc.line(&["a", "b", "y"]), Some(5));
        assert_eq!(doc.line(&["c", "d", "z"]), Some(8));
        assert_eq!(doc.line(&["a", "w"]), None);
        assert_eq!(doc.line(&["top", "w"]), None);
        let e = doc.error(&["c", "d", "z"], "expected a number");
        assert_eq!(e.to_string(), "t.toml:8: c.d.z: expected a number");
        let e = doc.error(&["a", "w"], "missing key");
        assert_eq!(e.to_string(), "t.toml: a.w: missing key");
    }

    #[test]
    fn syntax_errors_name_line_and_column() {
        let e = TomlDoc::parse("t.toml", "a = 1\n\n[b\nc = 2\n")
            .err()
            .unwrap();
        assert_eq!((e.line, e.key.as_deref()), (Some(3), None), "{e}");
        assert!(e.message.contains("(column "), "{e}");
        let e = TomlDoc::parse("t.toml", "a = 1\na = 2\n").err().unwrap();
        assert_eq!(e.line, Some(2), "{e}");
    }
}
