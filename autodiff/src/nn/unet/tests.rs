//! Tests of the U-Net demosaicker: parameter counts, initialisation, gradients of a tiny net and a short learning run.

use super::*;
use crate::check::{check_gradients, CheckConfig};
use crate::learn::ParamGrads;
use crate::optim::{Adam, Optimizer};
use std::f64::consts::TAU;

#[test]
fn parameter_counts_match_the_official_model() {
    let mut ps = ParamStore::<f32>::new();
    let net = UNet::new(&mut ps, "d", UNetConfig::official());
    assert_eq!(net.num_params(&ps), 482_168);
    assert_eq!(ps.numel(), 482_168);
    let mut ps = ParamStore::<f32>::new();
    let net = UNet::new(&mut ps, "d", UNetConfig::quick());
    assert_eq!(net.num_params(&ps), 117_560);
    assert_eq!(ps.name(net.param_ids()[0]), "d.inc.conv0.weight");
    assert!(ps.find("d.up1.up.bias").is_some() && ps.find("d.outc.bias").is_some());
}

#[test]
fn init_follows_pytorch_bounds() {
    let mut ps = ParamStore::<f64>::new();
    UNet::new(&mut ps, "d", UNetConfig::quick());
    for (name, bound) in [
        ("d.inc.conv0.weight", 1.0 / 72f64.sqrt()),
        ("d.up1.up.weight", 1.0 / 128f64.sqrt()),
        ("d.up2.up.bias", 1.0 / 64f64.sqrt()),
        ("d.outc.weight", 0.25),
    ] {
        let t = ps.get(ps.find(name).unwrap());
        let max = t.data().iter().fold(0.0f64, |m, &v| m.max(v.abs()));
        assert!(
            max < bound && max > 0.8 * bound,
            "{name}: max |w| {max}, bound {bound}"
        );
    }
}

#[test]
fn forward_shape_and_gradient_of_a_tiny_net() {
    let cfg = UNetConfig {
        in_channels: 2,
        out_channels: 3,
        widths: vec![2, 3],
        seed: 1,
    };
    let mut ps = ParamStore::<f64>::new();
    let net = UNet::new(&mut ps, "u", cfg);
    let ids = net.param_ids();
    let mut inputs = vec![Tensor::from_fn([2, 2, 4, 6], |i| {
        ((i * 7919) % 97) as f64 / 48.0 - 1.0
    })];
    inputs.extend(ids.iter().map(|&id| ps.get(id).clone()));
    // Every parameter is a checked input: v[0] is x, v[k + 1] is parameter ids[k].
    let r = check_gradients(
        |t, v| {
            net.forward_with(t, v[0], |_, id| {
                v[1 + ids.iter().position(|&i| i == id).unwrap()]
            })
        },
        &inputs,
        &CheckConfig::default(),
    );
    assert!(r.is_ok(), "{}", r.unwrap_err());
    let mut t = Tape::<f64>::new();
    let x = t.constant(inputs[0].clone());
    let y = net.forward(&mut t, &ps, x);
    assert_eq!(t.shape(y), crate::Shape::new(&[2, 3, 4, 6]));
}

#[test]
fn every_layer_is_tagged_and_every_block_has_its_scope() {
    let mut ps = ParamStore::<f32>::new();
    let net = UNet::new(&mut ps, "d", UNetConfig::quick()).with_block_scopes("D");
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([1, 8, 8, 8]));
    let a = net.forward_blocks(&mut t, &ps, x);
    let tags: Vec<&str> = t.tags().iter().map(|x| x.0).collect();
    let layers = [
        "d.inc.conv0",
        "d.inc.conv1",
        "d.down1.conv0",
        "d.down1.conv1",
        "d.down2.conv0",
        "d.down2.conv1",
        "d.up1.up",
        "d.up1.conv0",
        "d.up1.conv1",
        "d.up2.up",
        "d.up2.conv0",
        "d.up2.conv1",
        "d.outc",
    ];
    assert_eq!(tags, layers);
    for tag in layers {
        assert!(ps.find(&format!("{tag}.weight")).is_some(), "{tag}");
    }
    let scopes: Vec<_> = a.blocks.iter().map(|&b| t.scope_of(b).unwrap()).collect();
    assert_eq!(scopes, ["D.inc", "D.down1", "D.down2", "D.up1", "D.up2"]);
    assert_eq!(net.block_scopes().unwrap(), scopes.as_slice());
    assert_eq!(*a.blocks.last().unwrap(), a.output);
    let (_, _, h, _) = t.shape(a.blocks[2]).bchw("test");
    assert_eq!(h, 2, "the deepest block is 4× coarser");
    // without block scopes nothing is entered
    let mut ps = ParamStore::<f32>::new();
    let plain = UNet::new(&mut ps, "d", UNetConfig::quick());
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([1, 8, 8, 8]));
    let y = plain.forward(&mut t, &ps, x);
    assert_eq!(t.scope_of(y), None);
}

#[test]
#[should_panic(
    expected = "UNet: input (1, 8, 12, 16) does not fit (want 8 channels, H and W divisible by 8)"
)]
fn indivisible_size_panics() {
    let mut ps = ParamStore::<f32>::new();
    let net = UNet::new(&mut ps, "d", UNetConfig::official());
    let mut t = Tape::<f32>::new();
    let x = t.constant(Tensor::zeros([1, 8, 12, 16]));
    net.forward(&mut t, &ps, x);
}

/// Smooth random RGB images and their mosaic: each pixel keeps one of 3 colours (a fixed
/// random pattern), given to the net as 3 channels that are zero where not sampled.
fn mosaic_batch(
    rng: &mut StdRng,
    pattern: &[usize],
    b: usize,
    s: usize,
) -> (Tensor<f32>, Tensor<f32>) {
    let mut full = Tensor::<f32>::zeros([b, 3, s, s]);
    for img in full.data_mut().chunks_exact_mut(s * s) {
        let (fx, fy) = (rng.random_range(0.5..2.0), rng.random_range(0.5..2.0));
        let (px, py, base) = (
            rng.random_range(0.0..6.3),
            rng.random_range(0.0..6.3),
            rng.random_range(0.2..0.8),
        );
        let amp = rng.random_range(0.1..0.3);
        for (q, v) in img.iter_mut().enumerate() {
            let (i, j) = ((q / s) as f64 / s as f64, (q % s) as f64 / s as f64);
            *v = (base + amp * ((TAU * fx * i + px).sin() * (TAU * fy * j + py).cos())) as f32;
        }
    }
    let mut mosaic = Tensor::<f32>::zeros([b, 3, s, s]);
    for (q, m) in mosaic.data_mut().iter_mut().enumerate() {
        let (ch, px) = ((q / (s * s)) % 3, q % (s * s));
        if pattern[px] == ch {
            *m = full.data()[q];
        }
    }
    (mosaic, full)
}

#[test]
fn learns_to_demosaic_smooth_images() {
    let s = 16;
    let mut rng = StdRng::seed_from_u64(42);
    let pattern: Vec<usize> = (0..s * s).map(|_| rng.random_range(0..3)).collect();
    let mut ps = ParamStore::<f32>::new();
    let cfg = UNetConfig {
        in_channels: 3,
        out_channels: 3,
        widths: vec![8, 16],
        seed: 3,
    };
    let net = UNet::new(&mut ps, "d", cfg);
    let mut opt = Optimizer::new(Adam::default());
    let (test_x, test_y) = mosaic_batch(&mut rng, &pattern, 8, s);
    let mut tape = Tape::<f32>::new();
    let eval = |tape: &mut Tape<f32>, ps: &ParamStore<f32>| {
        tape.clear();
        let (x, y) = (tape.constant(test_x.clone()), tape.constant(test_y.clone()));
        let out = net.forward(tape, ps, x);
        let l = tape.mse(out, y);
        tape.value(l).item()
    };
    let before = eval(&mut tape, &ps);
    let mut grads = ParamGrads::new();
    let start = std::time::Instant::now();
    for _ in 0..150 {
        let (bx, by) = mosaic_batch(&mut rng, &pattern, 8, s);
        tape.clear();
        let (x, y) = (tape.constant(bx), tape.constant(by));
        let out = net.forward(&mut tape, &ps, x);
        let l = tape.mse(out, y);
        tape.backward(l);
        grads.fill_from_tape(&tape);
        opt.step(3e-3, &mut ps, &grads).unwrap();
    }
    let after = eval(&mut tape, &ps);
    eprintln!(
        "demosaic: test MSE {before:.4} → {after:.5} in {:?}",
        start.elapsed()
    );
    assert!(
        after * 10.0 <= before,
        "test MSE fell only from {before} to {after}"
    );
}
