//! The project's data files, read and written one way.
//!
//! - [`DataError`]: the error of every data file, naming the file, the
//!   1-based line where there is one, and the TOML dotted key or CSV column.
//! - [`Table`]: a CSV table with a header, its fields trimmed, CRLF line ends
//!   and a UTF-8 byte-order mark accepted, optionally with `#` comment lines,
//!   each row carrying its true line in the file.
//! - [`TomlDoc`]: a TOML document that can name the line of any key.
//! - [`write_atomic`]: result files written whole or not at all.

mod atomic;
mod error;
mod table;
mod toml_doc;

pub use atomic::write_atomic;
pub use error::{decode_utf8, DataError};
pub use table::{comment_lines, Row, Rows, Table};
pub use toml_doc::TomlDoc;
