use crate::{Load, SchedError};

/// Validated relative device speeds: finite and positive. A device of speed 2 runs a task of
/// cost 1 in half the time of a device of speed 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Speeds(Vec<f64>);

impl Speeds {
    /// Checks every speed; the error names the first bad one, or says there are none.
    pub fn new(speeds: Vec<f64>) -> Result<Self, SchedError> {
        if speeds.is_empty() {
            return Err(SchedError::NoDevices);
        }
        if let Some((device, &value)) = speeds
            .iter()
            .enumerate()
            .find(|(_, s)| !(s.is_finite() && **s > 0.0))
        {
            return Err(SchedError::BadSpeed { device, value });
        }
        Ok(Speeds(speeds))
    }

    /// `m` devices of speed 1.
    pub fn identical(m: usize) -> Result<Self, SchedError> {
        Speeds::new(vec![1.0; m])
    }

    /// The speeds, in device order.
    pub fn as_slice(&self) -> &[f64] {
        &self.0
    }

    /// Number of devices (at least one).
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Always false: validated speeds name at least one device.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The summed speed of all devices.
    pub fn total(&self) -> f64 {
        Load::sum(self.0.iter().copied()).value()
    }

    /// True when all devices run at the same speed, where the tighter bounds hold.
    pub fn are_identical(&self) -> bool {
        self.0.iter().all(|&s| s == self.0[0])
    }
}

impl std::ops::Index<usize> for Speeds {
    type Output = f64;
    fn index(&self, device: usize) -> &f64 {
        &self.0[device]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_speeds() {
        assert_eq!(Speeds::new(vec![]), Err(SchedError::NoDevices));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                Speeds::new(vec![1.0, bad]),
                Err(SchedError::BadSpeed { device: 1, .. })
            ));
        }
    }
}
