use super::super::{UNet, UNetConfig};
use super::OutputBox;
use crate::{ParamStore, Tape, Tensor};

fn net(widths: Vec<usize>) -> (UNet, ParamStore<f32>) {
    let mut ps = ParamStore::<f32>::new();
    let cfg = UNetConfig {
        in_channels: 2,
        out_channels: 3,
        widths,
        seed: 7,
    };
    (UNet::new(&mut ps, "u", cfg), ps)
}

/// The output `(C, H, W)` of one image `(2, h, w)`.
fn run(net: &UNet, ps: &ParamStore<f32>, x: &[f32], h: usize, w: usize) -> Vec<f32> {
    let mut tape = Tape::<f32>::new();
    let v = tape.constant_from([1, 2, h, w], x);
    let y = net.forward(&mut tape, ps, v);
    tape.value(y).data().to_vec()
}

fn image(h: usize, w: usize, seed: u32) -> Vec<f32> {
    Tensor::<f32>::from_fn([2, h, w], |i| {
        let k = (i as u32).wrapping_mul(2_654_435_761).wrapping_add(seed);
        (k % 1000) as f32 / 500.0 - 1.0
    })
    .data()
    .to_vec()
}

#[test]
fn reach_of_the_official_depths() {
    // Worked by hand from the module docs' rules, level by level.
    let (n2, _) = net(vec![4, 8]);
    assert_eq!(n2.alignment_px(), 2);
    assert_eq!(n2.input_interval([10, 10]), [2, 19]);
    let (n4, _) = net(vec![4, 8, 16, 32]);
    assert_eq!(n4.alignment_px(), 8);
    assert_eq!(n4.input_interval([40, 40]), [-6, 85]);
    assert_eq!(n4.exact_window([40, 40], 256), [0, 88]);
    assert_eq!(n4.exact_window([100, 130], 256), [48, 184]);
}

#[test]
fn the_longest_window_is_the_longest_over_every_start() {
    for widths in [
        vec![4],
        vec![4, 8],
        vec![4, 8, 16, 32],
        vec![4, 8, 16, 32, 64],
    ] {
        let (unet, _) = net(widths.clone());
        let config = UNetConfig {
            in_channels: 2,
            out_channels: 3,
            widths,
            seed: 7,
        };
        for (len, size) in [(1, 256), (31, 256), (40, 64), (200, 256), (64, 64)] {
            // Every start in the field, clamped as a real window is.
            let longest = (0..=size - len)
                .map(|a| {
                    let [s, e] = unet.exact_window([a, a + len - 1], size);
                    e - s
                })
                .max()
                .unwrap();
            let got = config.longest_exact_window(len, size);
            assert!(got >= longest, "{len} of {size}: {got} < {longest}");
            // Unclamped, in a field large enough, the longest start is reached.
            let free = (0..64)
                .map(|a| {
                    let [s, e] = unet.exact_window([512 + a, 512 + a + len - 1], 2048);
                    e - s
                })
                .max()
                .unwrap();
            assert_eq!(got, free.min(size), "{len} of {size}");
        }
    }
}

#[test]
fn a_window_decodes_its_box_as_the_whole_field_does() {
    let (net, ps) = net(vec![4, 8, 16]);
    let n = 64;
    let x = image(n, n, 3);
    let full = run(&net, &ps, &x, n, n);
    // Boxes in the middle, at a corner and at an edge.
    for (rows, cols) in [([26, 33], [20, 29]), ([0, 5], [58, 63]), ([30, 31], [0, 9])] {
        let [r0, r1] = net.exact_window(rows, n);
        let [c0, c1] = net.exact_window(cols, n);
        assert!(
            rows[0] == 0 || c1 - c0 < n,
            "window {c0}..{c1} is the whole field"
        );
        let (h, w) = (r1 - r0, c1 - c0);
        let crop: Vec<f32> = (0..2)
            .flat_map(|c| (r0..r1).flat_map(move |r| (c0..c1).map(move |k| (c, r, k))))
            .map(|(c, r, k)| x[(c * n + r) * n + k])
            .collect();
        let win = run(&net, &ps, &crop, h, w);
        for c in 0..3 {
            for r in rows[0]..=rows[1] {
                for k in cols[0]..=cols[1] {
                    let a = full[(c * n + r) * n + k];
                    let b = win[(c * h + r - r0) * w + k - c0];
                    assert!(
                        (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                        "box {rows:?}×{cols:?} channel {c} at ({r}, {k}): {a} whole, {b} window"
                    );
                }
            }
        }
    }
}

#[test]
fn a_boxed_decode_gives_the_whole_inputs_outputs_in_its_box() {
    let nets = [
        vec![4],
        vec![4, 8],
        vec![4, 8, 16],
        vec![4, 8, 16, 32],
        vec![4, 8, 16, 32, 64],
    ];
    for widths in nets {
        let (net, ps) = net(widths);
        let (h, w) = (64, 48);
        let x = image(h, w, 11);
        let full = run(&net, &ps, &x, h, w);
        // Middle, corners, edges, one pixel, a thin strip, near the far corner off the
        // pooling grid, and the whole input.
        for (rows, cols) in [
            ([20, 37], [13, 30]),
            ([0, 5], [42, 47]),
            ([58, 63], [0, 0]),
            ([31, 31], [17, 17]),
            ([1, 62], [23, 24]),
            ([49, 61], [33, 45]),
            ([0, 63], [0, 47]),
        ] {
            let mut tape = Tape::<f32>::new();
            let v = tape.constant_from([1, 2, h, w], &x);
            let out_box = OutputBox { rows, cols };
            let y = net.forward_box(&mut tape, &ps, v, out_box);
            let (bh, bw) = out_box.size();
            assert_eq!(tape.shape(y).dims(), &[1, 3, bh, bw]);
            let boxed = tape.value(y).data();
            for c in 0..3 {
                for r in 0..bh {
                    for k in 0..bw {
                        let a = full[(c * h + r + rows[0]) * w + k + cols[0]];
                        let b = boxed[(c * bh + r) * bw + k];
                        // The 3×3 convs sum each pixel in one order whatever the region;
                        // the 1×1 output conv is a GEMM, whose order may change with it.
                        assert!(
                            (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                            "{} levels, box {rows:?}×{cols:?}, channel {c} at ({r}, {k}): \
                             {a} whole, {b} boxed",
                            net.downs.len()
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn the_up_blocks_regions_of_a_box_in_the_middle_are_worked_by_hand() {
    let (net, _) = net(vec![4, 8, 16, 32]);
    // Level 0: [40, 41] → [38, 43]; level 1: [19, 21] → [17, 23] → [16, 23];
    // level 2: [8, 11] → [6, 13]. A box at the edge is clamped to the image.
    assert_eq!(
        net.up_regions([40, 41], 64),
        vec![[38, 43], [16, 23], [6, 13]]
    );
    assert_eq!(net.up_regions([0, 0], 64), vec![[0, 3], [0, 3], [0, 3]]);
    assert_eq!(
        net.up_regions([63, 63], 64),
        vec![[60, 63], [28, 31], [12, 15]]
    );
}

fn decode_box(rows: [usize; 2], cols: [usize; 2]) {
    let (net, ps) = net(vec![4, 8]);
    let mut tape = Tape::<f32>::new();
    let v = tape.constant_from([1, 2, 8, 8], &image(8, 8, 1));
    net.forward_box(&mut tape, &ps, v, OutputBox { rows, cols });
}

#[test]
#[should_panic(expected = "UNet::forward_box")]
fn a_box_past_its_input_is_refused() {
    decode_box([2, 8], [0, 1]);
}

#[test]
#[should_panic(expected = "UNet::forward_box")]
fn a_reversed_box_is_refused() {
    decode_box([5, 2], [0, 1]);
}

#[test]
fn outside_the_interval_nothing_reaches_the_box_and_at_its_edge_something_does() {
    let (net, ps) = net(vec![4, 8, 16]);
    let n = 64;
    let x = image(n, n, 5);
    let full = run(&net, &ps, &x, n, n);
    let rows = [30usize, 32];
    let [lo, hi] = net.input_interval([30, 32]);
    let changed = |row: i64| {
        let mut y = x.clone();
        for c in 0..2 {
            for k in 0..n {
                y[(c * n + row as usize) * n + k] += 5.0;
            }
        }
        let out = run(&net, &ps, &y, n, n);
        (0..3).any(|c| {
            (rows[0]..=rows[1])
                .any(|r| (0..n).any(|k| out[(c * n + r) * n + k] != full[(c * n + r) * n + k]))
        })
    };
    assert!(
        !changed(lo - 1) && !changed(hi + 1),
        "rows outside [{lo}, {hi}] reach the box"
    );
    assert!(
        changed(lo) && changed(hi),
        "the interval [{lo}, {hi}] is wider than the reach"
    );
}
