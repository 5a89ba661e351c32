//! Plane geometry: points and vectors as `[f64; 2]` (m), angles in rad
//! counter-clockwise from +x.
//!
//! ```text
//! e(a)  = (cos a, sin a)        unit vector along a
//! e'(a) = (-sin a, cos a)       e rotated a quarter turn counter-clockwise
//! nu(a) = (sin a, -cos a)       right-hand normal: where chain B sits from chain A
//! R(a) v = v_x e(a) + v_y e'(a) rotation by a
//! ```
//!
//! Plain arrays keep the hot loops free of conversions; the 3D body will add
//! its own types here.

/// A point or vector in the plane (m).
pub type Vec2 = [f64; 2];

/// Unit vector `e(a) = (cos a, sin a)`.
#[inline]
pub fn unit(angle: f64) -> Vec2 {
    let (s, c) = angle.sin_cos();
    [c, s]
}

/// Right-hand normal `nu(a) = (sin a, -cos a)`.
#[inline]
pub fn right_normal(angle: f64) -> Vec2 {
    let (s, c) = angle.sin_cos();
    [s, -c]
}

/// `a + s b`.
#[inline]
pub fn add_scaled(a: Vec2, s: f64, b: Vec2) -> Vec2 {
    [a[0] + s * b[0], a[1] + s * b[1]]
}

/// `a - b`.
#[inline]
pub fn sub(a: Vec2, b: Vec2) -> Vec2 {
    [a[0] - b[0], a[1] - b[1]]
}

/// Dot product.
#[inline]
pub fn dot(a: Vec2, b: Vec2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// The scalar cross product `a_x b_y - a_y b_x` (positive when `b` is
/// counter-clockwise of `a`).
#[inline]
pub fn cross(a: Vec2, b: Vec2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Euclidean length `|v|`.
#[inline]
pub fn norm(v: Vec2) -> f64 {
    v[0].hypot(v[1])
}

/// `v` rotated by `angle` (rad) counter-clockwise.
#[inline]
pub fn rotate(v: Vec2, angle: f64) -> Vec2 {
    let (s, c) = angle.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

/// `a - b` wrapped to [-pi, pi) (rad).
#[inline]
pub fn angle_difference(a: f64, b: f64) -> f64 {
    use std::f64::consts::PI;
    (a - b + PI).rem_euclid(2.0 * PI) - PI
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_consistent() {
        for a in [-4.0, -1.0, 0.0, 0.3, 2.0, 7.0] {
            let (e, nu) = (unit(a), right_normal(a));
            assert!(dot(e, nu).abs() < 1e-15);
            // nu is e turned clockwise: e x nu = -1.
            assert!((cross(e, nu) + 1.0).abs() < 1e-15);
            let r = rotate([1.0, 0.0], a);
            assert!((r[0] - e[0]).abs() < 1e-15 && (r[1] - e[1]).abs() < 1e-15);
            let back = sub(add_scaled(e, 2.0, nu), e);
            assert!((dot(back, nu) - 2.0).abs() < 1e-15);
            assert!((norm(add_scaled(e, 3.0, nu)) - 10f64.sqrt()).abs() < 1e-15);
        }
    }
}
