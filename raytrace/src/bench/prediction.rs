//! The thesis's prediction error, `Σ|estimated − full| / Σ full`, summed over a cell's
//! frames.

/// `Σ|estimated − full|` and `Σ full` of one frame, in default-model cost units.
#[derive(Clone, Copy, Debug, Default)]
pub struct ErrorSums {
    /// Sum of absolute differences.
    pub diff: f64,
    /// Sum of full costs.
    pub full: f64,
}

impl std::ops::AddAssign for ErrorSums {
    fn add_assign(&mut self, o: Self) {
        self.diff += o.diff;
        self.full += o.full;
    }
}

impl ErrorSums {
    /// The thesis's prediction error, `Σ|estimated − full| / Σ full` (0 for no work).
    pub fn ratio(self) -> f64 {
        if self.full > 0.0 {
            self.diff / self.full
        } else {
            0.0
        }
    }
}
