//! The Kalman filter's two operations on `θ = [k_e, c, ẋ_e, μ, b_e]` (fixed-size arrays,
//! no allocation): the prediction with the surface moving, and a measurement update whose
//! gain may leave some states alone (a Schmidt "consider" update, module docs).

/// Number of states.
pub const N: usize = 5;
/// Indices into θ.
pub const K: usize = 0;
pub const C: usize = 1;
pub const W: usize = 2;
pub const MU: usize = 3;
pub const B: usize = 4;

pub type Vec5 = [f64; N];
pub type Mat5 = [[f64; N]; N];

/// Prediction over `dt`: `c ← c + dt k ẋ_e` (linearised about θ for the covariance),
/// every other state a random walk with the variances `q` added per step.
pub fn predict(theta: &mut Vec5, p: &mut Mat5, dt: f64, q: &Vec5) {
    let (k, w) = (theta[K], theta[W]);
    theta[C] += dt * k * w;
    // F = I except row C: [dt w, 1, dt k, 0, 0]. P ← F P Fᵀ + diag(q).
    let mut fp = *p;
    for j in 0..N {
        fp[C][j] = p[C][j] + dt * w * p[K][j] + dt * k * p[W][j];
    }
    let mut out = fp;
    for i in 0..N {
        out[i][C] = fp[i][C] + dt * w * fp[i][K] + dt * k * fp[i][W];
    }
    for i in 0..N {
        out[i][i] += q[i];
    }
    *p = symmetric(out);
}

/// What one update did.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Update {
    /// Innovation `ν = f − hᵀθ` [N] and its variance `S = hᵀPh + r` [N²] before the update.
    pub nu: f64,
    pub s: f64,
}

/// `P h` and `S = hᵀ P h + r`, `ν = f − f̂` with `f̂` the model's prediction (`hᵀθ` for a
/// linear measurement: [`linear`]).
pub fn innovation(p: &Mat5, h: &Vec5, f: f64, f_hat: f64, r: f64) -> (Vec5, Update) {
    let mut ph = [0.0; N];
    for i in 0..N {
        for j in 0..N {
            ph[i] += p[i][j] * h[j];
        }
    }
    let mut s = r;
    for i in 0..N {
        s += h[i] * ph[i];
    }
    (ph, Update { nu: f - f_hat, s })
}

/// `hᵀ θ`.
pub fn linear(theta: &Vec5, h: &Vec5) -> f64 {
    (0..N).map(|i| h[i] * theta[i]).sum()
}

/// The measurement update with gain `K_i = (P h)_i / S` where `mask[i]`, 0 elsewhere, and
/// the covariance of that (sub-optimal where masked) gain, Joseph's form in closed form:
/// `P ← P − K (Ph)ᵀ − (Ph) Kᵀ + S K Kᵀ`.
pub fn update(theta: &mut Vec5, p: &mut Mat5, ph: &Vec5, u: Update, mask: &[bool; N]) {
    let mut g = [0.0; N];
    for i in 0..N {
        if mask[i] {
            g[i] = ph[i] / u.s;
        }
    }
    for i in 0..N {
        theta[i] += g[i] * u.nu;
    }
    let mut out = *p;
    for i in 0..N {
        for j in 0..N {
            out[i][j] += -g[i] * ph[j] - ph[i] * g[j] + u.s * g[i] * g[j];
        }
    }
    for (i, row) in out.iter_mut().enumerate() {
        row[i] = row[i].max(0.0);
    }
    *p = symmetric(out);
}

/// The estimate projected onto the constraint `θ_i = v` (an active inequality), weighted by
/// `P⁻¹`: `θ ← θ − P e_i (θ_i − v) / P_ii`, so that the states correlated with `θ_i` move
/// with it (the constrained Kalman filter's estimate projection).
pub fn project(theta: &mut Vec5, p: &Mat5, i: usize, v: f64) {
    let d = (theta[i] - v) / p[i][i];
    for (j, t) in theta.iter_mut().enumerate() {
        *t -= p[j][i] * d;
    }
    theta[i] = v;
}

/// `P ← P + σ² g gᵀ`: reopen the covariance along `g`.
pub fn reopen(p: &mut Mat5, g: &Vec5, var: f64) {
    for (row, gi) in p.iter_mut().zip(g) {
        for (pij, gj) in row.iter_mut().zip(g) {
            *pij += var * gi * gj;
        }
    }
}

fn symmetric(p: Mat5) -> Mat5 {
    let mut out = p;
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = 0.5 * (p[i][j] + p[j][i]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form Joseph update with the optimal gain equals the textbook
    /// `P − P h hᵀ P / S`, and a masked state keeps its value and its variance grows by no
    /// more than what the others' correlation carries.
    #[test]
    fn joseph_update_matches_the_textbook_and_a_masked_state_stays() {
        let mut p = [[0.0; N]; N];
        for i in 0..N {
            for j in 0..N {
                p[i][j] = if i == j { 2.0 + i as f64 } else { 0.3 / (1.0 + (i + j) as f64) };
            }
        }
        let theta = [1.0, 2.0, 3.0, 4.0, 5.0];
        let h = [0.5, -1.0, 0.0, 0.7, 0.1];
        let (ph, u) = innovation(&p, &h, 10.0, linear(&theta, &h), 0.4);
        let (mut t1, mut p1) = (theta, p);
        update(&mut t1, &mut p1, &ph, u, &[true; N]);
        for i in 0..N {
            for j in 0..N {
                let want = p[i][j] - ph[i] * ph[j] / u.s;
                assert!((p1[i][j] - want).abs() < 1e-12, "{i},{j}: {} vs {want}", p1[i][j]);
            }
        }
        let (mut t2, mut p2) = (theta, p);
        let mut mask = [true; N];
        mask[K] = false;
        update(&mut t2, &mut p2, &ph, u, &mask);
        assert_eq!(t2[K], theta[K]);
        assert_eq!(p2[K][K], p[K][K]);
        assert!(t2[C] != theta[C]);
        // and P stays positive definite: its diagonal and a 2×2 minor
        assert!(p2[C][C] > 0.0 && p2[K][K] * p2[C][C] > p2[K][C] * p2[K][C]);
    }

    /// The prediction moves c by dt·k·ẋ_e and adds the random walks.
    #[test]
    fn prediction_moves_the_surface_term() {
        let mut theta = [1000.0, 0.5, 0.01, 0.0, 0.0];
        let mut p = [[0.0; N]; N];
        p[W][W] = 1e-4;
        predict(&mut theta, &mut p, 1e-3, &[0.0, 0.0, 1e-6, 0.0, 0.0]);
        assert!((theta[C] - (0.5 + 1e-3 * 1000.0 * 0.01)).abs() < 1e-12);
        assert!((p[C][C] - (1e-3 * 1000.0) * (1e-3 * 1000.0) * 1e-4).abs() < 1e-15);
        assert!((p[W][W] - (1e-4 + 1e-6)).abs() < 1e-15);
    }
}
