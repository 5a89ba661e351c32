//! Factorization of the chains' mass matrices.

/// In-place Cholesky `A = L L^T` of a dense `k x k` row-major matrix (lower
/// triangle); the failing row on a non-positive pivot.
pub(super) fn cholesky(a: &mut [f64], k: usize) -> Result<(), usize> {
    for j in 0..k {
        let mut d = a[j * k + j];
        for p in 0..j {
            d -= a[j * k + p] * a[j * k + p];
        }
        if !(d > 0.0) {
            return Err(j);
        }
        let d = d.sqrt();
        a[j * k + j] = d;
        for i in j + 1..k {
            let mut s = a[i * k + j];
            for p in 0..j {
                s -= a[i * k + p] * a[j * k + p];
            }
            a[i * k + j] = s / d;
        }
    }
    Ok(())
}

pub(super) fn cholesky_solve(l: &[f64], k: usize, x: &mut [f64]) {
    for i in 0..k {
        let row = &l[i * k..i * k + i];
        let s: f64 = row.iter().zip(&x[..i]).map(|(a, b)| a * b).sum();
        x[i] = (x[i] - s) / l[i * k + i];
    }
    // L^T x = y by rows of L (contiguous), eliminating each solved unknown.
    for p in (0..k).rev() {
        x[p] /= l[p * k + p];
        let xp = x[p];
        for (xi, lpi) in x[..p].iter_mut().zip(&l[p * k..p * k + p]) {
            *xi -= lpi * xp;
        }
    }
}
