//! Least-squares calibration of `kB`, `kT ≥ 0` from measured task times: the step that turns
//! node and triangle counts into seconds on one device for one kind of ray.
//!
//! Two unknowns, so the normal equations are 2×2 and solved in closed form, on columns
//! scaled to unit length (counts are ~1e5, times ~1e-4 s: unscaled, the Gram matrix would mix
//! magnitudes 1e10 apart). `B` and `T` are strongly correlated in a BVH, so the system can be
//! singular, and the unconstrained optimum can put a negative weight on one of them. For two
//! non-negative unknowns the constrained optimum then lies on an axis, so the better of the
//! two one-parameter fits is the non-negative least-squares answer.

use super::{CostError, CostModel, Work};

/// Which parameters the fit kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitForm {
    /// Both `kB` and `kT` are positive.
    Both,
    /// `kT = 0`: time is explained by node visits alone.
    NodesOnly,
    /// `kB = 0`: time is explained by triangle tests alone.
    TrianglesOnly,
}

impl FitForm {
    /// Lower-case name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Both => "both",
            Self::NodesOnly => "nodes-only",
            Self::TrianglesOnly => "triangles-only",
        }
    }
}

/// A calibrated model and how well it explains the measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// `kB`, `kT` in seconds per node visit and per triangle test.
    pub model: CostModel,
    /// Which parameters were kept.
    pub form: FitForm,
    /// Coefficient of determination `1 − SSres / SStot` (can be negative: the model has no
    /// intercept); 1 when the times are constant and fitted exactly.
    pub r2: f64,
    /// Root-mean-square residual, in seconds.
    pub rms_residual: f64,
    /// Number of tasks fitted.
    pub n: usize,
}

/// Fits `seconds[i] ≈ kB·work[i].nodes + kT·work[i].tris` with `kB, kT ≥ 0`.
pub fn calibrate(work: &[Work], seconds: &[f64]) -> Result<Fit, CostError> {
    if work.len() != seconds.len() {
        return Err(CostError::LengthMismatch {
            what: "calibration needs one measured time per task",
            expected: work.len(),
            got: seconds.len(),
        });
    }
    if work.is_empty() {
        return Err(CostError::TooFewTasks {
            what: "calibration",
            needed: 1,
            got: 0,
        });
    }
    let bad = |what, task, value: f64| {
        (!(value.is_finite() && value >= 0.0)).then_some(CostError::BadValue { what, task, value })
    };
    for (i, (w, &y)) in work.iter().zip(seconds).enumerate() {
        if let Some(e) = bad("node count", i, w.nodes)
            .or_else(|| bad("triangle count", i, w.tris))
            .or_else(|| bad("measured time", i, y))
        {
            return Err(e);
        }
    }
    let dot = |f: &dyn Fn(usize) -> f64, g: &dyn Fn(usize) -> f64| -> f64 {
        (0..work.len()).map(|i| f(i) * g(i)).sum()
    };
    let b = |i: usize| work[i].nodes;
    let t = |i: usize| work[i].tris;
    let y = |i: usize| seconds[i];
    let (bb, tt, bt, by, ty) = (
        dot(&b, &b),
        dot(&t, &t),
        dot(&b, &t),
        dot(&b, &y),
        dot(&t, &y),
    );
    if bb == 0.0 && tt == 0.0 {
        return Err(CostError::Degenerate {
            what: "calibration",
            why: "every task has zero nodes and zero triangles",
        });
    }

    let nodes_only = CostModel {
        kb: if bb > 0.0 { by / bb } else { 0.0 },
        kt: 0.0,
    };
    let tris_only = CostModel {
        kb: 0.0,
        kt: if tt > 0.0 { ty / tt } else { 0.0 },
    };
    let ssr = |m: &CostModel| -> f64 {
        work.iter()
            .zip(seconds)
            .map(|(&w, &y)| (m.cost(w) - y).powi(2))
            .sum()
    };
    let (mut model, mut form) = if ssr(&nodes_only) <= ssr(&tris_only) {
        (nodes_only, FitForm::NodesOnly)
    } else {
        (tris_only, FitForm::TrianglesOnly)
    };
    if bb > 0.0 && tt > 0.0 {
        // Unit-length columns: the Gram matrix is [[1, c], [c, 1]] with c the cosine between
        // B and T (in [0, 1], counts are non-negative).
        let (sb, st) = (bb.sqrt(), tt.sqrt());
        let c = bt / (sb * st);
        let det = 1.0 - c * c;
        if det > 1e-12 {
            let (u, v) = (by / sb, ty / st);
            let (p, q) = ((u - c * v) / det, (v - c * u) / det);
            if p > 0.0 && q > 0.0 {
                model = CostModel {
                    kb: p / sb,
                    kt: q / st,
                };
                form = FitForm::Both;
            }
        }
    }

    let n = work.len();
    let res = ssr(&model);
    let mean = seconds.iter().sum::<f64>() / n as f64;
    let tot: f64 = seconds.iter().map(|y| (y - mean).powi(2)).sum();
    let r2 = if tot > 0.0 {
        1.0 - res / tot
    } else if res <= f64::EPSILON * mean * mean * n as f64 {
        1.0
    } else {
        0.0
    };
    Ok(Fit {
        model,
        form,
        r2,
        rms_residual: (res / n as f64).sqrt(),
        n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tasks whose `B` and `T` vary independently (a small deterministic generator).
    fn synthetic(n: usize) -> Vec<Work> {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| Work {
                nodes: 1e4 + 2e5 * next(),
                tris: 5e3 + 1e5 * next(),
            })
            .collect()
    }

    #[test]
    fn recovers_known_constants_without_noise() {
        let truth = CostModel { kb: 2e-9, kt: 7e-9 };
        let work = synthetic(50);
        let fit = calibrate(&work, &truth.costs(&work)).unwrap();
        assert_eq!(fit.form, FitForm::Both);
        assert!((fit.model.kb / truth.kb - 1.0).abs() < 1e-9, "{fit:?}");
        assert!((fit.model.kt / truth.kt - 1.0).abs() < 1e-9, "{fit:?}");
        assert!(fit.r2 > 1.0 - 1e-12 && fit.rms_residual < 1e-15 && fit.n == 50);
    }

    #[test]
    fn recovers_known_constants_approximately_with_noise() {
        let truth = CostModel { kb: 3e-9, kt: 1e-8 };
        let work = synthetic(400);
        // ±5 % deterministic noise.
        let y: Vec<f64> = truth
            .costs(&work)
            .iter()
            .enumerate()
            .map(|(i, c)| c * (1.0 + 0.05 * ((i as f64 * 2.399).sin())))
            .collect();
        let fit = calibrate(&work, &y).unwrap();
        assert!((fit.model.kb / truth.kb - 1.0).abs() < 0.1, "{fit:?}");
        assert!((fit.model.kt / truth.kt - 1.0).abs() < 0.1, "{fit:?}");
        assert!(fit.r2 > 0.9, "{fit:?}");
    }

    #[test]
    fn singular_or_negative_systems_fall_back_to_one_parameter() {
        // T proportional to B: singular; the fit still explains the times exactly.
        let work: Vec<Work> = (1..20)
            .map(|i| Work {
                nodes: i as f64,
                tris: 3.0 * i as f64,
            })
            .collect();
        let y: Vec<f64> = work.iter().map(|w| 2.0 * w.nodes).collect();
        let fit = calibrate(&work, &y).unwrap();
        assert_ne!(fit.form, FitForm::Both);
        assert!(fit.rms_residual < 1e-12 && fit.model.kb >= 0.0 && fit.model.kt >= 0.0);
        // Time falls as T grows at fixed B: the unconstrained kT would be negative.
        let work: Vec<Work> = (0..20)
            .map(|i| Work {
                nodes: 10.0 + i as f64,
                tris: 30.0 - i as f64,
            })
            .collect();
        let y: Vec<f64> = work.iter().map(|w| w.nodes - 0.2 * w.tris).collect();
        let fit = calibrate(&work, &y).unwrap();
        assert_eq!(fit.form, FitForm::NodesOnly);
        assert_eq!(fit.model.kt, 0.0);
    }

    #[test]
    fn bad_inputs_are_named() {
        let w = [Work {
            nodes: 1.0,
            tris: 1.0,
        }];
        assert!(matches!(
            calibrate(&w, &[]),
            Err(CostError::LengthMismatch { .. })
        ));
        assert!(matches!(
            calibrate(&[], &[]),
            Err(CostError::TooFewTasks { .. })
        ));
        let err = calibrate(&w, &[f64::NAN]).unwrap_err();
        assert!(err.to_string().contains("measured time of task 0"), "{err}");
        let zero = [Work::default(); 2];
        assert!(matches!(
            calibrate(&zero, &[1.0, 2.0]),
            Err(CostError::Degenerate { .. })
        ));
    }
}
