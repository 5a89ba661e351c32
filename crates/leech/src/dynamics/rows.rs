//! Products with the constraint rows' matrices: `n x m` matrices laid out
//! row by row like the Jacobian (entry `(i, r)` at `i m + r`), `m` small.
//!
//! Each kernel is written once for a row count `M` known at compile time,
//! `0` standing for a count known at run time only; [`by_rows!`] calls it
//! with `M = 3` for the body's weld, whose loops the compiler then unrolls
//! and keeps in registers (the same sums in the same order as the general
//! case, so results do not depend on which one runs).

/// Calls `kernel::<3>(args)` when `m` is the weld's three rows, else
/// `kernel::<0>(args)`.
macro_rules! by_rows {
    ($m:expr, $kernel:ident($($arg:expr),* $(,)?)) => {
        match $m {
            3 => $kernel::<3>($($arg),*),
            _ => $kernel::<0>($($arg),*),
        }
    };
}

/// The row count: `M`, or `m` when `M` is 0.
#[inline(always)]
fn rows<const M: usize>(m: usize) -> usize {
    if M == 0 {
        m
    } else {
        M
    }
}

/// `out = A^T x` (`m` = `out.len()` columns of `A`), in one pass over `A`'s rows.
pub(super) fn transposed_product(a: &[f64], x: &[f64], out: &mut [f64]) {
    by_rows!(out.len(), transposed_product_with(a, x, out));
}

fn transposed_product_with<const M: usize>(a: &[f64], x: &[f64], out: &mut [f64]) {
    let m = rows::<M>(out.len());
    out.iter_mut().for_each(|o| *o = 0.0);
    if m == 0 {
        return;
    }
    for (row, xi) in a.chunks_exact(m).zip(x) {
        for (o, j) in out[..m].iter_mut().zip(&row[..m]) {
            *o += j * xi;
        }
    }
}

/// `x += A c` (`m` = `c.len()` columns of `A`).
pub(super) fn add_product(a: &[f64], c: &[f64], x: &mut [f64]) {
    by_rows!(c.len(), add_product_with(a, c, x));
}

fn add_product_with<const M: usize>(a: &[f64], c: &[f64], x: &mut [f64]) {
    let m = rows::<M>(c.len());
    if m == 0 {
        return;
    }
    for (xi, row) in x.iter_mut().zip(a.chunks_exact(m)) {
        for (j, cr) in row[..m].iter().zip(&c[..m]) {
            *xi += j * cr;
        }
    }
}

/// `out = A^T B` (`m x m`, row-major) for `A`, `B` of `m` columns, in one
/// pass over their rows.
pub(super) fn gram(a: &[f64], b: &[f64], m: usize, out: &mut [f64]) {
    by_rows!(m, gram_with(a, b, m, out));
}

fn gram_with<const M: usize>(a: &[f64], b: &[f64], m: usize, out: &mut [f64]) {
    let m = rows::<M>(m);
    out.iter_mut().for_each(|o| *o = 0.0);
    if m == 0 {
        return;
    }
    for (ra, rb) in a.chunks_exact(m).zip(b.chunks_exact(m)) {
        for (r, x) in ra[..m].iter().enumerate() {
            for (o, y) in out[r * m..(r + 1) * m].iter_mut().zip(&rb[..m]) {
                *o += x * y;
            }
        }
    }
}
