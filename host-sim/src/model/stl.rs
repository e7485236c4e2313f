//! STL files, binary and ASCII, through the `stl_io` crate: read into raw triangles with typed
//! errors (a file that is not STL, one that ends early, a coordinate that is not a number),
//! and written (binary) for the built-in models and the tests.

use std::io::{Cursor, Read};
use std::path::Path;

use super::error::ModelError;

/// One triangle as read: three corners, mm.
pub type RawTriangle = [[f32; 3]; 3];

/// The largest model file read (512 MiB: about 10 million binary triangles).
pub const MAX_FILE_BYTES: u64 = 512 << 20;

/// Bytes of a binary STL's header and triangle count, and of one triangle.
const BINARY_HEADER: u64 = 84;
const BINARY_TRIANGLE: u64 = 50;

/// Reads the STL file at `path` (at most [`MAX_FILE_BYTES`]).
pub fn load(path: &Path) -> Result<Vec<RawTriangle>, ModelError> {
    let shown = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|e| ModelError::Io(shown.clone(), e))?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| ModelError::Io(shown.clone(), e))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(ModelError::TooLarge(shown, MAX_FILE_BYTES));
    }
    parse(&bytes)
}

/// Whether `bytes` have the exact length of a binary STL of the triangle count they declare.
fn binary_length_matches(bytes: &[u8]) -> Option<u64> {
    let count = u32::from_le_bytes(bytes.get(80..84)?.try_into().ok()?) as u64;
    (bytes.len() as u64 == BINARY_HEADER + BINARY_TRIANGLE * count).then_some(count)
}

/// Reads STL from memory. A file whose length is exactly what its binary header declares is
/// binary (even if its header begins with `solid`, as some exporters write); otherwise it
/// must be ASCII (`solid ...`). Anything else is refused, naming why.
pub fn parse(bytes: &[u8]) -> Result<Vec<RawTriangle>, ModelError> {
    // Keywords in any case (some exporters write `SOLID` ... `ENDSOLID`).
    let ascii = bytes
        .get(..5)
        .is_some_and(|w| w.eq_ignore_ascii_case(b"solid"))
        && bytes.get(5).is_none_or(|c| c.is_ascii_whitespace());
    let triangles = if binary_length_matches(bytes).is_some() {
        if ascii {
            // stl_io takes a file that starts with "solid " for ASCII: hide the word.
            let mut copy = bytes.to_vec();
            copy[..5].copy_from_slice(b"xxxxx");
            read_with_stl_io(&copy)?
        } else {
            read_with_stl_io(bytes)?
        }
    } else if ascii {
        let text = std::str::from_utf8(bytes).map_err(|e| {
            ModelError::NotStl(format!(
                "it starts with \"solid\" but is not text (invalid byte at offset {})",
                e.valid_up_to()
            ))
        })?;
        let lower = text.to_ascii_lowercase();
        let text = lower.as_str();
        if !text.contains("endsolid") {
            return Err(ModelError::Truncated(
                "the ASCII model ends before \"endsolid\"".into(),
            ));
        }
        check_ascii_numbers(text)?;
        // `solid` followed by a newline: stl_io wants "solid " with a space.
        let fixed;
        let text = if text.starts_with("solid ") {
            text
        } else {
            fixed = format!("solid {}", &text[5..]);
            &fixed
        };
        read_with_stl_io(text.as_bytes())?
    } else if bytes.len() < BINARY_HEADER as usize {
        return Err(ModelError::NotStl(format!(
            "{} bytes, neither ASCII (\"solid ...\") nor a binary STL (at least 84 bytes)",
            bytes.len()
        )));
    } else if looks_like_text(bytes) {
        return Err(ModelError::NotStl(
            "text that does not begin with \"solid\" (an ASCII STL does)".into(),
        ));
    } else {
        let count = u32::from_le_bytes(bytes[80..84].try_into().unwrap_or([0; 4])) as u64;
        let expected = BINARY_HEADER + BINARY_TRIANGLE * count;
        return Err(if (bytes.len() as u64) < expected {
            ModelError::Truncated(format!(
                "the binary header declares {count} triangles ({expected} bytes), the file has {} bytes",
                bytes.len()
            ))
        } else {
            ModelError::NotStl(format!(
                "not ASCII (\"solid ...\"), and as binary its header declares {count} triangles ({expected} bytes) but the file has {} bytes",
                bytes.len()
            ))
        });
    };
    for (k, t) in triangles.iter().enumerate() {
        for c in t.iter().flatten() {
            if !c.is_finite() || c.abs() > hollowpath::config::MAX_COORD_MM {
                return Err(ModelError::BadCoordinate {
                    triangle: k,
                    value: *c,
                });
            }
        }
    }
    Ok(triangles)
}

/// The numbers of an ASCII model's `vertex` and `facet normal` lines, checked before the
/// reader (whose errors name no line): the first that is not a number, or lies beyond the
/// coordinates a slice holds, is named with its line.
fn check_ascii_numbers(text: &str) -> Result<(), ModelError> {
    let limit = f64::from(hollowpath::config::MAX_COORD_MM);
    for (n, line) in text.lines().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let numbers = match words.as_slice() {
            ["vertex", rest @ ..] => rest,
            ["facet", "normal", rest @ ..] => rest,
            _ => continue,
        };
        let vertex = words[0] == "vertex";
        for word in numbers {
            let Ok(x) = word.parse::<f64>() else {
                return Err(ModelError::NotStl(format!(
                    "line {}: `{word}` is not a number",
                    n + 1
                )));
            };
            if !x.is_finite() || (vertex && x.abs() > limit) {
                return Err(ModelError::NotStl(format!(
                    "line {}: coordinate {word} is out of range (a model lies within {limit} mm of the origin)",
                    n + 1
                )));
            }
        }
    }
    Ok(())
}

/// Whether the first kilobyte is printable text (a binary STL's header may be text, but its
/// triangles are not).
fn looks_like_text(bytes: &[u8]) -> bool {
    bytes
        .iter()
        .take(1024)
        .all(|&b| b == b'\n' || b == b'\r' || b == b'\t' || (0x20..0x7f).contains(&b))
}

fn read_with_stl_io(bytes: &[u8]) -> Result<Vec<RawTriangle>, ModelError> {
    let mut cursor = Cursor::new(bytes);
    let reader = stl_io::create_stl_reader(&mut cursor).map_err(io_error)?;
    let mut out = Vec::new();
    for t in reader {
        let t = t.map_err(io_error)?;
        out.push([t.vertices[0].0, t.vertices[1].0, t.vertices[2].0]);
    }
    Ok(out)
}

fn io_error(e: std::io::Error) -> ModelError {
    match e.kind() {
        std::io::ErrorKind::UnexpectedEof => ModelError::Truncated(e.to_string()),
        _ => ModelError::NotStl(e.to_string()),
    }
}

/// A binary STL of `triangles` (corners in mm; the normals from the corners' order).
pub fn to_binary(triangles: &[[[f64; 3]; 3]]) -> Vec<u8> {
    let tris: Vec<stl_io::Triangle> = triangles
        .iter()
        .map(|t| {
            let v = |k: usize| stl_io::Vertex::new(t[k].map(|c| c as f32));
            let n = normal(t);
            stl_io::Triangle {
                normal: stl_io::Normal::new(n.map(|c| c as f32)),
                vertices: [v(0), v(1), v(2)],
            }
        })
        .collect();
    let mut out = Vec::new();
    // Writing into a Vec cannot fail.
    let _ = stl_io::write_stl(&mut out, tris.iter());
    out
}

/// An ASCII STL of `triangles`.
pub fn to_ascii(name: &str, triangles: &[[[f64; 3]; 3]]) -> String {
    use std::fmt::Write;
    let mut s = format!("solid {name}\n");
    for t in triangles {
        let n = normal(t);
        let _ = writeln!(s, "  facet normal {} {} {}", n[0], n[1], n[2]);
        s.push_str("    outer loop\n");
        for v in t {
            let _ = writeln!(
                s,
                "      vertex {} {} {}",
                v[0] as f32, v[1] as f32, v[2] as f32
            );
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    let _ = writeln!(s, "endsolid {name}");
    s
}

/// The unit normal of a triangle by the right-hand rule (zero for a degenerate one).
fn normal(t: &[[f64; 3]; 3]) -> [f64; 3] {
    let u = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
    let v = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if l > 0.0 {
        n.map(|c| c / l)
    } else {
        [0.0; 3]
    }
}
