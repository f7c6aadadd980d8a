//! A sweep's output directory: the manifest (`sweep.toml`: plan, digest, shard, columns), the journal of
//! finished runs (`runs.jsonl`, appended line by line, so a killed sweep loses at most the line it was
//! writing), and the results (`results.parquet`, `results.csv`) written from the journal sorted by index.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};
use toml::Spanned;

use super::outcome::{Cell, Outcome};
use super::plan::{Param, Plan};
use crate::input::sweep::Loaded;
use crate::input::InputError;

/// A sweep directory refused (its manifest or journal, as `InputError`), a write that failed, or a
/// `--shard` argument refused.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// A bad manifest or journal.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A file that could not be read or written.
    #[error("{}: {msg}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What failed.
        msg: String,
    },
    /// A `--shard` argument refused.
    #[error("--shard {arg}: {msg}")]
    Shard {
        /// The argument as given.
        arg: String,
        /// What is wrong with it.
        msg: String,
    },
}

fn io_err(path: &Path, msg: impl ToString) -> StoreError {
    StoreError::Io {
        path: path.to_path_buf(),
        msg: msg.to_string(),
    }
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> StoreError + '_ {
    move |e| io_err(path, e)
}

fn not_a_sweep(manifest: &Path) -> InputError {
    InputError::file(manifest, "no such file: not a sweep's output directory")
}

/// Shard `k` of `n` (0-based, as Slurm's `$SLURM_ARRAY_TASK_ID` of `--array=0-(n-1)`): the runs whose
/// index is `k` modulo `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard's index, 0..n.
    pub k: u64,
    /// Number of shards.
    pub n: u64,
}

impl Shard {
    /// The whole plan: one shard.
    pub const ALL: Shard = Shard { k: 0, n: 1 };

    /// Whether run `index` is in this shard.
    pub fn contains(&self, index: u64) -> bool {
        index % self.n == self.k
    }

    /// `all`, or `K/N`.
    pub fn label(&self) -> String {
        if *self == Self::ALL {
            "all".into()
        } else {
            format!("{}/{}", self.k, self.n)
        }
    }
}

impl std::str::FromStr for Shard {
    type Err = StoreError;
    fn from_str(arg: &str) -> Result<Self, StoreError> {
        let bad = |msg: String| StoreError::Shard {
            arg: arg.to_string(),
            msg,
        };
        let (k, n) = arg
            .split_once('/')
            .ok_or_else(|| bad("expected K/N, shard K (0-based) of N, e.g. 0/4".into()))?;
        let k: u64 = k
            .trim()
            .parse()
            .map_err(|_| bad(format!("K = `{k}` is not a whole number ≥ 0")))?;
        let n: u64 = n
            .trim()
            .parse()
            .map_err(|_| bad(format!("N = `{n}` is not a whole number ≥ 1")))?;
        if n == 0 || k >= n {
            return Err(bad(format!(
                "K must be in 0..N-1 and N at least 1 (K = {k}, N = {n}); with Slurm: --array=0-{}",
                n.max(1) - 1
            )));
        }
        Ok(Shard { k, n })
    }
}

/// One finished run: its index, seed, parameters (one per axis) and outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Record {
    /// The run's index in the plan.
    pub index: u64,
    /// The scenario's seed in the run.
    pub seed: u64,
    /// One value per axis, in the plan's order.
    pub params: Vec<Param>,
    /// The run's figures and verdicts.
    pub outcome: Outcome,
}

/// `sweep.toml`.
#[derive(Debug, Clone, PartialEq, Serialize)]
struct Manifest {
    name: String,
    plan: String,
    digest: String,
    runs: u64,
    shard: String,
    columns: Vec<String>,
    numeric: Vec<bool>,
}

impl Loaded {
    fn err<T>(&self, at: &Spanned<T>, key: &str, msg: String) -> StoreError {
        self.src.err(at, key, msg).into()
    }

    fn manifest(&self) -> Manifest {
        let f = &self.file;
        Manifest {
            name: f.name.clone(),
            plan: f.plan.clone(),
            digest: f.digest.get_ref().clone(),
            runs: *f.runs.get_ref(),
            shard: f.shard.get_ref().clone(),
            columns: f.columns.get_ref().clone(),
            numeric: f.numeric.clone(),
        }
    }
}

/// The plan and digest the directory belongs to.
pub const MANIFEST: &str = "sweep.toml";
/// One finished run per line, appended as runs end (what a rerun skips).
pub const JOURNAL: &str = "runs.jsonl";
/// The results table, one row per run.
pub const RESULTS_CSV: &str = "results.csv";
/// The results table in Parquet.
pub const RESULTS_PARQUET: &str = "results.parquet";

/// An output directory open for a plan's shard: its journal to append to, and the runs it already has.
pub struct Store {
    /// The output directory.
    pub dir: PathBuf,
    manifest: Manifest,
    journal: std::fs::File,
    /// Runs already in the journal.
    pub done: Vec<Record>,
}

impl Store {
    /// Open (or start) `dir` for `plan`'s `shard`. A directory of another plan or shard is refused at its
    /// manifest's line; a journal's last line cut short by a kill is dropped (the run runs again).
    pub fn open(dir: &Path, plan: &Plan, shard: Shard) -> Result<Self, StoreError> {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let mpath = dir.join(MANIFEST);
        let manifest = Manifest {
            name: plan.name.clone(),
            plan: plan.path.display().to_string(),
            digest: plan.digest.clone(),
            runs: plan.run_count(),
            shard: shard.label(),
            columns: plan.axes.iter().map(|a| a.name.clone()).collect(),
            numeric: plan.axes.iter().map(|a| a.numeric()).collect(),
        };
        match Loaded::read(&mpath)? {
            Some(l) => {
                if *l.file.digest.get_ref() != plan.digest {
                    return Err(l.err(
                        &l.file.digest,
                        "digest",
                        format!(
                            "this directory holds a sweep of another plan (or of another version of {} or its \
                             scenario): give another --out",
                            plan.path.display()
                        ),
                    ));
                }
                if *l.file.shard.get_ref() != shard.label() {
                    return Err(l.err(
                        &l.file.shard,
                        "shard",
                        format!(
                            "this directory holds shard {}, not {}: give another --out",
                            l.file.shard.get_ref(),
                            shard.label()
                        ),
                    ));
                }
            }
            None => write_bytes(
                &mpath,
                toml::to_string(&manifest)
                    .expect("manifest serialises")
                    .as_bytes(),
            )?,
        }
        let jpath = dir.join(JOURNAL);
        let done = read_journal(&jpath, manifest.runs, |i| shard.contains(i), true)?;
        let journal = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&jpath)
            .map_err(io(&jpath))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            manifest,
            journal,
            done,
        })
    }

    /// Append a finished run to the journal, in one write of one line.
    pub fn append(&mut self, r: &Record) -> Result<(), StoreError> {
        let mut line = serde_json::to_string(r).expect("a record serialises");
        line.push('\n');
        let p = self.dir.join(JOURNAL);
        self.journal.write_all(line.as_bytes()).map_err(io(&p))?;
        self.journal.flush().map_err(io(&p))
    }

    /// Write the results of `records` (all of this shard's runs): the journal sorted, Parquet and CSV.
    pub fn finish(&self, records: &mut [Record]) -> Result<(), StoreError> {
        write_results(&self.dir, &self.manifest, records)
    }
}

/// Read a journal: its records, each index once, within `runs` and `in_shard`. With `repair`, a last line
/// without its newline (a write cut short) is cut off the file.
fn read_journal(
    path: &Path,
    runs: u64,
    in_shard: impl Fn(u64) -> bool,
    repair: bool,
) -> Result<Vec<Record>, StoreError> {
    let text = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io(path)(e)),
    };
    let whole = text.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
    if whole < text.len() && repair {
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(io(path))?;
        f.set_len(whole as u64).map_err(io(path))?;
    }
    let text = String::from_utf8_lossy(&text[..whole]);
    let mut out: Vec<Record> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for (k, line) in text.lines().enumerate() {
        let bad = |msg: String| StoreError::from(InputError::line(path, k + 1, msg));
        let r: Record = serde_json::from_str(line).map_err(|e| bad(format!("not a run record: {e}")))?;
        if r.index >= runs || !in_shard(r.index) {
            return Err(bad(format!(
                "run {} is not one of this directory's runs",
                r.index
            )));
        }
        if !seen.insert(r.index) {
            return Err(bad(format!("run {} recorded twice", r.index)));
        }
        out.push(r);
    }
    Ok(out)
}

/// Write a whole file through a temporary beside it, so that a reader never sees half of it.
fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), StoreError> {
    crate::outputs::write_whole(path, |tmp| std::fs::write(tmp, bytes).map_err(io(path)), io(path))
}

fn write_results(dir: &Path, m: &Manifest, records: &mut [Record]) -> Result<(), StoreError> {
    records.sort_by_key(|r| r.index);
    let mut journal = String::new();
    for r in records.iter() {
        journal.push_str(&serde_json::to_string(r).expect("a record serialises"));
        journal.push('\n');
    }
    write_bytes(&dir.join(JOURNAL), journal.as_bytes())?;
    write_bytes(&dir.join(RESULTS_CSV), &csv_bytes(m, records))?;
    let p = dir.join(RESULTS_PARQUET);
    let bytes = parquet_bytes(m, records).map_err(|msg| io_err(&p, msg))?;
    write_bytes(&p, &bytes)
}

fn cell_text(c: &Cell) -> String {
    match c {
        Cell::F(v) => v.map(|x| x.to_string()).unwrap_or_default(),
        Cell::B(v) => v.map(|x| x.to_string()).unwrap_or_default(),
        Cell::U(v) => v.map(|x| x.to_string()).unwrap_or_default(),
        Cell::S(v) => v.clone().unwrap_or_default(),
    }
}

fn csv_bytes(m: &Manifest, records: &[Record]) -> Vec<u8> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let metric_names: Vec<&str> = Outcome::default().columns().iter().map(|c| c.0).collect();
    let mut header = vec!["index".to_string(), "seed".to_string()];
    header.extend(m.columns.iter().cloned());
    header.extend(metric_names.iter().map(|s| s.to_string()));
    w.write_record(&header).expect("writing to memory");
    for r in records {
        let mut row = vec![r.index.to_string(), r.seed.to_string()];
        row.extend(r.params.iter().map(Param::to_string));
        row.extend(r.outcome.columns().iter().map(|(_, c)| cell_text(c)));
        w.write_record(&row).expect("writing to memory");
    }
    w.into_inner().expect("writing to memory")
}

/// The results as a Parquet file (one row group, uncompressed): the same bytes for the same records.
fn parquet_bytes(m: &Manifest, records: &[Record]) -> Result<Vec<u8>, String> {
    use arrow_array::{
        ArrayRef, BooleanArray, Float64Array, RecordBatch, StringArray, UInt64Array, UInt8Array,
    };
    use arrow_schema::{DataType, Field, Schema};
    let mut fields = vec![
        Field::new("index", DataType::UInt64, false),
        Field::new("seed", DataType::UInt64, false),
    ];
    let mut cols: Vec<ArrayRef> = vec![
        Arc::new(UInt64Array::from_iter_values(records.iter().map(|r| r.index))),
        Arc::new(UInt64Array::from_iter_values(records.iter().map(|r| r.seed))),
    ];
    for (k, (name, numeric)) in m.columns.iter().zip(&m.numeric).enumerate() {
        if *numeric {
            fields.push(Field::new(name, DataType::Float64, true));
            cols.push(Arc::new(Float64Array::from_iter(records.iter().map(
                |r| match r.params.get(k) {
                    Some(Param::Num(x)) => Some(*x),
                    _ => None,
                },
            ))));
        } else {
            fields.push(Field::new(name, DataType::Utf8, true));
            cols.push(Arc::new(StringArray::from_iter(
                records.iter().map(|r| r.params.get(k).map(Param::to_string)),
            )));
        }
    }
    let per_run: Vec<Vec<(&'static str, Cell)>> = records.iter().map(|r| r.outcome.columns()).collect();
    for (j, (name, kind)) in Outcome::default().columns().into_iter().enumerate() {
        let col = per_run.iter().map(|c| &c[j].1);
        // The column of one kind of cell, as the Arrow array of that kind.
        macro_rules! column {
            ($cell:ident, $dt:ident, $array:ident) => {
                (
                    DataType::$dt,
                    Arc::new($array::from_iter(col.map(|c| match c {
                        Cell::$cell(v) => v.to_owned(),
                        _ => None,
                    }))) as ArrayRef,
                )
            };
        }
        let (dt, arr) = match kind {
            Cell::F(_) => column!(F, Float64, Float64Array),
            Cell::B(_) => column!(B, Boolean, BooleanArray),
            Cell::U(_) => column!(U, UInt8, UInt8Array),
            Cell::S(_) => column!(S, Utf8, StringArray),
        };
        fields.push(Field::new(name, dt, true));
        cols.push(arr);
    }
    let schema = Arc::new(Schema::new(fields));
    let batch = RecordBatch::try_new(schema.clone(), cols).map_err(|e| e.to_string())?;
    let props = parquet::file::properties::WriterProperties::builder()
        .set_compression(parquet::basic::Compression::UNCOMPRESSED)
        .build();
    let mut buf = Vec::new();
    let mut w =
        parquet::arrow::ArrowWriter::try_new(&mut buf, schema, Some(props)).map_err(|e| e.to_string())?;
    w.write(&batch).map_err(|e| e.to_string())?;
    w.close().map_err(|e| e.to_string())?;
    Ok(buf)
}

/// `mrfeel sweep merge`: join the shards in `dirs` (all of one plan) into `out`, as one process would have
/// written it. Shards of different plans, a run missing or recorded twice with other results are refused.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<usize, StoreError> {
    let mut first: Option<Loaded> = None;
    let mut all: std::collections::BTreeMap<u64, Record> = Default::default();
    for d in dirs {
        let mpath = d.join(MANIFEST);
        let l = Loaded::read(&mpath)?.ok_or_else(|| not_a_sweep(&mpath))?;
        if let Some(f) = &first {
            if l.file.digest.get_ref() != f.file.digest.get_ref() {
                return Err(l.err(
                    &l.file.digest,
                    "digest",
                    format!(
                        "a shard of another plan than {}'s (plan {} here, {} there): merge shards of one plan",
                        f.src.path.display(),
                        l.file.plan,
                        f.file.plan
                    ),
                ));
            }
            if l.file.columns.get_ref() != f.file.columns.get_ref()
                || l.file.runs.get_ref() != f.file.runs.get_ref()
            {
                return Err(l.err(
                    &l.file.columns,
                    "columns",
                    format!("differs from {}", f.src.path.display()),
                ));
            }
        }
        let shard: Shard = match l.file.shard.get_ref().as_str() {
            "all" => Shard::ALL,
            s => s
                .parse()
                .map_err(|e: StoreError| l.err(&l.file.shard, "shard", e.to_string()))?,
        };
        let runs = *l.file.runs.get_ref();
        for r in read_journal(&d.join(JOURNAL), runs, |i| shard.contains(i), false)? {
            match all.get(&r.index) {
                Some(prev) if *prev != r => {
                    let msg = format!("run {} differs from the same run in another shard", r.index);
                    return Err(io_err(&d.join(JOURNAL), msg));
                }
                _ => {
                    all.insert(r.index, r);
                }
            }
        }
        if first.is_none() {
            first = Some(l);
        }
    }
    let Some(first) = first else {
        return Err(io_err(out, "no shard directories to merge"));
    };
    let mut m = first.manifest();
    m.shard = Shard::ALL.label();
    let missing: Vec<u64> = (0..m.runs).filter(|i| !all.contains_key(i)).take(6).collect();
    if !missing.is_empty() {
        return Err(first.err(
            &first.file.runs,
            "runs",
            format!(
                "{} of the plan's {} runs are in these directories; missing runs {:?}{}: finish every shard first \
                 (rerun it: it resumes)",
                all.len(),
                m.runs,
                &missing[..missing.len().min(5)],
                if missing.len() > 5 { " and more" } else { "" }
            ),
        ));
    }
    std::fs::create_dir_all(out).map_err(io(out))?;
    let text = toml::to_string(&m).expect("manifest serialises");
    write_bytes(&out.join(MANIFEST), text.as_bytes())?;
    let mut records: Vec<Record> = all.into_values().collect();
    write_results(out, &m, &mut records)?;
    Ok(records.len())
}

/// The records of a finished output directory (for reports), with its axis names.
pub fn read_results(dir: &Path) -> Result<(Vec<String>, Vec<Record>), StoreError> {
    let mpath = dir.join(MANIFEST);
    let l = Loaded::read(&mpath)?.ok_or_else(|| not_a_sweep(&mpath))?;
    let recs = read_journal(&dir.join(JOURNAL), *l.file.runs.get_ref(), |_| true, false)?;
    Ok((l.file.columns.get_ref().clone(), recs))
}
