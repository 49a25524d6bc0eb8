//! The small quadratic program of the statics (`docs/model.md`,
//! "Statics"): the minimum-norm tensions above a floor that close a moment
//! balance, `min |t|^2` subject to `A t = b`, `t >= floor`, solved exactly as
//! a least distance program by Lawson & Hanson's non-negative least squares;
//! `None` when no tension set above the floor exists (a slack cable).

use faer::Mat;

/// Relative tolerance of the statics' quadratic program (`docs/spatial.md`,
/// "Statics"): the balance `A t = b` to `QP_RTOL (max|A| max(|t|, |floor|) +
/// max|b|)`, the floor and the multipliers to `QP_RTOL max(|t|, |t0|,
/// |floor|)` (`t0 = A^+ b`, maximum norms).
pub const QP_RTOL: f64 = 1e-10;

/// Least distance programming: a residual `|r|` of the NNLS problem at or
/// below this (of 1) certifies that no tension set above the floor exists.
const LDP_EMPTY: f64 = 1e-10;

/// The answer of [`min_norm_active`]: the tensions and their active set.
#[derive(Clone, Debug, PartialEq)]
pub struct AboveFloor {
    /// `t (m)`: the minimum-norm tensions, each `>= floor` exactly.
    pub t: Vec<f64>,
    /// `held (m)`: the active set, the cables held at the floor by the
    /// optimum (`t_i == floor`, multiplier `mu_i >= 0`). The other (free)
    /// tensions are the minimum-norm solution of `A_F t_F = b - A_S floor`:
    /// `t_F = A_F^T (A_F A_F^T)^+ (b - A_S floor)`.
    pub held: Vec<bool>,
    /// `mu (m)`: the multipliers of the floor constraints, `t = A^T nu + mu`
    /// (`mu >= 0` on `held`, `0` on the free cables).
    pub mu: Vec<f64>,
}

/// `min |t|^2` subject to `A t = b`, `t >= floor` (`A (n, m)`, `b (n)`), or
/// `None` when no such `t` exists: [`min_norm_active`]'s tensions.
pub fn min_norm_above(a: &Mat<f64>, b: &[f64], floor: f64) -> Option<Vec<f64>> {
    min_norm_active(a, b, floor).map(|s| s.t)
}

/// The minimum-norm solution of a consistent or inconsistent `M x = rhs`
/// (`M (r, c)`) by the singular value decomposition, singular values at or
/// below `max(r, c) eps sigma_max` taken as zero: `x = M^+ rhs (c)`, `nu =
/// (M M^T)^+ rhs (r)` (so that `x = M^T nu` when `rhs` is in the range), and,
/// when `null` is asked for, an orthonormal basis `(c, c - rank)` of the
/// null space of `M`.
struct MinNorm {
    x: Vec<f64>,
    nu: Vec<f64>,
    null: Option<Mat<f64>>,
}

fn min_norm_solve(m: &Mat<f64>, rhs: &[f64], null: bool) -> Option<MinNorm> {
    let (r, c) = (m.nrows(), m.ncols());
    if r == 0 || c == 0 {
        return Some(MinNorm {
            x: vec![0.0; c],
            nu: vec![0.0; r],
            null: null.then(|| Mat::<f64>::identity(c, c)),
        });
    }
    let svd = if null { m.svd() } else { m.thin_svd() }.ok()?;
    let (u, v) = (svd.U(), svd.V());
    let s = svd.S().column_vector();
    let k = r.min(c);
    let cut = (r.max(c) as f64) * f64::EPSILON * s[0];
    let rank = (0..k).filter(|&i| s[i] > cut).count(); // nonincreasing
    let mut x = vec![0.0; c];
    let mut nu = vec![0.0; r];
    for i in 0..rank {
        let ub = (0..r).map(|j| u[(j, i)] * rhs[j]).sum::<f64>();
        for (j, xj) in x.iter_mut().enumerate() {
            *xj += v[(j, i)] * ub / s[i];
        }
        for (j, nj) in nu.iter_mut().enumerate() {
            *nj += u[(j, i)] * ub / (s[i] * s[i]);
        }
    }
    let null = null.then(|| Mat::<f64>::from_fn(c, c - rank, |j, i| v[(j, rank + i)]));
    Some(MinNorm { x, nu, null })
}

/// Non-negative least squares, `min |E u - f|` subject to `u >= 0`, by the
/// active-set algorithm of Lawson & Hanson (Solving Least Squares Problems,
/// 1974, ch. 23, Algorithm NNLS): add the index of the largest positive
/// gradient `w = E^T (f - E u)` to the passive set `P`, solve the
/// unconstrained least squares on `P`; while that leaves a passive
/// component `<= 0`, step from `u` towards it only as far as feasibility
/// allows (the step-length test `alpha = min u_i / (u_i - z_i)`) and drop
/// the components that reach zero. Finite in exact arithmetic; an index
/// whose own coefficient comes out `<= 0` on entering (round-off) is
/// skipped until the next step.
fn nnls(e: &Mat<f64>, f: &[f64]) -> Option<Vec<f64>> {
    let (p, m) = (e.nrows(), e.ncols());
    let norm1 = (0..m)
        .map(|j| (0..p).map(|i| e[(i, j)].abs()).sum::<f64>())
        .fold(0.0f64, f64::max);
    let fnorm = f.iter().fold(0.0f64, |x, v| x.max(v.abs()));
    let tol = 10.0 * f64::EPSILON * (p.max(m) as f64) * norm1 * fnorm.max(1e-300);
    let mut u = vec![0.0; m];
    let mut passive = vec![false; m];
    let mut skip = vec![false; m];
    let gradient = |u: &[f64]| -> Vec<f64> {
        let res: Vec<f64> = (0..p)
            .map(|i| f[i] - (0..m).map(|j| e[(i, j)] * u[j]).sum::<f64>())
            .collect();
        (0..m)
            .map(|j| (0..p).map(|i| e[(i, j)] * res[i]).sum::<f64>())
            .collect()
    };
    // the least squares on the passive columns, zero elsewhere
    let solve = |passive: &[bool]| -> Option<Vec<f64>> {
        let cols: Vec<usize> = (0..m).filter(|&j| passive[j]).collect();
        let ep = Mat::<f64>::from_fn(p, cols.len(), |i, k| e[(i, cols[k])]);
        let zp = min_norm_solve(&ep, f, false)?.x;
        let mut z = vec![0.0; m];
        for (k, &j) in cols.iter().enumerate() {
            z[j] = zp[k];
        }
        Some(z)
    };
    let mut w = gradient(&u);
    for _ in 0..(3 * m + 10) {
        let Some(j) = (0..m)
            .filter(|&j| !passive[j] && !skip[j] && w[j] > tol)
            .max_by(|&x, &y| w[x].total_cmp(&w[y]))
        else {
            break;
        };
        passive[j] = true;
        let mut z = solve(&passive)?;
        if z[j] <= 0.0 {
            // round-off: the column adds nothing; try the next one
            passive[j] = false;
            skip[j] = true;
            continue;
        }
        for _ in 0..(3 * m + 10) {
            if (0..m).all(|i| !passive[i] || z[i] > 0.0) {
                break;
            }
            // step towards z as far as u stays >= 0
            let (mut alpha, mut stop) = (1.0f64, usize::MAX);
            for i in (0..m).filter(|&i| passive[i] && z[i] <= 0.0) {
                let a = if u[i] > 0.0 {
                    u[i] / (u[i] - z[i])
                } else {
                    0.0
                };
                if a < alpha || stop == usize::MAX {
                    (alpha, stop) = (a, i);
                }
            }
            for i in 0..m {
                u[i] += alpha * (z[i] - u[i]);
                if passive[i] && (i == stop || u[i] <= 0.0) {
                    passive[i] = false;
                    u[i] = 0.0;
                }
            }
            z = solve(&passive)?;
        }
        for i in 0..m {
            u[i] = if passive[i] { z[i].max(0.0) } else { 0.0 };
        }
        skip.fill(false);
        w = gradient(&u);
    }
    Some(u)
}

/// `min |t|^2` subject to `A t = b`, `t >= floor` (`A (n, m)`, `b (n)`):
/// the tensions, their active set and multipliers, or `None` when no `t >=
/// floor` balances (`docs/spatial.md`, "Statics").
///
/// Method: every solution is `t = t0 + Z y` with `t0 = A^+ b` (minimum
/// norm, orthogonal to the null space) and `Z (m, k)` an orthonormal basis
/// of the null space of `A`, so `|t|^2 = |t0|^2 + |y|^2`: the problem is the
/// least distance program `min |y|` subject to `Z y >= h`, `h = floor' - t0`
/// (`floor' = floor - QP_RTOL max(|t0|, |floor|) / 2`, so that a floor met
/// exactly stays feasible through round-off), solved exactly by Lawson & Hanson's Algorithm LDP (ch. 23): with `h`
/// scaled by `s = max|h|`, the NNLS problem `min |E u - e_(k+1)|`, `u >= 0`,
/// `E = [Z^T; h^T / s] (k + 1, m)`; residual `r = E u - e_(k+1)`. `|r| <=
/// 1e-10`: no `y` exists (`u` is a Farkas certificate: `u >= 0`, `A^T`-range,
/// `h . u > 0`); else `y = -s r_(1..k) / r_(k+1)` and the multipliers are `mu =
/// s u / |r|^2`. The answer is then re-solved on its active set `S = {u_i >
/// 0}` (`t_S = floor`, `t_F = A_F^+ (b - A_S floor)`, `mu_S = floor - A_S^T
/// nu`), kept when it satisfies the Karush–Kuhn–Tucker conditions to
/// [`QP_RTOL`]. `None` as well when `b` is not in the range of `A` or the
/// answer misses the balance or the floor by more than [`QP_RTOL`] of the
/// problem's scale; tensions within it below the floor are set to it.
pub fn min_norm_active(a: &Mat<f64>, b: &[f64], floor: f64) -> Option<AboveFloor> {
    let (n, m) = (a.nrows(), a.ncols());
    assert_eq!(b.len(), n, "min_norm_active: b has {} rows, A {n}", b.len());
    if !floor.is_finite() || b.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let amax = (0..n)
        .flat_map(|r| (0..m).map(move |c| (r, c)))
        .fold(0.0f64, |x, (r, c)| x.max(a[(r, c)].abs()));
    if !amax.is_finite() {
        return None;
    }
    let bmax = b.iter().fold(0.0f64, |x, v| x.max(v.abs()));
    let inf = |v: &[f64]| v.iter().fold(0.0f64, |x, y| x.max(y.abs()));
    // the balance and the floor, to QP_RTOL of the problem's scale
    let balanced = |t: &[f64]| {
        let size = inf(t).max(floor.abs());
        let tol = QP_RTOL * (amax * size + bmax) + 1e-300;
        (0..n).all(|r| ((0..m).map(|c| a[(r, c)] * t[c]).sum::<f64>() - b[r]).abs() <= tol)
    };
    let base = min_norm_solve(a, b, true)?;
    let (t0, z) = (base.x, base.null.unwrap_or_else(|| Mat::zeros(m, 0)));
    // the data's scale of the tensions
    let size0 = inf(&t0).max(floor.abs());
    let above = |t: &[f64], mu: &[f64]| {
        let tol = QP_RTOL * inf(t).max(size0);
        t.iter().all(|&v| v >= floor - tol) && mu.iter().all(|&v| v >= -tol)
    };
    let finish = |mut t: Vec<f64>, held: Vec<bool>, mut mu: Vec<f64>| {
        for i in 0..m {
            if held[i] {
                t[i] = floor;
                mu[i] = mu[i].max(0.0);
            } else {
                t[i] = t[i].max(floor);
                mu[i] = 0.0;
            }
        }
        AboveFloor { t, held, mu }
    };

    if !balanced(&t0) {
        return None; // b is not in the range of A
    }
    // the floor relaxed by half the tolerance: a floor met exactly (to
    // round-off) stays feasible; the answer is re-solved at the floor itself
    let relaxed = floor - 0.5 * QP_RTOL * size0;
    let h: Vec<f64> = t0.iter().map(|v| relaxed - v).collect();
    let s = inf(&h);
    if h.iter().all(|&v| v <= 0.0) {
        // the unconstrained minimum-norm solution is already above the floor
        return Some(finish(t0, vec![false; m], vec![0.0; m]));
    }
    // Algorithm LDP: min |y| subject to Z y >= h
    let k = z.ncols();
    let e = Mat::<f64>::from_fn(k + 1, m, |i, j| if i < k { z[(j, i)] } else { h[j] / s });
    let mut f = vec![0.0; k + 1];
    f[k] = 1.0;
    let u = nnls(&e, &f)?;
    let r: Vec<f64> = (0..=k)
        .map(|i| (0..m).map(|j| e[(i, j)] * u[j]).sum::<f64>() - f[i])
        .collect();
    let rho = r.iter().map(|v| v * v).sum::<f64>();
    if rho.sqrt() <= LDP_EMPTY || r[k] >= 0.0 {
        return None; // Z y >= h has no solution
    }
    let y: Vec<f64> = r[..k].iter().map(|v| -s * v / r[k]).collect();
    let t_ldp: Vec<f64> = (0..m)
        .map(|i| t0[i] + (0..k).map(|c| z[(i, c)] * y[c]).sum::<f64>())
        .collect();
    let held: Vec<bool> = u.iter().map(|&v| v > 0.0).collect();
    let mu_ldp: Vec<f64> = u.iter().map(|&v| s * v / rho).collect();

    // the same optimum re-solved on its active set
    let free: Vec<usize> = (0..m).filter(|&i| !held[i]).collect();
    let rhs: Vec<f64> = (0..n)
        .map(|r| {
            b[r] - (0..m)
                .filter(|&i| held[i])
                .map(|i| a[(r, i)] * floor)
                .sum::<f64>()
        })
        .collect();
    let af = Mat::<f64>::from_fn(n, free.len(), |r, c| a[(r, free[c])]);
    if let Some(sol) = min_norm_solve(&af, &rhs, false) {
        let mut t = vec![floor; m];
        let mut mu = vec![0.0; m];
        for (c, &i) in free.iter().enumerate() {
            t[i] = sol.x[c];
        }
        for i in (0..m).filter(|&i| held[i]) {
            mu[i] = floor - (0..n).map(|r| a[(r, i)] * sol.nu[r]).sum::<f64>();
        }
        if balanced(&t) && above(&t, &mu) {
            return Some(finish(t, held, mu));
        }
    }
    (balanced(&t_ldp) && above(&t_ldp, &mu_ldp)).then(|| finish(t_ldp, held, mu_ldp))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat(rows: &[&[f64]]) -> Mat<f64> {
        Mat::from_fn(rows.len(), rows[0].len(), |r, c| rows[r][c])
    }

    fn close(x: &[f64], y: &[f64], tol: f64) -> bool {
        x.len() == y.len() && x.iter().zip(y).all(|(a, b)| (a - b).abs() <= tol)
    }

    /// The Karush–Kuhn–Tucker conditions of `min |t|^2, A t = b, t >= floor`
    /// at `s`: balance, floor, `t - mu` in the range of `A^T`, `mu >= 0`,
    /// complementarity; all to `1e-10` of the scale.
    fn assert_kkt(a: &Mat<f64>, b: &[f64], floor: f64, s: &AboveFloor) {
        let (n, m) = (a.nrows(), a.ncols());
        let scale = s.t.iter().fold(floor.abs().max(1.0), |x, v| x.max(v.abs()));
        for r in 0..n {
            let lhs = (0..m).map(|c| a[(r, c)] * s.t[c]).sum::<f64>();
            assert!(
                (lhs - b[r]).abs() <= 1e-10 * scale,
                "balance {r}: {lhs} vs {}",
                b[r]
            );
        }
        for i in 0..m {
            assert!(s.t[i] >= floor, "t[{i}] = {} below {floor}", s.t[i]);
            assert!(s.mu[i] >= 0.0);
            if s.held[i] {
                assert_eq!(s.t[i], floor);
            } else {
                assert_eq!(s.mu[i], 0.0);
            }
        }
        // t - mu = A^T nu: orthogonal to the null space of A
        let g = t_minus_mu_off_range(a, s);
        assert!(g <= 1e-10 * scale, "stationarity off by {g}");
    }

    fn t_minus_mu_off_range(a: &Mat<f64>, s: &AboveFloor) -> f64 {
        let m = a.ncols();
        let d: Vec<f64> = (0..m).map(|i| s.t[i] - s.mu[i]).collect();
        let null = min_norm_solve(a, &vec![0.0; a.nrows()], true)
            .unwrap()
            .null
            .unwrap();
        (0..null.ncols())
            .map(|c| (0..m).map(|i| null[(i, c)] * d[i]).sum::<f64>().abs())
            .fold(0.0, f64::max)
    }

    /// The optimum by enumerating every active set (as the NumPy reference):
    /// the least-norm candidate that balances and stays above the floor.
    fn enumerated(a: &Mat<f64>, b: &[f64], floor: f64) -> Option<Vec<f64>> {
        let (n, m) = (a.nrows(), a.ncols());
        let mut best: Option<(f64, Vec<f64>)> = None;
        for mask in 0u32..(1 << m) {
            let held = |i: usize| mask & (1 << i) != 0;
            let free: Vec<usize> = (0..m).filter(|&i| !held(i)).collect();
            let rhs = Mat::<f64>::from_fn(n, 1, |r, _| {
                b[r] - (0..m)
                    .filter(|&i| held(i))
                    .map(|i| a[(r, i)] * floor)
                    .sum::<f64>()
            });
            let mut t = vec![floor; m];
            if !free.is_empty() {
                let af = Mat::<f64>::from_fn(n, free.len(), |r, c| a[(r, free[c])]);
                let tf = af.thin_svd().unwrap().pseudoinverse() * &rhs;
                for (c, &i) in free.iter().enumerate() {
                    t[i] = tf[(c, 0)];
                }
            }
            let size = t.iter().fold(floor.abs(), |x, v| x.max(v.abs()));
            let ok = (0..n).all(|r| {
                ((0..m).map(|c| a[(r, c)] * t[c]).sum::<f64>() - b[r]).abs() <= 1e-11 * (1.0 + size)
            }) && t.iter().all(|&v| v >= floor - 1e-12 * size.max(1e-300));
            let norm = t.iter().map(|v| v * v).sum::<f64>();
            if ok && best.as_ref().is_none_or(|(bn, _)| norm < *bn) {
                best = Some((norm, t));
            }
        }
        best.map(|(_, t)| t)
    }

    /// splitmix64, uniform in [-1, 1)
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    #[test]
    fn releases_a_held_cable_where_the_old_active_set_gave_up() {
        // one equation, three cables, floor 1: t0 = A^T b / 9 is below the
        // floor everywhere; holding the most negative ones in turn leaves no
        // free cable to close the balance, yet t = (3, 1, 1) does
        let a = mat(&[&[1.0, -2.0, -2.0]]);
        let s = min_norm_active(&a, &[-1.0], 1.0).expect("feasible");
        assert!(close(&s.t, &[3.0, 1.0, 1.0], 1e-12), "{:?}", s.t);
        assert_eq!(s.held, [false, true, true]);
        assert_kkt(&a, &[-1.0], 1.0, &s);
        // two equations, floor 0: t = (0.5, 2, 0)
        let a = mat(&[&[0.0, 1.0, -2.0], &[-2.0, 1.0, 2.0]]);
        let s = min_norm_active(&a, &[2.0, 1.0], 0.0).expect("feasible");
        assert!(close(&s.t, &[0.5, 2.0, 0.0], 1e-12), "{:?}", s.t);
        assert_eq!(s.held, [false, false, true]);
        assert_kkt(&a, &[2.0, 1.0], 0.0, &s);
        assert_eq!(min_norm_above(&a, &[2.0, 1.0], 0.0), Some(s.t));
    }

    #[test]
    fn no_tensions_above_the_floor_is_none() {
        let a = mat(&[&[1.0, 1.0]]);
        assert_eq!(min_norm_above(&a, &[-1.0], 0.0), None); // needs a push
        assert_eq!(min_norm_above(&a, &[1.0], 0.6), None); // 0.6 + 0.6 > 1
        let s = min_norm_active(&a, &[1.0], 0.5).expect("just feasible");
        assert_eq!(s.t, [0.5, 0.5]);
        // b out of the range of A
        let a = mat(&[&[1.0, 1.0], &[1.0, 1.0]]);
        assert_eq!(min_norm_above(&a, &[1.0, 2.0], 0.0), None);
        // more equations than cables: consistent or not
        let a = mat(&[&[1.0, 0.0], &[0.0, 1.0], &[1.0, 1.0]]);
        let t = min_norm_above(&a, &[1.0, 2.0, 3.0], 0.0).expect("consistent");
        assert!(close(&t, &[1.0, 2.0], 1e-12));
        assert_eq!(min_norm_above(&a, &[1.0, 2.0, 4.0], 0.0), None);
        assert_eq!(min_norm_above(&a, &[1.0, 2.0, 3.0], 1.5), None);
    }

    #[test]
    fn the_unconstrained_minimum_norm_above_the_floor_is_the_answer() {
        let a = mat(&[&[1.0, 1.0, 0.0], &[0.0, 1.0, 1.0]]);
        let b = [3.0, 3.0];
        // A^+ b = (1, 2, 1)
        let s = min_norm_active(&a, &b, 0.5).unwrap();
        assert!(close(&s.t, &[1.0, 2.0, 1.0], 1e-12), "{:?}", s.t);
        assert_eq!(s.held, [false; 3]);
        assert_eq!(s.mu, [0.0; 3]);
        assert_kkt(&a, &b, 0.5, &s);
    }

    #[test]
    fn random_problems_equal_the_enumerated_optimum_and_a_lower_floor_keeps_them_feasible() {
        let mut rng = Rng(7);
        let floors = [0.0, 0.3, 1.0];
        let (mut feasible, mut slack) = (0, 0);
        for trial in 0..160 {
            let n = 1 + trial % 4;
            let m = n + 1 + (trial / 4) % 4;
            let a = Mat::<f64>::from_fn(n, m, |_, _| rng.next());
            let b: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let mut higher_feasible = false;
            for &floor in floors.iter().rev() {
                let got = min_norm_active(&a, &b, floor);
                let want = enumerated(&a, &b, floor);
                assert_eq!(
                    got.is_some(),
                    want.is_some(),
                    "verdict, trial {trial}, floor {floor}"
                );
                // feasible at a higher floor: feasible at every lower one
                assert!(
                    !higher_feasible || got.is_some(),
                    "trial {trial}, floor {floor}"
                );
                higher_feasible = got.is_some();
                if let (Some(s), Some(t)) = (got, want) {
                    let size = t.iter().fold(1.0f64, |x, v| x.max(v.abs()));
                    assert!(
                        close(&s.t, &t, 1e-9 * size),
                        "trial {trial}: {:?} vs {t:?}",
                        s.t
                    );
                    assert_kkt(&a, &b, floor, &s);
                    // the free tensions from the active set alone
                    let free: Vec<usize> = (0..m).filter(|&i| !s.held[i]).collect();
                    let rhs: Vec<f64> = (0..n)
                        .map(|r| {
                            b[r] - (0..m)
                                .filter(|&i| s.held[i])
                                .map(|i| a[(r, i)] * floor)
                                .sum::<f64>()
                        })
                        .collect();
                    let af = Mat::<f64>::from_fn(n, free.len(), |r, c| a[(r, free[c])]);
                    let tf = min_norm_solve(&af, &rhs, false).unwrap().x;
                    for (c, &i) in free.iter().enumerate() {
                        assert!((tf[c].max(floor) - s.t[i]).abs() <= 1e-12 * size);
                    }
                    // the same problem in other units
                    let a2 = Mat::<f64>::from_fn(n, m, |r, c| a[(r, c)] * 1e-4);
                    let b2: Vec<f64> = b.iter().map(|v| v * 1e-4).collect();
                    let s2 = min_norm_active(&a2, &b2, floor).expect("scaled");
                    assert!(close(&s2.t, &s.t, 1e-9 * size));
                    feasible += 1;
                } else {
                    slack += 1;
                }
            }
        }
        assert!(
            feasible > 200 && slack > 200,
            "{feasible} feasible, {slack} slack"
        );
    }
}
