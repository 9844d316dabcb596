//! Movement prediction (paper 000, section 3.2): from the last positions of a
//! moved object, the boxes it will likely occupy over the next `n` moves, scaled by
//! `s` about their centres to cover the prediction's error; the session builds the
//! shafts those boxes meet before a move needs them (all boxes in one traversal,
//! Fig. 1).
//!
//! - `linear` (eq. 1): `p₊ₙ = p₀ + n t₀`, `t₀ = c₀ − c₋₁` the step of the box centre;
//! - `mean:M` (eq. 2): `t₀` replaced by the mean of the last `M` steps;
//! - `matrix` (eq. 3): `p₊ₙ = T₀ⁿ p₀` with `T₀ = W₀ W₋₁⁻¹` the last move's map
//!   (rotation included), applied to the corners of the current box.
//!
//! Boxes stay axis-aligned, as in the paper, even when the object turns.

use std::collections::VecDeque;

use glam::{DAffine3, DVec3};

use crate::{Error, Result};

/// A world box `(lo, hi)`.
pub type Aabb = (DVec3, DVec3);

/// The prediction method (`--predict`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// No prediction: shafts are built when a move needs them.
    None,
    /// Eq. 1.
    Linear,
    /// Eq. 2 over the last `M` steps.
    Mean(usize),
    /// Eq. 3.
    Matrix,
}

impl std::str::FromStr for Method {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "none" => Ok(Method::None),
            "linear" => Ok(Method::Linear),
            "matrix" => Ok(Method::Matrix),
            _ => s
                .strip_prefix("mean:")
                .and_then(|m| m.parse::<usize>().ok())
                .filter(|&m| m >= 1)
                .map(Method::Mean)
                .ok_or_else(|| {
                    Error::Usage(format!(
                        "--predict: expected none, linear, mean:M (M >= 1) or matrix, found \"{s}\""
                    ))
                }),
        }
    }
}

/// What one object's predictions start from: its world map and box after a move.
#[derive(Clone, Copy, Debug)]
struct Placed {
    world: DAffine3,
    bounds: Aabb,
}

/// Recent positions of each object and the boxes they predict.
#[derive(Clone, Debug)]
pub struct Predictor {
    method: Method,
    ahead: u32,
    scale: f64,
    history: Vec<VecDeque<Placed>>,
}

impl Predictor {
    /// A predictor for `objects` objects, `ahead` moves ahead, boxes scaled by
    /// `scale`.
    pub fn new(method: Method, ahead: u32, scale: f64, objects: usize) -> Self {
        Predictor {
            method,
            ahead,
            scale,
            history: vec![VecDeque::new(); objects],
        }
    }

    /// Records where object `o` stands after a move.
    pub fn record(&mut self, o: u32, world: DAffine3, bounds: Aabb) {
        let keep = match self.method {
            Method::Mean(m) => m + 1,
            _ => 2,
        };
        if let Some(h) = self.history.get_mut(o as usize) {
            h.push_back(Placed { world, bounds });
            while h.len() > keep {
                h.pop_front();
            }
        }
    }

    /// The predicted boxes of every object with two positions or more, for each of
    /// the next `ahead` moves.
    pub fn boxes(&self) -> Vec<Aabb> {
        let mut out = Vec::new();
        if self.method == Method::None {
            return out;
        }
        for h in &self.history {
            let (Some(now), Some(_)) = (h.back(), h.len().checked_sub(2).and_then(|i| h.get(i)))
            else {
                continue;
            };
            let c = |b: &Aabb| 0.5 * (b.0 + b.1);
            let steps: Vec<DVec3> = h
                .iter()
                .zip(h.iter().skip(1))
                .map(|(a, b)| c(&b.bounds) - c(&a.bounds))
                .collect();
            for n in 1..=self.ahead {
                let nf = f64::from(n);
                let b = match self.method {
                    Method::None => continue,
                    Method::Linear => shift(now.bounds, nf * steps[steps.len() - 1]),
                    Method::Mean(_) => {
                        let mean = steps.iter().sum::<DVec3>() / steps.len() as f64;
                        shift(now.bounds, nf * mean)
                    }
                    Method::Matrix => {
                        let before = h[h.len() - 2].world;
                        let step = now.world * before.inverse();
                        let mut m = DAffine3::IDENTITY;
                        for _ in 0..n {
                            m = step * m;
                        }
                        transform_box(&m, now.bounds)
                    }
                };
                out.push(scaled(b, self.scale));
            }
        }
        out
    }
}

fn shift(b: Aabb, d: DVec3) -> Aabb {
    (b.0 + d, b.1 + d)
}

/// The box of the corners of `b` mapped by `m`.
pub fn transform_box(m: &DAffine3, b: Aabb) -> Aabb {
    (0..8).fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), i| {
        let p = DVec3::new(
            if i & 1 == 0 { b.0.x } else { b.1.x },
            if i & 2 == 0 { b.0.y } else { b.1.y },
            if i & 4 == 0 { b.0.z } else { b.1.z },
        );
        let q = m.transform_point3(p);
        (lo.min(q), hi.max(q))
    })
}

/// `b` scaled by `s` about its centre.
fn scaled(b: Aabb, s: f64) -> Aabb {
    let c = 0.5 * (b.0 + b.1);
    let h = 0.5 * s * (b.1 - b.0);
    (c - h, c + h)
}

#[cfg(test)]
mod tests {
    use glam::DQuat;

    use super::*;

    fn unit_at(x: f64) -> (DAffine3, Aabb) {
        let m = DAffine3::from_translation(DVec3::new(x, 0.0, 0.0));
        (m, (DVec3::new(x, 0.0, 0.0), DVec3::new(x + 1.0, 1.0, 1.0)))
    }

    #[test]
    fn linear_extrapolates_the_last_step_n_times() {
        let mut p = Predictor::new(Method::Linear, 2, 1.0, 1);
        for x in [0.0, 0.5, 2.0] {
            let (m, b) = unit_at(x);
            p.record(0, m, b);
        }
        let b = p.boxes();
        assert_eq!(b.len(), 2);
        assert!((b[0].0.x - 3.5).abs() < 1e-12 && (b[1].0.x - 5.0).abs() < 1e-12);
    }

    #[test]
    fn mean_averages_the_last_steps_and_scale_grows_the_box() {
        let mut p = Predictor::new(Method::Mean(2), 1, 1.5, 1);
        for x in [0.0, 0.5, 2.0] {
            let (m, b) = unit_at(x);
            p.record(0, m, b);
        }
        let b = p.boxes()[0];
        // Mean step 1.0: centre 3.5, half width 0.75.
        assert!((b.0.x - 2.75).abs() < 1e-12 && (b.1.x - 4.25).abs() < 1e-12);
    }

    #[test]
    fn matrix_carries_a_turn_on() {
        let mut p = Predictor::new(Method::Matrix, 1, 1.0, 1);
        let b0 = (DVec3::new(1.0, -0.1, -0.1), DVec3::new(2.0, 0.1, 0.1));
        let q = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
        p.record(0, DAffine3::IDENTITY, b0);
        let m1 = DAffine3::from_quat(q);
        p.record(0, m1, transform_box(&m1, b0));
        let b = p.boxes()[0];
        // Two quarter turns: the box sits on the negative x axis.
        assert!(
            (b.0.x + 2.0).abs() < 1e-9 && (b.1.x + 1.0).abs() < 1e-9,
            "{b:?}"
        );
        assert!(Predictor::new(Method::None, 3, 1.1, 1).boxes().is_empty());
        assert!("mean:0".parse::<Method>().is_err() && "mean:3".parse::<Method>().is_ok());
    }
}
