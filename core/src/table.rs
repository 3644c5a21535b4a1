//! The CSV tables runs write and analyses read (`diagnostics.csv`, `bodies.csv`, a study's
//! `results.csv`), through the `csv` crate: one reader and one writer setup for all of
//! them. Fields are quoted only where they must be (a body named `a,b` is written
//! `"a,b"`), rows end in `\n`.

use crate::error::{Error, Result};
use crate::math::Real;
use std::io::Write;
use std::path::Path;

/// A CSV table: its header and its complete rows, as text.
#[derive(Clone, Debug)]
pub struct Table {
    /// The column names.
    pub header: Vec<String>,
    /// The rows with as many fields as the header.
    pub rows: Vec<csv::StringRecord>,
}

impl Table {
    /// The table at `path`; `None` when the file does not exist.
    pub fn read(path: &Path) -> Result<Option<Table>> {
        match std::fs::read_to_string(path) {
            Ok(text) => Table::parse(&text, path).map(Some),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(source) => Err(Error::Io { path: path.to_path_buf(), source }),
        }
    }

    /// The table in `text` (read from `path`, for the messages). Only complete rows count:
    /// a last row without its line end (a run killed while writing it) is left out, and so
    /// is a row with another number of fields than the header. Blank lines are skipped;
    /// fields are trimmed.
    pub fn parse(text: &str, path: &Path) -> Result<Table> {
        let complete = text.rfind('\n').map_or("", |end| &text[..=end]);
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(complete.as_bytes());
        let bad = |e: csv::Error| Error::Model(format!("{}: not a CSV table: {e}", path.display()));
        let header: Vec<String> = reader.headers().map_err(bad)?.iter().map(str::to_string).collect();
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(bad)?;
            if record.len() == header.len() {
                rows.push(record);
            }
        }
        Ok(Table { header, rows })
    }

    /// The index of column `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Column `name` as numbers (NaN where a cell is not one); `None` without that column.
    pub fn numbers(&self, name: &str) -> Option<Vec<Real>> {
        let k = self.index(name)?;
        Some(self.rows.iter().map(|r| r[k].parse().unwrap_or(Real::NAN)).collect())
    }

    /// The line of the file row `row` starts on (1 for the header).
    pub fn line(&self, row: usize) -> u64 {
        self.rows[row].position().map_or(0, |p| p.line())
    }
}

/// A CSV writer on `out`: rows end in `\n`, fields are quoted only where needed.
pub fn writer<W: Write>(out: W) -> csv::Writer<W> {
    csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).has_headers(false).from_writer(out)
}

/// The text of `rows` (after `header`) as CSV.
pub fn to_text<S: AsRef<[u8]>>(header: &[S], rows: impl IntoIterator<Item = Vec<String>>) -> Result<Vec<u8>> {
    let mut w = writer(Vec::new());
    let fail = |e: csv::Error| Error::Model(format!("CSV: {e}"));
    w.write_record(header).map_err(fail)?;
    for r in rows {
        w.write_record(&r).map_err(fail)?;
    }
    w.into_inner().map_err(|e| Error::Model(format!("CSV: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quoted name with a comma stays one field; a row cut short by a killed run (no line
    /// end) and a row with another count of fields are left out; what is written reads back.
    #[test]
    fn tables_read_what_they_write_and_only_complete_rows() {
        let rows = vec![
            vec!["1".to_string(), "0.5".into(), "disk, upper".into(), "".into()],
            vec!["2".to_string(), "1e-16".into(), "say \"lower\"".into(), "3".into()],
        ];
        let text = String::from_utf8(to_text(&["step", "time", "body", "fx"], rows.clone()).unwrap()).unwrap();
        assert_eq!(text, "step,time,body,fx\n1,0.5,\"disk, upper\",\n2,1e-16,\"say \"\"lower\"\"\",3\n");
        let t = Table::parse(&format!("{text}7,0.1\n\n3,1.5,cut",), Path::new("x.csv")).unwrap();
        assert_eq!(t.header, ["step", "time", "body", "fx"]);
        let read: Vec<Vec<String>> = t.rows.iter().map(|r| r.iter().map(str::to_string).collect()).collect();
        assert_eq!(read, rows);
        assert_eq!(t.numbers("time").unwrap(), [0.5, 1e-16]);
        assert!(t.numbers("fx").unwrap()[0].is_nan() && t.numbers("nope").is_none());
        assert_eq!((t.line(0), t.line(1)), (2, 3));
    }
}
