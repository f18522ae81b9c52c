//! The sandbox warp (authors' code, docs/references.md#p-bucket, sandbox P): identity positions, the motion rounded to whole
//! ONS pixels and applied as a zero-padded gather. Exact, no interpolation.
//!
//! `out[b, c, y, x] = v[b, c, y + s_y, x + s_x]` when inside, else 0; `mask[b, 0, y, x]` is 1
//! where inside. Backward scatters `dy` back to the gathered pixels. Sign: frame t+1 at p shows
//! frame t at p + s.

use autodiff::{Float, Tape, Tensor, Var};

/// Gathers `v (B, C, n, n)` at `p + shifts[b]`; returns `(warped, mask (B, 1, n, n))`.
pub fn integer_shift_warp<T: Float>(tape: &mut Tape<T>, v: Var, shifts: &[[i64; 2]]) -> (Var, Var) {
    let (b, c, h, w) = tape.shape(v).bchw("integer_shift_warp");
    assert_eq!(
        shifts.len(),
        b,
        "integer_shift_warp: {} shifts for a batch of {b}",
        shifts.len()
    );
    let src = tape.value(v).data();
    let mut out = Tensor::<T>::zeros([b, c, h, w]);
    let mut mask = Tensor::<T>::zeros([b, 1, h, w]);
    for_each_inside(shifts, (h, w), |bi, to, from| {
        mask.data_mut()[bi * h * w + to] = T::one();
        for ci in 0..c {
            let plane = (bi * c + ci) * h * w;
            out.data_mut()[plane + to] = src[plane + from];
        }
    });
    let shifts = shifts.to_vec();
    let warped = tape.custom_vjp("integer_shift_warp", &[v], out, move |cx, dx| {
        let dy = cx.dy.data();
        if let Some(g) = dx.slot_data(0) {
            for_each_inside(&shifts, (h, w), |bi, to, from| {
                for ci in 0..c {
                    let plane = (bi * c + ci) * h * w;
                    g[plane + from] += dy[plane + to];
                }
            });
        }
    });
    let mask = tape.constant(mask);
    (warped, mask)
}

/// Calls `f(b, to, from)` for every output pixel `to = y·w + x` of image `b` whose source
/// `from = (y + s_y)·w + (x + s_x)` lies inside the `h × w` plane, rows then columns.
fn for_each_inside(
    shifts: &[[i64; 2]],
    (h, w): (usize, usize),
    mut f: impl FnMut(usize, usize, usize),
) {
    for (bi, s) in shifts.iter().enumerate() {
        for y in 0..h as i64 {
            let ys = y + s[1];
            if ys < 0 || ys >= h as i64 {
                continue;
            }
            for x in 0..w as i64 {
                let xs = x + s[0];
                if xs < 0 || xs >= w as i64 {
                    continue;
                }
                f(
                    bi,
                    y as usize * w + x as usize,
                    ys as usize * w + xs as usize,
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use autodiff::check::{check_gradients, CheckConfig};

    #[test]
    fn shift_moves_content_and_masks_the_rest() {
        let mut tape = Tape::<f64>::new();
        let v = tape.constant(Tensor::from_fn([1, 1, 4, 4], |i| i as f64));
        let (w, m) = integer_shift_warp(&mut tape, v, &[[1, -1]]);
        // out[y, x] = v[y − 1, x + 1]
        assert_eq!(tape.value(w).data()[4], 1.0);
        assert_eq!(tape.value(w).data()[0], 0.0);
        assert_eq!(tape.value(m).data()[3 + 4], 0.0);
        assert_eq!(tape.value(m).data()[2 + 4], 1.0);
    }

    #[test]
    fn gradient_check() {
        let x = Tensor::from_fn([2, 2, 5, 5], |i| ((i * 7919) % 13) as f64 / 6.0 - 1.0);
        let report = check_gradients(
            |t, v| integer_shift_warp(t, v[0], &[[2, 0], [-1, 3]]).0,
            &[x],
            &CheckConfig::default(),
        );
        report.unwrap();
    }
}
