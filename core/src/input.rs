//! Reading the program's input files (cases, studies) with bounds: a size limit read
//! without reading further, UTF-8 with the place of the first invalid byte, and a
//! byte-order mark accepted; and the nesting limit that every RON parser of the program
//! applies (the case and study files through `ron`, `--set` values through
//! [`crate::ron_value`]).

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// The largest case or study file read: 16 MiB (the largest shipped example is 6 KiB).
pub const MAX_INPUT_BYTES: u64 = 16 << 20;

/// The deepest nesting of brackets (`(`, `[`, `Some(`, …) in a case file, a study file or a
/// `--set` value. The deepest shipped case nests 8 levels.
pub const MAX_NESTING: usize = 128;

/// Reads a case or study file as text: at most [`MAX_INPUT_BYTES`] (more is refused, and
/// never read), UTF-8 (else the line and column of the first invalid byte), a leading
/// byte-order mark dropped.
pub fn read_text(file: &Path) -> Result<String> {
    let io = |source| Error::Io { path: file.to_path_buf(), source };
    let handle = std::fs::File::open(file).map_err(io)?;
    let too_large = |size: String| Error::File {
        file: file.to_path_buf(),
        message: format!(
            "{size}, but a case or study file is at most {} MiB ({MAX_INPUT_BYTES} bytes): is it the right \
             file? (a list of 10,000 bodies takes about 1 MiB)",
            MAX_INPUT_BYTES >> 20
        ),
    };
    if let Ok(m) = handle.metadata() {
        if m.is_dir() {
            return Err(Error::File { file: file.to_path_buf(), message: "is a directory, not a case file".into() });
        }
        if m.is_file() && m.len() > MAX_INPUT_BYTES {
            return Err(too_large(format!("the file has {} bytes", m.len())));
        }
    }
    let mut bytes = Vec::new();
    handle.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(too_large(format!("the file holds more than {MAX_INPUT_BYTES} bytes (reading stopped there)")));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let good = e.utf8_error().valid_up_to();
        let before = std::str::from_utf8(&bytes[..good]).expect("valid up to there");
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        Error::Syntax {
            file: file.to_path_buf(),
            line,
            column,
            message: format!(
                "the byte 0x{:02x} is not UTF-8 text; a case file is UTF-8: save it as UTF-8 \
                 (or is it the right file?)",
                bytes[good]
            ),
        }
    })?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// `ron`'s options for the program's input: its recursion limit at [`MAX_NESTING`].
pub fn ron_options() -> ron::Options {
    ron::Options::default().with_recursion_limit(MAX_NESTING)
}

/// Refuses RON text whose brackets nest deeper than [`MAX_NESTING`], without recursion:
/// the message gives the column (from 1) where the limit is passed.
pub fn check_nesting(text: &str) -> std::result::Result<(), String> {
    let mut depth = 0usize;
    let mut in_string = false;
    let mut escaped = false;
    for (column, c) in text.chars().enumerate() {
        if in_string {
            match c {
                _ if escaped => escaped = false,
                '\\' => escaped = true,
                '"' => in_string = false,
                _ => {}
            }
            continue;
        }
        match c {
            '"' => in_string = true,
            '(' | '[' | '{' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Err(nesting_message(column + 1));
                }
            }
            ')' | ']' | '}' => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    Ok(())
}

/// What is wrong when RON nests too deep at `column` of a `--set` value, and the fix.
pub fn nesting_message(column: usize) -> String {
    format!("at column {column}: {}", nesting_message_here())
}

/// What is wrong when RON nests too deep (the place is given with it), and the fix.
pub fn nesting_message_here() -> String {
    format!(
        "brackets nest more than {MAX_NESTING} levels deep; an entry of a case or study nests at most \
         a few levels (e.g. `Some((model: \"pcg\"))`): remove the extra brackets"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nesting_is_counted_outside_strings() {
        let deep = format!("{}1{}", "(".repeat(MAX_NESTING + 1), ")".repeat(MAX_NESTING + 1));
        assert!(check_nesting(&deep).unwrap_err().contains(&format!("column {}", MAX_NESTING + 1)));
        let ok = format!("{}1{}", "(".repeat(MAX_NESTING), ")".repeat(MAX_NESTING));
        assert!(check_nesting(&ok).is_ok());
        let quoted = format!("\"{}\"", "(".repeat(1000));
        assert!(check_nesting(&quoted).is_ok());
    }
}
