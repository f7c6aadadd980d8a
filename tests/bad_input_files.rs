//! Bad input files through the command line: measurement CSVs (extra columns, the `sample_rate_hz`
//! metadata), the rig's URDF, the files a scenario names and the aircraft it flies. Each bad file is an
//! error naming the file, the line and the field, with a non-zero exit and no output file; never a panic.

use crate::common;
use common::mrfeel;

use std::path::{Path, PathBuf};
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A refused input: non-zero exit, no panic, the expected text on stderr, nothing on stdout.
fn refused(o: &Output, expect: &[&str]) -> String {
    let e = stderr(o);
    assert!(!o.status.success(), "accepted; stderr:\n{e}");
    assert_eq!(
        o.status.code(),
        Some(1),
        "exit status {:?}; stderr:\n{e}",
        o.status
    );
    assert!(!e.contains("panicked"), "{e}");
    for x in expect {
        assert!(e.contains(x), "expected `{x}` in:\n{e}");
    }
    assert!(
        o.stdout.is_empty(),
        "stdout: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    e
}

/// 1-based line of the first line of `text` containing `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).expect(needle) + 1
}

// ---------------------------------------------------------------------------------------------------
// Measurement CSVs

/// A 2 Hz sine test of the paper device at 1 A, sampled at 1 kHz for one period, with extra header
/// metadata and extra columns as given.
fn sine_csv(meta: &str, extra_header: &str, extra_field: impl Fn(usize) -> String) -> String {
    let mut s = format!("# source: bad_input_files test\n{meta}t_s,x_m,i_a,f_n{extra_header}\n");
    for k in 0..500 {
        let t = k as f64 * 0.001;
        let w = 2.0 * std::f64::consts::PI * 2.0;
        let x = 0.01 * (w * t).sin();
        let v = 0.01 * w * (w * t).cos();
        let f = 20.0 * v.signum() + 200.0 * v;
        s.push_str(&format!("{t},{x},1,{f}{}\n", extra_field(k)));
    }
    s
}

fn validate(csv: &Path) -> Output {
    let device = root().join("models/paper-device.toml");
    mrfeel(&["validate", s(csv), "--params", s(&device), "--json"])
}

#[test]
fn extra_columns_are_kept_and_ignored_whatever_they_hold() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.csv");
    std::fs::write(&plain, sine_csv("", "", |_| String::new())).unwrap();
    let extra = dir.path().join("extra.csv");
    let text = |k: usize| match k % 3 {
        0 => ",hello".to_string(),
        1 => ",".to_string(),
        _ => ",\"a, b\"".to_string(),
    };
    std::fs::write(&extra, sine_csv("", ",note_x", text)).unwrap();
    let (a, b) = (validate(&plain), validate(&extra));
    assert!(a.status.success(), "{}", stderr(&a));
    assert!(b.status.success(), "{}", stderr(&b));
    // Ignored: the same figures as without the column.
    let nrmse = |o: &Output| -> f64 {
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["nrmse"].as_f64().expect("nrmse")
    };
    assert_eq!(nrmse(&a), nrmse(&b));
}

#[test]
fn the_specs_own_columns_stay_strict_next_to_extra_ones() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("temp.csv");
    let text = sine_csv("", ",temp_c,note_x", |k| {
        if k == 7 {
            ",warm,x".into()
        } else {
            ",20,x".into()
        }
    });
    std::fs::write(&csv, &text).unwrap();
    let line = line_of(&text, "warm");
    refused(
        &validate(&csv),
        &[&format!(
            "temp.csv:{line}: column `temp_c`: not a number (value `warm`)"
        )],
    );
}

#[test]
fn malformed_or_non_positive_sample_rate_is_an_error_naming_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    for (value, why) in [
        ("abc", "not a number"),
        ("-200", "must be > 0"),
        ("0", "must be > 0"),
        ("inf", "not a finite number"),
    ] {
        let csv = dir.path().join("rate.csv");
        std::fs::write(
            &csv,
            sine_csv(&format!("# sample_rate_hz: {value}\n"), "", |_| String::new()),
        )
        .unwrap();
        // Line 2: after the `# source:` line.
        refused(
            &validate(&csv),
            &[
                "rate.csv:2: metadata `sample_rate_hz`: ",
                why,
                &format!("`{value}`"),
            ],
        );
    }
}

#[test]
fn a_declared_rate_that_contradicts_the_time_column_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("clock.csv");
    // The samples are 1 ms apart: 1000 Hz. 100 Hz is another clock.
    std::fs::write(&csv, sine_csv("# sample_rate_hz: 100\n", "", |_| String::new())).unwrap();
    refused(
        &validate(&csv),
        &["clock.csv:2: metadata `sample_rate_hz`: 100 Hz", "`t_s`"],
    );
    // The right rate passes.
    std::fs::write(&csv, sine_csv("# sample_rate_hz: 1000\n", "", |_| String::new())).unwrap();
    let o = validate(&csv);
    assert!(o.status.success(), "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------------
// Scenarios, the rig's URDF and the files a scenario names

/// `scenarios/<name>` written into `dir` with its `../models/` paths made absolute, then `edit`ed.
fn scenario(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> (PathBuf, String) {
    let text = std::fs::read_to_string(root().join("scenarios").join(name))
        .unwrap()
        .replace("\"../models/", &format!("\"{}/models/", root().display()));
    let text = edit(text);
    let p = dir.join("scn.toml");
    std::fs::write(&p, &text).unwrap();
    (p, text)
}

/// `mrfeel run` of a scenario into `dir/out.csv`; the output must not exist after a refusal.
fn run(dir: &Path, scn: &Path, extra: &[&str]) -> Output {
    let out = dir.join("out.csv");
    let mut args = vec!["run", s(scn), "--out", s(&out)];
    args.extend_from_slice(extra);
    let o = mrfeel(&args);
    if !o.status.success() {
        assert!(!out.exists(), "a refused run left {}", out.display());
    }
    o
}

/// Run the paper's feel loop on the shipped rig URDF with `from` replaced by `to`; the error names
/// `bad.urdf` at the line of `at` (in the edited text) and the given texts.
fn bad_urdf(from: &str, to: &str, at: &str, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let urdf = std::fs::read_to_string(root().join("models/stick-rig.urdf")).unwrap();
    assert!(urdf.contains(from), "{from}");
    let bad = urdf.replacen(from, to, 1);
    let path = dir.path().join("bad.urdf");
    std::fs::write(&path, &bad).unwrap();
    let (scn, _) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
        t.replace(&format!("{}/models/stick-rig.urdf", root().display()), s(&path))
    });
    let line = line_of(&bad, at);
    let mut want = vec![format!("bad.urdf:{line}: ")];
    want.extend(expect.iter().map(|x| x.to_string()));
    let want: Vec<&str> = want.iter().map(String::as_str).collect();
    refused(&run(dir.path(), &scn, &[]), &want);
}

#[test]
fn urdf_value_errors_name_the_real_line_element_and_attribute() {
    bad_urdf(
        r#"<mass value="0.383035"/>"#,
        r#"<mass value="heavy"/>"#,
        "heavy",
        &["link `stick`: inertial/mass: `value`: `heavy` is not a number"],
    );
    bad_urdf(
        r#"<joint name="piston_slide" type="prismatic">"#,
        r#"<joint name="piston_slide" type="prismatik">"#,
        "prismatik",
        &["joint `piston_slide`: `type`: `prismatik` is not one of: revolute"],
    );
    bad_urdf(
        r#"<origin xyz="-0.5221 0 0.15"/>"#,
        r#"<origin xyz="-0.5221 0"/>"#,
        r#"xyz="-0.5221 0""#,
        &["joint `cylinder_mount`: origin: `xyz`: `-0.5221 0` has 2 values, 3 expected"],
    );
    bad_urdf(
        r#"<mass value="0.383035"/>"#,
        r#"<mass valu="0.383035"/>"#,
        "valu=",
        &["link `stick`: inertial/mass: unknown attribute `valu` (allowed: value)"],
    );
}

#[test]
fn negative_joint_losses_in_the_urdf_are_errors_naming_the_attribute() {
    // A negative pivot damping fed energy in: an energy residual of -1.01 and an 85 kN load cell.
    bad_urdf(
        r#"<dynamics damping="0" friction="0"/>"#,
        r#"<dynamics damping="-5" friction="0"/>"#,
        r#"damping="-5""#,
        &["joint `stick_pivot`: dynamics: `damping`: -5 must be ≥ 0"],
    );
    bad_urdf(
        r#"<dynamics damping="0" friction="0"/>"#,
        r#"<dynamics damping="0" friction="-0.5"/>"#,
        r#"friction="-0.5""#,
        &["joint `stick_pivot`: dynamics: `friction`: -0.5 must be ≥ 0"],
    );
}

#[test]
fn urdf_that_is_not_xml_names_the_line() {
    bad_urdf(
        r#"<loop_joint name="rod_end_pin" type="revolute">"#,
        r#"<loop_jont name="rod_end_pin" type="revolute">"#,
        "</loop_joint>",
        &["`</loop_joint>` does not close `<loop_jont>` opened at line 207"],
    );
    bad_urdf("</robot>", "", "<robot name", &["`<robot>` is never closed"]);
}

#[test]
fn urdf_nested_too_deep_is_an_error_at_its_line_not_a_crash() {
    // 50 000 nested unknown elements took the URDF reader past the stack (SIGABRT, exit 134).
    let deep = format!(
        "\n  {}{}\n</robot>",
        "<deep>".repeat(50_000),
        "</deep>".repeat(50_000)
    );
    bad_urdf(
        "\n</robot>",
        &deep,
        "<deep>",
        &[
            "not a valid URDF (XML)",
            "`<deep>` is nested 257 elements deep",
            "256",
        ],
    );
}

#[test]
fn a_schedule_point_is_exactly_two_numbers() {
    // `[3.0]` was refused, but `[3.0, 5.0, "junk", 7]` passed as `[3.0, 5.0]`, the rest dropped.
    let dir = tempfile::tempdir().unwrap();
    for (point, found) in [
        ("[3.0, 5.0, \"junk\", 7]", "4"),
        ("[3.0, 5.0, 6.0]", "3"),
        ("[3.0]", "1"),
    ] {
        let (scn, text) = scenario(dir.path(), "c172p-pitch-tracking.toml", |t| {
            t.replacen("[3.0, 5.0]", point, 1)
        });
        let line = line_of(&text, point);
        refused(
            &run(dir.path(), &scn, &[]),
            &[
                &format!("scn.toml:{line}: "),
                &format!("invalid length {found}"),
                "[t_s, value]",
            ],
        );
    }
    let (scn, text) = scenario(dir.path(), "737-approach.toml", |t| {
        t.replacen("[3.0, 0.6]", "[3.0, 0.6, 0.7]", 1)
    });
    let line = line_of(&text, "[3.0, 0.6, 0.7]");
    refused(
        &run(dir.path(), &scn, &[]),
        &[&format!("scn.toml:{line}: "), "invalid length 3"],
    );
}

/// `paper-feel-loop.toml` with `tables` appended.
fn with_faults(dir: &Path, tables: &str) -> (PathBuf, String) {
    scenario(dir, "paper-feel-loop.toml", |t| format!("{t}\n{tables}"))
}

#[test]
fn a_fault_table_error_names_the_line_of_its_key_however_the_header_is_spelled() {
    // `[[ fault ]]` (valid TOML) was not found by a text search for `[[fault]]`: the error said line 0.
    let dir = tempfile::tempdir().unwrap();
    let (scn, text) = with_faults(
        dir.path(),
        "[[ fault ]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\n\n[[ fault ]]\n\
         kind = \"coil_shorted\"\nstart_s = 1.0\nend_s = 2.0\n",
    );
    let line = line_of(&text, "coil_shorted");
    refused(
        &run(dir.path(), &scn, &[]),
        &[&format!(
            "scn.toml:{line}: field `fault.2.kind`: `coil_shorted` is not one of"
        )],
    );
}

#[test]
fn a_fault_that_ends_where_it_starts_is_refused() {
    // Active on start_s ≤ t < end_s, it never acts: it was accepted and changed nothing.
    let dir = tempfile::tempdir().unwrap();
    let (scn, text) = with_faults(
        dir.path(),
        "[[fault]]\nkind = \"coil_open\"\nstart_s = 2.0\nend_s = 2.0\n",
    );
    let line = line_of(&text, "end_s = 2.0");
    refused(
        &run(dir.path(), &scn, &[]),
        &[&format!("scn.toml:{line}: field `fault.1.end_s`: "), "never act"],
    );
}

#[test]
fn a_device_stroke_that_the_urdf_contradicts_is_refused_naming_both_files() {
    // The device file's stroke_half_in was ignored by `run`, which took the URDF's piston stops.
    let dir = tempfile::tempdir().unwrap();
    let device = std::fs::read_to_string(root().join("models/paper-device.toml")).unwrap();
    let short = device.replacen("stroke_half_in = 2.0", "stroke_half_in = 1.0", 1);
    assert_ne!(short, device);
    let device_path = dir.path().join("short-stroke.toml");
    std::fs::write(&device_path, &short).unwrap();
    let (scn, _) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
        t.replace(
            &format!("{}/models/paper-device.toml", root().display()),
            s(&device_path),
        )
    });
    let urdf = std::fs::read_to_string(root().join("models/stick-rig.urdf")).unwrap();
    let limit = line_of(&urdf, r#"<limit lower="-0.0508" upper="0.0508""#);
    refused(
        &run(dir.path(), &scn, &[]),
        &[
            &format!("stick-rig.urdf:{limit}: joint `piston_slide`: limit"),
            "[-0.0508, 0.0508] m",
            "±0.0254 m (±1 in",
            &format!("short-stroke.toml:{}", line_of(&short, "stroke_half_in")),
        ],
    );
}

#[test]
fn duplicate_link_names_and_massless_moving_links_are_errors() {
    // The line of the duplicate, not of the first link; the first is named by its line.
    let urdf = std::fs::read_to_string(root().join("models/stick-rig.urdf")).unwrap();
    let first = line_of(&urdf, r#"<link name="stick">"#);
    let second = line_of(&urdf, r#"<link name="push_rod">"#);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.urdf");
    std::fs::write(
        &path,
        urdf.replacen(r#"<link name="push_rod">"#, r#"<link name="stick">"#, 1),
    )
    .unwrap();
    let (scn, _) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
        t.replace(&format!("{}/models/stick-rig.urdf", root().display()), s(&path))
    });
    refused(
        &run(dir.path(), &scn, &[]),
        &[&format!(
            "bad.urdf:{second}: link `stick`: name: a second link named `stick` (the first is at line {first})"
        )],
    );
    bad_urdf(
        r#"<mass value="0.383035"/>"#,
        r#"<mass value="0"/>"#,
        r#"<mass value="0"/>"#,
        &[
            "link `stick`: inertial/mass: mass 0 kg",
            "joint `stick_pivot` (revolute)",
            "mass > 0",
        ],
    );
}

#[test]
fn a_missing_file_named_by_a_scenario_names_the_scenario_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    for (from, key) in [
        ("models/pilot-hand.toml", "pilot.model"),
        ("models/paper-device.toml", "device.file"),
        ("models/stick-rig.urdf", "rig.urdf"),
    ] {
        let (scn, text) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
            t.replace(from, "models/nope.toml")
        });
        let line = line_of(&text, "nope.toml");
        refused(
            &run(dir.path(), &scn, &[]),
            &[&format!("scn.toml:{line}: field `{key}`: "), "nope.toml"],
        );
    }
}

#[test]
fn a_bad_pilot_model_file_names_both_files() {
    let dir = tempfile::tempdir().unwrap();
    let hand = dir.path().join("hand.toml");
    let good = std::fs::read_to_string(root().join("models/pilot-hand.toml")).unwrap();
    let bad = good.replacen("mass_kg", "mas_kg", 1);
    std::fs::write(&hand, &bad).unwrap();
    let (scn, text) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
        t.replace(&format!("{}/models/pilot-hand.toml", root().display()), s(&hand))
    });
    refused(
        &run(dir.path(), &scn, &[]),
        &[
            &format!("scn.toml:{}: field `pilot.model`: ", line_of(&text, "hand.toml")),
            &format!("hand.toml:{}: unknown field `mas_kg`", line_of(&bad, "mas_kg")),
        ],
    );
}

// ---------------------------------------------------------------------------------------------------
// Aircraft models

#[test]
fn an_aircraft_name_is_never_a_path() {
    let dir = tempfile::tempdir().unwrap();
    // In a scenario: the line and key.
    let (scn, text) = scenario(dir.path(), "c172p-pitch-tracking.toml", |t| {
        t.replacen("model = \"c172p\"", "model = \"../../c172p\"", 1)
    });
    refused(
        &run(dir.path(), &scn, &[]),
        &[
            &format!(
                "scn.toml:{}: field `aircraft.model`: ",
                line_of(&text, "../../c172p")
            ),
            "not a model name",
        ],
    );
    // On the command line: the models directory is not left.
    let (scn, _) = scenario(dir.path(), "c172p-pitch-tracking.toml", |t| t);
    let e = refused(
        &run(dir.path(), &scn, &["--aircraft", "../../models/aircraft/c172p"]),
        &[
            "aircraft `../../models/aircraft/c172p`: not a model name",
            "737, T37, c172p",
        ],
    );
    assert!(!e.contains("No such file"), "{e}");
}

/// `text` with the line `extra` (bytes, not UTF-8) put after its first line.
fn after_first_line(text: &str, extra: &[u8]) -> Vec<u8> {
    let at = text.find('\n').unwrap() + 1;
    [&text.as_bytes()[..at], extra, b"\n", &text.as_bytes()[at..]].concat()
}

/// Text inputs in another encoding (a Latin-1 `é` in a comment on line 2): the error names the file and
/// the line and column of the first byte that is not UTF-8, for the rig's URDF, the scenario and a device
/// file.
#[test]
fn a_text_input_that_is_not_utf8_names_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = std::fs::read_to_string(root().join("models/stick-rig.urdf")).unwrap();
    let path = dir.path().join("latin1.urdf");
    std::fs::write(&path, after_first_line(&urdf, b"<!-- caf\xe9 -->")).unwrap();
    let (scn, text) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
        t.replace(&format!("{}/models/stick-rig.urdf", root().display()), s(&path))
    });
    refused(
        &run(dir.path(), &scn, &[]),
        &["latin1.urdf", "line 2, column 9", "0xe9", "not UTF-8"],
    );
    std::fs::write(&scn, after_first_line(&text, b"# caf\xe9")).unwrap();
    refused(
        &run(dir.path(), &scn, &[]),
        &["scn.toml", "line 2, column 6", "not UTF-8"],
    );
    let device = std::fs::read_to_string(root().join("models/paper-device.toml")).unwrap();
    let dev = dir.path().join("dev.toml");
    std::fs::write(&dev, after_first_line(&device, b"# caf\xe9")).unwrap();
    let out = dir.path().join("mts.csv");
    refused(
        &mrfeel(&["mts", "--device", s(&dev), "--current", "1", "--out", s(&out)]),
        &["dev.toml", "line 2, column 6", "not UTF-8"],
    );
    assert!(!out.exists());
}

/// A physics rate within the scenario's range but too coarse for the rig and loop makes the integration
/// blow up: the run stops with an error naming `rig.physics_hz` and the time, writing nothing (it exited 0
/// with a piston at 1e32 m and NaN in the CSV); the same scenario at its own rate runs.
#[test]
fn a_simulation_that_diverges_is_an_error_not_results() {
    let dir = tempfile::tempdir().unwrap();
    let (scn, text) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
        t.replace("physics_hz = 1000.0", "physics_hz = 100.0")
            .replace("sample_rate_hz = 1000.0", "sample_rate_hz = 100.0")
    });
    let line = line_of(&text, "physics_hz = 100.0");
    let err = refused(
        &run(dir.path(), &scn, &[]),
        &[&format!("scn.toml:{line}: `rig.physics_hz`"), "diverged at t ="],
    );
    assert!(
        err.contains("stroke") || err.contains("is NaN") || err.contains("is inf"),
        "{err}"
    );
    let (ok, _) = scenario(dir.path(), "paper-feel-loop.toml", |t| t);
    let o = run(dir.path(), &ok, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A run of more physics steps than its results can hold is refused at the `duration_s` line (an hour at
/// 100 kHz, both within their ranges, aborted asking for 107 GB).
#[test]
fn a_run_too_long_for_its_physics_rate_is_refused_at_its_duration() {
    let dir = tempfile::tempdir().unwrap();
    let (scn, text) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
        t.replace("duration_s = 12.0", "duration_s = 3600.0")
            .replace("physics_hz = 1000.0", "physics_hz = 100000.0")
    });
    let at = format!("scn.toml:{}", line_of(&text, "duration_s = 3600.0"));
    refused(
        &run(dir.path(), &scn, &[]),
        &[&at, "duration_s", "360000000 physics steps", "1e7"],
    );
}

/// A flight condition the aircraft cannot hold (the C172 at 70 m/s needs 127 % throttle) is refused by the
/// trim with the line of `aircraft.airspeed_m_s`, where it had named the file alone; nothing is written.
#[test]
fn an_untrimmable_flight_condition_names_the_airspeed_line() {
    let dir = tempfile::tempdir().unwrap();
    let (scn, text) = scenario(dir.path(), "c172p-pitch-tracking.toml", |t| {
        t.replace("airspeed_m_s = 50.0", "airspeed_m_s = 70.0")
    });
    let line = line_of(&text, "airspeed_m_s = 70.0");
    refused(
        &run(dir.path(), &scn, &[]),
        &[&format!("scn.toml:{line}: aircraft: trim failed"), "throttle"],
    );
}

/// The device and the URDF a scenario names must be regular files (a comparison or a DAQ sweep reads them
/// for every run, which a pipe cannot give twice): a device node or a directory is refused at the key's
/// line, saying what it is.
#[test]
#[cfg(unix)]
fn a_scenario_file_that_is_a_device_or_a_directory_is_refused_at_its_key() {
    let dir = tempfile::tempdir().unwrap();
    let models = format!("{}/models/", root().display());
    for (to, says) in [
        ("/dev/zero", "not a regular file"),
        (models.as_str(), "a directory, not a file"),
    ] {
        let (scn, text) = scenario(dir.path(), "paper-feel-loop.toml", |t| {
            t.replace(
                &format!("file = \"{models}paper-device.toml\""),
                &format!("file = \"{to}\""),
            )
        });
        let line = line_of(&text, &format!("file = \"{to}\""));
        refused(
            &run(dir.path(), &scn, &[]),
            &[&format!("scn.toml:{line}: field `device.file`"), says],
        );
    }
}
