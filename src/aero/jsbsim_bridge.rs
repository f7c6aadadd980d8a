//! Live JSBSim co-simulation: `python/jsbsim_bridge.py` in a child process, stepped in lock-step with
//! the rig over stdin/stdout lines (one request line → one reply line; protocol in the script's
//! docstring). JSBSim runs at its own frame (the scenario's aircraft rate, 120 Hz by default) and the
//! rig at its physics rate; the flight loop sends one `step` per aircraft frame.
//!
//! The Python interpreter is `$MRFEEL_PYTHON` if set, else the repository's `.venv/bin/python`
//! (`bash scripts/python-env.sh` creates it with the pinned jsbsim). A missing interpreter, venv or
//! jsbsim is an error that says so and how to install it; every read has a timeout (never a hang);
//! the child is killed when the bridge is dropped. Each request's round trip is timed.

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::backend::{with_hinge, AircraftBackend};
use super::{AeroError, AircraftModel, AircraftState, HingeModel};

/// How to install the Python side, quoted in every error.
pub const INSTALL_HINT: &str =
    "create the Python environment with `bash scripts/python-env.sh` (installs the pinned jsbsim into .venv)";

/// Start-up (interpreter + `import jsbsim`) and trim may take a while on a loaded machine.
const START_TIMEOUT: Duration = Duration::from_secs(60);
/// One JSBSim frame takes tens of microseconds; this only catches a dead or stuck child.
const STEP_TIMEOUT: Duration = Duration::from_secs(20);

/// The reply's fields, in the order of `STATE_FIELDS` in `python/jsbsim_bridge.py`.
const N_FIELDS: usize = 16;

/// The repository's Python for the bridge: `$MRFEEL_PYTHON`, else `<repo>/.venv/bin/python`.
pub fn python_path() -> PathBuf {
    std::env::var_os("MRFEEL_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/.venv/bin/python")))
}

/// The bridge script.
pub fn script_path() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/python/jsbsim_bridge.py"))
}

/// Round-trip statistics of the `step` requests (request written → reply parsed), µs.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RoundTrip {
    pub count: u64,
    pub mean_us: f64,
    pub max_us: f64,
}

pub struct JsbsimBridge {
    label: String,
    name: String,
    hinge: HingeModel,
    estimates: Vec<String>,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    stderr_tail: Arc<Mutex<Vec<String>>>,
    tab_rad: f64,
    /// Feel computer's column neutral set at trim (powered controls), stick rad.
    feel_trim_rad: f64,
    rt_sum_us: f64,
    rt: RoundTrip,
}

impl JsbsimBridge {
    /// Start the bridge for aircraft `name` (JSBSim's folder name, `c172p`, `737`); the hinge and
    /// stick gearing come from the embedded model of the same name.
    pub fn spawn(name: &str, model: Arc<AircraftModel>) -> Result<Self, AeroError> {
        let py = python_path();
        let script = script_path();
        let fail = |why: String| AeroError::Input {
            what: format!("live JSBSim `jsbsim:{name}`"),
            why,
        };
        if !py.exists() {
            return Err(fail(format!(
                "Python interpreter {} not found; {INSTALL_HINT}",
                py.display()
            )));
        }
        let mut child = Command::new(&py)
            .arg("-u")
            .arg(&script)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| {
                fail(format!(
                    "cannot start {} {}: {e}; {INSTALL_HINT}",
                    py.display(),
                    script.display()
                ))
            })?;
        let stdout = child.stdout.take().ok_or_else(|| fail("no stdout pipe".into()))?;
        let stderr = child.stderr.take().ok_or_else(|| fail("no stderr pipe".into()))?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                match line {
                    Ok(l) => {
                        if tx.send(l).is_err() {
                            break;
                        }
                    }
                    Err(_) => break,
                }
            }
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
            hinge: HingeModel::from_model(&model),
            estimates: model.estimates.clone(),
            child,
            stdin,
            lines: rx,
            stderr_tail: tail,
            tab_rad: 0.0,
            feel_trim_rad: 0.0,
            rt_sum_us: 0.0,
            rt: RoundTrip::default(),
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

    /// Round-trip statistics of the `step` requests so far.
    pub fn round_trip(&self) -> RoundTrip {
        self.rt
    }

    fn error(&self, why: String) -> AeroError {
        let tail = self.stderr_tail.lock().map(|t| t.join("\n")).unwrap_or_default();
        AeroError::Input {
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
        let reply = self.read_line(timeout);
        let reply = match reply {
            Ok(r) => r,
            Err(e) => {
                let _ = self.child.kill();
                return Err(e);
            }
        };
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
        if line.starts_with("step") {
            self.rt.count += 1;
            self.rt_sum_us += us;
            self.rt.mean_us = self.rt_sum_us / self.rt.count as f64;
            self.rt.max_us = self.rt.max_us.max(us);
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
        Ok(with_hinge(&self.hinge, s))
    }
}

impl AircraftBackend for JsbsimBridge {
    fn label(&self) -> &str {
        &self.label
    }

    fn hinge(&self) -> &HingeModel {
        &self.hinge
    }

    fn estimates(&self) -> &[String] {
        &self.estimates
    }

    fn trim(&mut self, airspeed_m_s: f64, altitude_m: f64, dt_s: f64) -> Result<AircraftState, AeroError> {
        let s = self.request(
            &format!("init {} {airspeed_m_s:?} {altitude_m:?} {dt_s:?}", self.name),
            START_TIMEOUT,
        )?;
        let alpha_t = self.hinge.alpha_tail_rad(s.alpha_rad, s.q_rad_s, s.airspeed_m_s);
        self.tab_rad = self
            .hinge
            .trim_tab_rad(alpha_t, s.elevator_rad)
            .ok_or_else(|| AeroError::Trim {
                aircraft: self.label.clone(),
                airspeed_m_s,
                altitude_m,
                nz_g: 1.0,
                why: "the tab cannot zero the stick force at JSBSim's trim".into(),
            })?;
        self.feel_trim_rad = match &self.hinge.feel_computer {
            Some(fc) => fc.trim_rad(self.hinge.stick_from_elevator_rad(s.elevator_rad), s.mach),
            None => 0.0,
        };
        Ok(with_hinge(
            &self.hinge,
            AircraftState {
                tab_rad: self.tab_rad,
                feel_trim_rad: self.feel_trim_rad,
                ..s
            },
        ))
    }

    fn step(&mut self, elevator_rad: f64, throttle_ratio: f64) -> Result<AircraftState, AeroError> {
        self.request(&format!("step {elevator_rad:?} {throttle_ratio:?}"), STEP_TIMEOUT)
    }

    fn round_trip_us(&self) -> Option<(u64, f64, f64)> {
        Some((self.rt.count, self.rt.mean_us, self.rt.max_us))
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
