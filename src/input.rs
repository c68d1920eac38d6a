//! Reading the small text inputs of the command line: cost files and comma lists.

use std::io::{BufRead, Read};
use std::path::Path;

use crate::error::CliError;

/// Reads one non-negative cost per line from `path` (`-` for standard input). Blank lines and
/// lines starting with `#` are skipped. Every bad line is reported with its number.
pub fn read_costs(path: &Path) -> Result<Vec<f64>, CliError> {
    let bytes = read_text(path)?;
    let text = String::from_utf8(bytes).map_err(|e| CliError::Read {
        path: path.to_owned(),
        source: std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        ),
    })?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut costs = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |message: String| CliError::Line {
            path: path.to_owned(),
            line: i + 1,
            message,
        };
        let value: f64 = line
            .parse()
            .map_err(|_| bad(format!("{line:?} is not a number")))?;
        if !value.is_finite() || value < 0.0 {
            return Err(bad(format!("cost {value} must be finite and non-negative")));
        }
        costs.push(value);
    }
    Ok(costs)
}

/// Largest input file read into memory: a path such as `/dev/zero` given by mistake ends in
/// an error instead of filling memory.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// Opens an input file, or standard input for `-`, buffered.
pub fn open(path: &Path) -> Result<Box<dyn BufRead>, CliError> {
    if path == Path::new("-") {
        return Ok(Box::new(std::io::stdin().lock()));
    }
    let file = std::fs::File::open(path).map_err(|source| CliError::Read {
        path: path.to_owned(),
        source,
    })?;
    Ok(Box::new(std::io::BufReader::new(file)))
}

/// The error of an input past [`MAX_INPUT_BYTES`].
pub fn too_large(path: &Path) -> CliError {
    CliError::Read {
        path: path.to_owned(),
        source: std::io::Error::new(
            std::io::ErrorKind::FileTooLarge,
            format!("larger than the limit of {MAX_INPUT_BYTES} bytes"),
        ),
    }
}

/// Reads a whole text input, or standard input for `-`, up to [`MAX_INPUT_BYTES`]. NUL bytes
/// at the start (UTF-16, binary data, `/dev/zero`) end the read at once.
pub fn read_text(path: &Path) -> Result<Vec<u8>, CliError> {
    let read_err = |source| CliError::Read {
        path: path.to_owned(),
        source,
    };
    let mut input = open(path)?.take(MAX_INPUT_BYTES + 1);
    let mut bytes = Vec::new();
    let mut block = vec![0u8; 1 << 16];
    loop {
        let n = match input.read(&mut block) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(read_err(e)),
        };
        if bytes.len() < block.len() && block[..n].contains(&0) {
            return Err(read_err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "holds NUL bytes: binary data or UTF-16, not UTF-8 text",
            )));
        }
        bytes.extend_from_slice(&block[..n]);
    }
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(too_large(path));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn file(tag: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p = std::env::temp_dir().join(format!("cobalt-input-{}-{tag}", std::process::id()));
        std::fs::write(&p, bytes).expect("temp file");
        p
    }

    #[test]
    fn a_byte_order_mark_is_skipped_and_other_encodings_are_named() {
        let p = file("bom", b"\xEF\xBB\xBF1\n2\n");
        assert_eq!(read_costs(&p).unwrap(), [1.0, 2.0]);
        let p = file("utf16", b"\xFF\xFE1\x00\n\x00");
        let e = read_costs(&p).unwrap_err().to_string();
        assert!(e.contains("cobalt-input") && e.contains("UTF-8"), "{e}");
    }

    proptest! {
        /// Random bytes: costs that are all finite and non-negative, or an error naming the file.
        #[test]
        fn random_cost_files_never_panic(body in proptest::collection::vec(any::<u8>(), 0..256)) {
            let p = file("prop", &body);
            match read_costs(&p) {
                Ok(costs) => prop_assert!(costs.iter().all(|c| c.is_finite() && *c >= 0.0)),
                Err(e) => prop_assert!(e.to_string().contains("cobalt-input")),
            }
        }
    }
}
