//! 3D vectors and rotations, in the numbers layer beside [`crate::geom`]:
//! `Exp`, `Log`, the inverse right Jacobian and the local
//! (right-trivialized) derivatives of the two kinds of term the 3D body is
//! made of (docs/model3d.md sections 3 and 4), for the body, its scenes and
//! its pictures alike.
//!
//! A rotation `R` is perturbed on the right, `R Exp(delta)`, with `delta` a
//! rotation vector in the body's own frame (rad). Every function of rotations
//! is differentiated in these local coordinates at `delta = 0`:
//!
//! * a *linear term* `f = w . (R Exp(delta) a)` (a position or a height):
//!
//! ```text
//! df/ddelta   = a x (R^T w)
//! d2f/ddelta2 = (w' a^T + a w'^T) / 2 - (w' . a) I,        w' = R^T w
//! ```
//!
//! * a *relative term* `F(theta)`, `theta = Log(R_a^T R_b)` (a joint's
//!   energy, a weld's rotation rows). With `M = R_a^T R_b`, `P = Jr^-1(theta)`,
//!   `w = dF/dtheta` and `H_theta = d2F/dtheta2`:
//!
//! ```text
//! Jr^-1(theta) = I + [theta]/2 + c(t) [theta]^2,    t = |theta|,
//! c(t)         = 1/t^2 - (1 + cos t) / (2 t sin t)   (= 1/12 + t^2/720 + ...)
//! g   = P^T w                                            (gradient in eps, M Exp(eps))
//! H_e = P^T H_theta P + sym(D P),     D = d(P(theta)^T w)/dtheta  (w held fixed)
//! dF/ddelta_b = g,     dF/ddelta_a = -M g
//! H_bb = H_e,  H_aa = M H_e M^T,  H_ab = -M H_e + M [g]/2,  H_ba = H_ab^T
//! ```
//!
//! The last lines follow from `Exp(-delta_a) M Exp(delta_b) = M Exp(eps)`,
//! `eps = -M^T delta_a + delta_b - (M^T delta_a) x delta_b / 2 + O(3)`
//! (Baker-Campbell-Hausdorff), and `sym(D P)` is the second derivative of
//! `Log(Exp(theta) Exp(eps))` contracted with `w` (its antisymmetric part
//! cancels). The tests check every formula against finite differences.

/// A 3-vector.
pub type Vec3 = [f64; 3];
/// A 3 x 3 matrix, row-major (`m[row][column]`).
pub type Mat3 = [[f64; 3]; 3];

/// The identity.
pub const IDENTITY: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Below this angle (rad) the series of `c(t)` and `c'(t)/t` are used: their
/// truncation error there is below 1e-15, while the closed forms lose digits
/// to cancellation (`c'(t)/t` loses about `2/t^4` relative rounding).
const SERIES_ANGLE: f64 = 0.3;

/// `a . b`.
#[inline]
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a x b`.
#[inline]
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// `s a + b`.
#[inline]
pub fn axpy(s: f64, a: Vec3, b: Vec3) -> Vec3 {
    [s * a[0] + b[0], s * a[1] + b[1], s * a[2] + b[2]]
}

/// `s a`.
#[inline]
pub fn scale(s: f64, a: Vec3) -> Vec3 {
    [s * a[0], s * a[1], s * a[2]]
}

/// `[v]`, the matrix of `x -> v x x`.
#[inline]
pub fn hat(v: Vec3) -> Mat3 {
    [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]
}

/// `A B`.
#[inline]
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (row, a_row) in out.iter_mut().zip(a) {
        for (c, entry) in row.iter_mut().enumerate() {
            *entry = a_row[0] * b[0][c] + a_row[1] * b[1][c] + a_row[2] * b[2][c];
        }
    }
    out
}

/// `A^T B`.
#[inline]
pub fn mul_tn(a: &Mat3, b: &Mat3) -> Mat3 {
    mul(&transpose(a), b)
}

/// Column `k` of `a` (a frame's `k`-th axis).
#[inline]
pub fn column(a: &Mat3, k: usize) -> Vec3 {
    [a[0][k], a[1][k], a[2][k]]
}

/// `A^T`.
#[inline]
pub fn transpose(a: &Mat3) -> Mat3 {
    [[a[0][0], a[1][0], a[2][0]], [a[0][1], a[1][1], a[2][1]], [a[0][2], a[1][2], a[2][2]]]
}

/// `A v`.
#[inline]
pub fn apply(a: &Mat3, v: Vec3) -> Vec3 {
    [dot(a[0], v), dot(a[1], v), dot(a[2], v)]
}

/// `A^T v`.
#[inline]
pub fn apply_t(a: &Mat3, v: Vec3) -> Vec3 {
    [
        a[0][0] * v[0] + a[1][0] * v[1] + a[2][0] * v[2],
        a[0][1] * v[0] + a[1][1] * v[1] + a[2][1] * v[2],
        a[0][2] * v[0] + a[1][2] * v[1] + a[2][2] * v[2],
    ]
}

/// `s A + B`.
#[inline]
pub fn add_scaled(s: f64, a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = *b;
    for (row, a_row) in out.iter_mut().zip(a) {
        for (x, y) in row.iter_mut().zip(a_row) {
            *x += s * y;
        }
    }
    out
}

/// `(A + A^T) / 2`.
#[inline]
pub fn symmetric_part(a: &Mat3) -> Mat3 {
    let mut out = *a;
    for r in 0..3 {
        for c in 0..3 {
            out[r][c] = 0.5 * (a[r][c] + a[c][r]);
        }
    }
    out
}

/// `u v^T`.
#[inline]
fn outer(u: Vec3, v: Vec3) -> Mat3 {
    [scale(u[0], v), scale(u[1], v), scale(u[2], v)]
}

/// The rotation about the z axis by `angle` (rad): `+x` to `(cos, sin, 0)`.
pub fn rot_z(angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// `Exp(v) = I + sin t / t [v] + (1 - cos t) / t^2 [v]^2`, `t = |v|` (Rodrigues),
/// written as `(1 - b t^2) I + a [v] + b v v^T` (`[v]^2 = v v^T - t^2 I`).
/// Below 0.25 rad `a = sin t / t` and `b = (1 - cos t) / t^2` come from
/// their series, seven terms each (truncation below 1e-17): the solver's
/// steps are mostly that small, and the series costs a few products where
/// `sin` and `cos` cost tens.
pub fn exp(v: Vec3) -> Mat3 {
    let t2 = dot(v, v);
    let (a, b) = if t2 < 0.0625 {
        // sin t / t = sum (-t^2)^i / (2i + 1)!, (1 - cos t) / t^2 = sum (-t^2)^i / (2i + 2)!.
        const SIN: [f64; 7] =
            [1.0, -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0, 1.0 / 6227020800.0];
        const COS: [f64; 7] =
            [0.5, -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0, 1.0 / 3628800.0, -1.0 / 479001600.0, 1.0 / 87178291200.0];
        let horner = |c: &[f64; 7]| c.iter().rev().fold(0.0, |acc, ci| ci + t2 * acc);
        (horner(&SIN), horner(&COS))
    } else {
        let t = t2.sqrt();
        (t.sin() / t, (1.0 - t.cos()) / t2)
    };
    let d = 1.0 - b * t2;
    let (x, y, z) = (a * v[0], a * v[1], a * v[2]);
    let outer = |i: usize, j: usize| b * v[i] * v[j];
    [
        [d + outer(0, 0), outer(0, 1) - z, outer(0, 2) + y],
        [outer(1, 0) + z, d + outer(1, 1), outer(1, 2) - x],
        [outer(2, 0) - y, outer(2, 1) + x, d + outer(2, 2)],
    ]
}

/// `Log(R)`: the rotation vector of angle in `[0, pi]`, through the unit
/// quaternion (Shepperd's choice of the largest component), accurate for
/// every angle.
pub fn log(r: &Mat3) -> Vec3 {
    let trace = r[0][0] + r[1][1] + r[2][2];
    // Quaternion (w, x, y, z) from the largest of 1 + trace and 1 + 2 r_ii - trace.
    let candidates = [trace, r[0][0], r[1][1], r[2][2]];
    let (mut big, mut best) = (0, f64::NEG_INFINITY);
    for (i, v) in candidates.iter().enumerate() {
        let value = if i == 0 { *v } else { 2.0 * v - trace };
        if value > best {
            (big, best) = (i, value);
        }
    }
    let s = 2.0 * (1.0 + best).max(0.0).sqrt();
    // One division: the others become products.
    let (half, inv) = (0.25 * s, 1.0 / s);
    let q = match big {
        0 => [half, (r[2][1] - r[1][2]) * inv, (r[0][2] - r[2][0]) * inv, (r[1][0] - r[0][1]) * inv],
        1 => [(r[2][1] - r[1][2]) * inv, half, (r[0][1] + r[1][0]) * inv, (r[0][2] + r[2][0]) * inv],
        2 => [(r[0][2] - r[2][0]) * inv, (r[0][1] + r[1][0]) * inv, half, (r[1][2] + r[2][1]) * inv],
        _ => [(r[1][0] - r[0][1]) * inv, (r[0][2] + r[2][0]) * inv, (r[1][2] + r[2][1]) * inv, half],
    };
    // The same rotation with w >= 0: angle = 2 atan2(|v|, w) in [0, pi].
    let sign = if q[0] < 0.0 { -1.0 } else { 1.0 };
    let (w, v) = (sign * q[0], scale(sign, [q[1], q[2], q[3]]));
    let norm = dot(v, v).sqrt();
    if norm < 1e-300 {
        return [0.0; 3];
    }
    scale(angle_over_sine(norm, w), v)
}

/// `2 atan2(n, w) / n` (the rotation angle over `|v|` of a unit quaternion
/// `(w, v)`, `n = |v|`, `w >= 0`). Below 0.25 rad (`x = n / w < 1/8`) by the
/// series `(2 / w) atan(x) / x = (2 / w) sum_i (-x^2)^i / (2 i + 1)`, ten
/// terms (truncation below 1e-17 relative): the joints' angles are mostly
/// there, and the series costs a few products where `atan2` costs tens.
fn angle_over_sine(n: f64, w: f64) -> f64 {
    if n < 0.125 * w {
        const ATAN: [f64; 10] = [
            1.0,
            -1.0 / 3.0,
            1.0 / 5.0,
            -1.0 / 7.0,
            1.0 / 9.0,
            -1.0 / 11.0,
            1.0 / 13.0,
            -1.0 / 15.0,
            1.0 / 17.0,
            -1.0 / 19.0,
        ];
        let inv_w = 1.0 / w;
        let x2 = n * inv_w * (n * inv_w);
        2.0 * inv_w * ATAN.iter().rev().fold(0.0, |acc, c| c + x2 * acc)
    } else {
        2.0 * n.atan2(w) / n
    }
}

/// `c(t)` and `c'(t)/t` of `Jr^-1` (module doc), from `t^2`.
fn jr_inv_coefficients(t2: f64) -> (f64, f64) {
    if t2 < SERIES_ANGLE * SERIES_ANGLE {
        let c = 1.0 / 12.0 + t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 * (1.0 / 1209600.0 + t2 / 47900160.0)));
        let dc = 1.0 / 360.0 + t2 * (1.0 / 7560.0 + t2 * (1.0 / 201600.0 + t2 / 5987520.0));
        (c, dc)
    } else {
        let t = t2.sqrt();
        let cot = 1.0 / (0.5 * t).tan();
        let csc2 = 1.0 + cot * cot;
        let c = 1.0 / t2 - cot / (2.0 * t);
        let dc = -2.0 / (t2 * t) + cot / (2.0 * t2) + csc2 / (4.0 * t);
        (c, dc / t)
    }
}

/// `Jr^-1(theta)`, the inverse right Jacobian: `Log(Exp(theta) Exp(eps)) =
/// theta + Jr^-1(theta) eps + O(eps^2)`.
pub fn jr_inv(theta: Vec3) -> Mat3 {
    jr_inv_with(theta, jr_inv_coefficients(dot(theta, theta)).0)
}

/// `Jr^-1(theta)` given its coefficient `c(|theta|)`.
fn jr_inv_with(theta: Vec3, c: f64) -> Mat3 {
    let h = hat(theta);
    add_scaled(c, &mul(&h, &h), &add_scaled(0.5, &h, &IDENTITY))
}

/// The local derivatives of a relative term `F(Log(R_a^T R_b))` (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairTerms {
    /// `theta = Log(R_a^T R_b)` (rad).
    pub theta: Vec3,
    /// `d theta / d delta_b = Jr^-1(theta)`; `d theta / d delta_a = -Jr^-1(theta) M^T`
    /// ([`PairTerms::jacobian_a`]).
    pub jacobian_b: Mat3,
    /// `dF/ddelta_a`.
    pub grad_a: Vec3,
    /// `dF/ddelta_b`.
    pub grad_b: Vec3,
    /// `d2F/ddelta_a2`.
    pub h_aa: Mat3,
    /// `d2F/ddelta_a ddelta_b` (rows `a`, columns `b`).
    pub h_ab: Mat3,
    /// `d2F/ddelta_b2`.
    pub h_bb: Mat3,
}

impl PairTerms {
    /// `d theta / d delta_a = -Jr^-1(theta) M^T` for the `M` the terms were
    /// made from (only the weld's rows need it, so it is not formed for joints).
    pub fn jacobian_a(&self, m: &Mat3) -> Mat3 {
        scale_mat(-1.0, &mul(&self.jacobian_b, &transpose(m)))
    }
}

/// `s a`.
pub fn scale_mat(s: f64, a: &Mat3) -> Mat3 {
    add_scaled(s, a, &[[0.0; 3]; 3])
}

/// The derivatives of `F(theta)`, `theta = Log(M)`, `M = R_a^T R_b`, given
/// `w = dF/dtheta` (a function of `theta`: pass a closure) and the constant,
/// diagonal `H_theta = d2F/dtheta2 = diag(h_theta)` (module doc). Without
/// `hessian` the second derivatives are left zero (and not computed).
#[inline(always)]
pub fn pair_terms(m: &Mat3, gradient: impl Fn(Vec3) -> Vec3, h_theta: Vec3, hessian: bool) -> PairTerms {
    let theta = log(m);
    let (c, dc_over_t) = jr_inv_coefficients(dot(theta, theta));
    let p = jr_inv_with(theta, c);
    let w = gradient(theta);
    let g = apply_t(&p, w);
    let mut terms = PairTerms {
        theta,
        jacobian_b: p,
        grad_a: scale(-1.0, apply(m, g)),
        grad_b: g,
        h_aa: [[0.0; 3]; 3],
        h_ab: [[0.0; 3]; 3],
        h_bb: [[0.0; 3]; 3],
    };
    if !hessian {
        return terms;
    }
    // D = d(P^T w)/dtheta, P^T w = w - theta x w / 2 + c theta x (theta x w).
    let tw = dot(theta, w);
    let ttw = cross(theta, cross(theta, w));
    let mut d = scale_mat(0.5, &hat(w));
    d = add_scaled(dc_over_t, &outer(ttw, theta), &d);
    let bracket = add_scaled(-2.0, &outer(w, theta), &add_scaled(1.0, &outer(theta, w), &scale_mat(tw, &IDENTITY)));
    d = add_scaled(c, &bracket, &d);
    // H_e = P^T diag(h_theta) P + sym(D P), entry by entry.
    let dp = mul(&d, &p);
    let h_e: Mat3 = std::array::from_fn(|r| {
        std::array::from_fn(|c| {
            let pkp = h_theta[0] * p[0][r] * p[0][c] + h_theta[1] * p[1][r] * p[1][c] + h_theta[2] * p[2][r] * p[2][c];
            pkp + 0.5 * (dp[r][c] + dp[c][r])
        })
    });
    let mh = mul(m, &h_e);
    terms.h_aa = mul(&mh, &transpose(m));
    terms.h_ab = add_scaled(0.5, &mul(m, &hat(g)), &scale_mat(-1.0, &mh));
    terms.h_bb = h_e;
    terms
}

/// The local gradient and Hessian of a linear term `w . (R Exp(delta) a)`
/// (module doc).
pub fn linear_terms(r: &Mat3, w: Vec3, a: Vec3) -> (Vec3, Mat3) {
    let wl = apply_t(r, w);
    let sym = add_scaled(0.5, &outer(wl, a), &scale_mat(0.5, &outer(a, wl)));
    (cross(a, wl), add_scaled(-dot(wl, a), &IDENTITY, &sym))
}

/// The Hessian of [`linear_terms`] for `a = e_x` (a link's tangent: its
/// height, its share of a tip position), written out: with `w' = R^T w`,
///
/// ```text
/// [ 0       w'_y/2   w'_z/2 ]
/// [ w'_y/2  -w'_x    0      ]
/// [ w'_z/2  0        -w'_x  ]
/// ```
pub fn tangent_hessian(r: &Mat3, w: Vec3) -> Mat3 {
    let wl = apply_t(r, w);
    [[0.0, 0.5 * wl[1], 0.5 * wl[2]], [0.5 * wl[1], -wl[0], 0.0], [0.5 * wl[2], 0.0, -wl[0]]]
}

/// Whether `r` is a rotation: orthonormal to 1e-9, determinant +1 to 1e-9.
pub fn is_rotation(r: &Mat3) -> bool {
    let gram = mul_tn(r, r);
    let det = dot(r[0], cross(r[1], r[2]));
    let off = (0..3)
        .flat_map(|a| (0..3).map(move |b| (a, b)))
        .fold(0.0f64, |m, (a, b)| m.max((gram[a][b] - if a == b { 1.0 } else { 0.0 }).abs()));
    off <= 1e-9 && (det - 1.0).abs() <= 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Mat3, b: &Mat3, tol: f64) -> bool {
        (0..3).all(|r| (0..3).all(|c| (a[r][c] - b[r][c]).abs() <= tol))
    }

    #[test]
    fn log_inverts_exp_at_every_angle() {
        for v in [
            [0.0, 0.0, 0.0],
            [1e-9, -2e-9, 3e-10],
            [0.1, -0.2, 0.3],
            [1.0, 2.0, -0.5],
            [0.0, 0.0, 3.1],
            [2.0, -2.0, 1.2],
        ] {
            let back = log(&exp(v));
            assert!((0..3).all(|i| (back[i] - v[i]).abs() < 1e-12), "{v:?} -> {back:?}");
        }
    }

    #[test]
    fn angle_series_joins_atan2() {
        for angle in [1e-9, 1e-3, 0.1, 0.2499, 0.2501, 1.0] {
            let (n, w) = ((0.5f64 * angle).sin(), (0.5f64 * angle).cos());
            let exact = 2.0 * n.atan2(w) / n;
            assert!((angle_over_sine(n, w) - exact).abs() <= 4.0 * f64::EPSILON * exact, "{angle}");
        }
    }

    #[test]
    fn exp_series_joins_the_closed_form() {
        for t in [1e-9, 1e-3, 0.1, 0.2499, 0.2501, 1.0] {
            let v = scale(t / 14f64.sqrt(), [1.0, -2.0, 3.0]);
            let (s, c) = t.sin_cos();
            let h = hat(v);
            let closed = add_scaled((1.0 - c) / (t * t), &mul(&h, &h), &add_scaled(s / t, &h, &IDENTITY));
            assert!(close(&exp(v), &closed, 4.0 * f64::EPSILON), "{t}");
        }
    }

    #[test]
    fn exp_is_a_rotation() {
        let r = exp([0.3, -1.1, 0.7]);
        assert!(close(&mul_tn(&r, &r), &IDENTITY, 1e-15));
    }

    #[test]
    fn coefficients_join_continuously_at_the_series_switch() {
        let (below, above) = (jr_inv_coefficients(0.3f64.powi(2) * (1.0 - 1e-12)), jr_inv_coefficients(0.09));
        assert!((below.0 - above.0).abs() < 1e-13 && (below.1 - above.1).abs() < 1e-11, "{below:?} {above:?}");
    }

    #[test]
    fn tangent_hessian_is_the_linear_terms_along_x() {
        let (r, w) = (exp([0.3, -1.1, 0.7]), [0.4, -2.0, 1.3]);
        assert!(close(&tangent_hessian(&r, w), &linear_terms(&r, w, [1.0, 0.0, 0.0]).1, 1e-15));
    }

    #[test]
    fn jr_inv_is_the_derivative_of_log() {
        let theta = [0.4, -0.3, 0.9];
        let p = jr_inv(theta);
        let h = 1e-6;
        for k in 0..3 {
            let mut e = [0.0; 3];
            e[k] = h;
            let plus = log(&mul(&exp(theta), &exp(e)));
            let minus = log(&mul(&exp(theta), &exp(scale(-1.0, e))));
            for r in 0..3 {
                let fd = (plus[r] - minus[r]) / (2.0 * h);
                assert!((fd - p[r][k]).abs() < 1e-8, "{r} {k}: {fd} {}", p[r][k]);
            }
        }
    }
}
