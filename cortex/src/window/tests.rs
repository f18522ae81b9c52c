//! Tests of the decode windows: a window gives the whole field's percept at the cells asked for,
//! the longest window bounds every box, summed frames decode as summed activations, and a boxed
//! decode gives the window's percept in its box.

use super::*;
use crate::CortexConfig;

mod support {
    use super::*;

    /// A cortex of the tiny preset with every parameter drawn at random (so W, C and D are far
    /// from their identity initialisation).
    pub(super) fn scrambled(n: usize, widths: Vec<usize>) -> Cortex {
        let mut cfg = CortexConfig::preset("tiny").expect("tiny preset");
        cfg.ons_size_px = n;
        cfg.d.widths = widths;
        let mut cortex = Cortex::new(cfg).expect("cortex");
        let mut k = 17u32;
        let ids: Vec<_> = cortex.params.ids().collect();
        for id in ids {
            for v in cortex.params.get_mut(id).data_mut() {
                k = k.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *v += ((k >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 0.2;
            }
        }
        cortex
    }
}

mod whole_field {
    use super::support::scrambled;
    use super::*;

    #[test]
    fn windows_give_the_whole_field_percept_at_the_cells_asked_for() {
        let n = 64;
        let cortex = scrambled(n, vec![4, 8, 16]);
        let frames = 3;
        let ons: Vec<f32> = (0..frames * n * n)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) % 997) as f32 / 997.0)
            .collect();
        let whole = cortex.decode_frames(&ons, frames);
        let dim = cortex.percept_dim();
        // A box in the middle, one at a corner, one on an edge (one box per frame).
        let boxes = [([28, 35], [20, 27]), ([0, 7], [56, 63]), ([40, 47], [0, 7])];
        let sizes: Vec<Window> = boxes
            .iter()
            .map(|&(r, c)| cortex.exact_window(r, c))
            .collect();
        let (h, w) = (
            sizes.iter().map(|v| v.height).max().unwrap(),
            sizes.iter().map(|v| v.width).max().unwrap(),
        );
        assert!(h < n && w < n, "windows {sizes:?} are the whole field");
        // One size for the batch: each window grown, shifted inside the field.
        let windows: Vec<Window> = sizes.iter().map(|v| v.grown_to(h, w, n)).collect();
        let mut tape = Tape::<f32>::new();
        let o = tape.constant_from([frames, 1, n, n], &ons);
        let v = cortex.record_decode_windows(&mut tape, o, &windows, None);
        let got = tape.value(v).data();
        for (f, (&(rows, cols), win)) in boxes.iter().zip(&windows).enumerate() {
            for c in 0..dim {
                for r in rows[0]..=rows[1] {
                    for k in cols[0]..=cols[1] {
                        let a = whole[((f * dim + c) * n + r) * n + k];
                        let local = win.local_index(r * n + k, n).expect("inside its window");
                        let b = got[(f * dim + c) * h * w + local];
                        assert!(
                            (a - b).abs() <= 1e-5 * (1.0 + a.abs()),
                            "frame {f} channel {c} cell ({r}, {k}): {a} whole field, {b} window"
                        );
                    }
                }
            }
        }
    }
    #[test]
    fn the_longest_window_bounds_every_box_and_is_reached() {
        let n = 64;
        for widths in [vec![4, 8, 16], vec![4, 8, 16, 32]] {
            let cortex = scrambled(n, widths);
            for (rows_len, cols_len) in [(8, 8), (5, 13), (40, 2)] {
                let mut seen = (0, 0);
                for top in 0..=n - rows_len {
                    for left in 0..=n - cols_len {
                        let w = cortex
                            .exact_window([top, top + rows_len - 1], [left, left + cols_len - 1]);
                        seen = (seen.0.max(w.height), seen.1.max(w.width));
                    }
                }
                let got = longest_window(&cortex.config, rows_len, cols_len, n);
                assert_eq!(got, seen, "boxes of {rows_len} × {cols_len}");
            }
        }
        let mut identity = CortexConfig::preset("tiny").unwrap();
        identity.d.mode = crate::config::DMode::Identity;
        assert_eq!(longest_window(&identity, 5, 13, 64), (5, 13));
    }

    #[test]
    fn frames_summed_from_activations_decode_as_the_summed_ons_does() {
        let n = 64;
        let cortex = scrambled(n, vec![4, 8, 16]);
        // Three fixed frames and two sums of them with different weights.
        let basis: Vec<f32> = (0..3 * n * n)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) % 991) as f32 / 991.0)
            .collect();
        let weights = [[0.3f32, 1.2, 0.05], [2.0, 0.0, 0.7]];
        let pa_basis = cortex.activations(&basis, 3);
        let window = cortex.exact_window([20, 27], [30, 37]);
        let windows = [window; 2];
        let (h, w) = (window.height, window.width);
        let (mut ons, mut pa) = (vec![0f32; 2 * n * n], vec![0f32; 2 * h * w]);
        let mut cut = vec![0f32; h * w];
        for (f, wts) in weights.iter().enumerate() {
            for (k, &a) in wts.iter().enumerate() {
                let frame = &basis[k * n * n..(k + 1) * n * n];
                for (o, &x) in ons[f * n * n..(f + 1) * n * n].iter_mut().zip(frame) {
                    *o += a * x;
                }
                window.cut(&pa_basis[k * n * n..(k + 1) * n * n], n, &mut cut);
                for (o, &x) in pa[f * h * w..(f + 1) * h * w].iter_mut().zip(&cut) {
                    *o += a * x;
                }
            }
        }
        let mut tape = Tape::<f32>::new();
        let o = tape.constant_from([2, 1, n, n], &ons);
        let from_ons = cortex.record_decode_windows(&mut tape, o, &windows, None);
        let from_ons = tape.value(from_ons).data().to_vec();
        let from_pa = cortex.record_decode_activation_windows(&mut tape, &pa, &windows, None);
        let from_pa = tape.value(from_pa).data();
        assert_eq!(from_ons.len(), from_pa.len());
        let scale = from_ons.iter().fold(0f32, |m, x| m.max(x.abs()));
        for (i, (a, b)) in from_ons.iter().zip(from_pa).enumerate() {
            assert!(
                (a - b).abs() <= 1e-5 * scale,
                "value {i}: {a} from the summed ONS, {b} from summed activations (scale {scale})"
            );
        }
        // and a frame that is not the sum decodes otherwise
        pa.iter_mut().for_each(|x| *x *= 1.5);
        let other = cortex.record_decode_activation_windows(&mut tape, &pa, &windows, None);
        let other = tape.value(other).data();
        assert!(from_ons
            .iter()
            .zip(other)
            .any(|(a, b)| (a - b).abs() > 1e-3 * scale));
    }
}

mod boxes {
    use super::support::scrambled;
    use super::*;

    #[test]
    fn a_boxed_decode_gives_the_windows_percept_in_its_box() {
        let n = 64;
        let cortex = scrambled(n, vec![4, 8, 16]);
        let window = cortex.exact_window([20, 27], [30, 37]);
        let windows = [window; 2];
        let (h, w) = (window.height, window.width);
        let pa: Vec<f32> = (0..2 * h * w)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) % 983) as f32 / 983.0)
            .collect();
        let mut tape = Tape::<f32>::new();
        let whole = cortex.record_decode_activation_windows(&mut tape, &pa, &windows, None);
        let whole = tape.value(whole).data().to_vec();
        let dim = cortex.percept_dim();
        // The cells asked for, inside the window; and a box at the window's corner.
        let inside = |r: usize, c: usize| (r - window.top, c - window.left);
        let (r0, c0) = inside(20, 30);
        let (r1, c1) = inside(27, 37);
        for out_box in [
            OutputBox {
                rows: [r0, r1],
                cols: [c0, c1],
            },
            OutputBox {
                rows: [0, 3],
                cols: [w - 5, w - 1],
            },
        ] {
            let v =
                cortex.record_decode_activation_windows(&mut tape, &pa, &windows, Some(out_box));
            let (bh, bw) = out_box.size();
            assert_eq!(tape.shape(v).dims(), &[2, dim, bh, bw]);
            let boxed = tape.value(v).data();
            for (i, &b) in boxed.iter().enumerate() {
                let (plane, r, k) = (i / (bh * bw), i / bw % bh, i % bw);
                let a = whole[(plane * h + r + out_box.rows[0]) * w + k + out_box.cols[0]];
                assert!(
                    (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                    "{out_box:?}: plane {plane} at ({r}, {k}): {a} window, {b} box"
                );
            }
        }
    }
}
