//! User text in messages.
//!
//! An error that quotes what the user gave (a column name, a file name, a
//! material, a metadata field) must stay short and printable whatever the
//! input: a megabyte-long name or one full of NUL bytes is quoted by its
//! first characters, escaped, with its length. [`Quoted`] does that.

use std::fmt;

/// Characters of a quoted text shown before it is cut.
const SHOWN: usize = 40;

/// Displays text in double quotes with control characters, quotes and
/// backslashes escaped (as Rust's `{:?}` does), cut after 40 characters
/// with its length in bytes: `"abc"`, `"aaaa...aaa"... (5000 bytes)`.
#[derive(Debug, Clone, Copy)]
pub struct Quoted<'a>(pub &'a str);

impl fmt::Display for Quoted<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        QuotedUpTo(self.0, SHOWN).fmt(f)
    }
}

/// [`Quoted`] cut after the given number of characters instead of 40
/// (a listing that shows names whole up to the longest a name may be).
#[derive(Debug, Clone, Copy)]
pub struct QuotedUpTo<'a>(pub &'a str, pub usize);

impl fmt::Display for QuotedUpTo<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Self(text, shown) = *self;
        match text.char_indices().nth(shown) {
            None => write!(f, "{text:?}"),
            Some((end, _)) => write!(f, "{:?}... ({} bytes)", &text[..end], text.len()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_printable_and_cut() {
        assert_eq!(Quoted("velvet").to_string(), "\"velvet\"");
        assert_eq!(Quoted("a\0b\n").to_string(), "\"a\\0b\\n\"");
        let long = "x".repeat(100_000);
        let shown = Quoted(&long).to_string();
        assert!(shown.len() < 70 && shown.ends_with("... (100000 bytes)"), "{shown}");
        let wide = "é".repeat(50);
        assert!(Quoted(&wide).to_string().ends_with("(100 bytes)"));
        assert_eq!(QuotedUpTo(&wide, 50).to_string(), format!("\"{wide}\""));
        // Format characters (U+202E, U+200B) are escaped as control characters are.
        assert_eq!(Quoted("a\u{202e}b\u{200b}").to_string(), "\"a\\u{202e}b\\u{200b}\"");
    }
}
