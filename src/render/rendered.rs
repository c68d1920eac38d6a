//! What a render hands back to the command, encoded and ready to write: nothing is written
//! until every output is, so a failure leaves no partial set of files.

use serde::Serialize;

use crate::error::CliError;
use crate::output::Outputs;

/// The image, the cost image if asked for, and the pipeline's report.
pub struct Rendered<R> {
    pub image: Vec<u8>,
    pub cost_image: Option<Vec<u8>>,
    pub report: R,
}

impl<R: Serialize> Rendered<R> {
    /// Writes every output at once, then prints the report as JSON or `summary`.
    pub fn write(self, outputs: &Outputs, json: bool, summary: &str) -> Result<(), CliError> {
        let text = serde_json::to_string_pretty(&self.report)
            .map_err(|e| CliError::Write(e.to_string()))?;
        let text = format!("{text}\n");
        outputs.commit(&[
            ("out", &self.image),
            ("cost-image", self.cost_image.as_deref().unwrap_or_default()),
            ("report", text.as_bytes()),
        ])?;
        if json {
            outputs.print_json(&self.report)
        } else {
            outputs.print(summary)
        }
    }
}
