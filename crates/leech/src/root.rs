//! Bracketed root finding of a scalar function: regula falsi with the
//! Illinois rule.
//!
//! Given `f(a)` and `f(b)` of opposite signs, the next point is where the
//! secant through the ends crosses zero,
//!
//! ```text
//! c = (a f(b) - b f(a)) / (f(b) - f(a))
//! ```
//!
//! and `c` replaces the end whose value has the sign of `f(c)`. Plain regula
//! falsi keeps one end for ever on a convex stretch and converges linearly;
//! halving the kept end's value whenever the same end is kept twice in a row
//! (Illinois) restores superlinear convergence at no extra evaluation.
//!
//! ```
//! use leech::root::Bracket;
//! let f = |x: f64| x * x - 2.0;
//! let mut bracket = Bracket::new((0.0, f(0.0)), (2.0, f(2.0)));
//! let mut x = bracket.next();
//! for _ in 0..50 {
//!     bracket.narrow(x, f(x));
//!     x = bracket.next();
//! }
//! assert!((x - 2f64.sqrt()).abs() < 1e-12);
//! ```

/// A sign change of a function between two points, narrowed by
/// [`Bracket::narrow`] (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bracket {
    a: (f64, f64),
    b: (f64, f64),
    /// Which end was kept last: -1 `a`, 1 `b`, 0 none yet.
    kept: i8,
}

impl Bracket {
    /// The bracket between the points `a` and `b`, each `(x, f(x))`, their
    /// values of opposite signs.
    pub fn new(a: (f64, f64), b: (f64, f64)) -> Bracket {
        Bracket { a, b, kept: 0 }
    }

    /// Where the secant through the ends crosses zero.
    pub fn next(&self) -> f64 {
        let ((a, fa), (b, fb)) = (self.a, self.b);
        (a * fb - b * fa) / (fb - fa)
    }

    /// Moves the end whose value has the sign of `fc` to `(c, fc)`; an end
    /// kept twice in a row has its value halved (Illinois).
    pub fn narrow(&mut self, c: f64, fc: f64) {
        if fc.signum() == self.b.1.signum() {
            self.b = (c, fc);
            if self.kept == -1 {
                self.a.1 *= 0.5;
            }
            self.kept = -1;
        } else {
            self.a = (c, fc);
            if self.kept == 1 {
                self.b.1 *= 0.5;
            }
            self.kept = 1;
        }
    }

    /// The distance between the ends.
    pub fn width(&self) -> f64 {
        (self.b.0 - self.a.0).abs()
    }

    /// The second end, `(x, f(x))` (its value possibly halved).
    pub fn b(&self) -> (f64, f64) {
        self.b
    }
}
