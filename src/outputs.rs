//! Every output a command will write, checked before the command runs: a run either writes all it was
//! asked to or fails before it writes or prints anything (the path and the option named in the error).

use std::path::{Component, Path, PathBuf};

/// What an output option names: a file the command writes (its directory must exist), or a directory it
/// creates if need be and writes files into.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Kind {
    /// A file.
    File,
    /// A directory.
    Dir,
}

/// One output of a command: the option that names it, the path, and what it is.
pub type Output<'a> = (&'static str, &'a Path, Kind);

/// `path` without `.` components, so that `out/a` and `./out/a` compare equal.
fn normalised(path: &Path) -> PathBuf {
    path.components().filter(|c| *c != Component::CurDir).collect()
}

/// `dir` as a directory to look at (`.` for the empty parent of a bare file name).
fn or_here(dir: &Path) -> &Path {
    if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    }
}

/// Whether a file can be made in the existing directory `dir`: make one, with a new name no other run
/// uses, and remove it again.
fn probe_dir(dir: &Path) -> std::io::Result<()> {
    tempfile::Builder::new()
        .prefix(".mrfeel-write-check-")
        .tempfile_in(dir)?
        .close()
}

/// The kinds of file an output directory receives: every plot is written as PNG and SVG.
const PLOT_EXTENSIONS: [&str; 2] = ["png", "svg"];

/// Check that one output can be written, without writing it: a file's directory exists and takes a new
/// file (an existing file opens for writing); a directory exists or its nearest existing ancestor takes one.
fn check_output(option: &str, path: &Path, kind: Kind) -> Result<(), String> {
    let fail = |why: String| Err(format!("{option} {}: {why} (nothing was run)", path.display()));
    match kind {
        Kind::File => {
            if path.is_dir() {
                return fail("is a directory, not a file".into());
            }
            let dir = or_here(path.parent().unwrap_or(Path::new("")));
            match std::fs::metadata(dir) {
                Ok(m) if m.is_dir() => {}
                Ok(_) => return fail(format!("`{}` is not a directory", dir.display())),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                    return fail(format!("directory `{}` does not exist", dir.display()))
                }
                Err(e) => return fail(format!("directory `{}`: {e}", dir.display())),
            }
            let target = resolved(path);
            let probe = if is_stream(&target) {
                // A stream (`/dev/null`, a named pipe) is written directly when the results are ready;
                // opening a pipe now would wait for its reader, or end its reading.
                Ok(())
            } else if path.exists() {
                // A regular file is replaced through a new file beside what it names (`write_whole`): both
                // must be possible.
                let dir_of_target = target.parent().map(Path::to_path_buf).unwrap_or_default();
                std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .map(drop)
                    .and_then(|()| probe_dir(or_here(&dir_of_target)))
            } else {
                // Not the file itself: another run writing the same output may make it meanwhile.
                probe_dir(dir)
            };
            probe.or_else(|e| fail(format!("cannot write the file: {e}")))
        }
        Kind::Dir => {
            if let Ok(link) = std::fs::read_link(path) {
                if std::fs::metadata(path).is_err() {
                    return fail(format!(
                        "is a symbolic link to `{}`, which does not exist",
                        link.display()
                    ));
                }
            }
            if let Ok(entries) = std::fs::read_dir(path) {
                // The directory's files are plots and recordings; one that is itself a directory would
                // stop the run after its other outputs were written.
                for e in entries.flatten() {
                    let name = e.path();
                    if is_plot_file(&name) && name.is_dir() {
                        return fail(format!(
                            "holds a directory `{}` where a plot file would be written",
                            name.display()
                        ));
                    }
                }
            }
            // The nearest ancestor that exists (the rest is created with the directory).
            let found = path.ancestors().enumerate().find_map(|(n, p)| {
                let p = or_here(p);
                std::fs::metadata(p).ok().map(|m| (n, p, m))
            });
            match found {
                None => Ok(()),
                Some((0, _, m)) if !m.is_dir() => fail("exists and is not a directory".into()),
                Some((_, p, m)) if !m.is_dir() => fail(format!(
                    "cannot create the directory: `{}` is not a directory",
                    p.display()
                )),
                Some((_, p, _)) => {
                    probe_dir(p).or_else(|e| fail(format!("cannot write into `{}`: {e}", p.display())))
                }
            }
        }
    }
}

/// Where a file output ends up: the file a symbolic link points to (it is replaced, the link kept), else the
/// path itself.
fn resolved(path: &Path) -> PathBuf {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => {
            std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
        }
        _ => path.to_path_buf(),
    }
}

/// Whether an output's target exists and is not a regular file (`/dev/null`, a named pipe): a stream,
/// written directly, not a file to replace ([`write_whole`]) or to open before the run ([`check_output`]).
fn is_stream(target: &Path) -> bool {
    std::fs::metadata(target).is_ok_and(|m| !m.is_file())
}

/// What the name of every temporary file beside an output holds, after a dot and the output's stem.
const PARTIAL_MARK: &str = ".mrfeel-partial-";

/// A temporary file beside `target` for [`write_whole`]: hidden, made exclusively under an unpredictable
/// name (`.out.mrfeel-partial-XXXXXXXXXX.csv`: nothing planted there is written through), with `target`'s
/// extension (plot backends choose the format by it), locked so the next run knows it is not stale.
fn new_partial(target: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (stem, ext) = match name.rsplit_once('.') {
        Some((stem, ext)) if !stem.is_empty() => (stem.to_string(), format!(".{ext}")),
        _ => (name, String::new()),
    };
    let dir = or_here(target.parent().unwrap_or(Path::new("")));
    locked_temp(dir, &format!(".{stem}{PARTIAL_MARK}"), &ext)
}

/// A new file in `dir` named `prefix`, ten random characters and `suffix`, locked while this run lives.
fn locked_temp(dir: &Path, prefix: &str, suffix: &str) -> std::io::Result<tempfile::NamedTempFile> {
    let tmp = tempfile::Builder::new()
        .prefix(prefix)
        .suffix(suffix)
        .rand_bytes(10)
        .tempfile_in(dir)?;
    tmp.as_file().lock()?;
    Ok(tmp)
}

/// Least age of an empty, unlocked temporary file before it counts as stale (a live run's file is empty
/// and unlocked only between making and locking it).
const EMPTY_PARTIAL_AGE: std::time::Duration = std::time::Duration::from_secs(60);

/// Whether a temporary file ([`new_partial`], a set's journal) that no run holds locked may be one a live
/// run has just made and not yet locked: empty and younger than [`EMPTY_PARTIAL_AGE`].
fn maybe_unlocked_yet(meta: &std::fs::Metadata) -> bool {
    let young = meta
        .modified()
        .ok()
        .and_then(|m| m.elapsed().ok())
        .is_none_or(|age| age < EMPTY_PARTIAL_AGE);
    meta.len() == 0 && young
}

/// The regular files in `dir` whose names start with a dot and hold `mark`, with their metadata.
fn marked_files(dir: &Path, mark: &str) -> Vec<(PathBuf, std::fs::Metadata)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut found: Vec<(PathBuf, std::fs::Metadata)> = entries
        .flatten()
        .filter(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name.starts_with('.') && name.contains(mark)
        })
        .filter_map(|e| {
            let meta = e.path().symlink_metadata().ok()?;
            meta.is_file().then(|| (e.path(), meta))
        })
        .collect();
    found.sort_by(|a, b| a.0.cmp(&b.0));
    found
}

/// Remove the temporary files ([`new_partial`]) in `dir` that killed runs left behind (none locked), after
/// finishing the output sets ([`OutputSet`]) such a run had begun to rename into `dir`. Best effort.
fn remove_stale_partials(dir: &Path) {
    for (journal, meta) in marked_files(dir, SET_MARK) {
        if !maybe_unlocked_yet(&meta) {
            finish_killed_set(&journal);
        }
    }
    for (path, meta) in marked_files(dir, PARTIAL_MARK) {
        if maybe_unlocked_yet(&meta) {
            continue;
        }
        let Ok(f) = std::fs::File::open(&path) else {
            continue;
        };
        if f.try_lock().is_ok() {
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// Write the file `path` whole or not at all: `write` fills a temporary file beside it (the path it is
/// given), flushed and renamed over `path` once `write` succeeds (in an [`OutputSet`], at its commit); a
/// failure leaves the old file. Links are followed, permissions kept; a stream (`/dev/null`, a pipe) is
/// written directly. `io_error` turns a failure to make, flush or rename the temporary file into `E`.
pub fn write_whole<T, E>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<T, E>,
    io_error: impl Fn(std::io::Error) -> E,
) -> Result<T, E> {
    let target = resolved(path);
    if is_stream(&target) {
        return write(&target);
    }
    let dir = or_here(target.parent().unwrap_or(Path::new(""))).to_path_buf();
    remove_stale_partials(&dir);
    let tmp = new_partial(&target).map_err(&io_error)?;
    // On failure the temporary file is removed when `tmp` drops.
    let v = write(tmp.path())?;
    if let Ok(m) = std::fs::metadata(&target) {
        // Best effort: a file that cannot take the old permissions still replaces the old one whole.
        let _ = std::fs::set_permissions(tmp.path(), m.permissions());
    }
    // The writer may have written through a handle of its own: flush the file by its name.
    std::fs::File::open(tmp.path())
        .and_then(|f| f.sync_all())
        .map_err(&io_error)?;
    let staged = Staged { tmp, target, dir };
    if let Some(staged) = OutputSet::stage(staged) {
        staged.rename().map_err(&io_error)?;
    }
    Ok(v)
}

/// Flush a directory's entries (a rename into it) to the disk.
#[cfg(unix)]
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    std::fs::File::open(dir)?.sync_all()
}

/// Directories cannot be opened as files here; the rename is as durable as the system makes it.
#[cfg(not(unix))]
fn sync_dir(_dir: &Path) -> std::io::Result<()> {
    Ok(())
}

/// One output written whole and flushed beside its target, waiting to be renamed over it.
struct Staged {
    tmp: tempfile::NamedTempFile,
    target: PathBuf,
    /// The directory of `target` (and of `tmp`).
    dir: PathBuf,
}

impl Staged {
    fn rename(self) -> std::io::Result<()> {
        self.tmp.persist(&self.target).map_err(|e| e.error)?;
        sync_dir(&self.dir)
    }
}

/// What the name of an output set's journal holds, after a dot ([`OutputSet`]).
const SET_MARK: &str = "mrfeel-set-";

thread_local! {
    /// The outputs staged by this thread's open [`OutputSet`], `None` where no set is open.
    static SET: std::cell::RefCell<Option<Vec<Staged>>> = const { std::cell::RefCell::new(None) };
}

/// A command's outputs written as one set: while a set is open on a thread, [`write_whole`] stages its
/// flushed temporary file; [`OutputSet::commit`] renames them all, dropping the set uncommitted removes
/// them. Several files' renames are journalled (`.mrfeel-set-*.json`, locked while the run lives) so that
/// the next run finishes a killed one's set: never part new, part old.
pub struct OutputSet(());

impl OutputSet {
    /// Open a set on this thread. Panics if one is open already.
    pub fn open() -> Self {
        SET.with_borrow_mut(|s| {
            assert!(s.is_none(), "an output set is open already on this thread");
            *s = Some(Vec::new());
        });
        OutputSet(())
    }

    /// Hold `staged` for the commit of the open set; hand it back where no set is open.
    fn stage(staged: Staged) -> Option<Staged> {
        SET.with_borrow_mut(|s| match s {
            Some(v) => {
                v.push(staged);
                None
            }
            None => Some(staged),
        })
    }

    /// Rename every output staged so far into place, as one set; the set stays open for further outputs.
    /// The error names the output that could not be put in place.
    pub fn commit(&self) -> std::io::Result<()> {
        commit_open_set()
    }
}

/// Commit the outputs staged so far by this thread's open [`OutputSet`], if one is open: what a command
/// prints on stdout ([`crate::outln`]) comes after the files it reports.
#[doc(hidden)]
pub fn commit_open_set() -> std::io::Result<()> {
    let staged = SET.with_borrow_mut(|s| s.as_mut().map(std::mem::take).unwrap_or_default());
    commit(staged)
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        // Whatever is still staged is removed with its temporary files.
        SET.with_borrow_mut(|s| *s = None);
    }
}

/// Rename `staged` into place: one file directly, several through journals ([`OutputSet`]).
fn commit(staged: Vec<Staged>) -> std::io::Result<()> {
    fn named(target: &Path, e: std::io::Error) -> std::io::Error {
        std::io::Error::new(e.kind(), format!("writing {}: {e}", target.display()))
    }
    if staged.len() < 2 {
        for s in staged {
            let target = s.target.clone();
            s.rename().map_err(|e| named(&target, e))?;
        }
        return Ok(());
    }
    // Absolute, so that a run started elsewhere finds them.
    let pairs = staged
        .iter()
        .map(|s| -> std::io::Result<(PathBuf, PathBuf)> {
            Ok((
                std::path::absolute(s.tmp.path())?,
                std::path::absolute(&s.target)?,
            ))
        })
        .collect::<std::io::Result<Vec<(PathBuf, PathBuf)>>>()?;
    let text = serde_json::to_string(&pairs).map_err(|e| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("an output's name: {e}"))
    })?;
    let mut dirs: Vec<&Path> = staged.iter().map(|s| s.dir.as_path()).collect();
    dirs.sort();
    dirs.dedup();
    let mut journals = Vec::with_capacity(dirs.len());
    for dir in &dirs {
        journals.push(write_journal(dir, &text).map_err(|e| named(dir, e))?);
    }
    let synced: Vec<PathBuf> = dirs.iter().map(|d| d.to_path_buf()).collect();
    for s in staged {
        let target = s.target.clone();
        s.tmp.persist(&target).map_err(|e| named(&target, e.error))?;
    }
    for dir in &synced {
        sync_dir(dir).map_err(|e| named(dir, e))?;
    }
    for j in journals {
        let _ = j.close();
    }
    Ok(())
}

/// A set's journal in `dir`: made, locked, written and flushed; removed when the returned file drops.
fn write_journal(dir: &Path, text: &str) -> std::io::Result<tempfile::NamedTempFile> {
    use std::io::Write as _;
    let mut j = locked_temp(dir, &format!(".{SET_MARK}"), ".json")?;
    j.write_all(text.as_bytes())?;
    j.as_file().sync_all()?;
    sync_dir(dir)?;
    Ok(j)
}

/// Finish the set whose journal a killed run left at `journal` (unless a live run holds it locked): rename
/// each temporary file it lists that is still there, then remove the journal (one that does not parse was
/// cut short before any rename: removed, nothing renamed).
fn finish_killed_set(journal: &Path) {
    let Ok(f) = std::fs::File::open(journal) else {
        return;
    };
    if f.try_lock().is_err() {
        return;
    }
    let pairs: Vec<(PathBuf, PathBuf)> = std::fs::read_to_string(journal)
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok())
        .unwrap_or_default();
    for (tmp, target) in pairs {
        if tmp.is_file() {
            let _ = std::fs::rename(&tmp, &target);
        }
    }
    let _ = std::fs::remove_file(journal);
}

/// What a path names on disk, to tell whether two paths are one file: an existing file by device and inode
/// (hard links, symlinks, `a/../b` alike), else the canonical path of its nearest existing ancestor and the
/// rest.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum FileId {
    Inode(u64, u64),
    Path(PathBuf),
}

/// The [`FileId`] of `path`.
pub(crate) fn file_id(path: &Path) -> FileId {
    #[cfg(unix)]
    if let Ok(m) = std::fs::metadata(path) {
        use std::os::unix::fs::MetadataExt;
        return FileId::Inode(m.dev(), m.ino());
    }
    let mut rest = Vec::new();
    let mut p = normalised(path);
    loop {
        if let Ok(c) = std::fs::canonicalize(or_here(&p)) {
            return FileId::Path(rest.iter().rev().fold(c, |acc: PathBuf, part| acc.join(part)));
        }
        match (p.file_name().map(|n| n.to_os_string()), p.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                p = parent.to_path_buf();
            }
            _ => return FileId::Path(normalised(path)),
        }
    }
}

/// Check every output of a command before it runs: each path writable, no two options naming one file
/// (however spelled), and no output one of the command's `inputs` (the files it reads).
pub fn check_outputs(outs: &[Output<'_>], inputs: &[(&'static str, &Path)]) -> Result<(), String> {
    let ids: Vec<FileId> = outs.iter().map(|(_, p, _)| file_id(p)).collect();
    let input_ids: Vec<FileId> = inputs.iter().map(|(_, p)| file_id(p)).collect();
    for (k, &(opt, path, _)) in outs.iter().enumerate() {
        if let Some(j) = ids[..k].iter().position(|id| *id == ids[k]) {
            let (first, other, _) = outs[j];
            return Err(format!(
                "{first} {} and {opt} {} name the same file: give each output its own path (nothing was run)",
                other.display(),
                path.display()
            ));
        }
        if let Some((what, input)) = input_ids.iter().position(|id| *id == ids[k]).map(|j| inputs[j]) {
            return Err(format!(
                "{opt} {}: is the input {what} `{}`, which the run reads; writing it would destroy it (nothing \
                 was run)",
                path.display(),
                input.display()
            ));
        }
    }
    for &(opt, dir, kind) in outs {
        if kind == Kind::Dir {
            check_plot_dir(opt, dir, outs, inputs)?;
        }
    }
    for &(opt, path, kind) in outs {
        check_output(opt, path, kind)?;
    }
    Ok(())
}

/// Whether `path` names a plot file: a `.png` or `.svg` (any case).
fn is_plot_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| PLOT_EXTENSIONS.iter().any(|p| e.eq_ignore_ascii_case(p)))
}

/// No input or other output may lie in the plot directory `dir` with a plot file's name, nor be one of its
/// plot files by a link.
fn check_plot_dir(
    opt: &str,
    dir: &Path,
    outs: &[Output<'_>],
    inputs: &[(&'static str, &Path)],
) -> Result<(), String> {
    let dir_id = file_id(dir);
    let others: Vec<(String, &Path)> = outs
        .iter()
        .filter(|(_, p, k)| *k == Kind::File && !p.as_os_str().is_empty())
        .map(|(o, p, _)| (o.to_string(), *p))
        .chain(inputs.iter().map(|(what, p)| (format!("the input {what}"), *p)))
        .collect();
    for (what, p) in &others {
        let parent = or_here(p.parent().unwrap_or(Path::new("")));
        if is_plot_file(p) && file_id(parent) == dir_id {
            return Err(format!(
                "{opt} {}: {what} `{}` is in it with a plot file's name, which a plot could overwrite: give \
                 one of them another name or directory (nothing was run)",
                dir.display(),
                p.display()
            ));
        }
    }
    if let Ok(entries) = std::fs::read_dir(dir) {
        let ids: Vec<(FileId, &String, &Path)> = others.iter().map(|(w, p)| (file_id(p), w, *p)).collect();
        for e in entries.flatten() {
            let name = e.path();
            if !is_plot_file(&name) {
                continue;
            }
            let id = file_id(&name);
            if let Some((_, what, p)) = ids.iter().find(|(i, _, _)| *i == id) {
                return Err(format!(
                    "{opt} {}: its `{}` is {what} `{}`, which a plot would overwrite (nothing was run)",
                    dir.display(),
                    name.file_name().unwrap_or_default().to_string_lossy(),
                    p.display()
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// A writer that fails after writing part of its file leaves the old file as it was and nothing beside
    /// it; one that succeeds replaces it whole, with the old file's permissions; the error is the writer's.
    #[test]
    fn write_whole_replaces_a_file_only_when_the_writer_succeeds() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("out.csv");
        std::fs::write(&p, "old\n").unwrap();
        let failed: Result<(), String> = write_whole(
            &p,
            |tmp| {
                std::fs::write(tmp, "half a fi").unwrap();
                Err("disk full".into())
            },
            |e| e.to_string(),
        );
        assert_eq!(failed, Err("disk full".into()));
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old\n");
        assert_eq!(names(d.path()), ["out.csv"]);

        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
        }
        let written: Result<u8, String> = write_whole(
            &p,
            |tmp| {
                // Plot backends choose the format by the extension: the temporary file keeps it.
                assert_eq!(tmp.extension().and_then(|e| e.to_str()), Some("csv"));
                assert_eq!(tmp.parent(), p.parent());
                std::fs::write(tmp, "new\n").map_err(|e| e.to_string())?;
                Ok(7)
            },
            |e| e.to_string(),
        );
        assert_eq!(written, Ok(7));
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new\n");
        assert_eq!(names(d.path()), ["out.csv"]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o640);
        }
    }

    /// An output that is a symbolic link to a file: the file it points to is replaced, the link stays a link.
    #[test]
    #[cfg(unix)]
    fn write_whole_follows_a_symbolic_link() {
        let d = tempfile::tempdir().unwrap();
        let real = d.path().join("real.json");
        let link = d.path().join("link.json");
        std::fs::write(&real, "old").unwrap();
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_whole(&link, |tmp| std::fs::write(tmp, "new"), |e| e).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), "new");
        assert_eq!(names(d.path()), ["link.json", "real.json"]);
    }

    fn put(path: &Path, text: &str) -> std::io::Result<()> {
        write_whole(path, |tmp| std::fs::write(tmp, text), |e| e)
    }

    /// A temporary directory with the directories `a` and `b`, and an output path in each.
    fn two_dirs() -> (tempfile::TempDir, PathBuf, PathBuf, PathBuf, PathBuf) {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("a"), d.path().join("b"));
        std::fs::create_dir(&a).unwrap();
        std::fs::create_dir(&b).unwrap();
        let (fa, fb) = (a.join("out.csv"), b.join("device.json"));
        (d, a, b, fa, fb)
    }

    /// Within an open set, outputs in two directories keep their old contents until the commit, which puts
    /// both in place and leaves no temporary file or journal; a set dropped uncommitted (a command that
    /// failed) changes nothing and leaves nothing behind.
    #[test]
    fn an_output_set_is_put_in_place_whole_at_its_commit_or_not_at_all() {
        let (_d, a, b, fa, fb) = two_dirs();
        std::fs::write(&fa, "old a").unwrap();
        std::fs::write(&fb, "old b").unwrap();
        {
            let _set = OutputSet::open();
            put(&fa, "new a").unwrap();
            put(&fb, "new b").unwrap();
            assert_eq!(std::fs::read_to_string(&fa).unwrap(), "old a");
        }
        assert_eq!(std::fs::read_to_string(&fa).unwrap(), "old a");
        assert_eq!(std::fs::read_to_string(&fb).unwrap(), "old b");
        assert_eq!(
            (names(&a), names(&b)),
            (vec!["out.csv".to_string()], vec!["device.json".to_string()])
        );

        let set = OutputSet::open();
        put(&fa, "new a").unwrap();
        put(&fb, "new b").unwrap();
        assert_eq!(std::fs::read_to_string(&fb).unwrap(), "old b");
        set.commit().unwrap();
        drop(set);
        assert_eq!(std::fs::read_to_string(&fa).unwrap(), "new a");
        assert_eq!(std::fs::read_to_string(&fb).unwrap(), "new b");
        assert_eq!(
            (names(&a), names(&b)),
            (vec!["out.csv".to_string()], vec!["device.json".to_string()])
        );
    }

    /// A run killed between the renames of a set: its first output is new, the second still old, with the
    /// second's temporary file and a journal in each directory left behind. The next run writing into
    /// either directory finishes the set (the second output new) and removes the journal and temporary
    /// files; the other directory's journal goes with the next run there.
    #[test]
    fn a_set_a_killed_run_left_half_renamed_is_finished_by_the_next_run() {
        let (_d, a, b, fa, fb) = two_dirs();
        let (ta, tb) = (
            a.join(".out.mrfeel-partial-AbCdEfGhIj.csv"),
            b.join(".device.mrfeel-partial-KlMnOpQrSt.json"),
        );
        // The state the killed run left: `out.csv` renamed, `device.json` not yet.
        std::fs::write(&fa, "new a").unwrap();
        std::fs::write(&fb, "old b").unwrap();
        std::fs::write(&tb, "new b").unwrap();
        let journal = serde_json::to_string(&[(&ta, &fa), (&tb, &fb)]).unwrap();
        std::fs::write(a.join(".mrfeel-set-0123456789.json"), &journal).unwrap();
        std::fs::write(b.join(".mrfeel-set-9876543210.json"), &journal).unwrap();

        put(&b.join("other.csv"), "x").unwrap();
        assert_eq!(std::fs::read_to_string(&fb).unwrap(), "new b");
        assert_eq!(std::fs::read_to_string(&fa).unwrap(), "new a");
        assert_eq!(names(&b), ["device.json", "other.csv"]);
        put(&a.join("other.csv"), "y").unwrap();
        assert_eq!(names(&a), ["other.csv", "out.csv"]);
        assert_eq!(std::fs::read_to_string(&fa).unwrap(), "new a");
    }

    /// A journal a live run holds locked is left alone, and so are the temporary files it names.
    #[test]
    fn a_live_runs_journal_is_left_alone() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("out.csv");
        let tmp = d.path().join(".out.mrfeel-partial-AbCdEfGhIj.csv");
        std::fs::write(&target, "old").unwrap();
        std::fs::write(&tmp, "new").unwrap();
        let held_tmp = std::fs::File::open(&tmp).unwrap();
        held_tmp.lock().unwrap();
        let journal = d.path().join(".mrfeel-set-0123456789.json");
        std::fs::write(&journal, serde_json::to_string(&[(&tmp, &target)]).unwrap()).unwrap();
        let held = std::fs::File::open(&journal).unwrap();
        held.lock().unwrap();
        put(&d.path().join("other.csv"), "x").unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "old");
        assert!(journal.exists() && tmp.exists());
    }
}
