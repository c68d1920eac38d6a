//! Least-squares calibration of `kR`, `kB`, `kT ≥ 0` from measured task times: the step that
//! turns ray, node and triangle counts into seconds on one device for one kind of ray.
//!
//! Three non-negative unknowns: the constrained optimum is the unconstrained least-squares
//! fit on the terms it keeps, so every subset of the three terms that keeps `B` or `T` is
//! solved (normal equations of at most 3×3, on columns scaled to unit length: counts are
//! ~1e5, times ~1e-4 s, and unscaled the Gram matrix would mix magnitudes 1e10 apart) and the
//! feasible one with the least residual wins. `R` alone is not a model: it would rank tasks
//! by length and ignore what the estimate counted. `R`, `B` and `T` are strongly correlated
//! in a BVH (tasks of equal length make `R` a constant), so many subsets are singular and are
//! skipped.

use super::{CostModel, Work};

/// Which terms of `kR·R + kB·B + kT·T` the fit kept (the others are 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FitForm {
    /// `kR > 0`.
    pub rays: bool,
    /// `kB > 0`.
    pub nodes: bool,
    /// `kT > 0`.
    pub tris: bool,
}

impl FitForm {
    /// The terms kept, for reports: e.g. `rays+nodes`, `nodes+triangles`, or `none`.
    pub fn name(self) -> String {
        let terms = [
            (self.rays, "rays"),
            (self.nodes, "nodes"),
            (self.tris, "triangles"),
        ];
        let kept: Vec<&str> = terms.iter().filter(|t| t.0).map(|t| t.1).collect();
        if kept.is_empty() {
            "none".into()
        } else {
            kept.join("+")
        }
    }
}

/// Serialized as its [`FitForm::name`].
impl serde::Serialize for FitForm {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.name())
    }
}

/// A calibrated model and how well it explains the measurements; serialized as `kr`, `kb`,
/// `kt`, `r2`, `rms_residual`, `n` and `form`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Fit {
    /// `kR`, `kB`, `kT` in seconds per ray, node visit and triangle test.
    #[serde(flatten)]
    pub model: CostModel,
    /// Coefficient of determination `1 − SSres / SStot` (can be negative: the model has no
    /// free intercept); 1 when the times are constant and fitted exactly.
    pub r2: f64,
    /// Root-mean-square residual, in seconds.
    pub rms_residual: f64,
    /// Number of tasks fitted.
    pub n: usize,
    /// Which terms were kept.
    pub form: FitForm,
}

/// Fits `seconds[i] ≈ kR·work[i].rays + kB·work[i].nodes + kT·work[i].tris` with every
/// constant `≥ 0`. `None` if the lengths differ, there is no task, a count or a time is not
/// finite and non-negative, or every task has zero nodes and zero triangles.
pub fn calibrate(work: &[Work], seconds: &[f64]) -> Option<Fit> {
    let usable = |v: f64| v.is_finite() && v >= 0.0;
    let usable_task = |(w, &y): (&Work, &f64)| [w.rays, w.nodes, w.tris, y].into_iter().all(usable);
    if work.len() != seconds.len() || work.is_empty() || !work.iter().zip(seconds).all(usable_task)
    {
        return None;
    }
    let column = |k: usize, w: &Work| [w.rays, w.nodes, w.tris][k];
    let norms: [f64; 3] = std::array::from_fn(|k| {
        work.iter()
            .map(|w| column(k, w).powi(2))
            .sum::<f64>()
            .sqrt()
    });
    if norms[1] == 0.0 && norms[2] == 0.0 {
        return None;
    }
    let ssr = |m: &CostModel| -> f64 {
        work.iter()
            .zip(seconds)
            .map(|(&w, &y)| (m.cost(w) - y).powi(2))
            .sum()
    };
    // Scaled columns' Gram matrix and right-hand side.
    let gram: [[f64; 3]; 3] = std::array::from_fn(|a| {
        std::array::from_fn(|b| {
            if norms[a] == 0.0 || norms[b] == 0.0 {
                return 0.0;
            }
            work.iter()
                .map(|w| column(a, w) * column(b, w))
                .sum::<f64>()
                / (norms[a] * norms[b])
        })
    });
    let rhs: [f64; 3] = std::array::from_fn(|a| {
        if norms[a] == 0.0 {
            return 0.0;
        }
        work.iter()
            .zip(seconds)
            .map(|(w, y)| column(a, w) * y)
            .sum::<f64>()
            / norms[a]
    });
    let mut best: Option<(f64, CostModel, FitForm)> = None;
    // Every subset that keeps `B` or `T`: a fit by ray count alone would ignore the estimate.
    for subset in 2u8..8 {
        let keep: Vec<usize> = (0..3).filter(|k| subset & (1 << k) != 0).collect();
        if keep.iter().any(|&k| norms[k] == 0.0) {
            continue;
        }
        let Some(scaled) = solve(&gram, &rhs, &keep) else {
            continue;
        };
        if scaled.iter().any(|&c| c < 0.0) {
            continue;
        }
        let mut k = [0.0; 3];
        for (&term, c) in keep.iter().zip(&scaled) {
            k[term] = c / norms[term];
        }
        let model = CostModel {
            kr: k[0],
            kb: k[1],
            kt: k[2],
        };
        let form = FitForm {
            rays: k[0] > 0.0,
            nodes: k[1] > 0.0,
            tris: k[2] > 0.0,
        };
        let res = ssr(&model);
        // Ties go to the subset found first, the one with fewer terms among equals.
        if best.as_ref().is_none_or(|(r, _, _)| res < *r) {
            best = Some((res, model, form));
        }
    }
    // A single column with a non-negative right-hand side always solves, so `best` is set
    // whenever `B` or `T` is non-zero somewhere; the fallback is for safety only.
    let (res, model, form) = best.unwrap_or((
        ssr(&CostModel::counts_only(0.0, 0.0)),
        CostModel::counts_only(0.0, 0.0),
        FitForm {
            rays: false,
            nodes: false,
            tris: false,
        },
    ));

    let n = work.len();
    let mean = seconds.iter().sum::<f64>() / n as f64;
    let tot: f64 = seconds.iter().map(|y| (y - mean).powi(2)).sum();
    let r2 = if tot > 0.0 {
        1.0 - res / tot
    } else if res <= f64::EPSILON * mean * mean * n as f64 {
        1.0
    } else {
        0.0
    };
    Some(Fit {
        model,
        form,
        r2,
        rms_residual: (res / n as f64).sqrt(),
        n,
    })
}

/// The least-squares coefficients of the terms `keep` (unit-scaled), from the full Gram
/// matrix and right-hand side, by Gaussian elimination with partial pivoting; `None` when the
/// kept columns are (nearly) dependent.
fn solve(gram: &[[f64; 3]; 3], rhs: &[f64; 3], keep: &[usize]) -> Option<Vec<f64>> {
    let n = keep.len();
    let mut a: Vec<Vec<f64>> = keep
        .iter()
        .map(|&i| {
            let mut row: Vec<f64> = keep.iter().map(|&j| gram[i][j]).collect();
            row.push(rhs[i]);
            row
        })
        .collect();
    for col in 0..n {
        let pivot = (col..n).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        // Unit columns: a pivot this small means the kept columns are nearly parallel.
        if a[pivot][col].abs() < 1e-10 {
            return None;
        }
        a.swap(col, pivot);
        let lead = a[col].clone();
        for (r, row) in a.iter_mut().enumerate() {
            if r != col {
                let f = row[col] / lead[col];
                for (x, l) in row.iter_mut().zip(&lead).skip(col) {
                    *x -= f * l;
                }
            }
        }
    }
    Some((0..n).map(|i| a[i][n] / a[i][i]).collect())
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
                rays: (256.0 + 3840.0 * next()).round(),
            })
            .collect()
    }

    #[test]
    fn recovers_known_constants_without_noise() {
        let truth = CostModel {
            kr: 5e-8,
            kb: 2e-9,
            kt: 7e-9,
        };
        let work = synthetic(50);
        let fit = calibrate(&work, &truth.costs(&work)).unwrap();
        assert_eq!(fit.form.name(), "rays+nodes+triangles");
        assert!((fit.model.kr / truth.kr - 1.0).abs() < 1e-9, "{fit:?}");
        assert!((fit.model.kb / truth.kb - 1.0).abs() < 1e-9, "{fit:?}");
        assert!((fit.model.kt / truth.kt - 1.0).abs() < 1e-9, "{fit:?}");
        assert!(fit.r2 > 1.0 - 1e-12 && fit.rms_residual < 1e-15 && fit.n == 50);
        // Without a per-ray cost, none is found.
        let thesis = CostModel::counts_only(2e-9, 7e-9);
        let fit = calibrate(&work, &thesis.costs(&work)).unwrap();
        assert_eq!(fit.form.name(), "nodes+triangles");
        assert!((fit.model.kb / thesis.kb - 1.0).abs() < 1e-9, "{fit:?}");
    }

    #[test]
    fn recovers_known_constants_approximately_with_noise() {
        let truth = CostModel::counts_only(3e-9, 1e-8);
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
                rays: 64.0,
            })
            .collect();
        let y: Vec<f64> = work.iter().map(|w| 2.0 * w.nodes).collect();
        let fit = calibrate(&work, &y).unwrap();
        assert!(!(fit.form.nodes && fit.form.tris), "{fit:?}");
        assert!(fit.rms_residual < 1e-12 && fit.model.kb >= 0.0 && fit.model.kt >= 0.0);
        // Time falls as T grows at fixed B: the unconstrained kT would be negative.
        let work: Vec<Work> = (0..20)
            .map(|i| Work {
                nodes: 10.0 + i as f64,
                tris: 30.0 - i as f64,
                rays: 1.0 + (i % 3) as f64,
            })
            .collect();
        let y: Vec<f64> = work.iter().map(|w| w.nodes - 0.2 * w.tris).collect();
        let fit = calibrate(&work, &y).unwrap();
        assert!(!fit.form.tris, "{fit:?}");
        assert_eq!(fit.model.kt, 0.0);
        assert!(fit.model.kr >= 0.0 && fit.model.kb > 0.0, "{fit:?}");
    }

    #[test]
    fn bad_inputs_have_no_fit() {
        let w = [Work {
            nodes: 1.0,
            tris: 1.0,
            rays: 1.0,
        }];
        assert_eq!(calibrate(&w, &[]), None);
        assert_eq!(calibrate(&[], &[]), None);
        assert_eq!(calibrate(&w, &[f64::NAN]), None);
        assert_eq!(calibrate(&w, &[-1.0]), None);
        let zero = [Work::default(); 2];
        assert_eq!(calibrate(&zero, &[1.0, 2.0]), None);
    }
}
