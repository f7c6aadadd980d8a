//! Bad device files (`models/*.toml`) and fitted parameter files (`PARAMS.json`): every one is an error that
//! names the file, the line of the offending key (or of the table / object that lacks one) and the field,
//! with a non-zero exit and no panic, before anything is run: nothing on stdout, no output file written.
//! Good files that differ from the usual one only in what the format allows (a byte-order mark, an optional
//! key left out) load and give the same figures.

use crate::common;
use common::{mrfeel, s};

use std::path::PathBuf;
use std::process::Output;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A small real test (448 samples) from the damper data beside the repository.
fn small_test() -> String {
    s(&root().join("data/utfsm-mr-damper/2mm5Hz_0p50A.csv"))
}

/// The paper's device file, as shipped.
fn paper_device() -> String {
    std::fs::read_to_string(root().join("models/paper-device.toml")).expect("models/paper-device.toml")
}

/// A parameter file as `mrfeel fit --save` writes it (fitted on the UTFSM damper).
const PARAMS_JSON: &str = r#"{
  "model": "bingham",
  "current_limit_a": 14.0,
  "command_timing": "after-sample",
  "params": {
    "c0_n_s_per_m": {
      "value": 12513.063281463727,
      "std_err": 341.80334754392925,
      "unit": "N·s/m"
    },
    "fc0_n": {
      "value": 1.0000000000000004e-6,
      "std_err": null,
      "unit": "N"
    },
    "fc_gain_n_per_a": {
      "value": 474.42187869137,
      "std_err": 23.347773140333047,
      "unit": "N/A"
    },
    "te_s": {
      "value": 0.025000000000000026,
      "std_err": null,
      "unit": "s"
    },
    "tm_s": {
      "value": 0.025000000000000026,
      "std_err": null,
      "unit": "s"
    }
  }
}
"#;

/// `text` with `from` replaced (once; it must be there).
fn edit(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "`{from}` is not in the file");
    text.replacen(from, to, 1)
}

/// 1-based line of the first occurrence of `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    let at = text
        .find(needle)
        .unwrap_or_else(|| panic!("`{needle}` not in the file"));
    text[..at].matches('\n').count() + 1
}

/// The run failed cleanly before producing anything: exit 1, no panic, nothing on stdout, and the error
/// names every one of `needles` and never line 0. Returns stderr.
fn refused(o: &Output, needles: &[&str]) -> String {
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(
        o.status.code(),
        Some(1),
        "exit {:?}; stderr: {err}",
        o.status.code()
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        out.is_empty(),
        "stdout not empty on an error: {out}\nstderr: {err}"
    );
    assert!(!err.contains(":0:"), "an error at line 0: {err}");
    for n in needles {
        assert!(err.contains(n), "the error does not name `{n}`: {err}");
    }
    err
}

/// `mrfeel mts` on a device file with this text: refused with `needles` (plus `FILE:LINE: field `FIELD``),
/// and neither the output CSV nor the saved device written.
fn mts_refuses(text: &str, line: usize, field: &str, needles: &[&str]) {
    let d = tempfile::tempdir().unwrap();
    let dev = d.path().join("dev.toml");
    std::fs::write(&dev, text).unwrap();
    let out = d.path().join("o.csv");
    let saved = d.path().join("saved.json");
    let o = mrfeel(&[
        "mts",
        "--device",
        &s(&dev),
        "--current",
        "2",
        "--out",
        &s(&out),
        "--save-device",
        &s(&saved),
    ]);
    let at = format!("dev.toml:{line}: field `{field}`");
    let mut all = vec![at.as_str()];
    all.extend_from_slice(needles);
    refused(&o, &all);
    assert!(!out.exists() && !saved.exists(), "a file was written");
}

/// `mrfeel validate` with a parameter file of this text: refused with `FILE:LINE: field `FIELD`` and
/// `needles`, nothing printed on stdout and no plot folder made.
fn validate_refuses(text: &str, line: usize, field: &str, needles: &[&str]) -> String {
    let d = tempfile::tempdir().unwrap();
    let params = d.path().join("p.json");
    std::fs::write(&params, text).unwrap();
    let plot = d.path().join("plots");
    let o = mrfeel(&[
        "validate",
        &small_test(),
        "--params",
        &s(&params),
        "--json",
        "--plot",
        &s(&plot),
    ]);
    let at = format!("p.json:{line}: field `{field}`");
    let mut all = vec![at.as_str()];
    all.extend_from_slice(needles);
    let err = refused(&o, &all);
    assert!(!plot.exists(), "plots were written");
    err
}

/// `mrfeel validate --json` with a parameter file of this bytes: its `nrmse` (the run must succeed).
/// `validate --json` with a params file of these bytes: its JSON.
fn validate_json(bytes: &[u8]) -> serde_json::Value {
    let d = tempfile::tempdir().unwrap();
    let params = d.path().join("p.json");
    std::fs::write(&params, bytes).unwrap();
    let o = mrfeel(&["validate", &small_test(), "--params", &s(&params), "--json"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

fn validate_nrmse(bytes: &[u8]) -> f64 {
    let v = validate_json(bytes);
    let nrmse = v["nrmse"]
        .as_f64()
        .unwrap_or_else(|| panic!("nrmse not a number: {}", v["nrmse"]));
    assert!(nrmse.is_finite() && nrmse > 0.0, "{nrmse}");
    nrmse
}

// ------------------------------------------------------------------ 1: the driver's current limit

#[test]
fn a_negative_zero_or_nan_current_limit_in_a_device_file_is_refused_at_its_line() {
    let good = paper_device();
    let line = line_of(&good, "current_limit_a = 14.0");
    for (bad, shown) in [("-14.0", "-14"), ("0.0", "0"), ("nan", "NaN"), ("-inf", "-inf")] {
        let text = edit(
            &good,
            "current_limit_a = 14.0",
            &format!("current_limit_a = {bad}"),
        );
        mts_refuses(
            &text,
            line,
            "driver.current_limit_a",
            &[&format!("value {shown} A"), "positive, finite"],
        );
    }
}

#[test]
fn a_negative_or_zero_current_limit_in_a_params_file_is_refused_at_its_line() {
    let line = line_of(PARAMS_JSON, "\"current_limit_a\"");
    for (bad, shown) in [("-1.0", "-1"), ("0", "0")] {
        let text = edit(
            PARAMS_JSON,
            "\"current_limit_a\": 14.0",
            &format!("\"current_limit_a\": {bad}"),
        );
        validate_refuses(&text, line, "current_limit_a", &[&format!("value {shown} A")]);
    }
}

// ------------------------------------------------------------------ 2: the real line, never 0

#[test]
fn params_file_errors_name_the_line_of_the_offending_key() {
    // An unknown effect in the model: the line of "model".
    let text = edit(PARAMS_JSON, "\"bingham\"", "\"bingham+hysterisis\"");
    validate_refuses(&text, 2, "model", &["unknown effect `hysterisis`"]);
    // A value outside its bounds: the line of the parameter.
    let text = edit(PARAMS_JSON, "\"value\": 0.025000000000000026", "\"value\": -0.1");
    let te_line = line_of(&text, "\"te_s\"");
    validate_refuses(
        &text,
        te_line,
        "te_s",
        &["value -0.1 outside the allowed range [0, 1] s"],
    );
    // A misspelt parameter: its own line.
    let text = edit(PARAMS_JSON, "\"c0_n_s_per_m\": {", "\"c0_n_s_per_mm\": {");
    validate_refuses(
        &text,
        6,
        "c0_n_s_per_mm",
        &["unknown parameter for model `bingham`"],
    );
    // A value of the wrong type: the line of the value.
    let text = edit(
        PARAMS_JSON,
        "\"value\": 12513.063281463727",
        "\"value\": \"12513\"",
    );
    validate_refuses(
        &text,
        7,
        "c0_n_s_per_m.value",
        &["expected a number, found a string"],
    );
}

#[test]
fn a_missing_parameter_is_reported_at_the_table_or_object_that_lacks_it() {
    // PARAMS.json: the line of "params".
    let c0 = "    \"c0_n_s_per_m\": {\n      \"value\": 12513.063281463727,\n      \"std_err\": 341.80334754392925,\n      \"unit\": \"N·s/m\"\n    },\n";
    let text = edit(PARAMS_JSON, c0, "");
    validate_refuses(
        &text,
        line_of(&text, "\"params\""),
        "c0_n_s_per_m",
        &["missing parameter"],
    );
    // Device file: the line of [params].
    let good = paper_device();
    let text = edit(&good, "fc_gain_n_per_a = 4.83\n", "");
    mts_refuses(
        &text,
        line_of(&text, "[params]"),
        "fc_gain_n_per_a",
        &["missing parameter"],
    );
}

// ------------------------------------------------------------------ 3: the load cell

#[test]
fn a_non_positive_load_cell_range_in_a_device_file_names_the_field_and_value() {
    let good = paper_device();
    let line = line_of(&good, "range_n = 250.0");
    for (bad, shown) in [("-250.0", "-250"), ("0.0", "0"), ("inf", "inf")] {
        let text = edit(&good, "range_n = 250.0", &format!("range_n = {bad}"));
        mts_refuses(&text, line, "load_cell.range_n", &[&format!("value {shown} N")]);
    }
}

/// A parameter name written with a dot (`te.s` for `te_s`) is a dotted key to TOML: a table where a number
/// is expected. The error says so at its line, not "expected a borrowed string".
#[test]
fn a_dotted_parameter_name_is_explained_at_its_line() {
    let text = edit(&paper_device(), "te_s = ", "te.s = ");
    mts_refuses(
        &text,
        line_of(&text, "te.s = "),
        "te.s",
        &["a dotted key makes a table here (`te` holding `s`) where one value is expected"],
    );
}

/// A number below the smallest double (`1e-400`), which TOML parsers read as 0, is refused at its line by
/// the number written, not reported (or used) as 0.
#[test]
fn a_number_that_would_be_read_as_zero_is_refused_as_written() {
    let text = edit(&paper_device(), "te_s = 0.015", "te_s = 1e-400");
    mts_refuses(
        &text,
        line_of(&text, "te_s = "),
        "te_s",
        &[
            "1e-400 is below the smallest number a double holds",
            "write 0 if 0 is meant",
        ],
    );
}

// ------------------------------------------------------------------ 4: geometry and supply

#[test]
fn geometry_that_is_not_a_positive_length_or_does_not_fit_together_is_refused() {
    let good = paper_device();
    let cases = [
        (
            "stroke_half_in = 2.0",
            "stroke_half_in = -2.0",
            "geometry.stroke_half_in",
            "value -2 in",
        ),
        (
            "stroke_half_in = 2.0",
            "stroke_half_in = 0.0",
            "geometry.stroke_half_in",
            "value 0 in",
        ),
        (
            "piston_diameter_in = 3.125",
            "piston_diameter_in = -3.125",
            "geometry.piston_diameter_in",
            "value -3.125 in",
        ),
        (
            "cylinder_od_in = 4.0",
            "cylinder_od_in = nan",
            "geometry.cylinder_od_in",
            "value NaN in",
        ),
        (
            "piston_rod_length_in = 10.0",
            "piston_rod_length_in = 0",
            "geometry.piston_rod_length_in",
            "value 0 in",
        ),
        // The piston wider than the bore, the bore wider than the tube, the stroke longer than the cylinder.
        (
            "piston_diameter_in = 3.125",
            "piston_diameter_in = 3.75",
            "geometry.piston_diameter_in",
            "bore",
        ),
        (
            "cylinder_id_in = 3.5",
            "cylinder_id_in = 3.0",
            "geometry.piston_diameter_in",
            "bore",
        ),
        (
            "cylinder_od_in = 4.0",
            "cylinder_od_in = 3.25",
            "geometry.cylinder_id_in",
            "outside diameter",
        ),
        (
            "stroke_half_in = 2.0",
            "stroke_half_in = 4.0",
            "geometry.stroke_half_in",
            "longer than the cylinder",
        ),
    ];
    for (from, to, field, why) in cases {
        let text = edit(&good, from, to);
        let key = field.trim_start_matches("geometry.");
        mts_refuses(&text, line_of(&text, key), field, &[why]);
    }
}

#[test]
fn a_supply_limit_below_the_drivers_saturation_is_refused() {
    let good = paper_device();
    let text = edit(&good, "supply_limit_a = 17.0", "supply_limit_a = 5.0");
    mts_refuses(
        &text,
        line_of(&text, "supply_limit_a"),
        "driver.supply_limit_a",
        &["value 5 A is below the driver's saturation current_limit_a = 14 A"],
    );
    // Equal is a supply used to its limit: loads.
    let d = tempfile::tempdir().unwrap();
    let dev = d.path().join("dev.toml");
    std::fs::write(
        &dev,
        edit(&good, "supply_limit_a = 17.0", "supply_limit_a = 14.0"),
    )
    .unwrap();
    let out = d.path().join("o.csv");
    let o = mrfeel(&["mts", "--device", &s(&dev), "--current", "2", "--out", &s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.exists());
}

// ------------------------------------------------------------------ 5: params JSON keys and units

#[test]
fn an_unknown_top_level_key_in_a_params_file_is_refused_at_its_line() {
    let text = edit(
        PARAMS_JSON,
        "  \"command_timing\"",
        "  \"comand_timing\": \"at-sample\",\n  \"command_timing\"",
    );
    validate_refuses(&text, 4, "comand_timing", &["unknown key", "command_timing"]);
    // Inside a parameter too.
    let text = edit(
        PARAMS_JSON,
        "\"std_err\": 341.80334754392925",
        "\"std_error\": 341.80334754392925",
    );
    validate_refuses(&text, 8, "c0_n_s_per_m.std_error", &["unknown key"]);
}

#[test]
fn a_unit_other_than_the_parameters_is_refused_with_the_expected_unit() {
    // te_s is the 4th parameter: its unit is the 4th "unit": "s".
    let text = PARAMS_JSON.replacen("\"unit\": \"s\"", "\"unit\": \"ms\"", 1);
    let line = line_of(&text, "\"ms\"");
    validate_refuses(&text, line, "te_s.unit", &["\"ms\"", "te_s is in \"s\""]);
}

#[test]
fn a_key_given_twice_is_refused_at_its_second_line() {
    let text = edit(
        PARAMS_JSON,
        "    \"tm_s\": {",
        "    \"te_s\": {\"value\": 5.0},\n    \"tm_s\": {",
    );
    let first = line_of(&text, "\"te_s\"");
    let second = line_of(&text, "\"te_s\": {\"value\": 5.0}");
    validate_refuses(
        &text,
        second,
        "te_s",
        &["given twice", &format!("first at line {first}")],
    );
    let text = edit(
        PARAMS_JSON,
        "  \"model\": \"bingham\",",
        "  \"model\": \"bingham\",\n  \"model\": \"bingham\",",
    );
    validate_refuses(&text, 3, "model", &["given twice (first at line 2)"]);
}

/// The model-discovery contract (model-discovery.md) has `fit --save` write "the model name and fitted
/// parameters": `current_limit_a` and `command_timing` are optional, and their absence means the paper's
/// 14 A and `after-sample` (as in files written before those keys existed).
#[test]
fn the_optional_keys_left_out_mean_their_defaults() {
    let full = validate_nrmse(PARAMS_JSON.as_bytes());
    let no_limit = edit(PARAMS_JSON, "  \"current_limit_a\": 14.0,\n", "");
    let no_timing = edit(PARAMS_JSON, "  \"command_timing\": \"after-sample\",\n", "");
    assert_eq!(validate_nrmse(no_limit.as_bytes()), full);
    assert_eq!(validate_nrmse(no_timing.as_bytes()), full);
}

// ------------------------------------------------------------------ 6: byte-order mark

#[test]
fn a_params_file_with_a_byte_order_mark_loads_as_without() {
    let mut bom = "\u{feff}".as_bytes().to_vec();
    bom.extend_from_slice(PARAMS_JSON.as_bytes());
    assert_eq!(validate_nrmse(&bom), validate_nrmse(PARAMS_JSON.as_bytes()));
    // The standard errors the file saved are reported as saved, with the mark or without.
    for bytes in [&bom[..], PARAMS_JSON.as_bytes()] {
        let v = validate_json(bytes);
        assert_eq!(
            v["params"]["c0_n_s_per_m"]["std_err"].as_f64(),
            Some(341.80334754392925)
        );
        assert!(v["params"]["te_s"]["std_err"].is_null(), "{}", v["params"]);
    }
    // Lines are still counted from the first: an error after the mark is on its own line.
    let mut bad = "\u{feff}".as_bytes().to_vec();
    bad.extend_from_slice(edit(PARAMS_JSON, "\"after-sample\"", "\"sometimes\"").as_bytes());
    validate_refuses(
        &String::from_utf8(bad).unwrap(),
        4,
        "command_timing",
        &["`sometimes`"],
    );
}

// ------------------------------------------------------------------ 7: values that break the numbers

#[test]
fn parameters_that_make_the_force_unusable_are_refused_naming_the_parameter() {
    // 1e300 N·s/m is inside [0, inf] but makes the force and its square overflow (NaN figures with exit 0
    // before).
    let text = edit(PARAMS_JSON, "\"value\": 12513.063281463727", "\"value\": 1e300");
    let err = validate_refuses(&text, 6, "c0_n_s_per_m", &["value 1e300 N·s/m", "damper force"]);
    assert!(!err.contains("NaN"), "{err}");
    // The same in a device file.
    let good = paper_device();
    let text = edit(&good, "c0_n_s_per_m = 1.0", "c0_n_s_per_m = 1e300");
    mts_refuses(
        &text,
        line_of(&text, "c0_n_s_per_m = 1e300"),
        "c0_n_s_per_m",
        &["value 1e300"],
    );
    // A large but usable value is not refused: the figures are numbers.
    let big = edit(PARAMS_JSON, "\"value\": 12513.063281463727", "\"value\": 1e12");
    assert!(validate_nrmse(big.as_bytes()) > 1.0);
}

/// `weighting` records how the fit's tests shared its loss; a value that is neither is refused at its line.
#[test]
fn a_weighting_that_is_neither_tests_nor_samples_is_refused_at_its_line() {
    for (bad, shown) in [
        ("\"sample\"", "`sample` is not a weighting"),
        ("1", "found a number"),
    ] {
        let text = edit(
            PARAMS_JSON,
            "  \"command_timing\": \"after-sample\",\n",
            &format!("  \"command_timing\": \"after-sample\",\n  \"weighting\": {bad},\n"),
        );
        let line = line_of(&text, "\"weighting\"");
        validate_refuses(&text, line, "weighting", &["\"tests\" or \"samples\"", shown]);
    }
}

#[test]
fn an_acquisition_share_that_is_no_share_of_the_period_is_refused_at_its_line() {
    for (bad, shown) in [
        ("0", "value 0 is not"),
        ("-0.1", "value -0.1 is not"),
        ("1.5", "value 1.5 is not"),
        ("\"a tenth\"", "found a string"),
    ] {
        let text = edit(
            PARAMS_JSON,
            "  \"command_timing\": \"after-sample\",\n",
            &format!("  \"command_timing\": \"after-sample\",\n  \"acquisition_window_periods\": {bad},\n"),
        );
        let line = line_of(&text, "\"acquisition_window_periods\"");
        validate_refuses(
            &text,
            line,
            "acquisition_window_periods",
            &["a share of the drive period between 0 and 1", shown],
        );
    }
}
