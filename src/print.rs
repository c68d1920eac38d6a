//! What the commands print on standard output: text and JSON objects, where a closed pipe is
//! an error the command reports, not a panic.

use std::io::Write;

use crate::error::CliError;

/// Prints one JSON object on standard output.
pub fn print_json(value: &impl serde::Serialize) -> Result<(), CliError> {
    let text = serde_json::to_string(value).map_err(|e| CliError::Write(e.to_string()))?;
    print_text(&format!("{text}\n"))
}

/// Prints text on standard output; a closed pipe is an error, not a panic.
pub fn print_text(text: &str) -> Result<(), CliError> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .map_err(|e| CliError::Write(e.to_string()))
}
