//! `mrfeel compare SCENARIO [--feel a,b] [--json] [--plot DIR] [--rerun FILE.rrd] [--faults]`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context;
use mrfeel::compare::{CompareScenario, Comparison, Row, Trace};
use mrfeel::faults::FaultKind;
use mrfeel::viz::plot::{save_charts, Chart, Series};

#[derive(Debug, clap::Args)]
#[command(
    mut_arg("json", |a| a.help("Print the results as JSON on stdout (the tables go to stderr)")),
    mut_arg("rerun", |a| a.help("Write a Rerun recording (.rrd) of every run")),
)]
pub struct CompareArgs {
    /// Comparison scenario (`scenarios/compare-feel.toml`).
    pub scenario: PathBuf,
    /// Feel systems to compare, comma-separated (default: the scenario's `systems`): centring_spring,
    /// variable_gradient_spring, q_feel, mr, mr_spring, active.
    #[arg(long)]
    pub feel: Option<String>,
    #[command(flatten)]
    pub output: super::OutputArgs,
    /// Also run every fault of `mrfeel::faults` on every system and print the fault table.
    #[arg(long)]
    pub faults: bool,
}

/// Every file `mrfeel compare` of the comparison `scn` (loaded from `path`) reads, which no output may
/// overwrite: the comparison, its base scenario and the files that names, and its feel-spring file.
pub fn input_files(path: &Path, scn: &CompareScenario) -> Vec<(&'static str, PathBuf)> {
    let mut files = vec![
        ("comparison scenario", path.to_path_buf()),
        ("base scenario", scn.base.path.clone()),
    ];
    files.extend(scn.base.named_files());
    files.push(("feel-spring file", scn.springs_path.clone()));
    files
}

fn fmt(v: f64, prec: usize) -> String {
    if v.is_finite() {
        format!("{v:.prec$}")
    } else {
        "—".into()
    }
}

/// The comparison table (markdown, so it pastes into `docs/explanation/feel-systems.md`).
pub fn comparison_table(scn: &CompareScenario, c: &Comparison) -> String {
    let (l23, lpro, l25) = scn.limits.newtons();
    let mut s = format!(
        "Feel systems on the stick rig ({}): forces at the grip. Limits: 14 CFR 23.143(c) stick pitch temporary {:.0} lbf = {:.1} N; 25.143 pitch one hand {:.0} lbf = {:.1} N; prolonged {:.0} lbf = {:.1} N.\n\n",
        scn.name,
        scn.limits.part23_stick_pitch_temporary_lbf,
        l23,
        scn.limits.part25_pitch_one_hand_lbf,
        l25,
        scn.limits.pitch_prolonged_lbf,
        lpro
    );
    s += "| system | force RMS error N | breakout N | gradient N/rad | phase lag deg | re-centre offset deg | re-centre time s | injected J | dissipated J | coil mean W | coil peak W | peak force N | ≤ Part 23 | tracking RMS deg |\n";
    s += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (k, m, _, _) in &c.systems {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            k.name(),
            fmt(m.force_rms_error_n, 2),
            fmt(m.breakout_n, 2),
            fmt(m.force_gradient_n_per_rad, 1),
            fmt(m.phase_lag_deg, 1),
            fmt(m.recentre_offset_rad.to_degrees(), 2),
            fmt(m.recentre_time_s, 2),
            fmt(m.energy_injected_j, 4),
            fmt(m.energy_dissipated_j, 3),
            fmt(m.coil_power_mean_w, 2),
            fmt(m.coil_power_peak_w, 1),
            fmt(m.peak_force_n, 1),
            if m.within_part23_temporary { "yes" } else { "NO" },
            fmt(m.tracking_rms_deg, 2),
        );
    }
    s
}

/// The fault table (markdown).
pub fn fault_table(scn: &CompareScenario, c: &Comparison) -> String {
    let mut s = format!(
        "Faults active {}–{} s of the standard task (sinusoidal motion, deflect–hold, let go at {:.1} s).\n\n",
        scn.fault_test.start_s,
        scn.fault_test.end_s,
        scn.main_task().segment_start_s(2)
    );
    s += "| system | fault | active steps | peak force N | force RMS err N (healthy) | tracking RMS deg | cmd A min–max | applied A mean | yield N mean | hands-off moved deg | moves away alone |\n";
    s += "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (r, _) in &c.faults {
        let m = &r.m;
        let no_path = !r.system.has_electrical_path();
        if no_path && r.fault != FaultKind::ALL[0] {
            continue; // one row: a spring feel unit has no coil, driver or sensors for a fault to act on
        }
        s += &format!(
            "| {} | {} | {} | {} | {} ({}) | {} | {}–{} | {} | {} | {} | {} |\n",
            r.system.name(),
            if no_path {
                "any (no electrical path)"
            } else {
                r.fault.name()
            },
            m.fault_steps,
            fmt(m.peak_force_n, 1),
            fmt(m.force_rms_error_n, 2),
            fmt(m.healthy_force_rms_error_n, 2),
            fmt(m.tracking_rms_deg, 2),
            fmt(m.current_cmd_min_a, 1),
            fmt(m.current_cmd_max_a, 1),
            fmt(m.current_applied_mean_a, 2),
            fmt(m.yield_mean_n, 1),
            fmt(m.hands_off_moved_rad.to_degrees(), 2),
            if m.moves_without_pilot { "YES" } else { "no" },
        );
    }
    s
}

/// JSON: `{"scenario", "systems": {name: {...}}, "faults": {system: {fault: {...}}}}`.
pub fn to_json(scn: &CompareScenario, c: &Comparison) -> serde_json::Value {
    let systems: serde_json::Map<String, serde_json::Value> = c
        .systems
        .iter()
        .map(|(k, m, _, _)| (k.name().to_string(), serde_json::to_value(m).unwrap_or_default()))
        .collect();
    let mut faults: BTreeMap<&str, serde_json::Map<String, serde_json::Value>> = BTreeMap::new();
    for (r, _) in &c.faults {
        faults.entry(r.system.name()).or_default().insert(
            r.fault.name().to_string(),
            serde_json::to_value(r.m).unwrap_or_default(),
        );
    }
    let mut v = serde_json::json!({
        "scenario": scn.name,
        "systems": systems,
    });
    if !c.faults.is_empty() {
        v["faults"] = serde_json::to_value(faults).unwrap_or_default();
    }
    v
}

fn plots(c: &Comparison, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut fd = Chart::new(
        "Force–deflection, sinusoidal stick motion",
        "stick angle (deg)",
        "pilot force at the grip (N)",
    );
    let mut rel = Chart::new("Letting go: stick angle", "time (s)", "stick angle (deg)");
    let mut cur = Chart::new("Coil current", "time (s)", "coil current (A)");
    let mut brk = Chart::new("Breakout: slow force ramp", "grip force (N)", "stick angle (deg)");
    let every = 5;
    // Every fifth row of a trace, as a point.
    let line = |name: &str, tr: &Trace, f: fn(&Row) -> (f64, f64)| {
        Series::line(name, tr.rows.iter().step_by(every).map(f).collect())
    };
    // Every fifth row of the sinusoidal motion: the stick angle against `f` of the row.
    let sweep = |tr: &Trace, f: fn(&Row) -> f64| -> Vec<(f64, f64)> {
        let rows = tr.rows.iter().filter(|r| r.segment == 0).step_by(every);
        rows.map(|r| (r.theta_rad.to_degrees(), f(r))).collect()
    };
    for (k, _, main, b) in &c.systems {
        fd.series
            .push(Series::line(k.name(), sweep(main, |r| r.hand_force_n)));
        rel.series
            .push(line(k.name(), main, |r| (r.t_s, r.theta_rad.to_degrees())));
        if k.has_coil() {
            cur.series
                .push(line(k.name(), main, |r| (r.t_s, r.coil_current_a)));
        }
        brk.series
            .push(line(k.name(), b, |r| (r.hand_force_n, r.theta_rad.to_degrees())));
    }
    if let Some((_, _, main, _)) = c.systems.first() {
        let mut tgt = sweep(main, |r| r.target_grip_n);
        tgt.sort_by(|a, b| a.0.total_cmp(&b.0));
        fd.series.push(Series::dashed("target", tgt));
    }
    let mut files = save_charts(&[fd, rel, cur, brk], 2, dir, "compare-feel")?;
    if !c.faults.is_empty() {
        let mut charts = Vec::new();
        for &f in FaultKind::ALL {
            let mut ch = Chart::new(
                format!("{}: stick angle", f.name()),
                "time (s)",
                "stick angle (deg)",
            );
            for (r, tr) in c.faults.iter().filter(|(r, _)| r.fault == f) {
                ch.series
                    .push(line(r.system.name(), tr, |q| (q.t_s, q.theta_rad.to_degrees())));
            }
            charts.push(ch);
        }
        files.extend(save_charts(&charts, 2, dir, "compare-faults")?);
    }
    Ok(files)
}

/// Write the recording `path` whole or not at all ([`mrfeel::outputs::write_whole`]).
#[cfg(feature = "rerun")]
fn rerun_log(c: &Comparison, path: &Path) -> anyhow::Result<()> {
    // Rerun's errors repeat their sources in their own text: report the text once, not its chain.
    let once = |e: &dyn std::fmt::Display| anyhow::anyhow!("--rerun {}: {e}", path.display());
    mrfeel::outputs::write_whole(path, |tmp| rerun_log_into(c, tmp, once), |e| once(&e))
}

#[cfg(feature = "rerun")]
fn rerun_log_into(
    c: &Comparison,
    tmp: &Path,
    once: impl Fn(&dyn std::fmt::Display) -> anyhow::Error,
) -> anyhow::Result<()> {
    let rec = rerun::RecordingStreamBuilder::new("mrfeel-compare")
        .save(tmp)
        .map_err(|e| once(&e))?;
    let log = |prefix: String, tr: &mrfeel::compare::Trace| -> anyhow::Result<()> {
        let times: Vec<f64> = tr.rows.iter().map(|r| r.t_s).collect();
        type Col = (&'static str, fn(&mrfeel::compare::Row) -> f64);
        let cols: [Col; 6] = [
            ("stick_angle_deg", |r| r.theta_rad.to_degrees()),
            ("grip_force_n", |r| r.hand_force_n),
            ("target_grip_n", |r| r.target_grip_n),
            ("coil_current_a", |r| r.coil_current_a),
            ("load_cell_n", |r| r.load_cell_true_n),
            ("fault_active", |r| f64::from(r.faults != 0)),
        ];
        for (name, f) in cols {
            let values: Vec<f64> = tr.rows.iter().map(f).collect();
            rec.send_columns(
                format!("{prefix}/{name}"),
                [rerun::TimeColumn::new_duration_secs(
                    "time",
                    times.iter().copied(),
                )],
                rerun::Scalars::new(values)
                    .columns_of_unit_batches()
                    .map_err(|e| once(&e))?,
            )
            .map_err(|e| once(&e))?;
        }
        Ok(())
    };
    for (k, _, main, brk) in &c.systems {
        log(format!("compare/{}/task", k.name()), main)?;
        log(format!("compare/{}/breakout", k.name()), brk)?;
    }
    for (r, tr) in &c.faults {
        log(format!("faults/{}/{}", r.fault.name(), r.system.name()), tr)?;
    }
    rec.flush_blocking().map_err(|e| once(&e))?;
    Ok(())
}

/// `mrfeel compare` of the comparison loaded from `a.scenario`.
pub fn run_cmd(a: CompareArgs, scn: CompareScenario) -> anyhow::Result<()> {
    let dropped = scn.base.faults.faults.len();
    if dropped > 0 {
        mrfeel::noteln!(
            "compare: the {dropped} [[fault]] table(s) of the base scenario {} are not used: a comparison runs \
             the faults of its own file ({}) and, with --faults, each fault of its [fault_test] in turn",
            scn.base.path.display(),
            a.scenario.display()
        );
    }
    let systems = match &a.feel {
        Some(list) => mrfeel::compare::parse_feel_list(list).map_err(|e| match e {
            mrfeel::compare::CompareError::Feel(msg) => {
                anyhow::anyhow!("--feel {list}: {msg} (nothing was run)")
            }
            e => e.into(),
        })?,
        None => scn.systems.clone(),
    };
    let bar = super::progress_bar(1, "{bar:40} {pos}/{len} runs {elapsed}");
    let c = mrfeel::compare::compare(&scn, &systems, a.faults, |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })?;
    bar.finish_and_clear();
    if !scn.faults.is_empty() {
        let names: Vec<String> = scn
            .faults
            .faults
            .iter()
            .map(|f| format!("{} {}–{} s", f.kind.name(), f.start_s, f.end_s))
            .collect();
        mrfeel::noteln!("scheduled faults (in every run): {}", names.join(", "));
    }
    let mut text = comparison_table(&scn, &c);
    if a.faults {
        text += "\n";
        text += &fault_table(&scn, &c);
    }
    // The files first, stdout last: a run that fails to write prints no result.
    if let Some(dir) = &a.output.plot {
        for f in plots(&c, dir)? {
            mrfeel::noteln!("wrote {}", f.display());
        }
    }
    #[cfg(feature = "rerun")]
    if let Some(p) = &a.output.rerun {
        rerun_log(&c, p)?;
        mrfeel::noteln!("wrote {}", p.display());
    }
    if a.output.json {
        mrfeel::note!("{text}");
        mrfeel::outln!("{}", serde_json::to_string_pretty(&to_json(&scn, &c))?)?;
    } else {
        mrfeel::out!("{text}")?;
    }
    Ok(())
}
