//! Measurement files (`docs/spec/measurement-format.md`): `# key: value` metadata lines, then a CSV table
//! read with the `csv` crate. The spec's columns are numbers, checked strictly; other columns are kept as
//! text. Every refusal names the file, the line and the column or key.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::text::{quoted, NotAFile};
use super::InputError;
use crate::measurement::{Measurement, TextColumn, MAGNITUDE_LIMIT, OPTIONAL, REQUIRED};

/// Largest measurement file read, bytes: `mrfeel mts` writes at most 10⁷ samples of at most about 110
/// bytes each (1.1 GB).
pub(crate) const MEASUREMENT_LIMIT_BYTES: u64 = 2 << 30;

/// The metadata key the spec defines for the sampling rate.
pub(crate) const RATE_KEY: &str = "sample_rate_hz";

/// Read a measurement file (at most [`MEASUREMENT_LIMIT_BYTES`]; a device is refused), the force column
/// required or not.
pub(crate) fn read(path: &Path, force_required: bool) -> Result<Measurement, InputError> {
    let bytes =
        super::text::read_bytes(path, MEASUREMENT_LIMIT_BYTES).map_err(|msg| InputError::file(path, msg))?;
    parse(&bytes, path, force_required)
}

/// An error at `line` about the column `name`.
fn column(path: &Path, line: usize, name: &str, msg: impl std::fmt::Display) -> InputError {
    InputError::line(path, line, format!("column `{name}`: {msg}"))
}

/// An error at `line` about the declared sampling rate, whose value is `val`.
fn rate_error(path: &Path, line: usize, why: impl std::fmt::Display, val: &str) -> InputError {
    InputError::line(
        path,
        line,
        format!("metadata `{RATE_KEY}`: {why} (value `{val}`)"),
    )
}

fn not_csv(path: &Path, line: usize, why: impl std::fmt::Display) -> InputError {
    InputError::line(path, line, format!("not a CSV measurement file: {why}"))
}

/// Parse a measurement from bytes; `path` names it in messages.
pub(crate) fn parse(bytes: &[u8], path: &Path, force_required: bool) -> Result<Measurement, InputError> {
    let empty = || {
        InputError::file(
            path,
            "empty file: a measurement needs a header row (t_s,x_m,i_a,f_n,...) and data rows",
        )
    };
    if bytes.is_empty() {
        return Err(empty());
    }
    let text = super::text::decode(bytes).map_err(|e| not_csv(path, e.line, e.what()))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    if let Some(nul) = text.find('\0') {
        let line = super::text::line_of(text, nul);
        return Err(not_csv(path, line, "contains NUL bytes (a binary file?)"));
    }
    if text.trim().is_empty() {
        return Err(empty());
    }
    // A lone carriage return ends a line as `\n` does (csv counts only the latter).
    let normalized;
    let text = if text
        .match_indices('\r')
        .any(|(k, _)| text.as_bytes().get(k + 1) != Some(&b'\n'))
    {
        normalized = text.replace("\r\n", "\n").replace('\r', "\n");
        normalized.as_str()
    } else {
        text
    };
    let mut m = Measurement {
        path: path.to_path_buf(),
        ..Default::default()
    };

    // Metadata: the leading blank and `#` lines. The declared sample rate and its line.
    let mut rate: Option<(f64, usize)> = None;
    let mut start = 0; // byte offset of the header row
    let mut header_line = 1;
    for line in text.split_inclusive('\n') {
        let l = line.trim();
        if !(l.is_empty() || l.starts_with('#')) {
            break;
        }
        let l = l.trim_start_matches('#').trim();
        match l.split_once(':') {
            Some((key, val)) if !key.trim().is_empty() && !key.trim().contains(' ') => {
                let (key, val) = (key.trim(), val.trim());
                if key == RATE_KEY {
                    let bad = |why: String| rate_error(path, header_line, why, val);
                    let r = parse_rate(val).map_err(|why| bad(why.into()))?;
                    if let Some((first, at)) = rate.filter(|(first, _)| *first != r) {
                        return Err(bad(format!(
                            "declared again with another rate: {first} Hz at line {at} and {r} Hz here (one file, \
                             one rate)"
                        )));
                    }
                    rate = Some((r, header_line));
                }
                m.meta.insert(key.to_string(), val.to_string());
            }
            _ if !l.is_empty() => m.notes.push(l.to_string()),
            _ => {}
        }
        start += line.len();
        header_line += 1;
    }
    if start == text.len() {
        return Err(not_csv(
            path,
            header_line - 1,
            "only comment lines, no header row",
        ));
    }

    let body = &text[start..];
    let mut csv = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(body.as_bytes());
    let mut rec = csv::StringRecord::new();
    // A record's position is where the reader started it, before the blank lines it skipped.
    let line_of = |rec: &csv::StringRecord| {
        let p = rec.position().expect("a read record has a position");
        let skipped = body.as_bytes()[p.byte() as usize..]
            .iter()
            .take_while(|b| matches!(b, b'\r' | b'\n'))
            .filter(|&&b| b == b'\n')
            .count();
        header_line - 1 + p.line() as usize + skipped
    };
    let read = |csv: &mut csv::Reader<&[u8]>, rec: &mut csv::StringRecord| {
        csv.read_record(rec).map_err(|e| not_csv(path, header_line, e))
    };
    read(&mut csv, &mut rec)?;
    let header: Vec<String> = rec.iter().map(|s| s.trim().to_string()).collect();
    if header.len() < 2 {
        let first = body.lines().next().unwrap_or_default();
        let why = format!(
            "the header row `{}` has no comma-separated columns (expected t_s,x_m,i_a,f_n,...)",
            quoted(first, 60)
        );
        return Err(not_csv(path, header_line, why));
    }
    let mut seen = HashSet::with_capacity(header.len());
    if let Some(name) = header.iter().find(|name| !seen.insert(name.as_str())) {
        return Err(column(path, header_line, name, "appears twice in the header"));
    }
    let col = |name: &str| header.iter().position(|h| h == name);
    if let Some(req) = REQUIRED
        .iter()
        .find(|req| col(req).is_none() && (force_required || **req != "f_n"))
    {
        return Err(InputError::line(
            path,
            header_line,
            format!("missing required column `{req}` (required: t_s, x_m, i_a, f_n)"),
        ));
    }

    let known: Vec<bool> = header
        .iter()
        .map(|h| REQUIRED.contains(&h.as_str()) || OPTIONAL.contains(&h.as_str()))
        .collect();
    let t_col = col("t_s").unwrap_or(0);
    // Finest resolution the times are written with (for the clock check of `sample_rate_hz`).
    let mut t_resolution = f64::INFINITY;
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    let mut text_cols: Vec<TextColumn> = vec![TextColumn::default(); header.len()];
    while read(&mut csv, &mut rec)? {
        if rec.len() == 1 && rec[0].trim().is_empty() {
            continue;
        }
        let line = line_of(&rec);
        if rec.len() != header.len() {
            let msg = format!("row has {} fields, the header has {}", rec.len(), header.len());
            return Err(InputError::line(path, line, msg));
        }
        for (c, s) in rec.iter().map(str::trim).enumerate() {
            if !known[c] {
                text_cols[c].push(s);
                continue;
            }
            if c == t_col {
                t_resolution = t_resolution.min(written_resolution(s));
            }
            let why = match s.parse::<f64>().map(|v| (v, unmeasurable(v))) {
                Ok((v, None)) => {
                    cols[c].push(v);
                    continue;
                }
                Ok((_, Some(why))) => why,
                Err(_) if s.is_empty() => "empty field".into(),
                Err(_) => "not a number".into(),
            };
            let msg = format!("{why} (value `{}`)", quoted(s, 80));
            return Err(column(path, line, &header[c], msg));
        }
        m.lines.push(line);
    }
    if m.lines.is_empty() {
        return Err(InputError::line(path, header_line, "header only, no data rows"));
    }

    let mut take = |name: &str| col(name).map(|c| std::mem::take(&mut cols[c]));
    m.t_s = take("t_s").unwrap_or_default();
    if let Some((w, why)) = not_increasing(&m.t_s) {
        return Err(column(path, m.lines[w], "t_s", why));
    }
    if let Some((r, line)) = rate {
        if let Some(why) = clock_contradicts(r, &m.t_s, t_resolution) {
            return Err(rate_error(path, line, why, &m.meta[RATE_KEY]));
        }
    }
    m.x_m = take("x_m").unwrap_or_default();
    m.i_a = take("i_a").unwrap_or_default();
    m.f_n = take("f_n").unwrap_or_default();
    m.velocity_measured = col("v_m_s").is_some();
    m.v_m_s = take("v_m_s").unwrap_or_else(|| crate::signal::smooth_derivative(&m.t_s, &m.x_m));
    m.i_meas_a = take("i_meas_a");
    m.a_m_s2 = take("a_m_s2");
    m.temp_c = take("temp_c");
    for (c, name) in header.iter().enumerate() {
        if !known[c] {
            m.extra.insert(name.clone(), std::mem::take(&mut text_cols[c]));
        }
    }
    refuse_spikes(&m)?;
    Ok(m)
}

/// Refuse a sample that looks like a spike ([`crate::spikes`]): a reading
/// [`SPIKE_FACTOR`](crate::spikes::SPIKE_FACTOR) spreads of its column away from its neighbours, which no
/// sensor on a moving damper makes and which would drive every figure of a fit. Named by line and column,
/// with how many more there are.
fn refuse_spikes(m: &Measurement) -> Result<(), InputError> {
    let measured_v = m.velocity_measured.then_some(&m.v_m_s);
    let columns = [
        ("x_m", Some(&m.x_m)),
        ("i_a", Some(&m.i_a)),
        ("f_n", Some(&m.f_n)),
        ("v_m_s", measured_v),
        ("i_meas_a", m.i_meas_a.as_ref()),
        ("a_m_s2", m.a_m_s2.as_ref()),
        ("temp_c", m.temp_c.as_ref()),
    ];
    for (name, col) in columns {
        let Some(col) = col else { continue };
        let found = crate::spikes::spikes(col, crate::spikes::SPIKE_FACTOR);
        let Some(first) = found.first() else { continue };
        let more = match found.len() {
            1 => String::new(),
            n => {
                let lines: Vec<String> = found[1..]
                    .iter()
                    .take(5)
                    .map(|s| m.lines[s.index].to_string())
                    .collect();
                let etc = if n > 6 { ", …" } else { "" };
                format!(
                    "; {} more in this column, at lines {}{etc}",
                    n - 1,
                    lines.join(", ")
                )
            }
        };
        let num = super::text::short_number;
        let msg = format!(
            "looks like a spike: {} times the column's spread (its central 90 %) away from the median of its \
             neighbours, {}; no sensor moves so far for one sample: correct or remove it{more} (value `{}`)",
            num(first.spreads.round()),
            num(first.neighbours),
            num(first.value)
        );
        return Err(column(&m.path, m.lines[first.index], name, msg));
    }
    Ok(())
}

/// The first sample whose time is not after the previous one's, and why.
pub(crate) fn not_increasing(t: &[f64]) -> Option<(usize, String)> {
    let w = (1..t.len()).find(|&w| t[w] <= t[w - 1])?;
    let why = format!(
        "time {} s is not after the previous sample's {} s (time must increase strictly)",
        t[w],
        t[w - 1]
    );
    Some((w, why))
}

/// Why `v` is no measured value (NaN, infinite, or beyond [`MAGNITUDE_LIMIT`]), if it is not.
pub(crate) fn unmeasurable(v: f64) -> Option<String> {
    if v.is_nan() {
        Some("NaN is not a measurement".into())
    } else if v.is_infinite() {
        Some("infinite value".into())
    } else if v.abs() > MAGNITUDE_LIMIT {
        Some(format!(
            "beyond ±{MAGNITUDE_LIMIT:e}, where squares and the error figures stop being numbers (no \
             instrument reads this)"
        ))
    } else {
        None
    }
}

/// The number of a `sample_rate_hz` value: the unit may be written after it (`1000 Hz`), it is the key's own.
pub(crate) fn rate_number(val: &str) -> &str {
    let v = val.trim();
    v.strip_suffix("Hz")
        .or_else(|| v.strip_suffix("hz"))
        .unwrap_or(v)
        .trim()
}

/// A `sample_rate_hz` value: a finite positive number of hertz.
fn parse_rate(val: &str) -> Result<f64, &'static str> {
    let r: f64 = rate_number(val)
        .parse()
        .map_err(|_| "not a number (the sampling rate in Hz, e.g. `1000`)")?;
    if !r.is_finite() {
        return Err("not a finite number of Hz");
    }
    if r <= 0.0 {
        return Err("a sampling rate must be > 0 Hz");
    }
    Ok(r)
}

/// The resolution a number is written with: `0.0010` → 1e-4, `12` → 1, `2.5e-3` → 1e-4.
fn written_resolution(s: &str) -> f64 {
    let (mant, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().unwrap_or(0)),
        None => (s, 0),
    };
    let decimals = mant.split_once('.').map_or(0, |(_, d)| d.len()) as i32;
    10f64.powi(exp - decimals)
}

/// Why a declared rate `rate_hz` contradicts the time column, `None` when they agree: the median or the
/// mean interval of `t` lies within 1 % of `1 / rate_hz` plus the rounding of times written with
/// `resolution_s`. The median alone would refuse a record whose clock is coarsely rounded; the mean alone,
/// one with lost samples; a rate that neither matches is a different clock (times in ms, a wrong rate).
fn clock_contradicts(rate_hz: f64, t: &[f64], resolution_s: f64) -> Option<String> {
    if t.len() < 2 {
        return None;
    }
    let nominal = 1.0 / rate_hz;
    // Times rounded more coarsely than the nominal interval repeat (refused before this check): the
    // rounding allowed is at most one nominal interval.
    let q = if resolution_s.is_finite() {
        resolution_s.min(nominal)
    } else {
        0.0
    };
    let median = crate::signal::median_interval(t);
    let n = (t.len() - 1) as f64;
    let mean = (t[t.len() - 1] - t[0]) / n;
    // One interval is off by up to a rounding step, so the median tells a clock only where the step is
    // under half the interval (else twice the interval passes too); the mean over the record always does.
    let median_ok = q < 0.5 * nominal && (median - nominal).abs() <= 0.01 * nominal + q;
    let mean_ok = (mean - nominal).abs() <= 0.01 * nominal + 2.0 * q / n;
    if median_ok || mean_ok {
        return None;
    }
    Some(format!(
        "{rate_hz} Hz means a sample every {nominal:.6e} s, but column `t_s` has a sample every {median:.6e} s \
         ({:.6} Hz, median interval): the metadata or the time column is wrong (is `t_s` in seconds?)",
        1.0 / median
    ))
}

/// Read many files and directories of files ([`measurement_files`]).
pub fn read_all(paths: &[PathBuf]) -> Result<Vec<Measurement>, InputError> {
    measurement_files(paths)?
        .iter()
        .map(|f| Measurement::read(f))
        .collect()
}

/// The files [`read_all`] reads: each file as given, each directory's `*.csv` files (the extension in any
/// case) sorted by name, hidden ones (`.name.csv`, a killed run's temporary output) left out as a shell's
/// `*.csv` leaves them; directories are not recursed, and a directory without any is an error.
pub fn measurement_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, InputError> {
    let mut files = Vec::new();
    for p in paths {
        if !p.is_dir() {
            files.push(p.clone());
            continue;
        }
        let rd = std::fs::read_dir(p).map_err(|e| InputError::file(p, e.to_string()))?;
        let mut inner: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|q| {
                !q.file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with('.'))
                    && q.extension()
                        .and_then(|e| e.to_str())
                        .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
            })
            .collect();
        // A `.csv` entry that is no file is named, not skipped: a test would be left out without a word
        // (and a named pipe read from a listing could wait for ever).
        if let Some((q, what)) = inner.iter().find_map(|q| not_a_file(q).map(|w| (q, w))) {
            return Err(InputError::file(
                q,
                format!("{what} in a data directory: move it out, or name the files to read"),
            ));
        }
        if inner.is_empty() {
            return Err(InputError::file(p, "directory holds no .csv files"));
        }
        inner.sort();
        files.extend(inner);
    }
    Ok(files)
}

/// What a directory entry is when it is not a regular file (after following a link), or `None` for a file.
fn not_a_file(q: &Path) -> Option<String> {
    match std::fs::metadata(q) {
        Err(e) => Some(format!("unreadable ({e}; a broken link?)")),
        Ok(meta) => NotAFile::of(&meta).map(|kind| match kind {
            NotAFile::Directory => "a directory named like a measurement,".to_string(),
            NotAFile::Other => "not a file,".to_string(),
            other => format!("{}, not a file,", other.noun()),
        }),
    }
}
