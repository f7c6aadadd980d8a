//! The JSBSim reference tables in `scenarios/jsbsim/` (written by `python/jsbsim_reference.py`): `#`
//! header lines, then a CSV header row with the unit in each column name, then numbers.

use std::path::{Path, PathBuf};

use super::{InputError, Source};

/// One reference run: header comments and named numeric columns.
#[derive(Debug, Clone)]
pub struct ReferenceRun {
    /// The file read.
    pub path: PathBuf,
    /// The `#` comment lines, trimmed, without the `#`.
    pub comments: Vec<String>,
    /// Column names, in file order.
    pub columns: Vec<String>,
    /// One row of numbers per line, in column order.
    pub rows: Vec<Vec<f64>>,
}

impl ReferenceRun {
    /// Read a reference table.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        Self::parse(&Source::read(path)?.text, path)
    }

    /// Read a reference table's text; `path` places its errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, InputError> {
        let comments = text
            .lines()
            .filter_map(|l| l.strip_prefix('#'))
            .map(|c| c.trim().to_string())
            .collect();
        let mut csv = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .flexible(true)
            .from_reader(text.as_bytes());
        let line = |p: Option<&csv::Position>| p.map_or(1, |p| p.line() as usize);
        let columns: Vec<String> = match csv.headers() {
            Ok(h) if !h.is_empty() => h.iter().map(str::to_string).collect(),
            Ok(_) => return Err(InputError::file(path, "no header row")),
            Err(e) => return Err(InputError::line(path, line(e.position()), e.to_string())),
        };
        let mut rows = Vec::new();
        for record in csv.records() {
            let record = record.map_err(|e| InputError::line(path, line(e.position()), e.to_string()))?;
            let at = line(record.position());
            let row = record
                .iter()
                .map(str::parse::<f64>)
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| InputError::line(path, at, format!("not a number: {e}")))?;
            if row.len() != columns.len() {
                let msg = format!("{} values for {} columns", row.len(), columns.len());
                return Err(InputError::line(path, at, msg));
            }
            rows.push(row);
        }
        Ok(Self {
            path: path.to_path_buf(),
            comments,
            columns,
            rows,
        })
    }

    /// A column by name.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, InputError> {
        let k = self.columns.iter().position(|c| c == name).ok_or_else(|| {
            let msg = format!("no such column (columns: {})", self.columns.join(", "));
            InputError::field(&self.path, self.comments.len() + 1, name, msg)
        })?;
        Ok(self.rows.iter().map(|r| r[k]).collect())
    }
}
