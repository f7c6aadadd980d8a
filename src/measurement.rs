//! Test-rig measurements in the project's CSV format (`docs/spec/measurement-format.md`): the signals of
//! one test in SI units, read by `input::measurement` and written back.
//!
//! Required columns: `t_s`, `x_m`, `i_a`, `f_n`; optional `v_m_s` (else derived from `x_m`), `i_meas_a`,
//! `a_m_s2`, `temp_c`; any other column is kept as text.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::device::Inputs;
pub use crate::input::measurement::{measurement_files, read_all};
use crate::input::InputError;
pub use crate::signal::{smooth_derivative, uniform_interval};

/// Columns every test must have.
pub(crate) const REQUIRED: [&str; 4] = ["t_s", "x_m", "i_a", "f_n"];
/// Optional columns the tool understands.
pub(crate) const OPTIONAL: [&str; 4] = ["v_m_s", "i_meas_a", "a_m_s2", "temp_c"];

/// Largest magnitude a measured value may have (any column, its own unit): the model's force limit, beyond
/// which a fit's sums of squares overflow.
pub(crate) const MAGNITUDE_LIMIT: f64 = crate::device::model::FORCE_LIMIT_N;

/// A column beyond the format's, kept as written (trimmed, unquoted): one string, the fields separated by
/// NUL (which no input holds), so that many such columns take about the file's own size in memory.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TextColumn {
    text: String,
    rows: usize,
}

impl TextColumn {
    /// Append one row's field.
    pub fn push(&mut self, field: &str) {
        if self.rows > 0 {
            self.text.push('\0');
        }
        self.text.push_str(field);
        self.rows += 1;
    }

    /// The fields, one per row.
    pub fn fields(&self) -> impl Iterator<Item = &str> {
        self.text.split('\0').take(self.rows)
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.rows
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.rows == 0
    }
}

/// One test: signals in SI units, one value per sample.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Measurement {
    /// The file (or the name standing for it), for messages and tables.
    pub path: PathBuf,
    /// `# key: value` metadata (later values win).
    pub meta: BTreeMap<String, String>,
    /// Metadata lines that are not `key: value` (kept as free text).
    pub notes: Vec<String>,
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Displacement, m.
    pub x_m: Vec<f64>,
    /// Velocity, m/s: measured when `velocity_measured`, derived from `x_m` otherwise.
    pub v_m_s: Vec<f64>,
    /// Whether the file had a velocity column.
    pub velocity_measured: bool,
    /// Current command, A.
    pub i_a: Vec<f64>,
    /// Measured force, N (empty for a motion record without force).
    pub f_n: Vec<f64>,
    /// Measured coil current, A.
    pub i_meas_a: Option<Vec<f64>>,
    /// Measured acceleration, m/s².
    pub a_m_s2: Option<Vec<f64>>,
    /// Fluid temperature, °C.
    pub temp_c: Option<Vec<f64>>,
    /// Other columns by name, kept as written and ignored by the models.
    pub extra: BTreeMap<String, TextColumn>,
    /// 1-based file line of each sample (for error messages downstream).
    pub lines: Vec<usize>,
}

impl Measurement {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Error unless the file has at least `need` samples for `what` (e.g. "a fit of 5 parameters").
    pub fn require_samples(&self, need: usize, what: &str) -> Result<(), InputError> {
        match self.len() < need {
            true => Err(too_few_samples(&self.path, self.len(), need, what)),
            false => Ok(()),
        }
    }

    /// Acceleration: measured where the file has it, else the smoothing second derivative of `x_m`.
    pub(crate) fn acceleration(&self) -> Vec<f64> {
        match &self.a_m_s2 {
            Some(a) => a.clone(),
            None => smooth_derivative(&self.t_s, &self.v_m_s),
        }
    }

    /// Model inputs at every sample (velocity and acceleration as measured or derived).
    pub fn inputs(&self) -> Vec<Inputs> {
        let a = self.acceleration();
        (0..self.len())
            .map(|k| Inputs {
                t_s: self.t_s[k],
                x_m: self.x_m[k],
                v_m_s: self.v_m_s[k],
                a_m_s2: a[k],
                current_cmd_a: self.i_a[k],
            })
            .collect()
    }

    /// Sample rate from the metadata (checked when read), else from the median interval.
    pub fn sample_rate_hz(&self) -> f64 {
        let declared = self.meta.get(crate::input::measurement::RATE_KEY);
        match declared.and_then(|s| crate::input::measurement::rate_number(s).parse::<f64>().ok()) {
            Some(r) if r.is_finite() && r > 0.0 => r,
            _ => 1.0 / crate::signal::median_interval(&self.t_s),
        }
    }

    /// Read a measurement file.
    pub fn read(path: &Path) -> Result<Self, InputError> {
        crate::input::measurement::read(path, true)
    }

    /// Read a record of motion and current to predict the force of (`mrfeel simulate`): the force column
    /// optional ([`Measurement::f_n`] empty where absent).
    pub fn read_motion(path: &Path) -> Result<Self, InputError> {
        crate::input::measurement::read(path, false)
    }

    /// Parse a measurement from bytes; `path` is used in messages.
    pub fn parse(bytes: &[u8], path: &Path) -> Result<Self, InputError> {
        crate::input::measurement::parse(bytes, path, true)
    }

    /// A measurement from columns in memory (SI units), checked as a file's columns are; `name` stands for
    /// the file, errors name the column and the 0-based sample, and [`Measurement::lines`] holds 1-based
    /// sample numbers.
    pub fn from_columns(
        name: &str,
        t_s: Vec<f64>,
        x_m: Vec<f64>,
        i_a: Vec<f64>,
        f_n: Vec<f64>,
        v_m_s: Option<Vec<f64>>,
    ) -> Result<Self, InputError> {
        let fail = |why: String| InputError::file(name, why);
        let n = t_s.len();
        if n == 0 {
            return Err(fail("no samples: `t_s` is empty".into()));
        }
        let cols = [
            ("t_s", Some(&t_s)),
            ("x_m", Some(&x_m)),
            ("i_a", Some(&i_a)),
            ("f_n", Some(&f_n)),
            ("v_m_s", v_m_s.as_ref()),
        ];
        for (column, c) in cols {
            let Some(c) = c else { continue };
            if c.len() != n {
                return Err(fail(format!(
                    "column `{column}` has {} samples, `t_s` has {n}: every column needs one value per sample",
                    c.len()
                )));
            }
            let bad = c
                .iter()
                .enumerate()
                .find_map(|(k, &v)| crate::input::measurement::unmeasurable(v).map(|why| (k, why)));
            if let Some((k, why)) = bad {
                return Err(fail(format!(
                    "column `{column}`, sample {k}: {why} (value {})",
                    c[k]
                )));
            }
        }
        if let Some((k, why)) = crate::input::measurement::not_increasing(&t_s) {
            return Err(fail(format!("column `t_s`, sample {k}: {why}")));
        }
        let velocity_measured = v_m_s.is_some();
        let v_m_s = v_m_s.unwrap_or_else(|| smooth_derivative(&t_s, &x_m));
        Ok(Measurement {
            path: PathBuf::from(name),
            lines: (1..=n).collect(),
            t_s,
            x_m,
            v_m_s,
            velocity_measured,
            i_a,
            f_n,
            ..Default::default()
        })
    }

    /// Write in the measurement format, numbers in their shortest exact form (a file reads back to the
    /// same `f64` values). The velocity column is written only when measured.
    pub(crate) fn to_csv_string(&self) -> String {
        let mut s = String::new();
        for (k, v) in &self.meta {
            let _ = writeln!(s, "# {k}: {v}");
        }
        for n in &self.notes {
            let _ = writeln!(s, "# {n}");
        }
        let mut cols: Vec<(&str, &[f64])> = vec![("t_s", &self.t_s), ("x_m", &self.x_m)];
        if self.velocity_measured {
            cols.push(("v_m_s", &self.v_m_s));
        }
        cols.extend([("i_a", self.i_a.as_slice()), ("f_n", self.f_n.as_slice())]);
        for (name, c) in [
            ("i_meas_a", &self.i_meas_a),
            ("a_m_s2", &self.a_m_s2),
            ("temp_c", &self.temp_c),
        ] {
            cols.extend(c.as_deref().map(|c| (name, c)));
        }
        let names = cols
            .iter()
            .map(|(n, _)| *n)
            .chain(self.extra.keys().map(String::as_str));
        s.push_str(&names.map(csv_field).collect::<Vec<_>>().join(","));
        s.push('\n');
        let mut extra: Vec<_> = self.extra.values().map(TextColumn::fields).collect();
        for r in 0..self.len() {
            for (c, (_, col)) in cols.iter().enumerate() {
                let _ = write!(s, "{}{}", if c > 0 { "," } else { "" }, col[r]);
            }
            for col in &mut extra {
                s.push(',');
                s.push_str(&csv_field(col.next().unwrap_or("")));
            }
            s.push('\n');
        }
        s
    }

    /// Write to a file, whole or not at all ([`crate::outputs::write_whole`]).
    pub fn write(&self, path: &Path) -> Result<(), InputError> {
        let io = |e: std::io::Error| InputError::file(path, e.to_string());
        crate::outputs::write_whole(
            path,
            |tmp| std::fs::write(tmp, self.to_csv_string()).map_err(io),
            io,
        )
    }
}

/// The refusal of a record with `found` samples where `what` needs `need`.
pub(crate) fn too_few_samples(path: &Path, found: usize, need: usize, what: &str) -> InputError {
    InputError::file(
        path,
        format!("{found} samples, fewer than the {need} that {what} needs"),
    )
}

/// A field as written in a CSV row: quoted (RFC 4180) when it holds a comma, a quote, a line break or
/// leading or trailing blanks, so that it reads back the same.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.trim() != s {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A directory's measurement files are found whatever the case of their extension, other files and
    /// hidden ones (a killed run's temporary output) are not, and they come sorted by name.
    #[test]
    fn a_directory_gives_its_csv_files_in_any_case() {
        let d = tempfile::tempdir().unwrap();
        for name in [
            "b.csv",
            "A.CSV",
            "c.Csv",
            "notes.txt",
            "d.csv.bak",
            ".e.partial-7.csv",
        ] {
            std::fs::write(d.path().join(name), "").unwrap();
        }
        let files = measurement_files(&[d.path().to_path_buf()]).unwrap();
        let names: Vec<_> = files
            .iter()
            .map(|f| f.file_name().unwrap().to_str().unwrap())
            .collect();
        assert_eq!(names, ["A.CSV", "b.csv", "c.Csv"]);
    }

    /// A `.csv` entry of a data directory that is not a file (a named pipe, a broken link, a directory) is
    /// an error naming it, not skipped.
    #[test]
    #[cfg(unix)]
    fn a_csv_entry_that_is_no_file_is_named_not_skipped() {
        for (name, what) in [
            ("x.csv", "a named pipe"),
            ("broken.csv", "broken link"),
            ("sub.csv", "a directory"),
        ] {
            let d = tempfile::tempdir().unwrap();
            std::fs::write(d.path().join("a.csv"), "").unwrap();
            let p = d.path().join(name);
            match name {
                "x.csv" => {
                    let made = std::process::Command::new("mkfifo").arg(&p).status().unwrap();
                    assert!(made.success());
                }
                "broken.csv" => std::os::unix::fs::symlink("/nonexistent/m.csv", &p).unwrap(),
                _ => std::fs::create_dir(&p).unwrap(),
            }
            let e = measurement_files(&[d.path().to_path_buf()])
                .unwrap_err()
                .to_string();
            assert!(e.contains(name) && e.contains(what), "{e}");
        }
    }

    fn parse(s: &str) -> Result<Measurement, InputError> {
        Measurement::parse(s.as_bytes(), Path::new("test.csv"))
    }

    fn err(s: &str) -> String {
        parse(s).expect_err("must be rejected").to_string()
    }

    const GOOD: &str = "# source: unit test\n# sample_rate_hz: 100\n# free words here\nt_s,x_m,v_m_s,i_a,f_n,extra_u\n0,0,0.1,1,2,7\n0.01,0.001,0.1,1,2.5,8\n0.02,0.002,0.1,1,2.7,9\n";

    #[test]
    fn reads_metadata_columns_and_keeps_extras() {
        let m = parse(GOOD).unwrap();
        assert_eq!(m.len(), 3);
        assert_eq!(m.meta["source"], "unit test");
        assert_eq!(m.sample_rate_hz(), 100.0);
        assert_eq!(m.notes, vec!["free words here"]);
        assert_eq!(m.extra["extra_u"].fields().collect::<Vec<_>>(), ["7", "8", "9"]);
        assert!(m.velocity_measured);
        assert_eq!(m.lines, vec![5, 6, 7]);
    }

    #[test]
    fn column_order_does_not_matter() {
        let m = parse("f_n,i_a,x_m,t_s\n2,1,0,0\n3,1,0.1,1\n").unwrap();
        assert_eq!(m.f_n, vec![2.0, 3.0]);
        assert_eq!(m.t_s, vec![0.0, 1.0]);
        assert!(!m.velocity_measured);
    }

    #[test]
    fn missing_required_column_names_column_and_header_line() {
        let e = err("# c\nt_s,x_m,f_n\n0,0,0\n");
        assert!(e.contains("test.csv:2") && e.contains("`i_a`"), "{e}");
    }

    #[test]
    fn non_numeric_nan_and_infinite_values_name_line_and_column() {
        for (csv, want) in [
            ("0,0,0,0\n0.1,abc,0,0\n", ["test.csv:3", "`x_m`", "not a number"]),
            ("0,0,0,NaN\n", [":2", "`f_n`", "NaN"]),
            ("0,0,inf,0\n", [":2", "`i_a`", "infinite"]),
            ("0,0,,0\n", ["empty field"; 3]),
        ] {
            let e = err(&format!("t_s,x_m,i_a,f_n\n{csv}"));
            assert!(want.iter().all(|w| e.contains(w)), "{e}");
        }
    }

    #[test]
    fn time_must_increase_strictly() {
        let e = err("t_s,x_m,i_a,f_n\n0,0,0,0\n0.1,0,0,0\n0.1,0,0,0\n");
        assert!(e.contains("test.csv:4") && e.contains("`t_s`"), "{e}");
        let e = err("t_s,x_m,i_a,f_n\n0,0,0,0\n-0.1,0,0,0\n");
        assert!(e.contains("test.csv:3"), "{e}");
    }

    #[test]
    fn empty_header_only_and_not_csv_are_rejected() {
        for (bytes, want) in [
            (&b""[..], &["empty file"][..]),
            (b"\n\n", &["empty file"]),
            (b"t_s,x_m,i_a,f_n\n", &["header only", ":1"]),
            (b"{\"json\": true}\n", &["not a CSV"]),
            (&[0x89, 0x50, 0x4e, 0x47, 0xff, 0xfe, 0x00], &["not a CSV"]),
            // A Latin-1 byte on line 3: its line and column.
            (
                b"t_s,x_m,i_a,f_n\n0,0,0,0\n1,0,\xe9,0\n",
                &["test.csv:3:", "column 5: byte 0xe9"],
            ),
            (b"# only comments\n", &["no header"]),
        ] {
            let e = Measurement::parse(bytes, Path::new("test.csv"))
                .unwrap_err()
                .to_string();
            assert!(want.iter().all(|w| e.contains(w)), "{e}");
        }
    }

    #[test]
    fn ragged_rows_are_rejected_with_their_line() {
        let e = err("t_s,x_m,i_a,f_n\n0,0,0,0\n1,0,0\n");
        assert!(e.contains("test.csv:3") && e.contains("3 fields"), "{e}");
    }

    #[test]
    fn too_few_samples_names_what_needs_them() {
        let m = parse("t_s,x_m,i_a,f_n\n0,0,0,0\n1,0,0,0\n").unwrap();
        let e = m
            .require_samples(10, "a fit of 5 parameters")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("2 samples") && e.contains("10") && e.contains("fit"),
            "{e}"
        );
    }

    #[test]
    fn bom_and_mixed_line_endings_are_accepted() {
        let s = "\u{feff}# sample_rate_hz: 10\r\nt_s,x_m,i_a,f_n\r\n0,0,1,2\n0.1,0,1,3\r0.2,0,1,4\r\n";
        let m = parse(s).unwrap();
        assert_eq!(m.f_n, vec![2.0, 3.0, 4.0]);
        assert_eq!(m.meta["sample_rate_hz"], "10");
    }

    #[test]
    fn written_file_reads_back_to_identical_numbers() {
        let mut m = parse(GOOD).unwrap();
        m.f_n[1] = 0.1 + 0.2; // not representable in short decimal
        m.x_m[2] = -1.234_567_890_123_456_7e-5;
        let back = Measurement::parse(m.to_csv_string().as_bytes(), Path::new("test.csv")).unwrap();
        assert_eq!(back.f_n, m.f_n);
        assert_eq!(back.x_m, m.x_m);
        assert_eq!(back.v_m_s, m.v_m_s);
        assert_eq!(back.meta, m.meta);
        assert_eq!(back.extra, m.extra);
    }

    #[test]
    fn extra_columns_are_kept_and_ignored_whatever_they_hold() {
        let m =
            parse("t_s,x_m,i_a,f_n,note_x,empty_x\n0,0,1,2,hello,\n0.1,0,1,3,\"a, b\",\n0.2,0,1,4,NaN,7\n")
                .unwrap();
        assert_eq!(
            m.extra["note_x"].fields().collect::<Vec<_>>(),
            ["hello", "a, b", "NaN"]
        );
        assert_eq!(m.extra["empty_x"].fields().collect::<Vec<_>>(), ["", "", "7"]);
        // Kept: written back and read again to the same text.
        let back = Measurement::parse(m.to_csv_string().as_bytes(), Path::new("back.csv")).unwrap();
        assert_eq!(back.extra, m.extra);
        assert_eq!(back.f_n, m.f_n);
    }

    /// A quoted field may hold a line break (valid CSV): kept in its text column, the rows after it on
    /// their own lines, and written back the same.
    #[test]
    fn a_quoted_line_break_in_a_text_column_is_read() {
        let m = parse("t_s,x_m,i_a,f_n,note_x\n0,0,1,2,\"two\nlines\"\n0.1,0,1,3,one\n0.2,0,1,x,z\n");
        let e = m.expect_err("the bad force").to_string();
        assert!(e.contains("test.csv:5: column `f_n`"), "{e}");
        let m = parse("t_s,x_m,i_a,f_n,note_x\n0,0,1,2,\"two\nlines\"\n\n0.1,0,1,3,one\n").unwrap();
        assert_eq!(
            m.extra["note_x"].fields().collect::<Vec<_>>(),
            ["two\nlines", "one"]
        );
        assert_eq!(m.lines, [2, 5]);
        assert_eq!(m.f_n, [2.0, 3.0]);
        let back = Measurement::parse(m.to_csv_string().as_bytes(), Path::new("back.csv")).unwrap();
        assert_eq!(back.extra, m.extra);
    }

    /// Beyond the refusals of `tests/bad_input_files.rs`: NaN, an empty rate, a rate given twice.
    #[test]
    fn malformed_or_non_positive_sample_rate_names_line_and_key() {
        for (v, why) in [("NaN", "not a finite"), ("", "not a number")] {
            let e = err(&format!(
                "# source: x\n# sample_rate_hz: {v}\nt_s,x_m,i_a,f_n\n0,0,0,0\n"
            ));
            assert!(
                e.contains("test.csv:2") && e.contains("`sample_rate_hz`") && e.contains(why),
                "{v}: {e}"
            );
        }
        let e = err("# sample_rate_hz: 100\n# sample_rate_hz: 200\nt_s,x_m,i_a,f_n\n0,0,0,0\n");
        assert!(
            e.contains("test.csv:2") && e.contains("line 1") && e.contains("another rate"),
            "{e}"
        );
        // The same rate twice is no contradiction.
        parse("# sample_rate_hz: 100\n# sample_rate_hz: 100.0\nt_s,x_m,i_a,f_n\n0,0,0,0\n").unwrap();
        // The key's own unit may follow the number.
        let m = parse("# sample_rate_hz: 100 Hz\nt_s,x_m,i_a,f_n\n0,0,0,0\n0.0099,0,0,0\n").unwrap();
        assert_eq!(m.sample_rate_hz(), 100.0, "the declared rate, not the clock's");
    }

    #[test]
    fn declared_rate_must_agree_with_the_time_column() {
        let file = |rate: u32, n: usize, decimals: usize, t: &dyn Fn(f64) -> f64| {
            let rows: String = (0..n)
                .map(|k| format!("{:.*},0,0,0\n", decimals, t(k as f64)))
                .collect();
            format!("# sample_rate_hz: {rate}\nt_s,x_m,i_a,f_n\n{rows}")
        };
        // 3 kHz written with 4 decimals (intervals 0.0003 and 0.0004): agrees within the rounding.
        let m = parse(&file(3000, 30, 4, &|k| k / 3000.0)).unwrap();
        assert_eq!(m.sample_rate_hz(), 3000.0);
        // Lost samples (a constant rate is not required): the median interval still agrees.
        parse("# sample_rate_hz: 10\nt_s,x_m,i_a,f_n\n0,0,0,0\n0.1,0,0,0\n0.2,0,0,0\n0.5,0,0,0\n").unwrap();
        // Times written to the rate's own step (3 decimals at 1 kHz) cannot hide a clock at half the rate.
        let e = err(&file(1000, 200, 3, &|k| 0.002 * k));
        assert!(e.contains("`sample_rate_hz`") && e.contains("`t_s`"), "{e}");
        parse(&file(1000, 200, 3, &|k| 0.001 * k)).unwrap();
        // 3 % off is beyond the 1 % allowance and the rounding of 3-decimal times.
        let e = err("# sample_rate_hz: 10\nt_s,x_m,i_a,f_n\n0,0,0,0\n0.103,0,0,0\n0.206,0,0,0\n");
        assert!(e.contains("test.csv:1"), "{e}");
    }
}
