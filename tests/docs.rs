//! The documents hold together: every relative link in a Markdown file of the repository names a file that
//! exists (and a heading of it, where the link names one), and every `docs/….md` path that code, scenarios,
//! scripts or documents mention exists. A document moved or renamed without its links fails here. The
//! command-line reference is what `--help` prints.

use std::path::{Path, PathBuf};

use crate::common;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The repository's files with one of `exts`, outside build outputs, environments and version control.
fn files(exts: &[&str]) -> Vec<PathBuf> {
    fn walk(dir: &Path, exts: &[&str], out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                let skip = name.starts_with('.') || name.starts_with("target") || name == "out";
                if !skip {
                    walk(&path, exts, out);
                }
            } else if exts.iter().any(|e| name.ends_with(e)) {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(root(), exts, &mut out);
    out.sort();
    out
}

/// The targets of the inline links `[text](target)` of a Markdown text, with their line numbers.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            rest = &rest[at + 2..];
            let end = rest
                .find(|c: char| c == ')' || c.is_whitespace())
                .unwrap_or(rest.len());
            out.push((n + 1, rest[..end].to_string()));
            rest = &rest[end..];
        }
    }
    out
}

/// The anchors GitHub gives the headings of a Markdown text: lower case, spaces as `-`, punctuation dropped.
fn anchors(text: &str) -> Vec<String> {
    text.lines()
        .filter(|l| l.starts_with('#'))
        .map(|l| {
            l.trim_start_matches('#')
                .trim()
                .to_lowercase()
                .chars()
                .filter_map(|c| match c {
                    ' ' => Some('-'),
                    c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
                    _ => None,
                })
                .collect()
        })
        .collect()
}

fn shown(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

#[test]
fn every_relative_link_in_the_documents_names_a_file_and_heading_that_exist() {
    let docs = files(&[".md"]);
    assert!(
        docs.iter().any(|p| p.ends_with("docs/tutorial.md")),
        "the walk found no documents: {docs:?}"
    );
    let mut broken = Vec::new();
    let mut checked = 0;
    for doc in &docs {
        let text = std::fs::read_to_string(doc).unwrap();
        for (line, target) in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let dest = if file.is_empty() {
                doc.clone()
            } else {
                doc.parent().unwrap().join(file)
            };
            checked += 1;
            if !dest.exists() {
                broken.push(format!("{}:{line}: `{target}`: no such file", shown(doc)));
            } else if !anchor.is_empty() && dest.extension().is_some_and(|e| e == "md") {
                let heads = anchors(&std::fs::read_to_string(&dest).unwrap());
                if !heads.iter().any(|h| h == anchor) {
                    broken.push(format!("{}:{line}: `{target}`: no such heading", shown(doc)));
                }
            }
        }
    }
    assert!(checked > 100, "only {checked} relative links found");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn every_docs_path_mentioned_exists() {
    let mut missing = Vec::new();
    for file in files(&[".rs", ".md", ".toml", ".py", ".sh"]) {
        // The changelog records each change as it was made, paths included.
        if file == root().join("CHANGELOG.md") {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, line) in text.lines().enumerate() {
            for (at, _) in line.match_indices("docs/") {
                // `docs/` begins a path only where no other path or word runs into it.
                let before = line[..at].chars().next_back();
                if before.is_some_and(|c| c.is_alphanumeric() || c == '/' || c == '.' || c == '_') {
                    continue;
                }
                let path: String = line[at..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || matches!(c, '/' | '-' | '_' | '.'))
                    .collect();
                let path = path.trim_end_matches('.');
                if path.ends_with(".md") && !root().join(path).exists() {
                    missing.push(format!("{}:{}: `{path}`", shown(&file), n + 1));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "paths of documents that do not exist:\n{}",
        missing.join("\n")
    );
}

/// `docs/reference/cli.md` holds, under each `## \`mrfeel COMMAND\`` heading (and first, for `mrfeel`
/// itself), the block `mrfeel COMMAND --help` prints: an option added, renamed or described anew without
/// the reference fails here.
#[test]
fn the_cli_reference_is_what_help_prints() {
    let text = std::fs::read_to_string(root().join("docs/reference/cli.md")).unwrap();
    let mut command: Vec<String> = Vec::new();
    let mut block: Option<String> = None;
    let mut stale = Vec::new();
    let mut blocks = 0;
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("## `mrfeel ").and_then(|l| l.strip_suffix('`')) {
            command = name.split_whitespace().map(str::to_string).collect();
        } else if line == "```" {
            match block.take() {
                None => block = Some(String::new()),
                Some(body) => {
                    blocks += 1;
                    let mut args = command.clone();
                    args.push("--help".into());
                    let out = common::mrfeel(&args);
                    assert!(out.status.success(), "mrfeel {args:?}");
                    if String::from_utf8_lossy(&out.stdout) != body {
                        stale.push(format!("mrfeel {}", args.join(" ")));
                    }
                }
            }
        } else if let Some(body) = block.as_mut() {
            body.push_str(line);
            body.push('\n');
        }
    }
    assert!(blocks >= 12, "only {blocks} help blocks in docs/reference/cli.md");
    assert!(
        stale.is_empty(),
        "docs/reference/cli.md differs from what these print (copy their output into it):\n{}",
        stale.join("\n")
    );
}
