//! Tests of the convolution lowering: reflect padding, fold as the adjoint of pad, window views and row tiles.

use super::*;

fn rng(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

#[test]
fn reflect_matches_pytorch_convention() {
    // PyTorch 'reflect' on [a b c d] with pad 2: [c b | a b c d | c b].
    let got: Vec<_> = (-2..6)
        .map(|i| source(i, 4, Padding::Reflect).unwrap())
        .collect();
    assert_eq!(got, vec![2, 1, 0, 1, 2, 3, 2, 1]);
    assert_eq!(source(-1, 4, Padding::Zero), None);
}

#[test]
fn fold_is_adjoint_to_pad_and_im2col_matches_views() {
    // <pad(x), z> == <x, fold(z)> with z laid out planar at row width Wz.
    let mut rnd = rng(7);
    for mode in [Padding::Zero, Padding::Reflect] {
        for (c, h, w, k) in [(2, 2, 2, 3), (3, 3, 5, 3), (2, 6, 4, 5), (2, 3, 33, 3)] {
            let g = Geometry { c, h, w, k, mode };
            let (hp, wp, wz) = (g.hp(), g.wp(), g.wz());
            let x: Vec<f64> = (0..c * h * w).map(|_| rnd()).collect();
            let mut xp = vec![f64::NAN; g.padded_len()];
            g.pad(&x, &mut xp);
            let z: Vec<f64> = (0..c * hp * wz).map(|_| rnd()).collect();
            let lhs: f64 = (0..c)
                .flat_map(|ch| (0..hp).flat_map(move |u| (0..wp).map(move |v| (ch, u, v))))
                .map(|(ch, u, v)| xp[(ch * hp + u) * g.rw() + v] * z[(ch * hp + u) * wz + v])
                .sum();
            let mut dx = vec![0.0; x.len()];
            // Two tiles, to exercise the row offsets.
            let mid = hp / 2;
            for (u0, u1) in [(0, mid), (mid, hp)] {
                let t: Vec<f64> = (0..c)
                    .flat_map(|ch| z[(ch * hp + u0) * wz..(ch * hp + u1) * wz].to_vec())
                    .collect();
                g.fold_rows_add(&t, u0, u1, &mut dx);
            }
            let rhs: f64 = x.iter().zip(&dx).map(|(a, b)| a * b).sum();
            assert!(
                (lhs - rhs).abs() < 1e-12,
                "{mode:?} {c}x{h}x{w} k{k}: {lhs} vs {rhs}"
            );
            assert!(
                xp[c * g.plane()..].iter().all(|&v| v == 0.0),
                "slack is zero"
            );
            // im2col row c·k² + t is the strided view X_t row c.
            let (r0, r1) = (h / 2, h);
            let n = (r1 - r0) * g.rw();
            let mut col = vec![0.0; c * k * k * n];
            g.im2col(&xp, r0, r1, &mut col);
            for t in 0..k * k {
                let v = g.x_view(&xp, t, r0, r1);
                let mut picked = vec![0.0; c * n];
                let eye: Vec<f64> = (0..c * c)
                    .map(|i| f64::from(u8::from(i % (c + 1) == 0)))
                    .collect();
                f64::gemm_view(&mut picked, false, MatView::row_major(&eye, c, c), v, 1.0);
                for ch in 0..c {
                    assert_eq!(&col[(ch * k * k + t) * n..][..n], &picked[ch * n..][..n]);
                }
            }
        }
    }
}

#[test]
fn tiles_cover_all_rows() {
    for (rows, per_row) in [
        (64, 16 * 66),
        (16, 64 * 18),
        (258, 16 * 258),
        (3, 1),
        (1, 1 << 30),
    ] {
        let t = tiles(rows, per_row);
        assert_eq!(t.first().unwrap().0, 0);
        assert_eq!(t.last().unwrap().1, rows);
        assert!(t.windows(2).all(|p| p[0].1 == p[1].0));
    }
}
