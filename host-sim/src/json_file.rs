//! What the slice and printer files share: a text file read whole but never past a limit,
//! and the kind of a JSON value named in the lab's terms.

use std::io::Read;
use std::path::Path;

use serde_json::Value;

/// Why a bounded text file could not be read.
#[derive(Debug)]
pub enum ReadError {
    /// The operating system's error.
    Io(std::io::Error),
    /// The file has more than the limit's bytes (the limit).
    TooLarge(u64),
    /// The file is not UTF-8 text (the offset of the first invalid byte).
    NotUtf8(usize),
}

/// The text of the file at `path`, reading at most `limit + 1` bytes: a longer file (or an
/// endless one, `/dev/zero`) is [`ReadError::TooLarge`], never truncated.
pub fn read_text(path: &Path, limit: u64) -> Result<String, ReadError> {
    let file = std::fs::File::open(path).map_err(ReadError::Io)?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(ReadError::Io)?;
    if bytes.len() as u64 > limit {
        return Err(ReadError::TooLarge(limit));
    }
    String::from_utf8(bytes).map_err(|e| ReadError::NotUtf8(e.utf8_error().valid_up_to()))
}

/// What kind of JSON value `v` is, for messages ("expected a number, found a string").
pub fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

/// `limit` bytes in words: "4 MiB" when it is a whole number of MiB, else "1000 bytes".
pub fn size(limit: u64) -> String {
    if limit % (1 << 20) == 0 {
        format!("{} MiB", limit >> 20)
    } else {
        format!("{limit} bytes")
    }
}

/// Parses JSON `text` into a [`Value`], refusing a key that appears twice in one object (the
/// JSON reader would keep the last silently: a second `"holes"` would drop the first's).
pub fn parse_unique(text: &str) -> Result<Value, serde_json::Error> {
    serde_json::from_str::<Unique>(text)?;
    serde_json::from_str(text)
}

/// A JSON document walked only to find a key repeated within one object.
struct Unique;

impl<'de> serde::Deserialize<'de> for Unique {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Unique, D::Error> {
        d.deserialize_any(UniqueVisitor)
    }
}

struct UniqueVisitor;

impl<'de> serde::de::Visitor<'de> for UniqueVisitor {
    type Value = Unique;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("JSON")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Unique, A::Error> {
        let mut seen = std::collections::HashSet::new();
        while let Some(key) = map.next_key::<String>()? {
            if !seen.insert(key.clone()) {
                return Err(serde::de::Error::custom(format!(
                    "the key \"{key}\" appears twice in one object"
                )));
            }
            map.next_value::<Unique>()?;
        }
        Ok(Unique)
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Unique, A::Error> {
        while seq.next_element::<Unique>()?.is_some() {}
        Ok(Unique)
    }

    fn visit_bool<E>(self, _: bool) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_i64<E>(self, _: i64) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_u64<E>(self, _: u64) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_f64<E>(self, _: f64) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_str<E>(self, _: &str) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_unit<E>(self) -> Result<Unique, E> {
        Ok(Unique)
    }
}

/// Byte offset of 1-based `line`, `column`.
pub fn offset_of(text: &str, line: usize, column: usize) -> usize {
    let mut off = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            return off + column.saturating_sub(1).min(l.len());
        }
        off += l.len();
    }
    text.len()
}

/// Whether a JSON syntax error at `line` and `column` of `text` stands on `NaN` or an
/// infinity, which some writers put where a number belongs and JSON has no spelling for.
pub fn at_non_finite(text: &str, line: usize, column: usize) -> bool {
    // Bytes, not characters: the column may fall inside a character.
    let bytes = text.as_bytes();
    let mut k = offset_of(text, line, column).saturating_sub(1);
    while k < bytes.len() && b"-+,[: \t\r\n".contains(&bytes[k]) {
        k += 1;
    }
    // `Inf` and `inf` begin `Infinity` and `infinity` too.
    [&b"NaN"[..], b"nan", b"Inf", b"inf"]
        .iter()
        .any(|w| bytes[k..].starts_with(w))
}
