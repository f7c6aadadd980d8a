//! JSON objects read by `serde_json` with the line of every key: the reader counts the lines of the bytes
//! `serde_json` has taken when it hands over a key, so that a refusal found after parsing (a duplicate, a
//! value out of range for the model) still names its line.

use std::cell::{Cell, RefCell};
use std::fmt;
use std::rc::Rc;

use serde::de::{DeserializeSeed, Deserializer, MapAccess, Visitor};
use serde::Deserialize as _;
use serde_json::Value;

use super::{InputError, Source};

/// A JSON object: the line of its `{`, and its entries in file order (a key given twice appears twice).
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    pub line: usize,
    pub entries: Vec<Entry>,
}

/// One key of an object, with its line and its value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Entry {
    pub key: String,
    pub line: usize,
    pub value: Node,
}

/// A value: an object with its lines, or any other JSON value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Node {
    Object(Object),
    Value(Value),
}

impl Node {
    /// What the value is, for messages (`a string`, `an object`).
    pub fn kind(&self) -> &'static str {
        match self {
            Node::Object(_) => "an object",
            Node::Value(Value::Null) => "null",
            Node::Value(Value::Bool(_)) => "a boolean",
            Node::Value(Value::Number(_)) => "a number",
            Node::Value(Value::String(_)) => "a string",
            Node::Value(Value::Array(_)) => "an array",
            Node::Value(Value::Object(_)) => "an object",
        }
    }
}

impl Object {
    /// The first entry of `key`.
    pub fn get(&self, key: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.key == key)
    }

    /// The first key given twice: its entry (the second) and the line of the first.
    pub fn duplicate(&self) -> Option<(&Entry, usize)> {
        let mut seen = std::collections::HashMap::new();
        self.entries
            .iter()
            .find_map(|e| seen.insert(e.key.as_str(), e.line).map(|first| (e, first)))
    }
}

/// The parse of a JSON text whose top level must be an object. A syntax error names its line (and its
/// column in the message) and the path of the last key read before it, as `keys` maps it to a field.
pub fn parse(src: &Source, field: impl Fn(&[String]) -> String) -> Result<Node, InputError> {
    let text = src.text.strip_prefix('\u{feff}').unwrap_or(&src.text);
    let state = Rc::new(State::default());
    let reader = Lines {
        bytes: text.as_bytes(),
        state: state.clone(),
    };
    let mut de = serde_json::Deserializer::from_reader(reader);
    let node = NodeSeed(&state)
        .deserialize(&mut de)
        .and_then(|n| de.end().map(|()| n));
    node.map_err(|e| {
        let s = e.to_string();
        let msg = match s.rfind(" at line ") {
            Some(k) => format!("{} (column {})", &s[..k], e.column()),
            None => s,
        };
        let line = e.line().max(1);
        let last = state.last_key.borrow();
        let blamed = !e.is_eof() && !msg.starts_with("trailing characters") && !last.is_empty();
        match blamed {
            true => InputError::field(&src.path, line, field(&last), msg),
            false => InputError::line(&src.path, line, msg),
        }
    })
}

/// What the reader and the visitor share: the line of the bytes read so far, the key path being read, the
/// path of the last key read.
#[derive(Default)]
struct State {
    line: Cell<usize>,
    path: RefCell<Vec<String>>,
    last_key: RefCell<Vec<String>>,
}

/// The text handed to `serde_json` one byte at a time, its lines counted.
struct Lines<'a> {
    bytes: &'a [u8],
    state: Rc<State>,
}

impl std::io::Read for Lines<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let Some((&b, rest)) = self.bytes.split_first().filter(|_| !buf.is_empty()) else {
            return Ok(0);
        };
        buf[0] = b;
        self.bytes = rest;
        self.state
            .line
            .set(self.state.line.get() + usize::from(b == b'\n'));
        Ok(1)
    }
}

struct NodeSeed<'s>(&'s State);

impl<'de> DeserializeSeed<'de> for NodeSeed<'_> {
    type Value = Node;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Node, D::Error> {
        d.deserialize_any(self)
    }
}

/// Every value that is not an object is handed to `serde_json::Value`'s own deserialization.
macro_rules! forward {
    ($($method:ident($t:ty)),*) => {$(
        fn $method<E: serde::de::Error>(self, v: $t) -> Result<Node, E> {
            Ok(Node::Value(Value::from(v)))
        }
    )*};
}

impl<'de> Visitor<'de> for NodeSeed<'_> {
    type Value = Node;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }

    forward!(
        visit_bool(bool),
        visit_i64(i64),
        visit_u64(u64),
        visit_f64(f64),
        visit_str(&str),
        visit_string(String)
    );

    fn visit_unit<E: serde::de::Error>(self) -> Result<Node, E> {
        Ok(Node::Value(Value::Null))
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<Node, A::Error> {
        let v = Value::deserialize(serde::de::value::SeqAccessDeserializer::new(seq))?;
        Ok(Node::Value(v))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Node, A::Error> {
        let st = self.0;
        // The `{` has been read: the line is its own.
        let mut object = Object {
            line: st.line.get() + 1,
            entries: Vec::new(),
        };
        while let Some(key) = map.next_key::<String>()? {
            // The key has been read to its closing quote, and nothing after it.
            let line = st.line.get() + 1;
            st.path.borrow_mut().push(key.clone());
            *st.last_key.borrow_mut() = st.path.borrow().clone();
            let value = map.next_value_seed(NodeSeed(st))?;
            st.path.borrow_mut().pop();
            object.entries.push(Entry { key, line, value });
        }
        Ok(Node::Object(object))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_text(text: &str) -> Result<Node, InputError> {
        parse(&Source::new("p.json", text), |p| p.join("."))
    }

    /// Keys are found at their lines, objects at the line of their `{`, keys given twice in one object
    /// only; escaped quotes and key-like text inside strings do not confuse it.
    #[test]
    fn keys_are_found_at_their_lines() {
        let text =
            "{\n  \"a\": \"not \\\"b\\\": a key\",\n  \"p\": {\n    \"x\": {\"value\": 1},\n    \"y\": \
                    [ {\"value\": 2} ], \"z\":\n 3.5\n  }\n}";
        let Node::Object(top) = parse_text(text).unwrap() else {
            panic!()
        };
        assert_eq!((top.line, top.get("a").unwrap().line), (1, 2));
        let p = top.get("p").unwrap();
        let Node::Object(inner) = &p.value else { panic!() };
        assert_eq!((p.line, inner.line), (3, 3));
        let lines: Vec<_> = inner.entries.iter().map(|e| (e.key.as_str(), e.line)).collect();
        assert_eq!(lines, [("x", 4), ("y", 5), ("z", 5)]);
        assert_eq!(inner.get("z").unwrap().value, Node::Value(Value::from(3.5)));
        assert!(top.duplicate().is_none());
        let Node::Object(twice) = parse_text("{\"x\": 1,\n \"y\": {\"x\": 2},\n \"x\": 3}").unwrap() else {
            panic!()
        };
        let (e, first) = twice.duplicate().unwrap();
        assert_eq!((e.key.as_str(), e.line, first), ("x", 3, 1));
    }

    /// A syntax error names its line and the last key before it; text after the object, or a file that
    /// ends early, names no key.
    #[test]
    fn syntax_errors_name_their_line_and_key() {
        let e = parse_text("{\"a\": {\n \"b\": 1,\n \"c\": tru}}").unwrap_err();
        assert_eq!((e.line, e.field.as_deref()), (Some(3), Some("a.c")), "{e}");
        let e = parse_text("{\"a\": 1}\nx\n").unwrap_err();
        assert_eq!((e.line, e.field.as_deref()), (Some(2), None), "{e}");
        assert!(e.msg.contains("trailing characters"), "{e}");
        let e = parse_text("{\"a\": [1,").unwrap_err();
        assert_eq!(e.field, None, "{e}");
    }
}
