//! Live JSBSim co-simulation: `python/jsbsim_bridge.py` in a child process, stepped in lock-step with
//! the rig over stdin/stdout lines (one request line → one reply line; protocol in the script's
//! docstring), one `step` per aircraft frame (the scenario's aircraft rate, 120 Hz by default).
//!
//! The Python interpreter is the first of `$MRFEEL_PYTHON`, the `.venv/bin/python` of the mrfeel
//! checkout the command runs in (here or a folder above; `bash scripts/python-env.sh` creates it), and
//! `python3` on the `PATH`. The bridge scripts are built into the binary ([`crate::builtin`]) and written
//! to a temporary folder. A missing interpreter or jsbsim is an error saying how to install it; every read
//! has a timeout; the child is killed when the bridge is dropped.

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::backend::AircraftBackend;
use super::fbw::FlyByWire;
use super::{AeroError, AircraftModel, AircraftState, HingeModel};

/// How to install the Python side, quoted in every error.
pub(crate) const INSTALL_HINT: &str =
    "in an mrfeel checkout, `bash scripts/python-env.sh` creates .venv with the \
     pinned jsbsim; elsewhere, `python3 -m pip install jsbsim==1.3.3` into a Python named by MRFEEL_PYTHON";

/// Start-up (interpreter + `import jsbsim`) and trim may take a while on a loaded machine.
const START_TIMEOUT: Duration = Duration::from_secs(60);
/// One JSBSim frame takes tens of microseconds; this only catches a dead or stuck child.
const STEP_TIMEOUT: Duration = Duration::from_secs(20);

/// The reply's fields, in the order of `STATE_FIELDS` in `python/jsbsim_bridge.py`.
const N_FIELDS: usize = 16;

/// The environment variable naming the bridge's Python interpreter.
pub(crate) const PYTHON_ENV: &str = "MRFEEL_PYTHON";

/// The Python interpreter for the bridge and where it was found ([the module's order](self)).
pub fn python() -> (PathBuf, String) {
    if let Some(p) = std::env::var_os(PYTHON_ENV).filter(|p| !p.is_empty()) {
        return (PathBuf::from(p), format!("from {PYTHON_ENV}"));
    }
    let here = std::env::current_dir().ok();
    let checkout = here
        .iter()
        .flat_map(|d| d.ancestors())
        .find(|d| d.join("python/requirements.txt").is_file() && d.join(".venv/bin/python").exists());
    match checkout {
        Some(d) => (
            d.join(".venv/bin/python"),
            format!("the checkout's .venv ({})", d.display()),
        ),
        None => (
            PathBuf::from("python3"),
            format!("python3 on the PATH ({PYTHON_ENV} not set, no mrfeel checkout's .venv here)"),
        ),
    }
}

/// The bridge's Python interpreter ([`python`]).
pub fn python_path() -> PathBuf {
    python().0
}

/// The bridge scripts, built into the binary.
const SCRIPTS: [&str; 2] = ["python/jsbsim_bridge.py", "python/jsbsim_reference.py"];

/// Write the bridge scripts into a new temporary folder (removed when it is dropped); the bridge's path.
fn write_scripts() -> std::io::Result<(tempfile::TempDir, PathBuf)> {
    let dir = tempfile::Builder::new()
        .prefix("mrfeel-jsbsim-bridge-")
        .tempdir()?;
    for s in SCRIPTS {
        let text = crate::builtin::text(&std::path::Path::new(crate::builtin::ROOT).join(s))
            .ok_or_else(|| std::io::Error::other(format!("{s} is not built in")))?;
        let name = std::path::Path::new(s).file_name().unwrap_or_default();
        std::fs::write(dir.path().join(name), text)?;
    }
    let bridge = dir.path().join("jsbsim_bridge.py");
    Ok((dir, bridge))
}

pub(crate) struct JsbsimBridge {
    label: String,
    name: String,
    /// The hinge and stick gearing of a mechanically linked elevator; `None` for a fly-by-wire aircraft.
    hinge: Option<HingeModel>,
    fbw: Option<FlyByWire>,
    estimates: Vec<String>,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    stderr_tail: Arc<Mutex<Vec<String>>>,
    tab_rad: f64,
    /// Feel computer's column neutral set at trim (powered controls), stick rad.
    feel_trim_rad: f64,
    /// Round trips of the per-frame requests (`step`, `cmd`; not the trim), request written → reply
    /// parsed: count, sum and largest, µs.
    round_trips: (u64, f64, f64),
    /// The folder the bridge scripts were written to, removed with the bridge.
    _scripts: tempfile::TempDir,
}

impl JsbsimBridge {
    /// Start the bridge for aircraft `name` (`c172p`, `737`) with the hinge and stick gearing of `model`.
    pub fn spawn(name: &str, model: Arc<AircraftModel>) -> Result<Self, AeroError> {
        Self::start(name, Some(model.hinge.clone()), None, model.estimates.clone())
    }

    /// Start the bridge for the fly-by-wire aircraft `name` (`f16`), commanded through its FCS.
    pub fn spawn_fly_by_wire(name: &str, fbw: FlyByWire) -> Result<Self, AeroError> {
        let estimates = fbw.estimates.clone();
        Self::start(name, None, Some(fbw), estimates)
    }

    fn start(
        name: &str,
        hinge: Option<HingeModel>,
        fbw: Option<FlyByWire>,
        estimates: Vec<String>,
    ) -> Result<Self, AeroError> {
        let (py, found) = python();
        let fail = |why: String| AeroError::Refused {
            what: format!("live JSBSim `jsbsim:{name}`"),
            why,
        };
        crate::noteln!("JSBSim bridge: Python {} ({found})", py.display());
        if py.is_absolute() && !py.exists() {
            return Err(fail(format!(
                "Python interpreter {} ({found}) not found; {INSTALL_HINT}, or set {PYTHON_ENV}",
                py.display()
            )));
        }
        let (scripts, script) = write_scripts().map_err(|e| {
            fail(format!(
                "cannot write the bridge scripts to a temporary folder: {e}"
            ))
        })?;
        let mut child = Command::new(&py)
            .arg("-u")
            .arg(&script)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| {
                fail(format!(
                    "cannot start {} ({found}) {}: {e}; {INSTALL_HINT}, or set {PYTHON_ENV}",
                    py.display(),
                    script.display()
                ))
            })?;
        let stdout = child.stdout.take().ok_or_else(|| fail("no stdout pipe".into()))?;
        let stderr = child.stderr.take().ok_or_else(|| fail("no stderr pipe".into()))?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            BufReader::new(stdout)
                .lines()
                .map_while(Result::ok)
                .try_for_each(|l| tx.send(l))
        });
        let tail = Arc::new(Mutex::new(Vec::new()));
        let tail_w = Arc::clone(&tail);
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Ok(mut t) = tail_w.lock() {
                    t.push(line);
                    if t.len() > 20 {
                        t.remove(0);
                    }
                }
            }
        });
        let stdin = child.stdin.take();
        let mut b = Self {
            label: format!("jsbsim:{name}"),
            name: name.to_string(),
            hinge,
            fbw,
            estimates,
            child,
            stdin,
            lines: rx,
            stderr_tail: tail,
            tab_rad: 0.0,
            feel_trim_rad: 0.0,
            round_trips: (0, 0.0, 0.0),
            _scripts: scripts,
        };
        let hello = b.read_line(START_TIMEOUT)?;
        if let Some(msg) = hello.strip_prefix("error ") {
            return Err(b.error(msg.to_string()));
        }
        if !hello.starts_with("ready ") {
            return Err(b.error(format!("unexpected first line from the bridge: {hello:?}")));
        }
        Ok(b)
    }

    fn error(&self, why: String) -> AeroError {
        let tail = self.stderr_tail.lock().map(|t| t.join("\n")).unwrap_or_default();
        AeroError::Refused {
            what: format!("live JSBSim `{}`", self.label),
            why: if tail.is_empty() {
                why
            } else {
                format!("{why}\n--- bridge stderr (last lines) ---\n{tail}")
            },
        }
    }

    fn read_line(&mut self, timeout: Duration) -> Result<String, AeroError> {
        match self.lines.recv_timeout(timeout) {
            Ok(l) => Ok(l),
            Err(RecvTimeoutError::Timeout) => Err(self.error(format!(
                "no reply from the bridge within {} s (killed it)",
                timeout.as_secs()
            ))),
            Err(RecvTimeoutError::Disconnected) => {
                // Give stderr a moment to arrive for the message.
                std::thread::sleep(Duration::from_millis(100));
                Err(self.error(format!("the bridge exited without a reply; {INSTALL_HINT}")))
            }
        }
    }

    fn request(&mut self, line: &str, timeout: Duration) -> Result<AircraftState, AeroError> {
        let sent = Instant::now();
        let io = match self.stdin.as_mut() {
            Some(w) => writeln!(w, "{line}").and_then(|_| w.flush()),
            None => Err(std::io::Error::other("stdin closed")),
        };
        if let Err(e) = io {
            return Err(self.error(format!("cannot write to the bridge: {e}")));
        }
        let reply = self.read_line(timeout).inspect_err(|_| {
            let _ = self.child.kill();
        })?;
        let us = sent.elapsed().as_secs_f64() * 1e6;
        let Some(body) = reply.strip_prefix("ok ") else {
            let msg = reply.strip_prefix("error ").unwrap_or(&reply).to_string();
            return Err(self.error(format!("request `{line}` failed: {msg}")));
        };
        let v: Vec<f64> = body.split(' ').filter_map(|w| w.parse().ok()).collect();
        if v.len() != N_FIELDS {
            return Err(self.error(format!(
                "reply with {} numbers, expected {N_FIELDS}: {reply:?}",
                v.len()
            )));
        }
        if line.starts_with("step ") || line.starts_with("cmd ") {
            let (n, sum, max) = &mut self.round_trips;
            (*n, *sum, *max) = (*n + 1, *sum + us, max.max(us));
        }
        let s = AircraftState {
            t_s: v[0],
            u_m_s: v[1],
            w_m_s: v[2],
            q_rad_s: v[3],
            theta_rad: v[4],
            altitude_m: v[5],
            airspeed_m_s: v[6],
            alpha_rad: v[7],
            alphadot_rad_s: v[8],
            qbar_pa: v[9],
            qbar_elevator_pa: v[10],
            mach: v[11],
            nz_g: v[12],
            elevator_rad: v[13],
            throttle: v[14],
            thrust_n: v[15],
            tab_rad: self.tab_rad,
            feel_trim_rad: self.feel_trim_rad,
            ..AircraftState::default()
        };
        Ok(match &self.hinge {
            Some(h) => h.fill(s),
            None => s,
        })
    }
}

impl AircraftBackend for JsbsimBridge {
    fn label(&self) -> &str {
        &self.label
    }

    fn hinge(&self) -> Option<&HingeModel> {
        self.hinge.as_ref()
    }

    fn fly_by_wire(&self) -> Option<&FlyByWire> {
        self.fbw.as_ref()
    }

    fn estimates(&self) -> &[String] {
        &self.estimates
    }

    fn trim(&mut self, airspeed_m_s: f64, altitude_m: f64, dt_s: f64) -> Result<AircraftState, AeroError> {
        let s = self.request(
            &format!("init {} {airspeed_m_s:?} {altitude_m:?} {dt_s:?}", self.name),
            START_TIMEOUT,
        )?;
        let Some(hinge) = self.hinge.clone() else {
            return Ok(s);
        };
        let alpha_t = hinge.alpha_tail_rad(s.alpha_rad, s.q_rad_s, s.airspeed_m_s);
        self.tab_rad = hinge
            .trim_tab_rad(alpha_t, s.elevator_rad)
            .ok_or_else(|| AeroError::Trim {
                aircraft: self.label.clone(),
                airspeed_m_s,
                altitude_m,
                nz_g: 1.0,
                why: "the tab cannot zero the stick force at JSBSim's trim".into(),
            })?;
        self.feel_trim_rad = hinge.feel_trim_rad(s.elevator_rad, s.mach);
        Ok(hinge.fill(AircraftState {
            tab_rad: self.tab_rad,
            feel_trim_rad: self.feel_trim_rad,
            ..s
        }))
    }

    fn step(&mut self, elevator_rad: f64, throttle_ratio: f64) -> Result<AircraftState, AeroError> {
        self.request(&format!("step {elevator_rad:?} {throttle_ratio:?}"), STEP_TIMEOUT)
    }

    fn step_command(&mut self, command: f64, throttle_ratio: f64) -> Result<AircraftState, AeroError> {
        self.request(&format!("cmd {command:?} {throttle_ratio:?}"), STEP_TIMEOUT)
    }

    fn round_trip_us(&self) -> Option<(u64, f64, f64)> {
        let (n, sum, max) = self.round_trips;
        Some((n, if n == 0 { 0.0 } else { sum / n as f64 }, max))
    }
}

impl Drop for JsbsimBridge {
    fn drop(&mut self) {
        if let Some(mut w) = self.stdin.take() {
            let _ = writeln!(w, "quit");
        }
        // Closed stdin ends the bridge's read loop; wait briefly, then kill.
        let until = Instant::now() + Duration::from_millis(500);
        loop {
            match self.child.try_wait() {
                Ok(Some(_)) => return,
                Ok(None) if Instant::now() < until => std::thread::sleep(Duration::from_millis(5)),
                _ => break,
            }
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A missing interpreter, or one that exits without answering (no jsbsim), is an immediate error
    /// that says how to install it: no hang, no panic. (One test: both set the process's environment.)
    #[test]
    fn missing_or_silent_python_says_how_to_install() {
        let model = Arc::new(AircraftModel::load(&AircraftModel::builtin_path("c172p")).unwrap());
        std::env::set_var("MRFEEL_PYTHON", "/nonexistent/mrfeel/python");
        let missing = JsbsimBridge::spawn("c172p", Arc::clone(&model)).err();
        std::env::set_var("MRFEEL_PYTHON", "/bin/true");
        let t0 = Instant::now();
        let silent = JsbsimBridge::spawn("c172p", model).err();
        let waited = t0.elapsed();
        std::env::remove_var("MRFEEL_PYTHON");
        for e in [missing, silent] {
            let e = e.map(|e| e.to_string()).unwrap_or_default();
            assert!(e.contains("scripts/python-env.sh"), "{e}");
        }
        assert!(waited < Duration::from_secs(10), "waited {waited:?}");
    }
}
