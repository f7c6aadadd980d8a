//! Every output a command will write, checked before the command runs: a run either writes all it was
//! asked to or fails before it writes or prints anything (the path and the option named in the error).

use std::path::{Component, Path, PathBuf};

/// What an output option names: a file the command writes (its directory must exist), or a directory it
/// creates if need be and writes files into.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Kind {
    File,
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

/// Whether a file can be made in the existing directory `dir`: make one and remove it again.
fn probe_dir(dir: &Path) -> std::io::Result<()> {
    let probe = dir.join(format!(".mrfeel-write-check-{}", std::process::id()));
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)?;
    std::fs::remove_file(&probe)
}

/// The kinds of file an output directory receives: every plot is written as PNG and SVG.
const PLOT_EXTENSIONS: [&str; 2] = ["png", "svg"];

/// Check that one output can be written, without writing it: a file's directory exists and takes a new
/// file (an existing file is opened for writing, unchanged); a directory exists or can be created (its
/// nearest existing ancestor is a directory that takes a new file).
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
            let probe = if path.exists() {
                std::fs::OpenOptions::new().write(true).open(path).map(drop)
            } else {
                std::fs::OpenOptions::new()
                    .write(true)
                    .create_new(true)
                    .open(path)
                    .and_then(|_| std::fs::remove_file(path))
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
                    let ext = name.extension().and_then(|x| x.to_str()).unwrap_or("");
                    if PLOT_EXTENSIONS.contains(&ext) && name.is_dir() {
                        return fail(format!(
                            "holds a directory `{}` where a plot file would be written",
                            name.display()
                        ));
                    }
                }
            }
            for (n, p) in path.ancestors().enumerate() {
                let p = or_here(p);
                let Ok(m) = std::fs::metadata(p) else {
                    continue; // does not exist (yet): created with the directory
                };
                let what = if n == 0 {
                    "exists and is not a directory".to_string()
                } else {
                    format!(
                        "cannot create the directory: `{}` is not a directory",
                        p.display()
                    )
                };
                if !m.is_dir() {
                    return fail(what);
                }
                return probe_dir(p).or_else(|e| fail(format!("cannot write into `{}`: {e}", p.display())));
            }
            Ok(())
        }
    }
}

/// What a path names on disk, to tell whether two paths are one file: an existing file by its device and
/// inode (so a hard link, a symlink or `a/../b` spelling is the same file), otherwise the canonical path of
/// its nearest existing ancestor with the rest appended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FileId {
    Inode(u64, u64),
    Path(PathBuf),
}

/// The [`FileId`] of `path`.
pub fn file_id(path: &Path) -> FileId {
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

/// Check every output of a command before it runs, so that a run either writes all it was asked to or fails
/// before it writes or prints anything: each path must be writable, no two options may name the same path
/// (however it is spelled), and no output may be one of the command's `inputs` (the files it reads).
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
    for &(opt, path, kind) in outs {
        check_output(opt, path, kind)?;
    }
    Ok(())
}
