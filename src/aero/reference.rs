//! Reader for the JSBSim reference tables in `scenarios/jsbsim/` (written by
//! `python/jsbsim_reference.py`): `#` header lines, then a CSV header row with the unit in each
//! column name, then numbers.

use std::path::{Path, PathBuf};

use super::AeroError;

/// One reference run: header comments and named numeric columns.
#[derive(Debug, Clone)]
pub struct ReferenceRun {
    pub path: PathBuf,
    pub comments: Vec<String>,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

impl ReferenceRun {
    pub fn load(path: &Path) -> Result<Self, AeroError> {
        let text = crate::input::text::read_text(path).map_err(|msg| AeroError::Io {
            path: path.to_path_buf(),
            msg,
        })?;
        Self::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<Self, AeroError> {
        let mut comments = Vec::new();
        let mut columns: Option<Vec<String>> = None;
        let mut rows = Vec::new();
        for (k, line) in text.lines().enumerate() {
            let lineno = k + 1;
            if let Some(c) = line.strip_prefix('#') {
                comments.push(c.trim().to_string());
                continue;
            }
            if line.trim().is_empty() {
                continue;
            }
            match &columns {
                None => columns = Some(line.split(',').map(|s| s.trim().to_string()).collect()),
                Some(cols) => {
                    let row: Result<Vec<f64>, _> = line.split(',').map(|s| s.trim().parse::<f64>()).collect();
                    let row = row.map_err(|e| AeroError::Parse {
                        path: path.to_path_buf(),
                        line: lineno,
                        msg: format!("not a number: {e}"),
                    })?;
                    if row.len() != cols.len() {
                        return Err(AeroError::Parse {
                            path: path.to_path_buf(),
                            line: lineno,
                            msg: format!("{} values for {} columns", row.len(), cols.len()),
                        });
                    }
                    rows.push(row);
                }
            }
        }
        let columns = columns.ok_or_else(|| AeroError::Parse {
            path: path.to_path_buf(),
            line: 0,
            msg: "no header row".into(),
        })?;
        Ok(Self {
            path: path.to_path_buf(),
            comments,
            columns,
            rows,
        })
    }

    /// A column by name.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, AeroError> {
        let k = self
            .columns
            .iter()
            .position(|c| c == name)
            .ok_or_else(|| AeroError::Field {
                path: self.path.clone(),
                line: self.comments.len() + 1,
                field: name.to_string(),
                msg: format!("no such column (columns: {})", self.columns.join(", ")),
            })?;
        Ok(self.rows.iter().map(|r| r[k]).collect())
    }
}
