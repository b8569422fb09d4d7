//! Numeric CSV tables: the one reader behind every haptex CSV format.
//!
//! All haptex CSV files share the same shape (`docs/file-formats.md`): a
//! header row of column names, then rows of numbers; lines starting with `#`
//! are comments, blank lines are skipped, surrounding spaces are ignored.
//! Every error names the source (file path or `<stdin>`), the 1-based line
//! and, where it applies, the column.

use std::collections::HashMap;
use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// What went wrong in a table, without the location.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TableErrorKind {
    #[error("cannot read: {0}")]
    Io(String),
    #[error("no header row (the file is empty or only has comments)")]
    NoHeader,
    #[error("empty column name in the header")]
    EmptyColumnName,
    #[error("the column name has a control character (fields are separated by commas; is this a CSV file?)")]
    ControlCharacter,
    #[error("column name appears twice in the header")]
    DuplicateColumn,
    #[error("required column is missing (the header has: {present})")]
    MissingColumn { present: String },
    #[error("expected {expected} fields as in the header, found {found}")]
    FieldCount { expected: usize, found: usize },
    #[error("not a number: {text:?}{}", if text.contains([';', '\t']) { " (fields are separated by commas)" } else { "" })]
    NotANumber { text: String },
    #[error("not a finite number: {text:?}")]
    NonFinite { text: String },
    #[error("line longer than {limit} bytes (a haptex CSV line is a header or a row of numbers; is this a CSV file?)")]
    LineTooLong { limit: usize },
    #[error("expected one of {expected}, found {text:?}")]
    NotAWord { text: String, expected: String },
    #[error("{0}")]
    Invalid(String),
}

/// A column of words rather than numbers (a categorical column, such as a
/// carrier's shape): each field must be one of `words` (ASCII case is
/// ignored), and the table stores its index in `words` as the number.
#[derive(Debug, Clone, Copy)]
pub struct Category<'a> {
    pub column: &'a str,
    pub words: &'a [&'a str],
}

/// A table error with its location: source, line and column.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub struct TableError {
    /// File path, `<stdin>` or another label for where the text came from.
    pub source_name: String,
    /// 1-based line number in the source, when the error is tied to a line.
    pub line: Option<u64>,
    /// Column name, when the error is tied to a column.
    pub column: Option<String>,
    pub kind: TableErrorKind,
}

impl fmt::Display for TableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.source_name)?;
        if let Some(line) = self.line {
            write!(f, ", line {line}")?;
        }
        if let Some(column) = &self.column {
            write!(f, ", column '{column}'")?;
        }
        write!(f, ": {}", self.kind)
    }
}

/// Longest line the reader accepts, in bytes (1 MiB): far more than any
/// haptex header or row (a 500-output model matrix row is ~12 kB), and a
/// bound on the memory a file without line breaks (`/dev/zero`) can take.
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// A numeric table read from CSV, stored column by column.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    source_name: String,
    header_line: u64,
    columns: Vec<String>,
    /// Column name -> index, so lookups cost O(1) whatever the width.
    index: HashMap<String, usize>,
    data: Vec<Vec<f64>>,
    lines: Vec<u64>,
    /// The `#` comment lines before the header row, trimmed (at most
    /// [`MAX_LEADING_COMMENTS`] kept).
    comments: Vec<String>,
}

/// The most `#` lines before the header a [`Table`] keeps (where haptex's
/// own files state their conventions); later ones are skipped as before.
pub const MAX_LEADING_COMMENTS: usize = 256;
/// The most bytes of those comment lines kept, together: a line that would
/// go beyond is skipped, so a file of long comments costs no memory.
pub const MAX_LEADING_COMMENT_BYTES: usize = 64 << 10;

impl Table {
    /// Reads a table from CSV text. `source_name` labels errors.
    ///
    /// The format is deliberately plain (numbers need no quoting), so the
    /// reader is line based and its line numbers are exact: fields are split
    /// at commas, trimmed, and a pair of surrounding double quotes is removed.
    /// Time and memory are linear in the input; a line longer than
    /// [`MAX_LINE_BYTES`] is an error.
    pub fn read<R: Read>(reader: R, source_name: &str) -> Result<Self, TableError> {
        Self::read_with_categories(reader, source_name, &[])
    }

    /// [`Table::read`] with some columns holding words ([`Category`]): a
    /// word is stored as its index in the category's list, a field that is
    /// none of them is an error naming the line, the column and the words.
    pub fn read_with_categories<R: Read>(
        reader: R,
        source_name: &str,
        categories: &[Category<'_>],
    ) -> Result<Self, TableError> {
        let error = |line: Option<u64>, column: Option<String>, kind| TableError {
            source_name: source_name.to_string(),
            line,
            column,
            kind,
        };
        let mut lines = Lines {
            reader: BufReader::with_capacity(1 << 16, reader),
            buffer: Vec::new(),
            number: 0,
            comments: Some(Vec::new()),
        };
        let io_error = |(line, e): (u64, LineError)| {
            error(
                Some(line),
                None,
                match e {
                    LineError::Io(e) => TableErrorKind::Io(e.to_string()),
                    LineError::TooLong => TableErrorKind::LineTooLong { limit: MAX_LINE_BYTES },
                },
            )
        };

        let Some((header_line, header)) = lines.next_content().map_err(io_error)? else {
            // Name the line where the header was due: the end of the file
            // (line 1 of an empty one).
            return Err(error(Some(lines.number.max(1)), None, TableErrorKind::NoHeader));
        };
        let header = std::str::from_utf8(header)
            .map_err(|_| error(Some(header_line), None, TableErrorKind::Invalid("header is not UTF-8 text".into())))?;
        let mut columns: Vec<String> = Vec::new();
        let mut index: HashMap<String, usize> = HashMap::new();
        for name in header.split(',').map(unquote) {
            if name.is_empty() {
                return Err(error(Some(header_line), None, TableErrorKind::EmptyColumnName));
            }
            if name.chars().any(char::is_control) {
                return Err(error(Some(header_line), Some(column_label(name)), TableErrorKind::ControlCharacter));
            }
            if index.insert(name.to_string(), columns.len()).is_some() {
                return Err(error(Some(header_line), Some(column_label(name)), TableErrorKind::DuplicateColumn));
            }
            columns.push(name.to_string());
        }

        // Per column, the category it holds, if any.
        let coded: Vec<Option<&Category<'_>>> =
            columns.iter().map(|name| categories.iter().find(|c| c.column == name)).collect();
        // Comments after the header are skipped, not kept.
        let comments = lines.comments.take().unwrap_or_default();
        let mut data: Vec<Vec<f64>> = vec![Vec::new(); columns.len()];
        let mut row_lines = Vec::new();
        while let Some((line, row)) = lines.next_content().map_err(io_error)? {
            let mut found = 0;
            for field in row.split(|&b| b == b',') {
                if found < columns.len() {
                    let value = match coded[found] {
                        Some(category) => parse_word(field, category),
                        None => parse_number(field),
                    }
                    .map_err(|kind| error(Some(line), Some(column_label(&columns[found])), kind))?;
                    data[found].push(value);
                }
                found += 1;
            }
            if found != columns.len() {
                return Err(error(Some(line), None, TableErrorKind::FieldCount { expected: columns.len(), found }));
            }
            row_lines.push(line);
        }
        Ok(Self { source_name: source_name.to_string(), header_line, columns, index, data, lines: row_lines, comments })
    }

    /// The `#` comment lines before the header row, trimmed, in order (the
    /// first [`MAX_LEADING_COMMENTS`]).
    pub fn comments(&self) -> &[String] {
        &self.comments
    }

    /// Reads a table from a file; errors name the path.
    pub fn read_file(path: &Path) -> Result<Self, TableError> {
        let name = path.display().to_string();
        let file = File::open(path).map_err(|e| TableError {
            source_name: name.clone(),
            line: None,
            column: None,
            kind: TableErrorKind::Io(e.to_string()),
        })?;
        Self::read(file, &name)
    }

    /// Label of the source the table was read from.
    pub fn source_name(&self) -> &str {
        &self.source_name
    }

    /// Column names in file order.
    pub fn columns(&self) -> &[String] {
        &self.columns
    }

    /// Number of data rows.
    pub fn n_rows(&self) -> usize {
        self.lines.len()
    }

    /// Source line of data row `row`.
    pub fn line_of_row(&self, row: usize) -> u64 {
        self.lines[row]
    }

    /// Index of a column by name.
    pub fn column_index(&self, name: &str) -> Option<usize> {
        self.index.get(name).copied()
    }

    /// A column's values, or `None` if the header lacks it.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.column_index(name).map(|i| self.data[i].as_slice())
    }

    /// Column values by index.
    pub fn column_at(&self, index: usize) -> &[f64] {
        &self.data[index]
    }

    /// A column's values, or a "missing column" error naming the header line.
    pub fn require(&self, name: &str) -> Result<&[f64], TableError> {
        self.column(name).ok_or_else(|| self.missing(name))
    }

    /// The "required column is missing" error for `what` (a column name, or
    /// a description such as `mu (or ft_n and fn_n)`), at the header line.
    pub fn missing(&self, what: &str) -> TableError {
        TableError {
            source_name: self.source_name.clone(),
            line: Some(self.header_line),
            column: Some(column_label(what)),
            kind: TableErrorKind::MissingColumn { present: self.header_summary() },
        }
    }

    /// The header's column names for a message: all of them if there are
    /// few, else the first ten and the count.
    pub fn header_summary(&self) -> String {
        const SHOWN: usize = 10;
        let names: Vec<String> = self.columns.iter().take(SHOWN).map(|c| quote(c)).collect();
        if self.columns.len() > SHOWN {
            format!("{},... ({} columns)", names.join(","), self.columns.len())
        } else {
            names.join(",")
        }
    }

    /// Takes the column data out of the table (column order as in `columns`).
    pub fn into_columns(self) -> Vec<Vec<f64>> {
        self.data
    }

    /// An error located at data row `row` (and optionally a column); rows past
    /// the end (e.g. "too few rows") are reported at the header line.
    pub fn error_at(&self, row: Option<usize>, column: Option<&str>, message: impl Into<String>) -> TableError {
        TableError {
            source_name: self.source_name.clone(),
            line: Some(row.and_then(|r| self.lines.get(r).copied()).unwrap_or(self.header_line)),
            column: column.map(column_label),
            kind: TableErrorKind::Invalid(message.into()),
        }
    }
}

/// A content line with its 1-based number, or an error with the line it hit.
type NumberedLine<'a> = Result<Option<(u64, &'a [u8])>, (u64, LineError)>;

/// Why a line could not be read.
enum LineError {
    Io(std::io::Error),
    TooLong,
}

/// Reads lines, counting them, and yields only the content lines (not
/// blank, not `#` comments), without the line terminator.
struct Lines<R> {
    reader: BufReader<R>,
    buffer: Vec<u8>,
    number: u64,
    /// While `Some`, the comment lines met are kept here (trimmed, lossy
    /// UTF-8, at most [`MAX_LEADING_COMMENTS`] lines and
    /// [`MAX_LEADING_COMMENT_BYTES`] bytes).
    comments: Option<Vec<String>>,
}

impl<R: Read> Lines<R> {
    /// The next content line and its number; an I/O error comes with the
    /// line it hit.
    fn next_content(&mut self) -> NumberedLine<'_> {
        const BOM: &[u8] = "\u{feff}".as_bytes();
        loop {
            self.buffer.clear();
            let read = self.read_line().map_err(|e| (self.number + 1, e))?;
            if read == 0 {
                return Ok(None);
            }
            self.number += 1;
            let skip = if self.number == 1 && self.buffer.starts_with(BOM) { BOM.len() } else { 0 };
            let line = self.buffer[skip..].trim_ascii();
            if line.starts_with(b"#")
                && let Some(kept) = &mut self.comments
                && kept.len() < MAX_LEADING_COMMENTS
                && kept.iter().map(String::len).sum::<usize>() + line.len() <= MAX_LEADING_COMMENT_BYTES
            {
                kept.push(String::from_utf8_lossy(line).into_owned());
            }
            if !(line.is_empty() || line.starts_with(b"#")) {
                let start = skip + self.buffer[skip..].len() - self.buffer[skip..].trim_ascii_start().len();
                return Ok(Some((self.number, &self.buffer[start..start + line.len()])));
            }
        }
    }
}

impl<R: Read> Lines<R> {
    /// Reads up to and including the next `\n` into the buffer (like
    /// `read_until`), but refuses a line longer than [`MAX_LINE_BYTES`]
    /// before it is held in memory. Returns the bytes read (0 at the end).
    fn read_line(&mut self) -> Result<usize, LineError> {
        let mut read = 0;
        loop {
            let available = match self.reader.fill_buf() {
                Ok(bytes) => bytes,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(LineError::Io(e)),
            };
            if available.is_empty() {
                return Ok(read);
            }
            let (take, done) = match available.iter().position(|&b| b == b'\n') {
                Some(i) => (i + 1, true),
                None => (available.len(), false),
            };
            if self.buffer.len() + take > MAX_LINE_BYTES + 2 {
                return Err(LineError::TooLong);
            }
            self.buffer.extend_from_slice(&available[..take]);
            self.reader.consume(take);
            read += take;
            if done {
                return Ok(read);
            }
        }
    }
}

fn unquote(field: &str) -> &str {
    let field = field.trim();
    field.strip_prefix('"').and_then(|f| f.strip_suffix('"')).unwrap_or(field).trim()
}

fn parse_number(field: &[u8]) -> Result<f64, TableErrorKind> {
    let text = std::str::from_utf8(field)
        .map_err(|_| TableErrorKind::NotANumber { text: quote(&String::from_utf8_lossy(field)) })?;
    let text = unquote(text);
    if text.is_empty() {
        return Err(TableErrorKind::NotANumber { text: String::new() });
    }
    let value: f64 = text.parse().map_err(|_| TableErrorKind::NotANumber { text: quote(text) })?;
    if value.is_finite() { Ok(value) } else { Err(TableErrorKind::NonFinite { text: quote(text) }) }
}

fn parse_word(field: &[u8], category: &Category<'_>) -> Result<f64, TableErrorKind> {
    let text = unquote(std::str::from_utf8(field).unwrap_or(""));
    category.words.iter().position(|w| w.eq_ignore_ascii_case(text)).map(|i| i as f64).ok_or_else(|| {
        TableErrorKind::NotAWord { text: quote(&String::from_utf8_lossy(field)), expected: category.words.join(", ") }
    })
}

/// A column name as an error names it: whole if short, else its first 40
/// characters and its length (an error never carries a megabyte), with
/// control characters escaped.
fn column_label(name: &str) -> String {
    const KEEP: usize = 40;
    let mut label = String::new();
    for c in name.chars() {
        if label.len() >= KEEP {
            return format!("{label}... ({} bytes)", name.len());
        }
        label.extend(c.escape_debug());
    }
    label
}

/// A field as quoted in an error: whole if short, else its first 40
/// characters and how long it was (a message never carries a megabyte).
fn quote(text: &str) -> String {
    const KEEP: usize = 40;
    match text.char_indices().nth(KEEP) {
        None => text.to_string(),
        Some((end, _)) => format!("{}... ({} bytes)", &text[..end], text.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Table, TableError> {
        Table::read(text.as_bytes(), "t.csv")
    }

    /// The `#` lines before the header are kept, trimmed and in order (at
    /// most MAX_LEADING_COMMENTS); comments after it are not.
    #[test]
    fn keeps_the_comments_before_the_header() {
        let t = read("\u{feff}# one\n\n  # two  \nx_mm\n# after\n1\n").unwrap();
        assert_eq!(t.comments(), ["# one", "# two"]);
        let many: String = (0..MAX_LEADING_COMMENTS + 10).map(|i| format!("# c{i}\n")).collect::<String>() + "x\n1\n";
        let t = read(&many).unwrap();
        assert_eq!(t.comments().len(), MAX_LEADING_COMMENTS);
        assert_eq!(t.comments()[0], "# c0");
        assert!(read("x\n1\n").unwrap().comments().is_empty());
        // A comment that would pass the byte bound is skipped, the next
        // short one kept.
        let long = format!("# {}\n# short\nx\n1\n", "a".repeat(MAX_LEADING_COMMENT_BYTES));
        assert_eq!(read(&long).unwrap().comments(), ["# short"]);
    }

    #[test]
    fn a_category_column_holds_the_index_of_its_word() {
        let carrier = Category { column: "carrier", words: &["sine", "square", "none"] };
        let t =
            Table::read_with_categories("v,carrier\n1, Square\n2,\"none\"\n3,sine\n".as_bytes(), "m.csv", &[carrier])
                .unwrap();
        assert_eq!(t.column("carrier").unwrap(), [1.0, 2.0, 0.0]);
        let e =
            Table::read_with_categories("v,carrier\n1,sine\n2,triangle\n".as_bytes(), "m.csv", &[carrier]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "m.csv, line 3, column 'carrier': expected one of sine, square, none, found \"triangle\""
        );
        // Without the category the same file is a number error.
        assert!(matches!(read("v,carrier\n1,sine\n").unwrap_err().kind, TableErrorKind::NotANumber { .. }));
    }

    #[test]
    fn reads_columns_comments_and_line_numbers() {
        let t = read("# a comment\nx_mm, mu\n0,0.5\n\n# mid comment\n1.5 ,0.6\n").unwrap();
        assert_eq!(t.columns(), ["x_mm", "mu"]);
        assert_eq!(t.column("x_mm").unwrap(), [0.0, 1.5]);
        assert_eq!(t.column("mu").unwrap(), [0.5, 0.6]);
        assert_eq!(t.line_of_row(0), 3);
        assert_eq!(t.line_of_row(1), 6);
    }

    #[test]
    fn line_numbers_count_blank_comment_and_crlf_lines() {
        let t = read("\u{feff}#c\r\nx,y\r\n1,2\r\n\r\n#c\r\n3,\"4\"\r\n").unwrap();
        assert_eq!(t.columns(), ["x", "y"]);
        assert_eq!(t.column("y").unwrap(), [2.0, 4.0]);
        assert_eq!((t.line_of_row(0), t.line_of_row(1)), (3, 6));
    }

    /// A file without line breaks (`/dev/zero`) is refused once a line
    /// passes the limit, not read until memory runs out.
    #[test]
    fn endless_line_is_refused_at_the_limit() {
        let endless = std::io::repeat(b'0');
        let e = Table::read(endless, "zero").unwrap_err();
        assert_eq!(e.kind, TableErrorKind::LineTooLong { limit: MAX_LINE_BYTES });
        assert_eq!(e.line, Some(1));
        let long_row = format!("x,y\n1,{}\n", "2".repeat(MAX_LINE_BYTES));
        let e = read(&long_row).unwrap_err();
        assert_eq!((e.line, e.kind), (Some(2), TableErrorKind::LineTooLong { limit: MAX_LINE_BYTES }));
        // A line just under the limit is fine.
        let ok = format!("x\n0.{}\n", "1".repeat(MAX_LINE_BYTES - 10));
        assert_eq!(read(&ok).unwrap().n_rows(), 1);
    }

    /// A column name is named short and printable in errors, whatever the
    /// header holds; a name with a control character is refused.
    #[test]
    fn column_names_in_errors_are_short_and_printable() {
        let long = "c".repeat(5000);
        let e = read(&format!("{long}\nx\n")).unwrap_err();
        let column = e.column.clone().unwrap();
        assert!(column.len() < 80 && column.ends_with("(5000 bytes)"), "{column}");
        assert!(e.to_string().len() < 200, "{e}");
        let e = read(&format!("x,{}#\n1,2\n", "\0".repeat(1000))).unwrap_err();
        assert_eq!(e.kind, TableErrorKind::ControlCharacter, "{e}");
        assert!(e.column.as_deref().unwrap().ends_with("(1001 bytes)"), "{e}");
        assert!(e.to_string().len() < 200 && !e.to_string().contains('\0'), "{e}");
        let e = read("x\tmu\n1\t2\n").unwrap_err();
        assert!(e.to_string().contains("separated by commas"), "{e}");
    }

    #[test]
    fn long_fields_are_quoted_short() {
        let e = read(&format!("x\n{}\n", "9".repeat(400))).unwrap_err();
        assert!(matches!(&e.kind, TableErrorKind::NonFinite { text } if text.len() < 80), "{e}");
        let e = read(&format!("x\n{}\n", "é".repeat(400))).unwrap_err();
        assert!(e.to_string().contains("(800 bytes)"), "{e}");
    }

    #[test]
    fn error_display_names_source_line_and_column() {
        let e = read("x_mm,mu\n0,0.5\n1,abc\n").unwrap_err();
        assert_eq!(e.to_string(), "t.csv, line 3, column 'mu': not a number: \"abc\"");
    }
}
