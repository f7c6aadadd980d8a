//! `mrfeel mts`: the virtual MTS machine on the command line.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::measurement::Measurement;
use mrfeel::mts::{with_hidden_effects, MtsTest, Protocol, SensorSpec};
use mrfeel::viz::plot::{save_charts, Chart, Series};

#[derive(Args, Debug, Clone)]
pub struct MtsArgs {
    /// Device file (`models/*.toml` or a fitted PARAMS.json); default: the paper's device (models/paper-device.toml).
    #[arg(long)]
    pub device: Option<PathBuf>,
    /// Current levels, A, one per block, comma-separated (the current steps between blocks).
    #[arg(long, value_delimiter = ',', required = true)]
    pub current: Vec<f64>,
    /// Displacement protocol: sine, triangle (constant velocity) or multisine.
    #[arg(long, default_value = "sine")]
    pub protocol: String,
    /// Displacement amplitude, m (peak, from mid-stroke).
    #[arg(long, default_value_t = 0.0254)]
    pub amplitude_m: f64,
    /// Frequency, Hz (the lowest tone for a multisine, whose tones span a decade).
    #[arg(long, default_value_t = 0.5)]
    pub frequency_hz: f64,
    /// Protocol cycles per current block.
    #[arg(long, default_value_t = 3.0)]
    pub cycles: f64,
    /// DAQ sample rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    pub sample_rate_hz: f64,
    /// Integration rate of the device model, Hz.
    #[arg(long, default_value_t = 10_000.0)]
    pub physics_hz: f64,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Load-cell noise, N (standard deviation).
    #[arg(long, default_value_t = 0.15)]
    pub force_noise_n: f64,
    /// Load-cell range, N (±); default: the device file's load cell, else 250 N.
    #[arg(long)]
    pub load_cell_range_n: Option<f64>,
    /// Displacement-sensor noise, m (standard deviation).
    #[arg(long, default_value_t = 2e-6)]
    pub position_noise_m: f64,
    /// Velocity-channel noise, m/s (standard deviation).
    #[arg(long, default_value_t = 2e-4)]
    pub velocity_noise_m_s: f64,
    /// ADC resolution of every channel, bits (0: no quantisation).
    #[arg(long, default_value_t = 16)]
    pub adc_bits: u32,
    /// Do not record velocity (readers then derive it from displacement).
    #[arg(long)]
    pub no_velocity: bool,
    /// Also record the coil current (the Eq. 3 state) as `i_meas_a`.
    #[arg(long)]
    pub coil_current: bool,
    /// Hidden effects added to the device for synthetic data, comma-separated (e.g. hysteresis,asymmetry).
    #[arg(long, value_delimiter = ',')]
    pub effects: Vec<String>,
    /// Set a model parameter, NAME=VALUE (repeatable), e.g. --set hyst_x_yield_m=0.001.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Write the device this run simulated (model with its hidden effects, every parameter) as a
    /// PARAMS.json. The hidden effects' strengths are scaled to each run's test, so runs with other
    /// protocols are other devices; give this file to later runs as `--device` (without `--effects`) to
    /// test the same device again. The file holds the damper model, not the rig: a device TOML's
    /// `[geometry]` (stroke) and load-cell range are not in it, so the displacement channel's full scale,
    /// and with it its ADC rounding (about 1 µm), can differ from a run of the TOML.
    #[arg(long, value_name = "PARAMS.json")]
    pub save_device: Option<PathBuf>,
    /// Output CSV (measurement format).
    #[arg(long)]
    pub out: PathBuf,
    /// Write force–displacement, force–velocity and force–time plots per current (PNG and SVG) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// Load the device named on the command line, or the paper's.
pub fn load_device(path: Option<&Path>, registry: &Registry) -> Result<DeviceConfig> {
    Ok(match path {
        Some(p) => DeviceConfig::load(p, registry)?,
        None => DeviceConfig::from_toml(
            mrfeel::builtin::PAPER_DEVICE,
            Path::new("<built-in>/models/paper-device.toml"),
            registry,
        )?,
    })
}

/// `--set NAME=VALUE` items; a parameter set twice is refused (which value was meant?).
fn parse_set(items: &[String]) -> Result<Vec<(String, f64)>> {
    let mut out: Vec<(String, f64)> = Vec::with_capacity(items.len());
    for s in items {
        let (k, v) = s
            .split_once('=')
            .with_context(|| format!("--set `{s}`: expected NAME=VALUE"))?;
        let v: f64 = v
            .trim()
            .parse()
            .with_context(|| format!("--set `{s}`: `{v}` is not a number"))?;
        let k = k.trim().to_string();
        if k.is_empty() {
            bail!("--set `{s}`: expected NAME=VALUE (the name is empty)");
        }
        if let Some((_, first)) = out.iter().find(|(name, _)| *name == k) {
            bail!("--set {k}: set twice (to {first} and to {v}); give each parameter once (nothing was run)");
        }
        out.push((k, v));
    }
    Ok(out)
}

/// `--effects` items: each named once, and none the device already has (it would be added to nothing).
fn check_effects(effects: &[String], device: &DeviceConfig) -> Result<()> {
    for (k, e) in effects.iter().enumerate() {
        if e.trim().is_empty() {
            bail!(
                "--effects {}: empty effect name (nothing was run)",
                effects.join(",")
            );
        }
        if effects[..k].contains(e) {
            bail!(
                "--effects {}: effect `{e}` named twice; name each effect once (nothing was run)",
                effects.join(",")
            );
        }
        if device.model.spec().has(e) {
            bail!(
                "--effects {}: the device (`{}`, model `{}`) already has `{e}`; a hidden effect is one the \
                 device lacks (nothing was run)",
                effects.join(","),
                device.path.display(),
                device.model.name()
            );
        }
    }
    Ok(())
}

/// The sensor options checked where the user gave them, so that an error names the option (the device
/// file's load-cell range is checked, at its line, when the file is read).
fn check_sensor_options(a: &MtsArgs, range_n: f64) -> Result<()> {
    let channels = [
        ("load_cell", a.force_noise_n, range_n, "--force-noise-n"),
        ("displacement", a.position_noise_m, 1.0, "--position-noise-m"),
        ("velocity", a.velocity_noise_m_s, 1.0, "--velocity-noise-m-s"),
    ];
    for (channel, noise, range, noise_option) in channels {
        if let Err(e) = mrfeel::sensors::check_channel(channel, noise, range, a.adc_bits) {
            let option = match e.field {
                "noise_rms" => noise_option,
                "range" => "--load-cell-range-n",
                _ => "--adc-bits",
            };
            bail!("{option}: {e}");
        }
    }
    Ok(())
}

/// Refuse a record that does not say what happened: a channel that saturated at its sensor's range (its
/// readings clipped: the load cell's, and the displacement's or the velocity's, whose noise can push them
/// there), or a force that quantised to zero at every sample, which the measurement reader then refuses.
fn check_record(m: &mrfeel::measurement::Measurement, test: &MtsTest) -> Result<()> {
    let clipped = |y: &[f64], range: f64| y.iter().filter(|v| v.abs() >= range * 0.999).count();
    let short = mrfeel::input::text::short_number;
    let range_n = short(test.load_cell.range);
    let n = clipped(&m.f_n, test.load_cell.range);
    if n > 0 {
        bail!(
            "the load cell saturated at ±{range_n} N on {n} samples: raise --load-cell-range-n or lower the current/velocity (nothing written)"
        );
    }
    let n = clipped(&m.x_m, test.displacement.range);
    if n > 0 {
        bail!(
            "the displacement reading reached the sensor's ±{} m on {n} samples (clipped there): lower --position-noise-m or raise --adc-bits (nothing written)",
            short(test.displacement.range)
        );
    }
    if m.velocity_measured {
        let n = clipped(&m.v_m_s, test.velocity.range);
        if n > 0 {
            bail!(
                "the velocity reading reached the sensor's ±{} m/s on {n} samples (clipped there): lower --velocity-noise-m-s or raise --adc-bits (nothing written)",
                short(test.velocity.range)
            );
        }
    }
    if m.f_n.iter().all(|&f| f == 0.0) {
        bail!(
            "the force reads 0 at every sample: one step of the {}-bit load cell over ±{range_n} N is coarser than the force; lower --load-cell-range-n or raise --adc-bits (nothing written)",
            test.load_cell.bits
        );
    }
    Ok(())
}

pub fn run(a: MtsArgs) -> Result<()> {
    if let Some(path) = &a.save_device {
        mrfeel::device::ParamsFile::check_path("--save-device", path).map_err(anyhow::Error::msg)?;
    }
    let registry = Registry::builtin();
    let overrides = parse_set(&a.set)?;
    let device = load_device(a.device.as_deref(), &registry)?;
    check_effects(&a.effects, &device)?;
    let protocol = Protocol::from_name(&a.protocol, a.amplitude_m, a.frequency_hz)?;
    let range_n = a.load_cell_range_n.or(device.load_cell_range_n).unwrap_or(250.0);
    check_sensor_options(&a, range_n)?;
    let stroke = device.geometry.map(|g| g.stroke_half_m);
    let test = MtsTest {
        protocol,
        currents_a: a.current.clone(),
        cycles_per_block: a.cycles,
        sample_rate_hz: a.sample_rate_hz,
        physics_hz: a.physics_hz,
        load_cell: SensorSpec {
            noise_std: a.force_noise_n,
            range: range_n,
            bits: a.adc_bits,
        },
        displacement: SensorSpec {
            noise_std: a.position_noise_m,
            range: stroke.unwrap_or(a.amplitude_m * 1.25).max(a.amplitude_m * 1.01),
            bits: a.adc_bits,
        },
        velocity: SensorSpec {
            noise_std: a.velocity_noise_m_s,
            range: 10.0,
            bits: a.adc_bits,
        },
        record_velocity: !a.no_velocity,
        record_coil_current: a.coil_current,
        stroke_limit_m: stroke,
        seed: a.seed,
    };
    let mut damper = if a.effects.is_empty() && overrides.is_empty() {
        device.damper()
    } else {
        with_hidden_effects(
            &device.model,
            &device.params,
            &a.effects,
            &overrides,
            &test,
            &registry,
        )?
    };
    let m = test.run(&mut damper)?;
    check_record(&m, &test)?;
    m.write(&a.out)?;
    if let Some(path) = &a.save_device {
        mrfeel::device::ParamsFile::new(damper.model(), damper.params(), None)
            .write(path)
            .with_context(|| format!("writing {}", path.display()))?;
        mrfeel::noteln!("saved the simulated device to {}", path.display());
    }
    mrfeel::noteln!(
        "wrote {} samples of `{}` to {}",
        m.len(),
        damper.model().name(),
        a.out.display()
    );
    // The files first, stdout last: a run that fails to write prints no result.
    if let Some(dir) = &a.plot {
        let files = plot_test(&m, &test, dir)?;
        for f in files {
            mrfeel::noteln!("plot: {}", f.display());
        }
    }
    print_summary(&m, &test)?;
    Ok(())
}

/// Per current block: the mean |force| over samples at more than 80 % of the block's peak speed, skipping
/// the first cycle (lags settling). Returns (current, force, samples used).
pub fn steady_force_per_block(m: &Measurement, test: &MtsTest) -> Vec<(f64, f64, usize)> {
    let block = test.block_s();
    let cycle = 1.0 / test.protocol.base_frequency_hz();
    test.currents_a
        .iter()
        .enumerate()
        .map(|(b, &i)| {
            let (t0, t1) = (b as f64 * block + cycle.min(block * 0.5), (b + 1) as f64 * block);
            let idx: Vec<usize> = (0..m.len())
                .filter(|&k| m.t_s[k] >= t0 && m.t_s[k] < t1)
                .collect();
            let vmax = idx.iter().map(|&k| m.v_m_s[k].abs()).fold(0.0, f64::max);
            let sel: Vec<usize> = idx
                .into_iter()
                .filter(|&k| m.v_m_s[k].abs() > 0.8 * vmax)
                .collect();
            let f = sel.iter().map(|&k| m.f_n[k].abs()).sum::<f64>() / sel.len().max(1) as f64;
            (i, f, sel.len())
        })
        .collect()
}

fn print_summary(m: &Measurement, test: &MtsTest) -> std::io::Result<()> {
    mrfeel::outln!(
        "{:>10}  {:>16}  {:>16}",
        "current_a",
        "force_n (steady)",
        "paper (Sec. 4)"
    )?;
    for (i, f, _) in steady_force_per_block(m, test) {
        let paper = mrfeel::builtin::PAPER_POINTS
            .iter()
            .find(|(pi, _)| (pi - i).abs() < 1e-9)
            .map(|(_, pf)| format!("{pf:.0} N"))
            .unwrap_or_else(|| "-".into());
        mrfeel::outln!("{i:>10.2}  {f:>16.2}  {paper:>16}")?;
    }
    Ok(())
}

/// Force–displacement (the paper's Fig. 8), force–velocity (Fig. 9 / 11) and force–time plots, one series
/// per current block, with the paper's measured forces as dashed reference lines in the force–velocity panel.
pub fn plot_test(m: &Measurement, test: &MtsTest, dir: &Path) -> Result<Vec<PathBuf>> {
    let block = test.block_s();
    let mut fx = Chart::new(
        "Force vs displacement (cf. paper Fig. 8)",
        "displacement x [mm]",
        "force [N]",
    );
    let mut fv = Chart::new(
        "Force vs velocity (cf. paper Fig. 9, 11)",
        "velocity v [mm/s]",
        "force [N]",
    );
    let mut ft = Chart::new("Force and current vs time", "time [s]", "force [N]");
    for (b, &i) in test.currents_a.iter().enumerate() {
        let idx: Vec<usize> = (0..m.len())
            .filter(|&k| m.t_s[k] >= b as f64 * block && m.t_s[k] < (b + 1) as f64 * block)
            .collect();
        let name = format!("{i} A");
        fx.series.push(Series::line(
            &name,
            idx.iter().map(|&k| (m.x_m[k] * 1e3, m.f_n[k])).collect(),
        ));
        fv.series.push(Series::points(
            &name,
            idx.iter().map(|&k| (m.v_m_s[k] * 1e3, m.f_n[k])).collect(),
        ));
        ft.series.push(Series::line(
            &name,
            idx.iter().map(|&k| (m.t_s[k], m.f_n[k])).collect(),
        ));
    }
    let vmax = m.v_m_s.iter().fold(0.0f64, |a, v| a.max(v.abs())) * 1e3;
    let mut named = false;
    for (i, f) in mrfeel::builtin::PAPER_POINTS {
        if test.currents_a.iter().any(|c| (c - i).abs() < 1e-9) {
            let name = if named {
                String::new()
            } else {
                "paper, Sec. 4".to_string()
            };
            named = true;
            fv.series.push(Series::dashed(name, vec![(0.0, f), (vmax, f)]));
            fv.series.push(Series::dashed("", vec![(-vmax, -f), (0.0, -f)]));
        }
    }
    Ok(save_charts(&[fx, fv, ft], 3, dir, "mts")?)
}
