//! The one rule for names that become file names.
//!
//! Every string a user gives that haptex may ever use as a component of a
//! path (a material, whose strokes a library export writes under
//! `DIR/MATERIAL/`; a recipe's download file; a recording's stem and its
//! streams' names; the members an FE database's `metadata.json` or an
//! export's manifest lists; the files of an upload) is checked against
//! [`check_name`] where it enters: the command-line flag, the recording's
//! metadata, the recipe, the HTTP body, and again where it is read back
//! from a library or database file someone else may have written. The
//! multi-file writers check the names of what they write with it too
//! ([`crate::io::OutputDir`]).
//!
//! A name is accepted when it is
//!
//! - not empty, and at most [`MAX_NAME_CHARS`] characters and
//!   [`MAX_NAME_BYTES`] bytes of UTF-8 (room for a suffix such as
//!   `.recording.json` within the 255 bytes file systems allow);
//! - not `.` or `..` (the directory itself and its parent), and does not
//!   begin with `.` (a hidden file, and haptex's own temporary files begin
//!   with `.haptex-`);
//! - does not begin with `-` (a command-line tool given the file, `ls` or
//!   `sha256sum -c` on a manifest, would read it as an option);
//! - neither begins nor ends with white space (invisible, and lost by
//!   shells and by Windows, which drops trailing spaces);
//! - free of `/` and `\` (path separators on Unix and Windows) and `:`
//!   (a drive or a stream on Windows: `C:x` joined to a directory there
//!   names another place);
//! - free of every character of Unicode's general category *Other* (C):
//!   control characters (Cc: NUL, ESC, DEL, ...), format characters (Cf:
//!   the right-to-left override U+202E, zero-width spaces and joiners
//!   U+200B-U+200F, U+2060-U+2064, the byte-order mark U+FEFF, the soft
//!   hyphen U+00AD, ...: invisible, they make names that look like others),
//!   private-use characters (Co: drawn differently by every font),
//!   surrogates (Cs) and unassigned code points (Cn); and of the line and
//!   paragraph separators U+2028 and U+2029 (Zl, Zp). The categories come
//!   from the Unicode Character Database through the `unicode-properties`
//!   crate (Unicode 18), not from a list kept here.
//!
//! Spaces inside a name, letters and digits of any script, punctuation and
//! symbols (`my bump`, `Baumwolle-Köper`, `P24 (sandpaper)`) are accepted.
//! Names are not normalized: `é` and `e` + U+0301 are two names.

use std::fmt;

use unicode_properties::{GeneralCategory, GeneralCategoryGroup, UnicodeGeneralCategory};

use crate::text::Quoted;

/// Most characters of a name.
pub const MAX_NAME_CHARS: usize = 100;
/// Most bytes (UTF-8) of a name.
pub const MAX_NAME_BYTES: usize = 200;

/// A name breaks the rule of [`check_name`]; `Display` quotes the name
/// ([`Quoted`]) and says why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{} is not accepted as a name: {problem}", Quoted(name))]
pub struct NameError {
    pub name: String,
    pub problem: NameProblem,
}

/// What is wrong with a name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NameProblem {
    Empty,
    /// Only white space.
    Blank,
    TooLong {
        chars: usize,
        bytes: usize,
    },
    /// `.` or `..`.
    DotName,
    /// A relative path ([`check_relative_path`]) that begins with `/`.
    Absolute,
    LeadingDot,
    LeadingDash,
    /// White space at the start or the end.
    EdgeWhiteSpace,
    /// `/`, `\` or `:`.
    Separator(char),
    /// A character of category Other (C) or a line or paragraph separator.
    Forbidden(char, GeneralCategory),
}

impl fmt::Display for NameProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Empty => write!(f, "it is empty"),
            Self::Blank => write!(f, "it is only white space"),
            Self::TooLong { chars, bytes } => write!(
                f,
                "{chars} characters ({bytes} bytes), more than the {MAX_NAME_CHARS} characters and \
                 {MAX_NAME_BYTES} bytes a name may have"
            ),
            Self::DotName => write!(f, "'.' and '..' name a directory itself and its parent"),
            Self::Absolute => write!(f, "it is an absolute path"),
            Self::LeadingDot => write!(f, "it begins with '.' (a hidden file; haptex's temporary files begin so)"),
            Self::LeadingDash => write!(f, "it begins with '-' (command-line tools would read it as an option)"),
            Self::EdgeWhiteSpace => write!(f, "it begins or ends with white space"),
            Self::Separator(c) => write!(f, "it holds {c:?}, a path separator (or a drive on Windows)"),
            Self::Forbidden(c, category) => {
                let what = match category {
                    GeneralCategory::Control => "a control character (Unicode category Cc)",
                    GeneralCategory::Format => "an invisible format character (Unicode category Cf)",
                    GeneralCategory::PrivateUse => "a private-use character (Unicode category Co)",
                    GeneralCategory::Surrogate => "a surrogate (Unicode category Cs)",
                    GeneralCategory::Unassigned => "an unassigned code point (Unicode category Cn)",
                    GeneralCategory::LineSeparator => "a line separator (Unicode category Zl)",
                    GeneralCategory::ParagraphSeparator => "a paragraph separator (Unicode category Zp)",
                    _ => "a character names may not hold",
                };
                write!(f, "it holds U+{:04X}, {what}", u32::from(*c))
            }
        }
    }
}

/// The problem of a character a name may not hold anywhere.
fn forbidden(c: char) -> Option<NameProblem> {
    if matches!(c, '/' | '\\' | ':') {
        return Some(NameProblem::Separator(c));
    }
    invisible_category(c).map(|category| NameProblem::Forbidden(c, category))
}

/// The category of a character of Unicode's category Other (C: control,
/// format, surrogate, private use, unassigned) or a line or paragraph
/// separator: what a name may not hold, and what a message escapes.
fn invisible_category(c: char) -> Option<GeneralCategory> {
    // ASCII is decided without the table: only its controls are category C.
    if c.is_ascii() {
        return c.is_ascii_control().then_some(GeneralCategory::Control);
    }
    let category = c.general_category();
    let refused = c.general_category_group() == GeneralCategoryGroup::Other
        || matches!(category, GeneralCategory::LineSeparator | GeneralCategory::ParagraphSeparator);
    refused.then_some(category)
}

/// Whether `c` is a character no name may hold because it is not drawn
/// (or drawn differently by every font): a control, format, private-use,
/// surrogate or unassigned character, a line or paragraph separator. Text
/// shown to a person escapes these (the server's error messages).
pub fn is_invisible(c: char) -> bool {
    invisible_category(c).is_some()
}

/// Checks `name` against the rule of the module documentation. Linear in
/// the name's length.
pub fn check_name(name: &str) -> Result<(), NameError> {
    problem(name).map_or(Ok(()), |problem| Err(NameError { name: name.to_string(), problem }))
}

/// Whether `name` passes [`check_name`].
pub fn is_valid_name(name: &str) -> bool {
    problem(name).is_none()
}

fn problem(name: &str) -> Option<NameProblem> {
    if name.is_empty() {
        return Some(NameProblem::Empty);
    }
    // Characters first: a name of NUL bytes is reported by its NUL, not
    // by its length.
    if let Some(p) = name.chars().find_map(forbidden) {
        return Some(p);
    }
    let chars = name.chars().count();
    if chars > MAX_NAME_CHARS || name.len() > MAX_NAME_BYTES {
        return Some(NameProblem::TooLong { chars, bytes: name.len() });
    }
    if name.trim().is_empty() {
        return Some(NameProblem::Blank);
    }
    if name == "." || name == ".." {
        return Some(NameProblem::DotName);
    }
    if name.starts_with('.') {
        return Some(NameProblem::LeadingDot);
    }
    if name.starts_with('-') {
        return Some(NameProblem::LeadingDash);
    }
    if name.trim() != name {
        return Some(NameProblem::EdgeWhiteSpace);
    }
    None
}

/// Checks a relative path `a/b/c` (components separated by `/`, as in an
/// archive, a manifest or a metadata file): every component is a name
/// ([`check_name`]); so it is neither absolute nor leaves its directory.
/// At most [`MAX_PATH_COMPONENTS`] components.
pub fn check_relative_path(path: &str) -> Result<(), NameError> {
    if path.starts_with('/') {
        return Err(NameError { name: path.to_string(), problem: NameProblem::Absolute });
    }
    let mut count = 0;
    for component in path.split('/') {
        count += 1;
        if count > MAX_PATH_COMPONENTS {
            return Err(NameError {
                name: path.to_string(),
                problem: NameProblem::TooLong { chars: path.chars().count(), bytes: path.len() },
            });
        }
        check_name(component).map_err(|e| NameError { name: path.to_string(), ..e })?;
    }
    Ok(())
}

/// Most components of a relative path ([`check_relative_path`]).
pub const MAX_PATH_COMPONENTS: usize = 16;

/// Names every entry point must refuse, one of each kind the rule names:
/// the examples the tests walk every writer with (with a name of 5000
/// characters and one of NUL bytes they add), and the fuzz target's seeds.
pub const HOSTILE_NAMES: &[&str] = &[
    "..",
    ".",
    "a/../../b",
    "../x",
    "/abs",
    "\\",
    "a\\..\\b",
    "c:x",
    "nul\0byte",
    "rtl\u{202e}vsc.csv",
    "zero\u{200b}width",
    "bom\u{feff}",
    "soft\u{ad}hyphen",
    "word\u{2060}joiner",
    "esc\u{1b}[31m",
    "del\u{7f}",
    "next\u{85}line",
    "line\u{2028}separator",
    "private\u{e000}use",
    "",
    " ",
    "   ",
    "\t",
    " leading",
    "trailing ",
    ".hidden",
    "-rf",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordinary_names_pass() {
        for good in ["velvet", "my bump", "paper-160gsm", "P24 (sandpaper)", "Baumwolle-Köper", "木", "a.b", "x-", "é"]
        {
            check_name(good).unwrap();
        }
        check_name(&"x".repeat(MAX_NAME_CHARS)).unwrap();
    }

    #[test]
    fn each_problem_is_named() {
        let cases: [(&str, NameProblem); 14] = [
            ("", NameProblem::Empty),
            ("   ", NameProblem::Blank),
            (".", NameProblem::DotName),
            ("..", NameProblem::DotName),
            (".hidden", NameProblem::LeadingDot),
            ("-rf", NameProblem::LeadingDash),
            (" velvet", NameProblem::EdgeWhiteSpace),
            ("velvet\u{a0}", NameProblem::EdgeWhiteSpace),
            ("a/b", NameProblem::Separator('/')),
            ("a\\b", NameProblem::Separator('\\')),
            ("c:x", NameProblem::Separator(':')),
            ("a\0b", NameProblem::Forbidden('\0', GeneralCategory::Control)),
            ("evil\u{202e}gpj", NameProblem::Forbidden('\u{202e}', GeneralCategory::Format)),
            ("a\u{2028}b", NameProblem::Forbidden('\u{2028}', GeneralCategory::LineSeparator)),
        ];
        for (name, problem) in cases {
            assert_eq!(check_name(name).unwrap_err().problem, problem, "{name:?}");
        }
        // 100 characters but 200 bytes: accepted; one more of either is not.
        check_name(&"é".repeat(MAX_NAME_CHARS)).unwrap();
        let long = "é".repeat(MAX_NAME_CHARS + 1);
        assert_eq!(check_name(&long).unwrap_err().problem, NameProblem::TooLong { chars: 101, bytes: 202 });
    }

    #[test]
    fn the_message_quotes_the_name_and_says_why() {
        let e = check_name("a\u{202e}b").unwrap_err().to_string();
        assert_eq!(
            e,
            "\"a\\u{202e}b\" is not accepted as a name: it holds U+202E, an invisible format character \
                       (Unicode category Cf)"
        );
        let e = check_name(&"\0".repeat(100_000)).unwrap_err().to_string();
        assert!(e.len() < 300 && e.contains("(100000 bytes)") && e.contains("control character"), "{e}");
    }

    #[test]
    fn relative_paths_check_every_component() {
        check_relative_path("velvet/stroke-1.csv").unwrap();
        for bad in ["", "/abs", "a//b", "a/", "a/../b", "./a", "a/.", "a\\b/c", "a/\u{200b}"] {
            assert!(check_relative_path(bad).is_err(), "{bad:?}");
        }
        assert!(check_relative_path(&vec!["a"; MAX_PATH_COMPONENTS + 1].join("/")).is_err());
        let e = check_relative_path("a/../b").unwrap_err();
        assert_eq!((e.name.as_str(), e.problem), ("a/../b", NameProblem::DotName));
    }
}
