//! The foundation through the command line: the virtual MTS machine, its CSV, device files and errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use mrfeel::measurement::Measurement;

use crate::common;
use common::mrfeel;

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn mts_csv_reads_back_to_the_same_numbers_and_same_seed_same_bytes() {
    let d = tmp();
    let (a, b, c) = (
        d.path().join("a.csv"),
        d.path().join("b.csv"),
        d.path().join("c.csv"),
    );
    let args = |out: &PathBuf, seed: &str| -> Vec<String> {
        [
            "mts",
            "--current",
            "2.2,5,14",
            "--protocol",
            "sine",
            "--amplitude-m",
            "0.0254",
            "--frequency-hz",
            "0.5",
        ]
        .iter()
        .map(|x| x.to_string())
        .chain(["--seed".into(), seed.into(), "--out".into(), s(out).into()])
        .collect()
    };
    for (out, seed) in [(&a, "7"), (&b, "7"), (&c, "8")] {
        let o = Command::new(env!("CARGO_BIN_EXE_mrfeel"))
            .args(args(out, seed))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", text(&o).1);
    }
    let (ba, bb, bc) = (
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        std::fs::read(&c).unwrap(),
    );
    assert_eq!(ba, bb, "same seed, same bytes");
    assert_ne!(ba, bc, "another seed, other noise");
    let m = Measurement::read(&a).unwrap();
    // 3 blocks of 3 cycles at 0.5 Hz sampled at 1 kHz.
    assert_eq!(m.len(), 18_000);
    assert!(m.velocity_measured);
    // Written again, it reads back to identical numbers (shortest round-trip formatting).
    let again = d.path().join("again.csv");
    m.write(&again).unwrap();
    let m2 = Measurement::read(&again).unwrap();
    assert_eq!(
        (m2.t_s, m2.x_m, m2.v_m_s, m2.i_a, m2.f_n),
        (m.t_s, m.x_m, m.v_m_s, m.i_a, m.f_n)
    );
}

#[test]
fn mts_summary_reports_the_papers_forces_and_plots_are_written() {
    let d = tmp();
    let out = d.path().join("t.csv");
    let plots = d.path().join("plots");
    let o = mrfeel(&[
        "mts",
        "--current",
        "2.2,5,14",
        "--protocol",
        "triangle",
        "--amplitude-m",
        "0.0254",
        "--frequency-hz",
        "0.2",
        "--out",
        s(&out),
        "--plot",
        s(&plots),
    ]);
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    // The steady force per current printed on stdout is within 10 % of the paper's (10, 25, 70 N).
    let forces: Vec<f64> = stdout
        .lines()
        .skip(1)
        .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
        .collect();
    for (got, want) in forces.iter().zip([10.0, 25.0, 70.0]) {
        assert!((got - want).abs() <= 0.1 * want, "{got} vs {want}\n{stdout}");
    }
    for f in ["mts.png", "mts.svg"] {
        let meta = std::fs::metadata(plots.join(f)).unwrap();
        assert!(meta.len() > 10_000, "{f} is too small to hold three panels");
    }
}

#[test]
fn bad_device_file_names_file_line_and_field() {
    let d = tmp();
    let dev = d.path().join("dev.toml");
    std::fs::write(
        &dev,
        "model = \"bingham\"\n[params]\nfc0_n = 0.0\nfc_gain_n_per_a = 5.0\nc0_n_s_per_m = -1.0\nte_s = 0.01\ntm_s = 0.01\n",
    )
    .unwrap();
    let o = mrfeel(&[
        "mts",
        "--device",
        s(&dev),
        "--current",
        "1",
        "--out",
        s(&d.path().join("x.csv")),
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("dev.toml:5") && err.contains("c0_n_s_per_m") && err.contains("range"),
        "{err}"
    );
    assert!(!d.path().join("x.csv").exists(), "no output on error");

    std::fs::write(&dev, "model = \"bingham+wobble\"\n[params]\n").unwrap();
    let (_, err) = text(&mrfeel(&[
        "mts",
        "--device",
        s(&dev),
        "--current",
        "1",
        "--out",
        "/dev/null",
    ]));
    assert!(
        err.contains("dev.toml:1") && err.contains("wobble") && err.contains("known effects"),
        "{err}"
    );

    std::fs::write(&dev, "model = \"bingham\"\ncolour = 3\n[params]\n").unwrap();
    let (_, err) = text(&mrfeel(&[
        "mts",
        "--device",
        s(&dev),
        "--current",
        "1",
        "--out",
        "/dev/null",
    ]));
    assert!(err.contains("dev.toml:2") && err.contains("colour"), "{err}");
}

#[test]
fn bad_protocol_and_amplitude_are_refused_with_a_reason() {
    let d = tmp();
    let out = d.path().join("x.csv");
    let o = mrfeel(&["mts", "--current", "1", "--protocol", "square", "--out", s(&out)]);
    assert!(!o.status.success() && text(&o).1.contains("unknown protocol `square`"));
    let o = mrfeel(&["mts", "--current", "1", "--amplitude-m", "0.06", "--out", s(&out)]);
    assert!(
        !o.status.success() && text(&o).1.contains("stroke"),
        "{}",
        text(&o).1
    );
    let o = mrfeel(&["mts", "--current", "1,-2", "--out", s(&out)]);
    assert!(!o.status.success() && text(&o).1.contains("-2"), "{}", text(&o).1);
    assert!(!out.exists());
}

#[test]
fn load_cell_saturation_is_an_error_not_a_clipped_record() {
    let d = tmp();
    let out = d.path().join("x.csv");
    // 14 A on the paper's device gives ~68 N; a 50 N cell saturates.
    let o = mrfeel(&[
        "mts",
        "--current",
        "14",
        "--load-cell-range-n",
        "50",
        "--out",
        s(&out),
    ]);
    assert!(
        !o.status.success() && text(&o).1.contains("saturated"),
        "{}",
        text(&o).1
    );
    assert!(!out.exists());
    // The other channels clip too (noise pushes them to their sensor's range), and a force coarser than
    // one step of the ADC reads zero throughout, which `fit` then refuses: each exited 0 with the file.
    for (args, says) in [
        (["--position-noise-m", "1"], "displacement reading reached"),
        (["--velocity-noise-m-s", "100"], "velocity reading reached"),
        (["--load-cell-range-n", "1e300"], "force reads 0 at every sample"),
    ] {
        let mut argv = vec!["mts", "--current", "1", "--out", s(&out)];
        argv.extend(args);
        let o = mrfeel(&argv);
        assert!(
            !o.status.success() && text(&o).1.contains(says),
            "{args:?}: {}",
            text(&o).1
        );
        assert!(!out.exists(), "{args:?} wrote the record");
    }
}

/// Synthetic data made with hidden effects can serve as a blind test: its CSV names none of them (nor the
/// model); the `--save-device` file does.
#[test]
fn mts_hidden_effects_are_named_only_in_the_saved_device() {
    let dir = tmp();
    let (csv, dev) = (dir.path().join("blind.csv"), dir.path().join("truth.json"));
    let o = mrfeel(&[
        "mts",
        "--current",
        "3,9",
        "--cycles",
        "1",
        "--effects",
        "hysteresis,asymmetry",
        "--out",
        s(&csv),
        "--save-device",
        s(&dev),
    ]);
    assert!(o.status.success(), "{:?}", text(&o));
    let data = std::fs::read_to_string(&csv).unwrap();
    for word in ["hysteresis", "asymmetry", "hyst_", "asym_", "bingham"] {
        assert!(!data.contains(word), "the CSV reveals `{word}`");
    }
    let truth = std::fs::read_to_string(&dev).unwrap();
    assert!(truth.contains("bingham+") && truth.contains("hysteresis") && truth.contains("asymmetry"));
}
