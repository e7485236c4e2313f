//! The subcommands' work, one module each, and their command line.

pub(crate) mod args;
pub(crate) mod plan;
pub(crate) mod simulate;

use std::path::Path;

/// Creates the output folder `out` (and its parents); a file of that name is named as such.
pub(crate) fn create_out(out: &Path) -> Result<(), String> {
    if out.is_file() {
        return Err(format!(
            "--out {} is a file: give a folder for the results",
            out.display()
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))
}
