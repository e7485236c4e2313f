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
