//! `[[fault]]` tables (in a scenario or a comparison, read in the file's one pass): the faults a run schedules ([`crate::faults`]).
//!
//! ```toml
//! [[fault]]
//! kind = "coil_open"       # a crate::faults::FaultKind, snake_case
//! start_s = 2.0            # active on start_s ≤ t < end_s, within the run
//! end_s = 4.0
//! # noise_rms_n = 10.0     # load_cell_noisy only (default 10 N)
//! # extra_latency_s = 0.05 # latency_spike only (default 50 ms)
//! ```

use serde::Deserialize;
use toml::Spanned;

use super::{InputError, Source, Variant};
use crate::faults::{Fault, FaultKind, FaultSchedule};

/// One `[[fault]]` table as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FaultTable {
    kind: Spanned<Variant<FaultKind>>,
    start_s: Spanned<f64>,
    end_s: Spanned<f64>,
    noise_rms_n: Option<Spanned<f64>>,
    extra_latency_s: Option<Spanned<f64>>,
}

/// What is wrong with a fault window `start_s ≤ t < end_s` in a run of `run_s` seconds (`run` names it), if
/// anything: the key at fault and why (a fault that never acts, or acts where the run never goes).
pub fn window_error(start_s: f64, end_s: f64, run_s: f64, run: &str) -> Option<(&'static str, String)> {
    if !(start_s.is_finite() && (0.0..=run_s).contains(&start_s)) {
        return Some((
            "start_s",
            format!("value {start_s} outside the allowed range [0, {run_s}] s (within the {run})"),
        ));
    }
    if start_s >= run_s {
        return Some((
            "start_s",
            format!("value {start_s} s is where the {run} ends ({run_s} s): the fault would never act"),
        ));
    }
    if !(end_s.is_finite() && end_s >= start_s && end_s <= run_s) {
        let msg = format!(
            "value {end_s} outside the allowed range [{start_s}, {run_s}] s (after start_s, within the \
             {run}: to last to its end, write {run_s})"
        );
        return Some(("end_s", msg));
    }
    if end_s <= start_s {
        let msg = format!(
            "value {end_s} s is not after start_s = {start_s} s: the fault would never act (it is active \
             from start_s until end_s)"
        );
        return Some(("end_s", msg));
    }
    None
}

/// The faults of `tables` (from `src`) in a run of `run_s` seconds; an error names `fault.K.key`, K the
/// table's number from 1.
pub fn schedule(src: &Source, tables: &[FaultTable], run_s: f64) -> Result<FaultSchedule, InputError> {
    let mut faults = Vec::with_capacity(tables.len());
    for (k, t) in tables.iter().enumerate() {
        let field = |key: &str| format!("fault.{}.{key}", k + 1);
        let kind = src.variant(&t.kind, &field("kind"))?;
        let (start_s, end_s) = (*t.start_s.get_ref(), *t.end_s.get_ref());
        if let Some((key, msg)) = window_error(start_s, end_s, run_s, "run") {
            let at = if key == "start_s" { &t.start_s } else { &t.end_s };
            return Err(src.err(at, &field(key), msg));
        }
        let mut f = Fault::new(kind, start_s, end_s);
        let param = |v: &Spanned<f64>, key: &str, only: FaultKind, hi: f64, unit: &str| {
            if kind != only {
                let msg = format!("only used by kind = \"{}\"", only.name());
                return Err(src.err(v, &field(key), msg));
            }
            src.within(v, &field(key), 0.0..=hi, unit)
        };
        if let Some(v) = &t.noise_rms_n {
            f.noise_rms_n = param(v, "noise_rms_n", FaultKind::LoadCellNoisy, 250.0, "N")?;
        }
        if let Some(v) = &t.extra_latency_s {
            f.extra_latency_s = param(v, "extra_latency_s", FaultKind::LatencySpike, 10.0, "s")?;
        }
        faults.push(f);
    }
    Ok(FaultSchedule { faults })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::faults::mask_names;

    /// The faults of a text that holds `[[fault]]` tables among other keys.
    fn parse(text: &str) -> Result<FaultSchedule, String> {
        #[derive(Deserialize)]
        struct Faults {
            #[serde(default)]
            fault: Vec<FaultTable>,
        }
        let src = Source::new("s.toml", text);
        let tables = src.toml::<Faults>().map_err(|e| e.to_string())?;
        schedule(&src, &tables.fault, 5.0).map_err(|e| e.to_string())
    }

    /// `text` is refused with a message holding both `at` (file, line, field) and `what`.
    fn refused(text: &str, at: &str, what: &str) {
        let e = parse(text).unwrap_err();
        assert!(e.contains(at) && e.contains(what), "{e}");
    }

    #[test]
    fn schedule_parses_and_windows_are_half_open() {
        let text = "name = \"x\"\n[other]\na = 1\n\n[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\n\n[[fault]]\nkind = \"load_cell_noisy\"\nstart_s = 0.5\nend_s = 3.0\nnoise_rms_n = 4.0\n";
        let s = parse(text).unwrap();
        assert_eq!(s.faults.len(), 2);
        assert!(s.active(FaultKind::CoilOpen, 0.999).is_none());
        assert!(s.active(FaultKind::CoilOpen, 1.0).is_some());
        assert!(s.active(FaultKind::CoilOpen, 2.0).is_none());
        assert_eq!(s.faults[1].noise_rms_n, 4.0);
        assert_eq!(mask_names(s.active_mask(1.5)), "coil_open+load_cell_noisy");
    }

    #[test]
    fn bad_fault_entries_name_line_and_key() {
        let bad_kind = "[[fault]]\nkind = \"coil_shorted\"\nstart_s = 1.0\nend_s = 2.0\n";
        refused(bad_kind, "s.toml:2: field `fault.1.kind`", "coil_open");
        // The header spelled with spaces (valid TOML), the bad table the second: its own `kind` line.
        let spaced = format!(
            "[[ fault ]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\n\n[[ fault ]]\n{}",
            &bad_kind[10..]
        );
        let e = parse(&spaced).unwrap_err();
        assert!(e.starts_with("s.toml:7: field `fault.2.kind`"), "{e}");
        let late = "a = 1\n[[fault]]\nkind = \"coil_open\"\nstart_s = 9.0\nend_s = 10.0\n";
        let e = parse(late).unwrap_err();
        assert!(
            e.contains("s.toml:4") && e.contains("start_s") && e.contains("[0, 5]"),
            "{e}"
        );
        // A fault that starts where the run ends, or ends after it: never acting, or acting on a time the
        // run does not reach (the file says something the run would not do).
        let at_end = "[[fault]]\nkind = \"coil_open\"\nstart_s = 5.0\nend_s = 6.0\n";
        refused(at_end, "s.toml:3: field `fault.1.start_s`", "never act");
        let past = "[[fault]]\nkind = \"coil_open\"\nstart_s = 4.0\nend_s = 6.0\n";
        refused(past, "s.toml:4: field `fault.1.end_s`", "[4, 5]");
        assert!(parse("[[fault]]\nkind = \"coil_open\"\nstart_s = 4.0\nend_s = 5.0\n").is_ok());
        // A value of the wrong type is named by its key; a missing key by the table.
        let typed = "[[fault]]\nkind = \"coil_open\"\nstart_s = \"x\"\nend_s = 2.0\n";
        refused(typed, "s.toml:3: field `start_s`", "invalid type");
        refused(
            "[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\n",
            "s.toml:1:",
            "end_s",
        );
        let empty = "[[fault]]\nkind = \"coil_open\"\nstart_s = 2.0\nend_s = 2.0\n";
        refused(empty, "s.toml:4: field `fault.1.end_s`", "never act");
        let wrong_param = "[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\nnoise_rms_n = 1.0\n";
        assert!(parse(wrong_param).unwrap_err().contains("noise_rms_n"));
        let unknown = "[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\nseverity = 1\n";
        refused(unknown, "s.toml:5", "severity");
    }
}
