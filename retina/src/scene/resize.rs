//! Resizing planar images `(planes, h, w)` f32, separably along rows and columns.
//!
//! Along each axis: enlarging interpolates linearly between the two nearest pixels with the
//! corners aligned (the first and last pixels keep their places, as
//! [`super::pool::resize_bilinear`] does); shrinking averages the input pixels each output
//! pixel covers, each weighted by the length of its overlap (an area average, so a scene shrunk
//! by the eye's field size does not alias). A constant image stays constant either way.
//!
//! [`resize_short_side`] scales an image so its short side is a given size, keeping the aspect
//! ratio: the authors' preprocessing brings every NTIRE photograph to a short side of the field
//! plus the eye-motion margin (authors' code, docs/references.md#scenes, step 3).

/// The output pixels' input taps along one axis: `(first input index, weights)`.
fn taps(n_in: usize, n_out: usize) -> Vec<(usize, Vec<f32>)> {
    assert!(
        n_in > 0 && n_out > 0,
        "resize: empty axis ({n_in} → {n_out})"
    );
    if n_out >= n_in {
        let scale = if n_out > 1 {
            (n_in - 1) as f64 / (n_out - 1) as f64
        } else {
            0.0
        };
        (0..n_out)
            .map(|j| {
                let f = j as f64 * scale;
                let i0 = (f.floor() as usize).min(n_in.saturating_sub(2));
                let t = (f - i0 as f64) as f32;
                if n_in == 1 {
                    (0, vec![1.0])
                } else {
                    (i0, vec![1.0 - t, t])
                }
            })
            .collect()
    } else {
        let s = n_in as f64 / n_out as f64;
        (0..n_out)
            .map(|j| {
                let (a, b) = (j as f64 * s, (j + 1) as f64 * s);
                let first = a.floor() as usize;
                let last = (b.ceil() as usize).min(n_in);
                let w: Vec<f32> = (first..last)
                    .map(|i| ((b.min(i as f64 + 1.0) - a.max(i as f64)) / s) as f32)
                    .collect();
                (first, w)
            })
            .collect()
    }
}

/// Resize `(planes, h, w)` data to `(planes, nh, nw)` (module docs).
pub fn resize(data: &[f32], planes: usize, h: usize, w: usize, nh: usize, nw: usize) -> Vec<f32> {
    assert_eq!(
        data.len(),
        planes * h * w,
        "resize: {} values for {planes}×{h}×{w}",
        data.len()
    );
    if (nh, nw) == (h, w) {
        return data.to_vec();
    }
    let (ty, tx) = (taps(h, nh), taps(w, nw));
    let mut rows = vec![0.0f32; w];
    let mut out = Vec::with_capacity(planes * nh * nw);
    for p in 0..planes {
        let src = &data[p * h * w..(p + 1) * h * w];
        for (y0, wy) in &ty {
            rows.iter_mut().for_each(|v| *v = 0.0);
            for (k, &a) in wy.iter().enumerate() {
                let row = &src[(y0 + k) * w..(y0 + k + 1) * w];
                rows.iter_mut().zip(row).for_each(|(o, &v)| *o += a * v);
            }
            out.extend(tx.iter().map(|(x0, wx)| {
                wx.iter()
                    .enumerate()
                    .map(|(k, &a)| a * rows[x0 + k])
                    .sum::<f32>()
            }));
        }
    }
    out
}

/// Sizes `(nh, nw)` with `min(nh, nw) = short_px` and the aspect ratio of `(h, w)`, rounded.
pub fn short_side_size(h: usize, w: usize, short_px: usize) -> (usize, usize) {
    let scale = short_px as f64 / h.min(w).max(1) as f64;
    let long = |n: usize| ((n as f64 * scale).round() as usize).max(short_px);
    if h <= w {
        (short_px, long(w))
    } else {
        (long(h), short_px)
    }
}

/// Resize `(planes, h, w)` data so its short side is `short_px` (module docs): `(data, nh, nw)`.
pub fn resize_short_side(
    data: &[f32],
    planes: usize,
    h: usize,
    w: usize,
    short_px: usize,
) -> (Vec<f32>, usize, usize) {
    let (nh, nw) = short_side_size(h, w, short_px);
    (resize(data, planes, h, w, nh, nw), nh, nw)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::pool::resize_bilinear;

    #[test]
    fn shrinking_averages_the_pixels_each_output_covers() {
        // 2 planes of 4×6 → 2×3: each output is the mean of a 2×2 block.
        let data: Vec<f32> = (0..48).map(|i| (i * i % 17) as f32).collect();
        let out = resize(&data, 2, 4, 6, 2, 3);
        for p in 0..2 {
            for y in 0..2 {
                for x in 0..3 {
                    let at = |yy: usize, xx: usize| data[p * 24 + yy * 6 + xx];
                    let mean = (at(2 * y, 2 * x)
                        + at(2 * y, 2 * x + 1)
                        + at(2 * y + 1, 2 * x)
                        + at(2 * y + 1, 2 * x + 1))
                        / 4.0;
                    let got = out[p * 6 + y * 3 + x];
                    assert!((got - mean).abs() < 1e-5, "p{p} ({y},{x}): {got} vs {mean}");
                }
            }
        }
        // A fractional factor keeps the mean of a ramp and the value of a constant.
        let ramp: Vec<f32> = (0..7).map(|i| i as f32).collect();
        let r = resize(&ramp, 1, 1, 7, 1, 3);
        assert!((r.iter().sum::<f32>() / 3.0 - 3.0).abs() < 1e-5, "{r:?}");
        assert!(r.windows(2).all(|w| w[0] < w[1]), "{r:?}");
        let flat = resize(&[0.7; 35], 1, 5, 7, 3, 4);
        assert!(flat.iter().all(|&v| (v - 0.7).abs() < 1e-6), "{flat:?}");
    }

    #[test]
    fn enlarging_is_the_pools_bilinear_resize() {
        let data: Vec<f32> = (0..30).map(|i| ((i * 7) % 11) as f32 * 0.1).collect();
        let a = resize(&data, 2, 3, 5, 7, 9);
        let b = resize_bilinear(&data, 2, 3, 5, 7, 9);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-5, "{x} vs {y}");
        }
    }

    #[test]
    fn the_short_side_lands_on_the_size_asked() {
        assert_eq!(short_side_size(482, 512, 542), (542, 576));
        assert_eq!(short_side_size(482, 512, 192), (192, 204));
        assert_eq!(short_side_size(512, 482, 96), (102, 96));
        let (d, nh, nw) = resize_short_side(&[1.0; 2 * 40 * 48], 2, 40, 48, 96);
        assert_eq!((nh, nw, d.len()), (96, 115, 2 * 96 * 115));
    }
}
