//! One-sided spatial derivatives of a grid function: first-order upwind, ENO2 and WENO5.
//!
//! Each scheme turns seven consecutive samples `s[0..7] = phi_{i-3} .. phi_{i+3}` along one axis
//! into the left and right derivatives `(D-phi_i, D+phi_i)`. The formulas are those of Osher &
//! Fedkiw, *Level Set Methods and Dynamic Implicit Surfaces* (2003), ch. 3.3-3.4, which are also
//! what ToolboxLS (`upwindFirstFirst`, `upwindFirstENO2`, `upwindFirstWENO5`) and
//! hj_reachability implement. They are written branch-free over whole rows so that the
//! compiler vectorises them.

use serde::{Deserialize, Serialize};

/// The spatial discretisation of the gradient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Spatial {
    /// First-order one-sided differences.
    Upwind1,
    /// Second-order essentially non-oscillatory.
    Eno2,
    /// Fifth-order weighted ENO (Jiang & Peng 2000).
    Weno5,
}

impl Spatial {
    /// The order of accuracy on smooth functions.
    pub fn order(self) -> u32 {
        match self {
            Spatial::Upwind1 => 1,
            Spatial::Eno2 => 2,
            Spatial::Weno5 => 5,
        }
    }
}

/// Computes `dm[j] = D-phi` and `dp[j] = D+phi` at every `j` of a row, where `rows[o][j]` is
/// `phi` at offset `o - 3` along the axis from node `j`.
#[inline(always)]
pub fn derivatives_row(
    scheme: Spatial,
    rows: &[&[f32]; 7],
    inv_dx: f32,
    dm: &mut [f32],
    dp: &mut [f32],
) {
    let n = dm.len();
    let [r0, r1, r2, r3, r4, r5, r6] = rows.map(|r| &r[..n]);
    let dp = &mut dp[..n];
    match scheme {
        Spatial::Upwind1 => {
            for j in 0..n {
                dm[j] = (r3[j] - r2[j]) * inv_dx;
                dp[j] = (r4[j] - r3[j]) * inv_dx;
            }
        }
        Spatial::Eno2 => {
            // D-phi_i = (phi_i - phi_{i-1})/dx + dx * c, with c the second divided difference
            // (phi_{k+1} - 2 phi_k + phi_{k-1}) / (2 dx^2) of smaller magnitude among k = i-1, i;
            // D+phi_i mirrors it with k = i, i+1.
            let half = 0.5 * inv_dx;
            for j in 0..n {
                let c_left = (r3[j] - 2.0 * r2[j] + r1[j]) * half;
                let c_mid = (r4[j] - 2.0 * r3[j] + r2[j]) * half;
                let c_right = (r5[j] - 2.0 * r4[j] + r3[j]) * half;
                let m_left = if c_left.abs() < c_mid.abs() {
                    c_left
                } else {
                    c_mid
                };
                let m_right = if c_right.abs() < c_mid.abs() {
                    c_right
                } else {
                    c_mid
                };
                dm[j] = (r3[j] - r2[j]) * inv_dx + m_left;
                dp[j] = (r4[j] - r3[j]) * inv_dx - m_right;
            }
        }
        Spatial::Weno5 => {
            for j in 0..n {
                let d0 = (r1[j] - r0[j]) * inv_dx;
                let d1 = (r2[j] - r1[j]) * inv_dx;
                let d2 = (r3[j] - r2[j]) * inv_dx;
                let d3 = (r4[j] - r3[j]) * inv_dx;
                let d4 = (r5[j] - r4[j]) * inv_dx;
                let d5 = (r6[j] - r5[j]) * inv_dx;
                dm[j] = weno5(d0, d1, d2, d3, d4);
                dp[j] = weno5(d5, d4, d3, d2, d1);
            }
        }
    }
}

/// The WENO5 combination of the five first differences `v1..v5` (Osher & Fedkiw eq. 3.28-3.39):
/// three third-order candidates, weighted by their smoothness, so that the result is fifth-order
/// where the function is smooth and falls back to the smoothest candidate at kinks.
#[inline(always)]
fn weno5(v1: f32, v2: f32, v3: f32, v4: f32, v5: f32) -> f32 {
    let phi1 = v1 * (1.0 / 3.0) - v2 * (7.0 / 6.0) + v3 * (11.0 / 6.0);
    let phi2 = -v2 * (1.0 / 6.0) + v3 * (5.0 / 6.0) + v4 * (1.0 / 3.0);
    let phi3 = v3 * (1.0 / 3.0) + v4 * (5.0 / 6.0) - v5 * (1.0 / 6.0);
    let (q23, q13, q12) = weight_products(v1, v2, v3, v4, v5);
    let (a1, a2, a3) = (0.1 * q23, 0.6 * q13, 0.3 * q12);
    (a1 * phi1 + a2 * phi2 + a3 * phi3) / (a1 + a2 + a3)
}

/// The smoothness indicators `s_k` of the three stencils (Jiang & Shu), turned into the
/// products `(q2 q3, q1 q3, q1 q2)` with `q_k = (s_k + eps)^2`, so that the normalised weights
/// `a_k = c_k / q_k` take a single division: `a_1 : a_2 : a_3 = c_1 q2 q3 : c_2 q1 q3 : c_3 q1 q2`.
/// `eps` is Jiang & Shu's constant 1e-6 (also hj_reachability's `WENO_EPS`); Osher & Fedkiw
/// scale it by the largest squared difference, which costs more and changes little.
#[inline(always)]
fn weight_products(v1: f32, v2: f32, v3: f32, v4: f32, v5: f32) -> (f32, f32, f32) {
    let a = v1 - 2.0 * v2 + v3;
    let b = v1 - 4.0 * v2 + 3.0 * v3;
    let s1 = (13.0 / 12.0) * a * a + 0.25 * b * b;
    let a = v2 - 2.0 * v3 + v4;
    let b = v2 - v4;
    let s2 = (13.0 / 12.0) * a * a + 0.25 * b * b;
    let a = v3 - 2.0 * v4 + v5;
    let b = 3.0 * v3 - 4.0 * v4 + v5;
    let s3 = (13.0 / 12.0) * a * a + 0.25 * b * b;
    let eps = 1e-6f32;
    let q1 = (s1 + eps) * (s1 + eps);
    let q2 = (s2 + eps) * (s2 + eps);
    let q3 = (s3 + eps) * (s3 + eps);
    (q2 * q3, q1 * q3, q1 * q2)
}

/// `weno5` of a window of five differences to the left (`v1..v5`) and to the right (the same
/// window reversed). The right derivative at node `i` and the left one at node `i + 1` use the
/// same five differences, and reversing a window maps its smoothness indicators onto each
/// other (`S1 <-> S3`, `S2` fixed), so both come from one set of indicators.
#[inline(always)]
fn weno5_pair(v1: f32, v2: f32, v3: f32, v4: f32, v5: f32) -> (f32, f32) {
    let (q23, q13, q12) = weight_products(v1, v2, v3, v4, v5);
    // Left: candidates on (v1, v2, v3), (v2, v3, v4), (v3, v4, v5); weights 0.1, 0.6, 0.3.
    let l1 = v1 * (1.0 / 3.0) - v2 * (7.0 / 6.0) + v3 * (11.0 / 6.0);
    let l2 = -v2 * (1.0 / 6.0) + v3 * (5.0 / 6.0) + v4 * (1.0 / 3.0);
    let l3 = v3 * (1.0 / 3.0) + v4 * (5.0 / 6.0) - v5 * (1.0 / 6.0);
    let (a1, a2, a3) = (0.1 * q23, 0.6 * q13, 0.3 * q12);
    let left = (a1 * l1 + a2 * l2 + a3 * l3) / (a1 + a2 + a3);
    // Right: the window reversed, so its first stencil is (v5, v4, v3) with indicator s3.
    let r1 = v5 * (1.0 / 3.0) - v4 * (7.0 / 6.0) + v3 * (11.0 / 6.0);
    let r2 = -v4 * (1.0 / 6.0) + v3 * (5.0 / 6.0) + v2 * (1.0 / 3.0);
    let r3 = v3 * (1.0 / 3.0) + v2 * (5.0 / 6.0) - v1 * (1.0 / 6.0);
    let (b1, b2, b3) = (0.1 * q12, 0.6 * q13, 0.3 * q23);
    let right = (b1 * r1 + b2 * r2 + b3 * r3) / (b1 + b2 + b3);
    (left, right)
}

/// Like [`derivatives_row`] for samples laid out along one strided line: node `j`'s
/// neighbour at offset `o` (from -3 to 3) is `p[j + (o + 3) * stride]`, `p` holding
/// `dm.len() + 6 * stride` samples. With WENO5 each window of differences is evaluated once
/// for both the left derivative at one node and the right derivative at the node before it.
#[inline(always)]
pub fn derivatives_strided(
    scheme: Spatial,
    p: &[f32],
    stride: usize,
    inv_dx: f32,
    dm: &mut [f32],
    dp: &mut [f32],
) {
    let span = dm.len();
    if scheme != Spatial::Weno5 || span < stride {
        let rows: [&[f32]; 7] = core::array::from_fn(|o| &p[o * stride..][..span]);
        derivatives_row(scheme, &rows, inv_dx, dm, dp);
        return;
    }
    let n = span + stride;
    let window = |r: &[&[f32]; 6], q: usize| {
        weno5_pair(
            (r[1][q] - r[0][q]) * inv_dx,
            (r[2][q] - r[1][q]) * inv_dx,
            (r[3][q] - r[2][q]) * inv_dx,
            (r[4][q] - r[3][q]) * inv_dx,
            (r[5][q] - r[4][q]) * inv_dx,
        )
    };
    let all: [&[f32]; 6] = core::array::from_fn(|o| &p[o * stride..][..n]);
    // Window q gives D- at node q and D+ at node q - stride.
    for q in 0..stride {
        dm[q] = window(&all, q).0;
    }
    for q in span..n {
        dp[q - stride] = window(&all, q).1;
    }
    // The bulk, with every slice cut to the same length so that the loop vectorises.
    let m = span - stride;
    let [r0, r1, r2, r3, r4, r5] = core::array::from_fn(|o| &p[o * stride + stride..][..m]);
    let dm_mid = &mut dm[stride..span];
    let dp_mid = &mut dp[..m];
    for i in 0..m {
        let (l, r) = weno5_pair(
            (r1[i] - r0[i]) * inv_dx,
            (r2[i] - r1[i]) * inv_dx,
            (r3[i] - r2[i]) * inv_dx,
            (r4[i] - r3[i]) * inv_dx,
            (r5[i] - r4[i]) * inv_dx,
        );
        dm_mid[i] = l;
        dp_mid[i] = r;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strided_weno_matches_the_row_form() {
        for stride in [1usize, 3] {
            let span = 20;
            let p: Vec<f32> = (0..span + 6 * stride)
                .map(|i| {
                    ((i as f32) * 0.37).sin() + ((i * i) as f32 * 0.01).cos() + (i % 5) as f32 * 0.2
                })
                .collect();
            let (mut dm, mut dp) = (vec![0f32; span], vec![0f32; span]);
            derivatives_strided(Spatial::Weno5, &p, stride, 2.0, &mut dm, &mut dp);
            let rows: [&[f32]; 7] = core::array::from_fn(|o| &p[o * stride..][..span]);
            let (mut em, mut ep) = (vec![0f32; span], vec![0f32; span]);
            derivatives_row(Spatial::Weno5, &rows, 2.0, &mut em, &mut ep);
            for j in 0..span {
                assert!(
                    (dm[j] - em[j]).abs() <= 1e-4 * (1.0 + em[j].abs()),
                    "D- at {j}"
                );
                assert!(
                    (dp[j] - ep[j]).abs() <= 1e-4 * (1.0 + ep[j].abs()),
                    "D+ at {j}"
                );
            }
        }
    }

    /// Observed order of the left derivative of sin on refining grids.
    fn observed_order(scheme: Spatial) -> f64 {
        let errors: Vec<f64> = [0.4f64, 0.2]
            .iter()
            .map(|&h| {
                let x0 = 0.3;
                let s: Vec<f32> = (0..7)
                    .map(|o| (x0 + (o as f64 - 3.0) * h).sin() as f32)
                    .collect();
                let rows: [&[f32]; 7] = core::array::from_fn(|o| &s[o..o + 1]);
                let (mut dm, mut dp) = ([0f32], [0f32]);
                derivatives_row(scheme, &rows, (1.0 / h) as f32, &mut dm, &mut dp);
                let exact = x0.cos();
                (f64::from(dm[0]) - exact)
                    .abs()
                    .max((f64::from(dp[0]) - exact).abs())
            })
            .collect();
        (errors[0] / errors[1]).log2()
    }

    #[test]
    fn orders_of_accuracy_on_a_smooth_function() {
        // (Spacings 0.4 and 0.2: coarse enough that f32 rounding does not blur WENO5's error.)
        assert!((observed_order(Spatial::Upwind1) - 1.0).abs() < 0.3);
        assert!((observed_order(Spatial::Eno2) - 2.0).abs() < 0.3);
        assert!(observed_order(Spatial::Weno5) > 4.0);
    }

    #[test]
    fn all_schemes_are_exact_on_linear_functions_and_pick_sides_at_kinks() {
        for scheme in [Spatial::Upwind1, Spatial::Eno2, Spatial::Weno5] {
            let lin: Vec<f32> = (0..7).map(|o| 2.0 * o as f32 - 1.0).collect();
            let rows: [&[f32]; 7] = core::array::from_fn(|o| &lin[o..o + 1]);
            let (mut dm, mut dp) = ([0f32], [0f32]);
            derivatives_row(scheme, &rows, 1.0, &mut dm, &mut dp);
            assert!((dm[0] - 2.0).abs() < 1e-4 && (dp[0] - 2.0).abs() < 1e-4);
            // |x| with the kink at the centre node: left slope -1, right slope +1.
            let abs: Vec<f32> = (0..7).map(|o| (o as f32 - 3.0).abs()).collect();
            let rows: [&[f32]; 7] = core::array::from_fn(|o| &abs[o..o + 1]);
            derivatives_row(scheme, &rows, 1.0, &mut dm, &mut dp);
            assert!((dm[0] + 1.0).abs() < 0.05, "{scheme:?} D- = {}", dm[0]);
            assert!((dp[0] - 1.0).abs() < 0.05, "{scheme:?} D+ = {}", dp[0]);
        }
    }
}
