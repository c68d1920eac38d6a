//! Whether a frame runs on every device or on the fastest class alone.
//!
//! Adding a device must never make a render slower, and a plan cannot promise that by itself:
//! a device far slower than another still holds up the frame with the one task it started,
//! its share of the estimate is slow, and its threads take the cores that feed a GPU
//! (`docs/results.md`, "CPU cores beside an H100", has what they cost). So the renderer measures
//! both ways and keeps the faster: per shader and mode (which decide what a frame costs on
//! every device), it keeps the seconds per path of the latest frame rendered on every device
//! and of the latest on the fastest class alone, and renders the next frame the way that was
//! faster. A frame on every device is weighed only once it was planned at measured or recalled
//! speeds: the first, at equal speeds, measures them, and a slow device's share of it says
//! nothing of what a plan that knows its speed gives. The way in use is
//! measured again on every frame, so when it slows down past the other's figure the other is
//! tried again. The figures travel with the devices to the next renderer over them
//! ([`crate::paths::PathRenderer::into_kept`]) and, through a calibration file, to the next
//! run ([`crate::paths::PathRenderer::remember`]).

use super::Mode;
use crate::calibration::Choice;
use crate::shade::Shader;

/// Which frames a figure belongs to: a shader's name ([`Shader::name`]) and the mode.
pub(crate) type ChoiceKey = (&'static str, Mode);

/// The key of frames of `shader` in `mode`.
pub(crate) fn choice_key(shader: &Shader, mode: Mode) -> ChoiceKey {
    (shader.name(), mode)
}

/// The shaders' names ([`Shader::name`]), whose choices a calibration file may keep.
pub(crate) const SHADERS: [&str; 2] = ["ao", "whitted"];

impl Choice {
    /// Whether the next frame runs on the fastest class alone. `known` says whether every
    /// class's speed is known (measured or recalled), and so which class is the fastest.
    ///
    /// Untried, the fastest class alone goes first when it is known: that frame is the
    /// baseline itself. Otherwise every device goes first, which measures every speed.
    pub fn alone_next(&self, known: bool) -> bool {
        match (self.all, self.alone) {
            (Some(all), Some(alone)) => alone <= all,
            (None, None) => known,
            (Some(_), None) => true,
            (None, Some(_)) => false,
        }
    }

    /// Keeps the seconds per path of a frame rendered `alone` or not; a figure that is not
    /// finite and positive (an empty frame) is not kept.
    pub fn record(&mut self, alone: bool, seconds_per_path: f64) {
        if !(seconds_per_path.is_finite() && seconds_per_path > 0.0) {
            return;
        }
        if alone {
            self.alone = Some(seconds_per_path);
        } else {
            self.all = Some(seconds_per_path);
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::calibration::Choice;

    #[test]
    fn each_way_is_tried_once_then_the_faster_is_kept_until_it_slows() {
        let mut t = Choice::default();
        assert!(!t.alone_next(false), "speeds unknown: every device first");
        assert!(t.alone_next(true), "speeds known: the baseline first");
        t.record(false, 3.0);
        assert!(t.alone_next(false), "then the other way");
        t.record(true, 1.0);
        assert!(t.alone_next(false));
        t.record(true, 2.0);
        assert!(t.alone_next(false), "still faster than every device's 3");
        t.record(true, 4.0);
        assert!(!t.alone_next(false), "slowed past it: every device again");
        t.record(false, f64::NAN);
        t.record(false, 0.0);
        assert_eq!(t.all, Some(3.0), "an empty frame teaches nothing");
    }
}
