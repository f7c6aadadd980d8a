//! The Python package `mrfeel`: measurements as NumPy arrays, models with `fit`, `predict` and `score`,
//! the diagnosis and scenario runs. Every call goes through [`mrfeel::prelude`], the functions the command
//! line calls, so Python and `mrfeel fit/validate/diagnose/run` give the same numbers to the bit. Long work
//! runs with the GIL released, on a worker thread, while the calling thread watches for Ctrl-C.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use mrfeel::prelude::{
    self, AcquisitionChoice, DeviceConfig, FitSetup, Measurement, ParamsFile, TimingChoice, Weighting,
};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

pyo3::create_exception!(
    mrfeel,
    Error,
    PyValueError,
    "Bad input or a failed command, with the message the mrfeel command line prints (file, line, field)."
);

/// The message of an error as the command line prints it (`error: {e:#}`), as a Python exception.
fn err(e: anyhow::Error) -> PyErr {
    Error::new_err(format!("{e:#}"))
}

/// Run `f` with the GIL released, on a worker thread, and check for Ctrl-C every 50 ms meanwhile: on
/// Ctrl-C the library is asked to stop ([`mrfeel::interrupt`]), the worker's result is dropped and
/// `KeyboardInterrupt` raised.
fn work<T: Send>(py: Python<'_>, f: impl FnOnce() -> anyhow::Result<T> + Send) -> PyResult<T> {
    mrfeel::interrupt::clear();
    let (result, interrupted) = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::channel::<()>();
            let worker = s.spawn(move || {
                let r = f();
                let _ = tx.send(());
                r
            });
            let mut interrupted = None;
            // Until the worker has sent its result, or dropped the sender by panicking.
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                rx.recv_timeout(Duration::from_millis(50))
            {
                if interrupted.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        mrfeel::interrupt::request();
                        interrupted = Some(e);
                    }
                }
            }
            (worker.join(), interrupted)
        })
    });
    mrfeel::interrupt::clear();
    if let Some(e) = interrupted {
        return Err(e);
    }
    match result {
        Ok(r) => r.map_err(err),
        Err(_) => Err(PyRuntimeError::new_err(
            "mrfeel: internal error (a panic); please report it",
        )),
    }
}

/// A 1-D float64 copy of an array-like (NumPy array, list), or an error naming `column`.
fn column(py: Python<'_>, obj: &Bound<'_, PyAny>, column: &str) -> PyResult<Vec<f64>> {
    let np = py.import("numpy")?;
    let arr = np
        .call_method1("ascontiguousarray", (obj, "float64"))
        .map_err(|e| Error::new_err(format!("column `{column}`: not an array of numbers ({e})")))?;
    let arr: PyReadonlyArray1<'_, f64> = arr.extract().map_err(|_| {
        let ndim = arr
            .getattr("ndim")
            .and_then(|n| n.extract::<usize>())
            .unwrap_or(0);
        Error::new_err(format!(
            "column `{column}`: expected a 1-D array of samples, got {ndim} dimension(s)"
        ))
    })?;
    Ok(arr.as_slice()?.to_vec())
}

fn array<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

/// A value given as a JSON text, as Python objects (`json.loads`): dicts, lists, numbers, `None` for null.
fn from_json<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// `s` as one of the values of a command-line option (`weighting`, `command_timing`).
fn choice<T: Copy>(what: &str, s: &str, all: &[T], name: fn(T) -> &'static str) -> PyResult<T> {
    all.iter().copied().find(|&v| name(v) == s).ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|&v| name(v)).collect();
        Error::new_err(format!("{what} `{s}`: expected one of {}", names.join(", ")))
    })
}

/// `acquisition`: `"auto"` (also `None`), `"as-logged"` or a moving average's window in samples.
fn acquisition(obj: Option<&Bound<'_, PyAny>>) -> PyResult<AcquisitionChoice> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(AcquisitionChoice::Auto);
    };
    let s = obj.str()?.to_string();
    s.parse()
        .map_err(|why: String| Error::new_err(format!("acquisition `{s}`: {why}")))
}

/// A path given as `str` or `os.PathLike`, if `obj` is one.
fn path_of(obj: &Bound<'_, PyAny>) -> Option<PathBuf> {
    if obj.is_instance_of::<PyString>() || obj.hasattr("__fspath__").unwrap_or(false) {
        obj.extract::<PathBuf>().ok()
    } else {
        None
    }
}

/// The measurements of `obj`: a `Measurement`, a CSV file or directory of them (`str`, `os.PathLike`), or
/// a sequence of these.
fn measurements(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Measurement>> {
    let one = |o: &Bound<'_, PyAny>| -> PyResult<Option<Vec<Measurement>>> {
        if let Ok(m) = o.cast::<PyMeasurement>() {
            return Ok(Some(vec![m.get().inner.as_ref().clone()]));
        }
        match path_of(o) {
            Some(p) => prelude::read(&[p]).map(Some).map_err(|e| err(e.into())),
            None => Ok(None),
        }
    };
    if let Some(ms) = one(obj)? {
        return Ok(ms);
    }
    let mut all = Vec::new();
    for item in obj
        .try_iter()
        .map_err(|_| Error::new_err("expected a Measurement, a CSV path, or a list of them".to_string()))?
    {
        let item = item?;
        match one(&item)? {
            Some(ms) => all.extend(ms),
            None => {
                return Err(Error::new_err(format!(
                    "expected a Measurement or a CSV path, got {}",
                    item.get_type().name()?
                )))
            }
        }
    }
    Ok(all)
}

/// One test of the damper: time, displacement, current command and force (SI units, one value per
/// sample), as a CSV file of the measurement format holds it.
#[pyclass(name = "Measurement", module = "mrfeel", frozen)]
struct PyMeasurement {
    inner: Arc<Measurement>,
}

#[pymethods]
impl PyMeasurement {
    /// A measurement from arrays: time `t` (s, strictly increasing), displacement `x` (m), current command
    /// `i` (A), force `f` (N), optionally velocity `v` (m/s; derived from `x` when absent). `name` stands
    /// for the file name (tables, and the cross-validation group: the name up to its last `_`, or `group`).
    #[staticmethod]
    #[pyo3(signature = (t, x, i, f, v=None, name="arrays", group=None))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays(
        py: Python<'_>,
        t: &Bound<'_, PyAny>,
        x: &Bound<'_, PyAny>,
        i: &Bound<'_, PyAny>,
        f: &Bound<'_, PyAny>,
        v: Option<&Bound<'_, PyAny>>,
        name: &str,
        group: Option<String>,
    ) -> PyResult<Self> {
        let v = v.map(|v| column(py, v, "v_m_s")).transpose()?;
        let mut m = Measurement::from_columns(
            name,
            column(py, t, "t_s")?,
            column(py, x, "x_m")?,
            column(py, i, "i_a")?,
            column(py, f, "f_n")?,
            v,
        )
        .map_err(|e| err(e.into()))?;
        if let Some(g) = group {
            m.meta.insert("group".into(), g);
        }
        Ok(Self { inner: Arc::new(m) })
    }

    /// A measurement file (`docs/spec/measurement-format.md`), checked as the command line checks it.
    #[staticmethod]
    fn from_csv(path: PathBuf) -> PyResult<Self> {
        let m = Measurement::read(&path).map_err(|e| err(e.into()))?;
        Ok(Self { inner: Arc::new(m) })
    }

    /// Time, s.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        array(py, &self.inner.t_s)
    }

    /// Displacement, m.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        array(py, &self.inner.x_m)
    }

    /// Velocity, m/s: measured, or derived from the displacement.
    #[getter]
    fn v<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        array(py, &self.inner.v_m_s)
    }

    /// Current command, A.
    #[getter]
    fn i<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        array(py, &self.inner.i_a)
    }

    /// Measured force, N.
    #[getter]
    fn f<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        array(py, &self.inner.f_n)
    }

    /// Whether the velocity was measured (else derived from the displacement).
    #[getter]
    fn velocity_measured(&self) -> bool {
        self.inner.velocity_measured
    }

    /// The file (or the name given to the arrays).
    #[getter]
    fn name(&self) -> String {
        self.inner.path.display().to_string()
    }

    /// The `# key: value` metadata of the file.
    #[getter]
    fn meta(&self) -> std::collections::BTreeMap<String, String> {
        self.inner.meta.clone()
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Measurement({:?}, {} samples, {:.3} s)",
            self.name(),
            self.inner.len(),
            self.inner.t_s.last().unwrap_or(&0.0) - self.inner.t_s.first().unwrap_or(&0.0)
        )
    }

    /// The samples as a pandas DataFrame (columns `t_s`, `x_m`, `v_m_s`, `i_a`, `f_n`); needs pandas.
    fn to_pandas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let pd = py.import("pandas").map_err(|_| {
            pyo3::exceptions::PyImportError::new_err("to_pandas needs pandas: pip install pandas")
        })?;
        let d = PyDict::new(py);
        let m = &self.inner;
        for (name, col) in [
            ("t_s", &m.t_s),
            ("x_m", &m.x_m),
            ("v_m_s", &m.v_m_s),
            ("i_a", &m.i_a),
            ("f_n", &m.f_n),
        ] {
            d.set_item(name, array(py, col))?;
        }
        pd.call_method1("DataFrame", (d,))
    }
}

/// A fitted (or loaded) model: what `mrfeel fit --save` writes and `validate --params` reads.
struct Saved {
    file: ParamsFile,
    config: DeviceConfig,
    /// `fit --json` of the fit that made it, when it was fitted here.
    report: Option<String>,
}

/// A damper model: `bingham` plus effects joined by `+` (`"bingham+hysteresis"`). `fit` it to measurements,
/// then `predict` the force on any motion, `score` it on other tests, `save` it as PARAMS.json.
#[pyclass(name = "Model", module = "mrfeel")]
struct PyModel {
    spec: String,
    current_limit_a: Option<f64>,
    saved: Option<Saved>,
}

impl PyModel {
    fn saved(&self) -> PyResult<&Saved> {
        self.saved.as_ref().ok_or_else(|| {
            Error::new_err(format!(
                "model `{}` has no parameters yet: fit it first (Model.fit) or load one (Model.load)",
                self.spec
            ))
        })
    }

    fn from_file(file: ParamsFile, name: &Path, report: Option<String>) -> PyResult<Self> {
        let config = prelude::saved_model(&file, name).map_err(err)?;
        Ok(Self {
            spec: file.model.clone(),
            current_limit_a: file.current_limit_a,
            saved: Some(Saved { file, config, report }),
        })
    }
}

#[pymethods]
impl PyModel {
    /// A model to fit. `current_limit_a`: the driver's saturation of the current command (default: 14 A,
    /// or the largest command in the data if higher).
    #[new]
    #[pyo3(signature = (spec="bingham", current_limit_a=None))]
    fn new(spec: &str, current_limit_a: Option<f64>) -> PyResult<Self> {
        // Refused here, not at the first fit: an unknown effect or a bad limit.
        prelude::model(
            spec,
            current_limit_a.unwrap_or(mrfeel::device::PAPER_CURRENT_LIMIT_A),
        )
        .map_err(err)?;
        if let Some(l) = current_limit_a {
            prelude::current_limit(Some(l), &[]).map_err(err)?;
        }
        Ok(Self {
            spec: spec.to_string(),
            current_limit_a,
            saved: None,
        })
    }

    /// A model saved by `save` or `mrfeel fit --save` (PARAMS.json), or a device `.toml`.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let registry = mrfeel::device::Registry::builtin();
        let config = DeviceConfig::load(&path, &registry).map_err(|e| err(e.into()))?;
        let text = std::fs::read_to_string(&path).ok();
        // PARAMS.json as written (with its record of the fit); a device file as its model and values.
        let file = match text.and_then(|t| serde_json::from_str::<ParamsFile>(&t).ok()) {
            Some(f) => f,
            None => {
                let mut f = ParamsFile::new(&config.model, &config.params, Some(&config.std_errs));
                f.command_timing = Some(config.command_timing.as_str().to_string());
                f.acquisition_window_periods = config.acquisition_window_periods;
                f
            }
        };
        Ok(Self {
            spec: file.model.clone(),
            current_limit_a: file.current_limit_a,
            saved: Some(Saved {
                file,
                config,
                report: None,
            }),
        })
    }

    /// Fit the model to `measurements` (a `Measurement`, a CSV path or directory, or a list of them) jointly,
    /// each test from its own start, as `mrfeel fit` does; returns the model. `weighting`: `"tests"` (each
    /// test counts once) or `"samples"`; `acquisition`: `"auto"`, `"as-logged"` or a moving average's window
    /// in samples; `command_timing`: `"auto"`, `"after-sample"` or `"at-sample"`.
    #[pyo3(signature = (measurements, weighting="tests", acquisition=None, command_timing="auto"))]
    fn fit<'py>(
        mut slf: PyRefMut<'py, Self>,
        measurements: &Bound<'py, PyAny>,
        weighting: &str,
        acquisition: Option<&Bound<'py, PyAny>>,
        command_timing: &str,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let py = slf.py();
        let ms = self::measurements(measurements)?;
        let acq = self::acquisition(acquisition)?;
        let setup = FitSetup {
            model: slf.spec.clone(),
            current_limit_a: slf.current_limit_a,
            weighting: self::choice("weighting", weighting, &Weighting::ALL, Weighting::as_str)?,
            command_timing: self::choice(
                "command_timing",
                command_timing,
                &TimingChoice::ALL,
                TimingChoice::as_str,
            )?,
        };
        let (file, report) = work(py, move || {
            let data = prelude::prepare(&ms, acq, None)?;
            let model = prelude::fit_model(&data.tests, &setup)?;
            let fitted = prelude::fit(model, data, &setup);
            let pred = fitted.predictions();
            let report = serde_json::to_string(&fitted.report(&pred))?;
            Ok((fitted.params_file(), report))
        })?;
        let fitted = Self::from_file(file, Path::new("PARAMS.json"), Some(report))?;
        *slf = fitted;
        Ok(slf)
    }

    /// The model's force, N, on the motion and current commands of a `Measurement` (its force is not used),
    /// or of arrays `t` (s), `x` (m), `i` (A) and optionally `v` (m/s): from the first sample, the current
    /// commands read as in the fit, the motion as given.
    #[pyo3(signature = (measurement_or_t, x=None, i=None, v=None))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        measurement_or_t: &Bound<'py, PyAny>,
        x: Option<&Bound<'py, PyAny>>,
        i: Option<&Bound<'py, PyAny>>,
        v: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let saved = self.saved()?;
        let m: Arc<Measurement> = match measurement_or_t.cast::<PyMeasurement>() {
            Ok(m) => m.get().inner.clone(),
            Err(_) => {
                let (Some(x), Some(i)) = (x, i) else {
                    return Err(Error::new_err(
                        "predict takes a Measurement, or the arrays t, x and i (and optionally v)",
                    ));
                };
                let t = column(py, measurement_or_t, "t_s")?;
                let zeros = vec![0.0; t.len()];
                let v = v.map(|v| column(py, v, "v_m_s")).transpose()?;
                let m = Measurement::from_columns(
                    "arrays",
                    t,
                    column(py, x, "x_m")?,
                    column(py, i, "i_a")?,
                    zeros,
                    v,
                )
                .map_err(|e| err(e.into()))?;
                Arc::new(m)
            }
        };
        let config = &saved.config;
        let force = work(py, || Ok(prelude::predict(config, &m)))?;
        Ok(PyArray1::from_vec(py, force))
    }

    /// The model run unchanged on `measurements` (as `fit` takes them) and its error, as `mrfeel validate
    /// --json` reports it: `nrmse`, `rmse_n`, `samples`, per file under `files`, and the parameters.
    #[pyo3(signature = (measurements, acquisition=None))]
    fn score<'py>(
        &self,
        py: Python<'py>,
        measurements: &Bound<'py, PyAny>,
        acquisition: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let saved = self.saved()?;
        let ms = self::measurements(measurements)?;
        let acq = self::acquisition(acquisition)?;
        let config = &saved.config;
        let text = work(py, move || {
            let data = prelude::prepare(&ms, acq, config.acquisition_window_periods)?;
            let (_, _, out) = prelude::validate(config, data)?;
            Ok(serde_json::to_string(&out)?)
        })?;
        from_json(py, &text)
    }

    /// The parameters: name → `{"value", "std_err", "unit"}` (`std_err` None where not estimated).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let saved = self.saved()?;
        from_json(
            py,
            &serde_json::to_string(&saved.file.params).map_err(|e| err(e.into()))?,
        )
    }

    /// `mrfeel fit --json` of the fit that made this model (None for a loaded one).
    #[getter]
    fn fit_report<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        match self.saved()?.report.as_deref() {
            Some(r) => Ok(Some(from_json(py, r)?)),
            None => Ok(None),
        }
    }

    /// The model's name: `bingham` plus its effects.
    #[getter]
    fn spec(&self) -> String {
        self.spec.clone()
    }

    /// Write PARAMS.json (as `mrfeel fit --save`, read by `mrfeel validate --params` and `Model.load`).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        ParamsFile::check_path("save", &path).map_err(Error::new_err)?;
        self.saved()?
            .file
            .write(&path)
            .map_err(|e| Error::new_err(format!("writing {}: {e}", path.display())))
    }

    fn __repr__(&self) -> String {
        match &self.saved {
            Some(s) => format!(
                "Model({:?}, {} parameters fitted)",
                self.spec,
                s.file.params.len()
            ),
            None => format!("Model({:?}, not fitted)", self.spec),
        }
    }
}

/// The outcome of `diagnose`: `to_dict()` is `mrfeel diagnose --json`.
#[pyclass(name = "Diagnosis", module = "mrfeel", frozen)]
struct PyDiagnosis {
    json: String,
    table: String,
    final_model: ParamsFile,
}

#[pymethods]
impl PyDiagnosis {
    /// `mrfeel diagnose --json`: the starting model's figures, the ranked `candidates`, the `missing`
    /// effects, the `final` model and the `steps` of the search.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        from_json(py, &self.json)
    }

    /// The effects found missing, most important first.
    #[getter]
    fn missing<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.to_dict(py)?.get_item("missing")
    }

    /// The final model, fitted on every test.
    #[getter]
    fn final_model(&self) -> PyResult<PyModel> {
        PyModel::from_file(self.final_model.clone(), Path::new("PARAMS.json"), None)
    }

    /// The table `mrfeel diagnose` prints.
    fn __str__(&self) -> String {
        self.table.clone()
    }
}

/// Find where `model` fails on `measurements` (as `Model.fit` takes them) and name the missing effects by
/// the held-out error they remove, as `mrfeel diagnose` does: with `model=None` the base is chosen by
/// held-out error, and terms beyond the named effects are searched for unless `named_only`.
#[pyfunction]
#[pyo3(signature = (measurements, model=None, weighting="tests", acquisition=None, command_timing="auto", current_limit_a=None, named_only=false))]
#[allow(clippy::too_many_arguments)]
fn diagnose<'py>(
    py: Python<'py>,
    measurements: &Bound<'py, PyAny>,
    model: Option<&str>,
    weighting: &str,
    acquisition: Option<&Bound<'py, PyAny>>,
    command_timing: &str,
    current_limit_a: Option<f64>,
    named_only: bool,
) -> PyResult<PyDiagnosis> {
    let ms = self::measurements(measurements)?;
    let acq = self::acquisition(acquisition)?;
    let setup = prelude::DiagnoseSetup {
        model: model.unwrap_or_default().to_string(),
        current_limit_a,
        weighting: choice("weighting", weighting, &Weighting::ALL, Weighting::as_str)?,
        command_timing: choice(
            "command_timing",
            command_timing,
            &TimingChoice::ALL,
            TimingChoice::as_str,
        )?,
        progress: false,
    };
    work(py, move || {
        let data = prelude::prepare(&ms, acq, None)?;
        let registry = mrfeel::device::Registry::builtin();
        let d = prelude::diagnose_in(data, &setup, &registry, !named_only)?;
        Ok(PyDiagnosis {
            json: serde_json::to_string(&prelude::DiagnoseJson::new(&d.diagnosis))?,
            table: mrfeel::ident::report::diagnose_table(&d.diagnosis),
            final_model: d.final_model,
        })
    })
}

/// A Python override value (bool, int, float, str, or a list or dict of them) as the JSON value the
/// scenario's overrides take.
fn json_value(v: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    use serde_json::Value;
    // `bool` before `int`: Python's True is an int.
    if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if let Ok(i) = v.extract::<i64>() {
        return Ok(Value::from(i));
    }
    if let Ok(x) = v.extract::<f64>() {
        return serde_json::Number::from_f64(x)
            .map(Value::Number)
            .ok_or_else(|| Error::new_err(format!("overrides: {x} is not a finite number")));
    }
    if let Ok(s) = v.extract::<String>() {
        return Ok(Value::String(s));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut m = serde_json::Map::new();
        for (k, x) in d.iter() {
            m.insert(k.extract::<String>()?, json_value(&x)?);
        }
        return Ok(Value::Object(m));
    }
    if let Ok(items) = v.try_iter() {
        return Ok(Value::Array(
            items.map(|x| json_value(&x?)).collect::<PyResult<_>>()?,
        ));
    }
    Err(Error::new_err(format!(
        "overrides: {} is not a scenario value (bool, int, float, str, list, dict)",
        v.repr()?
    )))
}

/// Run a scenario (`scenarios/*.toml`) headless, as `mrfeel run`: returns `(columns, summary)`, the columns
/// of `mrfeel run --out`'s CSV by name (NumPy arrays, or one pandas DataFrame with `pandas=True`) and the
/// summary of `mrfeel run --json`. `overrides` replaces scenario values by dotted key, as `mrfeel run --set`
/// (`{"feel.gradient_n_per_m": 900.0}`); paths given there are relative to the working directory.
#[pyfunction]
#[pyo3(signature = (path, overrides=None, pandas=false))]
fn run_scenario<'py>(
    py: Python<'py>,
    path: PathBuf,
    overrides: Option<&Bound<'py, PyDict>>,
    pandas: bool,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let overrides = match overrides {
        Some(d) => d
            .iter()
            .map(|(k, v)| Ok((k.extract::<String>()?, json_value(&v)?)))
            .collect::<PyResult<Vec<_>>>()?,
        None => Vec::new(),
    };
    let (columns, summary) = work(py, || {
        let scn = prelude::load_scenario_with(&path, &overrides, "overrides")?;
        let res = prelude::run_scenario(&scn, &path)?;
        let summary = serde_json::to_string(&prelude::run_summary(&res, &scn)?)?;
        Ok((res.columns(), summary))
    })?;
    let d = PyDict::new(py);
    for (name, col) in columns {
        d.set_item(name, PyArray1::from_vec(py, col))?;
    }
    let columns = if pandas {
        py.import("pandas")
            .map_err(|_| {
                pyo3::exceptions::PyImportError::new_err("pandas=True needs pandas: pip install pandas")
            })?
            .call_method1("DataFrame", (d,))?
    } else {
        d.into_any()
    };
    Ok((columns, from_json(py, &summary)?))
}

/// mrfeel: simulation and model discovery for magneto-rheological artificial feel systems, from Python.
#[pymodule(name = "mrfeel")]
fn mrfeel_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add_class::<PyMeasurement>()?;
    m.add_class::<PyModel>()?;
    m.add_class::<PyDiagnosis>()?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(run_scenario, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
