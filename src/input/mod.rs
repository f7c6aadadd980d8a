//! The input layer: every file mrfeel reads is read here, into a typed schema, and every refusal is one
//! [`InputError`] naming the file, the line and the field. Domain modules take the checked structs and do
//! not read files.
//!
//! TOML files are read with serde into schemas whose values carry their place ([`toml::Spanned`]); a
//! schema's range checks go through [`Source`], so that a value out of range names its own line.

/// [`Source::within`] of the value at `section.key` (a local named after its section, or `f.section.key`),
/// the field named by that path: `within!(src, geometry.chord_m, 0.05..=50.0, "m")`; no unit: `""`.
macro_rules! within {
    ($src:expr, $f:ident . $sec:ident . $key:ident, $($rest:tt)*) => {
        within!(@ $src, $f.$sec.$key, concat!(stringify!($sec), ".", stringify!($key)), $($rest)*)
    };
    ($src:expr, $sec:ident . $key:ident, $($rest:tt)*) => {
        within!(@ $src, $sec.$key, concat!(stringify!($sec), ".", stringify!($key)), $($rest)*)
    };
    (@ $src:expr, $v:expr, $field:expr, $range:expr $(, $unit:expr)?) => {
        $src.within(&$v, $field, $range, within!(@unit $($unit)?))
    };
    (@unit) => { "" };
    (@unit $unit:expr) => { $unit };
}

pub(crate) mod aircraft;
pub mod compare;
pub(crate) mod faults;
pub(crate) mod hand;
pub(crate) mod json;
pub(crate) mod measurement;
pub(crate) mod motor;
pub(crate) mod params;
pub mod reference;
pub(crate) mod scenario;
pub(crate) mod springs;
pub mod sweep;
pub mod text;
pub mod urdf;

use std::fmt;
use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};

use serde::de::{DeserializeOwned, IntoDeserializer};
use toml::Spanned;

/// An input refused: the file, where in it (line, field) when that is known, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputError {
    /// The file refused.
    pub path: PathBuf,
    /// 1-based line.
    pub line: Option<usize>,
    /// The key or column, as written in the file (dotted for a nested key: `rig.physics_hz`).
    pub field: Option<String>,
    /// Why it is refused.
    pub msg: String,
}

impl InputError {
    /// The whole file is refused (it cannot be read, or lacks something that has no line).
    pub fn file(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Self {
            path: path.into(),
            line: None,
            field: None,
            msg: msg.into(),
        }
    }

    /// A line is refused.
    pub fn line(path: impl Into<PathBuf>, line: usize, msg: impl Into<String>) -> Self {
        Self {
            line: Some(line),
            ..Self::file(path, msg)
        }
    }

    /// A field's value, at its line, is refused.
    pub fn field(
        path: impl Into<PathBuf>,
        line: usize,
        field: impl Into<String>,
        msg: impl Into<String>,
    ) -> Self {
        Self {
            line: Some(line),
            field: Some(field.into()),
            ..Self::file(path, msg)
        }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(field) = &self.field {
            write!(f, ": field `{field}`")?;
        }
        write!(f, ": {}", self.msg)
    }
}

impl std::error::Error for InputError {}

/// A text input file: its path (for errors) and its text (for lines).
#[derive(Debug, Clone)]
pub struct Source {
    /// Where the text was read from.
    pub path: PathBuf,
    /// The whole text.
    pub text: String,
}

impl Source {
    /// Read a text file ([`text::read_text`]: built-in files, size limit, the first byte that is not UTF-8).
    pub fn read(path: &Path) -> Result<Self, InputError> {
        let text = text::read_text(path).map_err(|msg| InputError::file(path, msg))?;
        Ok(Self::new(path, text))
    }

    /// A text already in memory, placed at `path` for its errors.
    pub fn new(path: impl Into<PathBuf>, text: impl Into<String>) -> Self {
        Self {
            path: path.into(),
            text: text.into(),
        }
    }

    /// The text read as TOML into `T`: a syntax error, an unknown key or a value of the wrong type names
    /// its line and key.
    pub fn toml<T: serde::de::DeserializeOwned>(&self) -> Result<T, InputError> {
        text::parse_toml(&self.text).map_err(|e| InputError {
            path: self.path.clone(),
            line: Some(e.line),
            field: e.field,
            msg: e.msg,
        })
    }

    /// 1-based line of a byte offset.
    pub fn line_of(&self, offset: usize) -> usize {
        text::line_of(&self.text, offset)
    }

    /// 1-based line of a span's start.
    pub(crate) fn line_at(&self, span: std::ops::Range<usize>) -> usize {
        self.line_of(span.start)
    }

    /// An error at a spanned value's line, naming `field`.
    pub fn err<T>(&self, at: &Spanned<T>, field: &str, msg: impl Into<String>) -> InputError {
        InputError::field(&self.path, self.line_at(at.span()), field, msg)
    }

    /// A number checked to lie in `range` (`unit` for the message): a value outside, or not finite, names
    /// its line and field with the allowed range.
    pub(crate) fn within(
        &self,
        v: &Spanned<f64>,
        field: &str,
        range: RangeInclusive<f64>,
        unit: &str,
    ) -> Result<f64, InputError> {
        let x = *v.get_ref();
        if x.is_finite() && range.contains(&x) {
            return Ok(x);
        }
        let [x, lo, hi] = [x, *range.start(), *range.end()].map(text::short_number);
        let msg = format!("value {x} outside the allowed range [{lo}, {hi}] {unit}");
        Err(self.err(v, field, msg.trim_end()))
    }

    /// An integer checked to lie in `range`.
    pub(crate) fn within_int(
        &self,
        v: &Spanned<i64>,
        field: &str,
        range: RangeInclusive<i64>,
    ) -> Result<i64, InputError> {
        let x = *v.get_ref();
        if range.contains(&x) {
            return Ok(x);
        }
        let (lo, hi) = range.into_inner();
        Err(self.err(
            v,
            field,
            format!("value {x} outside the allowed range [{lo}, {hi}]"),
        ))
    }

    /// The variant a spanned name chose, or an error at its line naming `field` and the names allowed.
    pub(crate) fn variant<E: Clone>(&self, v: &Spanned<Variant<E>>, field: &str) -> Result<E, InputError> {
        v.get_ref().chosen.clone().map_err(|msg| self.err(v, field, msg))
    }

    /// The file this one names at `at` (`field`), found as [`crate::builtin::resolve`] finds it: a built-in
    /// file or a regular file that exists (files named are read once per run of a comparison or a sweep,
    /// which a pipe cannot give twice).
    pub(crate) fn named_file(&self, at: &Spanned<PathBuf>, field: &str) -> Result<PathBuf, InputError> {
        use text::NotAFile;
        let file = crate::builtin::resolve(self.path.parent().unwrap_or(Path::new(".")), at.get_ref());
        if crate::builtin::is_builtin(&file) {
            return Ok(file);
        }
        let msg = match std::fs::metadata(&file).map(|m| NotAFile::of(&m)) {
            Ok(None) => return Ok(file),
            Ok(Some(NotAFile::Directory)) => format!("{}: a directory, not a file", file.display()),
            Ok(Some(kind)) => format!(
                "{}: not a regular file ({}); this file is read once per run, so it must be one",
                file.display(),
                kind.noun()
            ),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                format!("{}: {e}; {}", file.display(), crate::builtin::not_found_hint())
            }
            Err(e) => format!("{}: {e}", file.display()),
        };
        Err(self.err(at, field, msg))
    }

    /// The file named at `at` ([`Source::named_file`]) read by `load`: its path and what it holds; an error
    /// of its own is placed at `at`.
    pub(crate) fn load_named<T, E: fmt::Display>(
        &self,
        at: &Spanned<PathBuf>,
        field: &str,
        load: impl FnOnce(&Path) -> Result<T, E>,
    ) -> Result<(PathBuf, T), InputError> {
        let path = self.named_file(at, field)?;
        let loaded = load(&path).map_err(|e| self.err(at, field, e.to_string()))?;
        Ok((path, loaded))
    }
}

/// A name that chooses a variant of `E` (a serde enum of unit variants), read without failing so that the
/// check refuses an unknown name at its key's line, dotted key and all ([`Source::variant`]).
#[derive(Debug, Clone)]
pub(crate) struct Variant<E> {
    name: String,
    chosen: Result<E, String>,
}

impl<E> Variant<E> {
    /// The name as written.
    pub(crate) fn name(&self) -> &str {
        &self.name
    }
}

impl<'de, E: DeserializeOwned> serde::Deserialize<'de> for Variant<E> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = <String as serde::Deserialize>::deserialize(d)?;
        let de: serde::de::value::StrDeserializer<NotOneOf> = name.as_str().into_deserializer();
        let chosen = E::deserialize(de).map_err(|e| e.0);
        Ok(Self { name, chosen })
    }
}

/// Why a name is not a variant: `` `x` is not one of: a, b ``.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct NotOneOf(String);

impl serde::de::Error for NotOneOf {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Self(msg.to_string())
    }
    fn unknown_variant(name: &str, names: &'static [&'static str]) -> Self {
        Self(format!("`{name}` is not one of: {}", names.join(", ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Rig {
        physics_hz: Spanned<f64>,
    }

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct File {
        rig: Rig,
    }

    const TEXT: &str = "# a scenario\n\n[rig]\nphysics_hz = 50.0\n";

    #[test]
    fn a_value_out_of_range_names_its_file_line_and_field() {
        let src = Source::new("scn.toml", TEXT);
        let f: File = src.toml().unwrap();
        let e = src
            .within(&f.rig.physics_hz, "rig.physics_hz", 100.0..=1e5, "Hz")
            .unwrap_err();
        assert_eq!((e.line, e.field.as_deref()), (Some(4), Some("rig.physics_hz")));
        assert_eq!(
            e.to_string(),
            "scn.toml:4: field `rig.physics_hz`: value 50 outside the allowed range [100, 100000] Hz"
        );
    }

    #[test]
    fn an_unknown_key_is_refused_at_its_line() {
        let src = Source::new("scn.toml", format!("{TEXT}physics_hx = 1.0\n"));
        let e = src.toml::<File>().unwrap_err();
        assert_eq!(e.line, Some(5), "{e}");
        assert!(e.msg.contains("physics_hx"), "{e}");
    }
}
