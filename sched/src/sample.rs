//! The sampling rate of a cost estimator: the share of each task's items (rays, bodies,
//! queries) it looks at. Every estimator of the workspace samples; they share this type.

/// Why a sampling rate was refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("sample rate {value} is invalid: it must be in (0, 1]")]
pub struct BadSampleRate {
    /// The rejected rate.
    pub value: f64,
}

/// The share of each task's items an estimator looks at, in `(0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct SampleRate(f64);

impl SampleRate {
    /// Every item: the estimate equals the full count.
    pub const FULL: Self = Self(1.0);
    /// 12.5 %, the thesis's chosen trade-off between overhead and accuracy (Table 4.1).
    pub const THESIS: Self = Self(0.125);
    /// 1/32: where a sampled item costs as much as a traced one (a CPU renders each sampled
    /// path for real), this keeps the estimate a few percent of the work; tasks of a few
    /// hundred items then get only a few samples each.
    pub const ONE_IN_32: Self = Self(0.03125);
    /// 1/64: half of [`Self::ONE_IN_32`]'s cost, where items alike in cost need fewer samples.
    pub const ONE_IN_64: Self = Self(0.015625);

    /// Checks the rate: finite and in `(0, 1]`.
    pub fn new(rate: f64) -> Result<Self, BadSampleRate> {
        if rate.is_finite() && rate > 0.0 && rate <= 1.0 {
            Ok(Self(rate))
        } else {
            Err(BadSampleRate { value: rate })
        }
    }

    /// The rate as a fraction.
    pub fn get(self) -> f64 {
        self.0
    }

    /// How many of `len` items are kept: `ceil(len · rate)`, at least one of a non-empty
    /// task. The tiny epsilon keeps `4096 · 0.125` at 512 despite rounding in the rate.
    pub fn samples(self, len: usize) -> usize {
        if len == 0 {
            return 0;
        }
        ((len as f64 * self.0 - 1e-9).ceil() as usize).clamp(1, len)
    }

    /// For estimators that take every `stride`-th item of a task: `1 / rate`, rounded.
    pub fn stride(self) -> usize {
        ((1.0 / self.0).round() as usize).max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_outside_zero_one_are_refused_by_value() {
        for bad in [0.0, -0.5, 1.5, f64::NAN, f64::INFINITY] {
            let err = SampleRate::new(bad).unwrap_err();
            assert!(err.to_string().contains("sample rate"), "{err}");
        }
        assert_eq!(SampleRate::new(0.125), Ok(SampleRate::THESIS));
        assert_eq!(SampleRate::THESIS.samples(4096), 512);
        assert_eq!(SampleRate::THESIS.samples(513), 65);
        assert_eq!(SampleRate::THESIS.stride(), 8);
        assert_eq!(SampleRate::new(0.3).map(SampleRate::stride), Ok(3));
    }
}
