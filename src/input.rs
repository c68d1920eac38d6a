//! Reading the small text inputs of the command line: cost files and comma lists.

use std::io::Read;
use std::path::Path;

use crate::error::CliError;

/// Reads one non-negative cost per line from `path` (`-` for standard input). Blank lines and
/// lines starting with `#` are skipped. Every bad line is reported with its number.
pub fn read_costs(path: &Path) -> Result<Vec<f64>, CliError> {
    let read_err = |source| CliError::Read {
        path: path.to_owned(),
        source,
    };
    let mut text = String::new();
    if path == Path::new("-") {
        std::io::stdin()
            .read_to_string(&mut text)
            .map_err(read_err)?;
    } else {
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_string(&mut text))
            .map_err(read_err)?;
    }
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

/// Parses `1,1,2.5` into numbers, naming the flag and the bad item.
pub fn parse_list(flag: &'static str, value: &str) -> Result<Vec<f64>, CliError> {
    value
        .split(',')
        .map(|item| {
            item.trim().parse::<f64>().map_err(|_| CliError::Arg {
                flag,
                value: value.to_owned(),
                message: format!("{:?} is not a number", item.trim()),
            })
        })
        .collect()
}
