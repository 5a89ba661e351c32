//! Sines and cosines of many angles at once, for the solver's evaluations.
//!
//! The library's `sin_cos` is a call per angle that the compiler cannot
//! vectorize, and at thousands of links it was the largest single cost of a
//! static solve. Here the angle is reduced by `pi/2` (Cody-Waite, in two
//! rounds as fdlibm's `__rem_pio2` does) and the fdlibm/musl kernels of `sin`
//! and `cos` on `[-pi/4, pi/4]` are evaluated without branches, so a loop over
//! a slice runs in vector registers. The results are within about one unit in
//! the last place of the library's. Angles beyond [`FAST_RANGE`] (where the
//! two-round reduction is no longer exact) fall back to the library.

/// Largest `|angle|` (rad) handled by the polynomial path: `round(angle 2/pi)`
/// must fit in 20 bits for the products with the 33-bit parts of `pi/2` to be exact.
const FAST_RANGE: f64 = 1e5;

/// `1.5 * 2^52`: adding it rounds to an integer and leaves that integer in the
/// low bits of the mantissa.
const ROUNDING: f64 = 6755399441055744.0;

// pi/2 in parts: the first 33 bits, the next 33 bits, and the rest.
const PIO2_1: f64 = 1.5707963267341256;
const PIO2_2: f64 = 6.077100506303966e-11;
const PIO2_2T: f64 = 2.0222662487959506e-21;

// fdlibm's minimax coefficients of sin and cos on [-pi/4, pi/4].
const S1: f64 = -0.16666666666666632;
const S2: f64 = 0.00833333333332249;
const S3: f64 = -0.0001984126982985795;
const S4: f64 = 2.7557313707070068e-06;
const S5: f64 = -2.5050760253406863e-08;
const S6: f64 = 1.58969099521155e-10;
const C1: f64 = 0.0416666666666666;
const C2: f64 = -0.001388888888887411;
const C3: f64 = 2.480158728947673e-05;
const C4: f64 = -2.7557314351390663e-07;
const C5: f64 = 2.087572321298175e-09;
const C6: f64 = -1.1359647557788195e-11;

/// `(sin, cos)` of one angle with `|angle| <= FAST_RANGE` (NaN in, NaN out),
/// without branches.
#[inline(always)]
fn sin_cos_reduced(x: f64) -> (f64, f64) {
    let shifted = x * std::f64::consts::FRAC_2_PI + ROUNDING;
    let quadrant = shifted.to_bits();
    let n = shifted - ROUNDING;
    // x - n pi/2 as y0 + y1 (fdlibm's second round, good to about 118 bits).
    let t = x - n * PIO2_1;
    let w = n * PIO2_2;
    let r = t - w;
    let w = n * PIO2_2T - ((t - r) - w);
    let y0 = r - w;
    let y1 = (r - y0) - w;
    // The kernels with the reduction's tail (musl's __sin and __cos).
    let z = y0 * y0;
    let z2 = z * z;
    let rs = S2 + z * (S3 + z * S4) + z * z2 * (S5 + z * S6);
    let v = z * y0;
    let sin = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * S1);
    let rc = z * (C1 + z * (C2 + z * C3)) + z2 * z2 * (C4 + z * (C5 + z * C6));
    let hz = 0.5 * z;
    let one_minus = 1.0 - hz;
    let cos = one_minus + (((1.0 - one_minus) - hz) + (z * rc - y0 * y1));
    // Quadrant n mod 4: (s, c), (c, -s), (-s, -c), (-c, s).
    let swap = quadrant & 1 != 0;
    let (s, c) = if swap { (cos, sin) } else { (sin, cos) };
    let s = f64::from_bits(s.to_bits() ^ ((quadrant & 2) << 62));
    let c = f64::from_bits(c.to_bits() ^ ((quadrant.wrapping_add(1) & 2) << 62));
    (s, c)
}

/// Writes `sin` and `cos` of each of `angles` (all three slices of one length).
pub(crate) fn sin_cos_into(angles: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    let n = angles.len();
    let (sin, cos) = (&mut sin[..n], &mut cos[..n]);
    let mut far = false;
    for ((x, s), c) in angles.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        (*s, *c) = sin_cos_reduced(*x);
        far |= x.abs() > FAST_RANGE;
    }
    if far {
        for ((x, s), c) in angles.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
            (*s, *c) = x.sin_cos();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place.
    fn ulps(a: f64, b: f64) -> u64 {
        let key = |x: f64| {
            let bits = x.to_bits() as i64;
            if bits < 0 {
                i64::MIN - bits
            } else {
                bits
            }
        };
        key(a).abs_diff(key(b))
    }

    #[test]
    fn agrees_with_the_library_to_an_ulp_or_two() {
        // Angles across many periods, near multiples of pi/2, and tiny ones.
        let mut angles: Vec<f64> =
            (0..200_000).map(|i| -60.0 + 120.0 * (i as f64 * 0.618_033_988_749_895).fract()).collect();
        for k in -40..40 {
            let base = k as f64 * std::f64::consts::FRAC_PI_2;
            angles.extend([base, base + 1e-9, base - 1e-12, f64::from_bits(base.to_bits() + 1)]);
        }
        angles.extend([0.0, -0.0, 1e-300, -1e-8, 0.785, -0.786, 2.356, 1e4 + 0.3, -99_999.9]);
        let (mut sin, mut cos) = (vec![0.0; angles.len()], vec![0.0; angles.len()]);
        sin_cos_into(&angles, &mut sin, &mut cos);
        for (i, x) in angles.iter().enumerate() {
            let (s, c) = x.sin_cos();
            // Relative to the larger of the pair: near a zero of one, its
            // ulps are meaningless and its absolute error is what counts.
            let scale = s.abs().max(c.abs());
            assert!((sin[i] - s).abs() <= 2.0 * f64::EPSILON * scale, "sin({x}): {} vs {s}", sin[i]);
            assert!((cos[i] - c).abs() <= 2.0 * f64::EPSILON * scale, "cos({x}): {} vs {c}", cos[i]);
            if s.abs() > 0.1 {
                assert!(ulps(sin[i], s) <= 2, "sin({x}): {} vs {s}", sin[i]);
            }
            if c.abs() > 0.1 {
                assert!(ulps(cos[i], c) <= 2, "cos({x}): {} vs {c}", cos[i]);
            }
        }
    }

    #[test]
    fn far_and_special_angles_follow_the_library() {
        let angles = [1e6, -3e7, 0.5, f64::NAN, f64::INFINITY];
        let (mut sin, mut cos) = ([0.0; 5], [0.0; 5]);
        sin_cos_into(&angles, &mut sin, &mut cos);
        for (i, x) in angles.iter().enumerate() {
            let (s, c) = x.sin_cos();
            assert!(sin[i].to_bits() == s.to_bits() || (s.is_nan() && sin[i].is_nan()), "sin({x})");
            assert!(cos[i].to_bits() == c.to_bits() || (c.is_nan() && cos[i].is_nan()), "cos({x})");
        }
    }
}
