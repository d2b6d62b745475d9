//! The Bjøntegaard delta rate (G. Bjøntegaard, "Calculation of average PSNR
//! differences between RD-curves", ITU-T VCEG-M33, 2001): the average
//! difference in log-rate between two rate–distortion curves over the
//! quality range both cover, as a percentage of the reference's rate.
//! Negative: the tested codec needs fewer bits for the same quality.
//!
//! Quality here is an error relative to the diagonal, so we use
//! D = −20 log10(error) (the PSNR form), fit log10(rate) as a cubic in D by
//! least squares (exact through four points), and integrate both fits over
//! the overlapping D interval.

/// BD-rate in percent of `test` against `reference`, each a list of
/// (rate, error) points. A point whose error is no lower than that of a
/// cheaper point on its curve is dominated (no encoder would choose it) and
/// left out: a cubic through such a bend swings wildly (1e137 % was seen
/// for a smoothness curve), and at the grid's floor a surface error that
/// rises by 2 % between the two highest rates would otherwise void the
/// figure. `None` with fewer than four points left on a side, or no
/// overlap in quality.
pub fn bd_rate(reference: &[(f64, f64)], test: &[(f64, f64)]) -> Option<f64> {
    let prep = |pts: &[(f64, f64)]| -> Vec<(f64, f64)> {
        pts.iter()
            .filter(|(r, e)| r.is_finite() && *r > 0.0 && e.is_finite() && *e > 0.0)
            .map(|&(r, e)| (-20.0 * e.log10(), r.log10()))
            .collect()
    };
    let (mut a, mut b) = (prep(reference), prep(test));
    // Points of equal rate (a codec stuck at its smallest size) say nothing twice.
    for p in [&mut a, &mut b] {
        p.sort_by(|x, y| x.1.total_cmp(&y.1));
        p.dedup_by(|x, y| (x.1 - y.1).abs() < 1e-9);
    }
    for p in [&mut a, &mut b] {
        let mut best = f64::NEG_INFINITY;
        p.retain(|x| {
            let keep = x.0 > best;
            best = best.max(x.0);
            keep
        });
    }
    if a.len() < 4 || b.len() < 4 {
        return None;
    }
    let range = |p: &[(f64, f64)]| {
        (p.iter().map(|x| x.0).fold(f64::INFINITY, f64::min), p.iter().map(|x| x.0).fold(f64::NEG_INFINITY, f64::max))
    };
    let ((a0, a1), (b0, b1)) = (range(&a), range(&b));
    let (lo, hi) = (a0.max(b0), a1.min(b1));
    if hi - lo <= 1e-9 {
        return None;
    }
    let (pa, pb) = (cubic_fit(&a)?, cubic_fit(&b)?);
    let avg = (integral(&pb, lo, hi) - integral(&pa, lo, hi)) / (hi - lo);
    Some((10f64.powf(avg) - 1.0) * 100.0)
}

/// Least-squares cubic y = c0 + c1 t + c2 t² + c3 t³ with t = (x − m) / s,
/// centred and scaled for conditioning; returns (m, s, coefficients).
fn cubic_fit(pts: &[(f64, f64)]) -> Option<(f64, f64, [f64; 4])> {
    let m = pts.iter().map(|p| p.0).sum::<f64>() / pts.len() as f64;
    let s = pts.iter().map(|p| (p.0 - m).abs()).fold(0.0, f64::max).max(1e-12);
    // Normal equations (4 x 4), solved by Gaussian elimination with pivoting.
    let mut a = [[0.0f64; 5]; 4];
    for &(x, y) in pts {
        let t = (x - m) / s;
        let pw = [1.0, t, t * t, t * t * t];
        for i in 0..4 {
            for j in 0..4 {
                a[i][j] += pw[i] * pw[j];
            }
            a[i][4] += pw[i] * y;
        }
    }
    for col in 0..4 {
        let piv = (col..4).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, piv);
        for row in 0..4 {
            if row != col {
                let f = a[row][col] / a[col][col];
                for k in col..5 {
                    a[row][k] -= f * a[col][k];
                }
            }
        }
    }
    Some((m, s, [0, 1, 2, 3].map(|i| a[i][4] / a[i][i])))
}

/// ∫ of the fitted cubic over x in [lo, hi].
fn integral(fit: &(f64, f64, [f64; 4]), lo: f64, hi: f64) -> f64 {
    let (m, s, c) = fit;
    let prim = |x: f64| {
        let t = (x - m) / s;
        s * (c[0] * t + c[1] * t * t / 2.0 + c[2] * t.powi(3) / 3.0 + c[3] * t.powi(4) / 4.0)
    };
    prim(hi) - prim(lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_curve_is_zero_and_half_rate_is_minus_fifty() {
        let r: Vec<(f64, f64)> = [100.0, 200.0, 400.0, 800.0, 1600.0].iter().map(|&k| (k, 1.0 / k)).collect();
        assert!(bd_rate(&r, &r).unwrap().abs() < 1e-9);
        let half: Vec<(f64, f64)> = r.iter().map(|&(k, e)| (k / 2.0, e)).collect();
        assert!((bd_rate(&r, &half).unwrap() + 50.0).abs() < 1e-6);
        assert!(bd_rate(&r[..3], &half).is_none());
        // No overlap in quality.
        let far: Vec<(f64, f64)> = r.iter().map(|&(k, e)| (k, e * 1e-6)).collect();
        assert!(bd_rate(&r, &far).is_none());
        // A dominated point (error no lower than a cheaper one's) is left
        // out: with it the figure would swing, without it four points remain.
        let mut bent = r.clone();
        bent[2].1 = 1.0 / 150.0;
        assert!((bd_rate(&r, &bent).unwrap() - bd_rate(&r, &[r[0], r[1], r[3], r[4]]).unwrap()).abs() < 1e-9);
        bent[3].1 = 1.0 / 150.0;
        assert!(bd_rate(&r, &bent).is_none() && bd_rate(&bent, &r).is_none());
    }
}
