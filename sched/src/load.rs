use std::cmp::Ordering;

/// A running sum of task costs that stays exact across the whole range of `f64` inputs.
///
/// A plain `f64` sum loses small costs next to large ones (1e12 + 1e-12 == 1e12) and drifts
/// over a million additions, which breaks ties between devices and shifts makespans. `Load`
/// is a double-double: `hi` is the correctly rounded sum and `lo` the rounding error, kept by
/// Knuth's TwoSum, giving about 106 bits; enough for 10^6 costs spanning 1e-12..1e12.
#[derive(Debug, Clone, Copy, Default)]
pub struct Load {
    hi: f64,
    lo: f64,
}

impl Load {
    /// The empty sum.
    pub const ZERO: Load = Load { hi: 0.0, lo: 0.0 };

    /// A sum holding one value.
    pub fn new(value: f64) -> Self {
        Load { hi: value, lo: 0.0 }
    }

    /// This sum plus `x`.
    #[must_use]
    pub fn plus(self, x: f64) -> Load {
        let (s, e) = two_sum(self.hi, x);
        let (hi, lo) = fast_two_sum(s, e + self.lo);
        Load { hi, lo }
    }

    /// This sum plus another.
    #[must_use]
    pub fn plus_load(self, other: Load) -> Load {
        let (s, e) = two_sum(self.hi, other.hi);
        let (hi, lo) = fast_two_sum(s, e + self.lo + other.lo);
        Load { hi, lo }
    }

    /// The sum, rounded to the nearest `f64`.
    pub fn value(self) -> f64 {
        self.hi
    }

    /// Sums a sequence of values.
    pub fn sum(values: impl IntoIterator<Item = f64>) -> Load {
        values.into_iter().fold(Load::ZERO, Load::plus)
    }
}

// Knuth: s + e == a + b exactly.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

// Dekker, valid when |a| >= |b| (true here: `a` is the rounded sum, `b` its error).
fn fast_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

impl PartialEq for Load {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Load {}

impl PartialOrd for Load {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Load {
    /// Loads are sums of validated, finite costs, so they are never NaN; a normalised
    /// double-double compares lexicographically.
    fn cmp(&self, other: &Self) -> Ordering {
        let by = |a: f64, b: f64| a.partial_cmp(&b).unwrap_or(Ordering::Equal);
        by(self.hi, other.hi).then_with(|| by(self.lo, other.lo))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_tiny_costs_next_to_huge_ones() {
        let l = Load::new(1e12).plus(1e-12).plus(1e-12);
        assert!(l > Load::new(1e12));
        assert_eq!(l.plus(-1e12).value(), 2e-12);
    }

    #[test]
    fn a_million_tenths_sum_to_exactly_the_product() {
        let l = Load::sum(std::iter::repeat_n(0.1, 1_000_000));
        // The exact sum of a million copies of the double nearest 0.1, rounded once.
        assert_eq!(l.value(), 100_000.0);
        let naive: f64 = std::iter::repeat_n(0.1, 1_000_000).sum();
        assert_ne!(naive, l.value(), "the naive sum drifts; Load must not");
    }

    #[test]
    fn equal_sequences_compare_equal() {
        let a = Load::sum([0.1, 0.2, 0.3]);
        let b = Load::sum([0.1, 0.2, 0.3]);
        assert_eq!(a, b);
        assert!(a < a.plus(1e-30));
    }
}
