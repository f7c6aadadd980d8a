//! Where things are in an input file's text, for errors that name the line.

/// 1-based line of a byte offset in `text` (offsets past the end are on the last line).
pub fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Parse a TOML text, every error placed in it ([`TomlError`]). A number the parser would read as another
/// is refused first: a decimal with a non-zero digit below the smallest double (`1e-400`), which TOML
/// parsers read as 0 without a word, so that the error a range check then gives ("value 0") would not name
/// the number written.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, TomlError> {
    check_numbers(text)?;
    toml::from_str(text).map_err(|e| TomlError::new(text, &e))
}

/// The first `key = number` line (outside multi-line strings) whose decimal reads as 0 though it has a
/// non-zero digit.
fn check_numbers(text: &str) -> Result<(), TomlError> {
    let mut open: Option<&str> = None;
    for (k, l) in text.lines().enumerate() {
        let was_open = open.is_some();
        for delim in ["\"\"\"", "'''"] {
            let odd = l.matches(delim).count() % 2 == 1;
            match open {
                Some(d) if d == delim && odd => open = None,
                None if odd => open = Some(delim),
                _ => {}
            }
        }
        if was_open || open.is_some() || l.trim_start().starts_with('#') {
            continue;
        }
        let Some((key, value)) = l.split_once('=') else {
            continue;
        };
        let value = value.split('#').next().unwrap_or("").trim();
        let digits = value.replace('_', "");
        let mantissa = digits.split(['e', 'E']).next().unwrap_or("");
        if digits.parse::<f64>() == Ok(0.0) && mantissa.contains(|c: char| ('1'..='9').contains(&c)) {
            return Err(TomlError {
                line: k + 1,
                field: bare_key(key),
                msg: format!(
                    "{value} is below the smallest number a double holds (about 4.9e-324) and would be read as \
                     0: write 0 if 0 is meant"
                ),
            });
        }
    }
    Ok(())
}

/// A TOML parser's error placed in its file, for a `file:line: …` message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TomlError {
    /// The line of the error's span (1 where the parser gives none).
    pub(crate) line: usize,
    /// The key that line sets, where the parser's message names no field: a value of the wrong type
    /// (`duration_s = "12"`: ``invalid type: string "12", expected f64``) is then named by its key.
    pub(crate) field: Option<String>,
    /// The parser's message; for a file whose lines end in a bare carriage return, which TOML does not
    /// allow (and for which the parser's message can be empty), what to do about it.
    pub(crate) msg: String,
}

impl TomlError {
    pub(crate) fn new(text: &str, e: &toml::de::Error) -> Self {
        if let Some(cr) = text
            .match_indices('\r')
            .find(|(at, _)| text.as_bytes().get(at + 1) != Some(&b'\n'))
        {
            return Self {
                line: line_of(text, cr.0),
                field: None,
                msg: "a line ends in a bare carriage return (CR, old Mac line endings), which TOML does not \
                      allow: save the file with LF or CRLF line endings"
                    .into(),
            };
        }
        let line = e.span().map_or(1, |s| line_of(text, s.start));
        let msg = e.message().trim().to_string();
        let field = e
            .span()
            .and_then(|s| toml_key_at(text, s.start))
            .or_else(|| toml_key_of_line(text, line))
            .filter(|_| !msg.contains("field `"));
        // A dotted key (`te.s = 0.015` in `[params]`) makes a table where a value with a line is expected;
        // the parser then says "expected a borrowed string", which tells a person nothing.
        let msg = match field.as_deref().and_then(|f| f.split_once('.')) {
            Some((table, rest)) if msg.contains("expected a borrowed string") => format!(
                "a dotted key makes a table here (`{table}` holding `{rest}`) where one value is expected; no \
                 name here has a dot in it"
            ),
            _ => msg,
        };
        Self { line, field, msg }
    }

    #[cfg(test)]
    /// The message with the field named where the parser's does not name it: `` `duration_s`: invalid
    /// type: … ``.
    pub(crate) fn message(&self) -> String {
        match &self.field {
            Some(f) => format!("`{f}`: {}", self.msg),
            None => self.msg.clone(),
        }
    }
}

/// The key a TOML line sets (`name = value`, or dotted: `laser.noise_rms_m = value`), if it sets one.
fn toml_key_of_line(text: &str, line: usize) -> Option<String> {
    let l = text
        .lines()
        .nth(line.checked_sub(1)?)?
        .trim_start_matches('\u{feff}')
        .trim();
    let (key, _) = l.split_once('=')?;
    bare_key(key)
}

/// A key as written before its `=`, quotes and spaces around its parts taken off, if it is a key.
fn bare_key(written: &str) -> Option<String> {
    let parts: Vec<&str> = written.split('.').map(|p| p.trim().trim_matches('"')).collect();
    let bare = parts.iter().all(|p| {
        !p.is_empty()
            && p.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    });
    bare.then(|| parts.join("."))
}

/// The key whose value is at byte `offset`: the line's own key, and inside an inline table on that line
/// (`rig = { urdf = "…", physics_hz = "x" }`) the inner key after it (`rig.physics_hz`). `None` where the
/// offset is not after a `key =` on its line.
fn toml_key_at(text: &str, offset: usize) -> Option<String> {
    let offset = offset.min(text.len());
    let start = text[..offset].rfind('\n').map_or(0, |p| p + 1);
    let before = text[start..offset].trim_start_matches('\u{feff}');
    let outer = bare_key(before.split_once('=')?.0)?;
    // The nearest `key =` before the value, inside the braces of an inline table.
    let inner_text = before.rsplit_once('=')?.0;
    let inner = inner_text
        .rfind('{')
        .and_then(|b| bare_key(inner_text[b + 1..].rsplit(',').next()?));
    Some(match inner {
        Some(k) => format!("{outer}.{k}"),
        None => outer,
    })
}

/// Where a text's first byte that is not UTF-8 is: 1-based line and column (in characters, as an editor
/// shows it), and the byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("line {line}, {}", self.what())]
pub(crate) struct NotUtf8 {
    pub(crate) line: usize,
    pub(crate) column: usize,
    pub(crate) byte: u8,
}

impl NotUtf8 {
    /// What is wrong at the line, without the line: `column C: byte 0xNN is not UTF-8 text (…)`.
    pub(crate) fn what(&self) -> String {
        format!(
            "column {}: byte 0x{:02x} is not UTF-8 text (a binary file, or another encoding?)",
            self.column, self.byte
        )
    }
}

/// `bytes` as text, or where its first byte that is not UTF-8 is.
pub(crate) fn decode(bytes: &[u8]) -> Result<&str, NotUtf8> {
    std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        // The bytes before `at` are valid UTF-8.
        let valid = std::str::from_utf8(&bytes[..at]).unwrap_or_default();
        let start = valid.rfind('\n').map_or(0, |p| p + 1);
        NotUtf8 {
            line: line_of(valid, at),
            column: valid[start..].chars().count() + 1,
            byte: bytes[at],
        }
    })
}

/// A number for a message: plain where that is short, in exponent form where it is not (1e300, not three
/// hundred digits).
pub fn short_number(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e15).contains(&a) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// Text from an input for a message: control characters escaped (`\u{1b}`: a terminal's escape codes are
/// shown, not obeyed; line breaks too, so that the quote stays on its line) and at most `max` characters,
/// the middle left out and counted (a 5 MB field does not make a 5 MB message).
pub(crate) fn quoted(s: &str, max: usize) -> String {
    let escape = |c: char| -> String {
        if c.is_control() {
            c.escape_default().collect()
        } else {
            c.to_string()
        }
    };
    let n = s.chars().count();
    if n <= max {
        return s.chars().map(escape).collect();
    }
    let head = max.div_ceil(2);
    let tail = max / 2;
    let start: String = s.chars().take(head).map(escape).collect();
    let end: String = s.chars().skip(n - tail).map(escape).collect();
    format!("{start}…[{} characters left out]…{end}", n - head - tail)
}

/// A whole message for the terminal: each line quoted (control characters escaped) to at most `max` characters, the line breaks
/// kept.
pub fn printable(message: &str, max: usize) -> String {
    message
        .split('\n')
        .map(|l| quoted(l, max))
        .collect::<Vec<_>>()
        .join("\n")
}

/// A number for people, to `digits` significant digits: plain between 0.001 and a million (`62.6440`,
/// `0.0108469`), in exponent form beyond (`1.00e-6`, `2.50e8`); 0 as `0`.
pub(crate) fn significant(v: f64, digits: usize) -> String {
    let digits = digits.max(1);
    let a = v.abs();
    if !v.is_finite() || a == 0.0 {
        return if a == 0.0 { "0".into() } else { v.to_string() };
    }
    if (1e-3..1e6).contains(&a) {
        let decimals = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.*e}", digits - 1)
    }
}

/// What a path is when it is not a regular file (links followed), for messages that say so.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NotAFile {
    Directory,
    NamedPipe,
    /// A character or block device (`/dev/zero`, a disk, a terminal).
    Device,
    Socket,
    Other,
}

impl NotAFile {
    /// `None` for a regular file.
    pub(crate) fn of(meta: &std::fs::Metadata) -> Option<Self> {
        let kind = meta.file_type();
        if kind.is_file() {
            return None;
        }
        if kind.is_dir() {
            return Some(Self::Directory);
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            if kind.is_fifo() {
                return Some(Self::NamedPipe);
            }
            if kind.is_char_device() || kind.is_block_device() {
                return Some(Self::Device);
            }
            if kind.is_socket() {
                return Some(Self::Socket);
            }
        }
        Some(Self::Other)
    }

    /// `a named pipe`, `a device`, …
    pub(crate) fn noun(self) -> &'static str {
        match self {
            Self::Directory => "a directory",
            Self::NamedPipe => "a named pipe",
            Self::Device => "a device",
            Self::Socket => "a socket",
            Self::Other => "something else",
        }
    }
}

/// Largest text input (a scenario, device, parameter, pilot, spring, aircraft or URDF file) read, bytes:
/// the largest of them in this repository is under 100 KiB.
pub(crate) const TEXT_LIMIT_BYTES: u64 = 64 << 20;

/// Read an input file whole (a built-in file by its path, a pipe as a file), refusing a device
/// (`/dev/zero`, a disk) or more than `limit` bytes (`yes |`): a wrong path is an error, not a read until
/// memory runs out.
pub(crate) fn read_bytes(path: &std::path::Path, limit: u64) -> Result<Vec<u8>, String> {
    use std::io::Read;
    if let Some(text) = crate::builtin::text(path) {
        return Ok(text.as_bytes().to_vec());
    }
    let too_long = || {
        format!(
            "longer than {} MiB, more than any input of this kind can be (is this the file you meant?)",
            limit >> 20
        )
    };
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if NotAFile::of(&meta) == Some(NotAFile::Device) {
        return Err("not a file but a device; give a file or a pipe".into());
    }
    // A file says its length: refused before reading it (a pipe only when it has said too much).
    if meta.is_file() && meta.len() > limit {
        return Err(too_long());
    }
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut bytes = Vec::new();
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        return Err(too_long());
    }
    Ok(bytes)
}

/// Read a text input file (a built-in file by its path; a device, or more than 64 MiB, refused). A file
/// that is not UTF-8 names the line and column of its first invalid byte, which
/// `std::fs::read_to_string` does not.
pub fn read_text(path: &std::path::Path) -> Result<String, String> {
    let bytes = read_bytes(path, TEXT_LIMIT_BYTES)?;
    String::from_utf8(bytes).map_err(|e| match decode(e.as_bytes()) {
        Err(at) => at.to_string(),
        Ok(_) => e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_for_people_keep_their_significant_digits() {
        assert_eq!(significant(62.644014, 6), "62.6440");
        assert_eq!(significant(-4.143014, 4), "-4.143");
        assert_eq!(significant(0.01084694, 4), "0.01085");
        assert_eq!(significant(1e-6, 3), "1.00e-6");
        assert_eq!(significant(2.5e8, 3), "2.50e8");
        assert_eq!(significant(0.0, 3), "0");
        assert_eq!(significant(999.96, 4), "1000.0");
    }

    const TEXT: &str =
        "base = \"a.toml\"\n\n[springs]\nfile = \"s.toml\"\nfiles_extra = 1\n[[faults]]\nkind = \"x\"\n";

    /// A decimal below the smallest double, which the parser reads as 0 without a word, is refused at its
    /// line and key; zeros, small numbers a double holds, comments and strings are not.
    #[test]
    fn a_number_that_would_be_read_as_zero_is_refused_at_its_line() {
        let e = check_numbers("a = 1\n[t]\nb.c = 2.5e-400 # tiny\n").unwrap_err();
        assert_eq!((e.line, e.field.as_deref()), (3, Some("b.c")));
        assert!(
            e.msg.starts_with("2.5e-400 is below the smallest number"),
            "{}",
            e.msg
        );
        for fine in [
            "a = 0.0\nb = 0e5\nc = -0.0\nd = 1e-300\ne = 5e-324\n",
            "# a = 1e-400\n",
            "s = \"1e-400\"\n",
            "s = \"\"\"\nx = 1e-400\n\"\"\"\n",
            "s = '''\nx = 1e-400\n'''\n",
        ] {
            assert_eq!(check_numbers(fine), Ok(()), "{fine}");
        }
        let parsed: Result<toml::Value, _> = parse_toml("x = 1e-400\n");
        assert_eq!(parsed.unwrap_err().line, 1);
    }

    /// A value of the wrong type is named by its key however the key is written: plain, dotted, or inside
    /// an inline table (the parser's message names none; the inline table's own key was named before).
    #[test]
    fn a_wrong_value_is_named_by_its_full_key() {
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Rig {
            urdf: String,
            physics_hz: f64,
        }
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Doc {
            duration_s: f64,
            rig: Rig,
        }
        for (text, line, key) in [
            (
                "duration_s = \"12\"\n[rig]\nurdf = \"a\"\nphysics_hz = 1.0\n",
                1,
                "duration_s",
            ),
            (
                "duration_s = 1.0\n[rig]\nurdf = \"a\"\nphysics_hz = \"x\"\n",
                4,
                "physics_hz",
            ),
            (
                "duration_s = 1.0\nrig.urdf = \"a\"\nrig.physics_hz = \"x\"\n",
                3,
                "rig.physics_hz",
            ),
            (
                "duration_s = 1.0\nrig = { urdf = \"a\", physics_hz = \"x\" }\n",
                2,
                "rig.physics_hz",
            ),
        ] {
            let e = toml::from_str::<Doc>(text).unwrap_err();
            let placed = TomlError::new(text, &e);
            assert_eq!(
                (placed.line, placed.field.as_deref()),
                (line, Some(key)),
                "{text}: {}",
                placed.msg
            );
            assert!(
                placed.message().starts_with(&format!("`{key}`: ")),
                "{}",
                placed.message()
            );
        }
        // Bare carriage returns are explained, whatever the parser said.
        let e = toml::from_str::<Doc>("duration_s = 1.0\r[rig]\r").unwrap_err();
        assert!(TomlError::new("duration_s = 1.0\r[rig]\r", &e)
            .msg
            .contains("bare carriage return"));
    }

    /// A quote of input never holds a control character and is bounded, whatever the input; short text
    /// is quoted as it is.
    #[test]
    fn quotes_of_input_are_bounded_and_escape_control_characters() {
        assert_eq!(quoted("x_m", 80), "x_m");
        assert_eq!(quoted("a\u{1b}[31mb\r\n", 80), "a\\u{1b}[31mb\\r\\n");
        let long = "é".repeat(5_000_000);
        let q = quoted(&long, 80);
        assert!(q.chars().count() < 120, "{}", q.len());
        assert!(q.contains("4999920 characters left out"), "{q}");
        let msg = printable(&format!("error: {}\nline two \u{7}", "x".repeat(10_000)), 200);
        assert_eq!(msg.lines().count(), 2);
        assert!(msg
            .lines()
            .all(|l| l.chars().count() < 260 && !l.chars().any(char::is_control)));
    }

    #[test]
    fn offsets_are_found_at_their_lines() {
        assert_eq!(line_of(TEXT, 0), 1);
        assert_eq!(line_of(TEXT, TEXT.find("file =").unwrap()), 4);
        assert_eq!(line_of(TEXT, usize::MAX), TEXT.lines().count() + 1);
    }

    #[test]
    fn a_byte_that_is_not_utf8_is_placed_by_line_and_character() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("t.toml");
        // Line 2 holds `x`, a two-byte `é`, then a lone 0xff: the third character.
        std::fs::write(&p, b"ab\nx\xc3\xa9\xff\n").unwrap();
        let e = read_text(&p).unwrap_err();
        assert!(e.starts_with("line 2, column 3: byte 0xff"), "{e}");
        std::fs::write(&p, "ab\nxé\n").unwrap();
        assert_eq!(read_text(&p).unwrap(), "ab\nxé\n");
        assert!(read_text(&d.path().join("none")).is_err());
    }
}
