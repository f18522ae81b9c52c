//! Forward-forward on a small problem: it separates positive from negative data (goodness
//! gap up ≥ 10×), and its update of a lower layer is not backprop's of the same objectives.

use autodiff::learn::{threshold_goodness_loss, Backprop, ForwardForward, LearningRule};
use autodiff::optim::{Adam, Optimizer};
use autodiff::{ParamId, ParamStore, Tape, Tensor, Var};

/// Deterministic values in [−1, 1) (Knuth's multiplicative hash).
fn unit(i: usize) -> f64 {
    (((i * 2654435761) >> 9) % 2000) as f64 / 1000.0 - 1.0
}

/// `‖a − b‖ / ‖b‖`.
fn rel_diff(a: &Tensor<f64>, b: &Tensor<f64>) -> f64 {
    let d: f64 = a
        .data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).powi(2))
        .sum();
    (d / b.sum_sq()).sqrt()
}

/// Hinton's supervised forward-forward on two interleaved classes: the input is a point and
/// a one-hot label; positive data carry the right label, negative data the other one.
/// Layers `(4 → 24) → (24 → 24)` with ReLU, goodness = mean square of a layer's units, the
/// second layer reading the first's output normalised to unit RMS.
struct Labelled {
    pos: Tensor<f64>,
    neg: Tensor<f64>,
}

impl Labelled {
    fn new() -> Self {
        let n = 64;
        let point = |i: usize| {
            let class = i % 2;
            let r = 0.5 + class as f64 + 0.2 * unit(5 * i);
            let a = std::f64::consts::PI * unit(11 * i + 1);
            ([r * a.cos(), r * a.sin()], class)
        };
        let make = |right: bool| {
            Tensor::from_fn([n, 4], |k| {
                let (xy, class) = point(k / 4);
                let label = if right { class } else { 1 - class };
                match k % 4 {
                    j @ 0..=1 => xy[j],
                    j => f64::from(u8::from(j - 2 == label)),
                }
            })
        };
        Labelled {
            pos: make(true),
            neg: make(false),
        }
    }

    fn params() -> ParamStore<f64> {
        let mut p = ParamStore::new();
        p.add("l1", Tensor::from_fn([4, 24], |i| unit(13 * i + 5) * 0.5));
        p.add("l2", Tensor::from_fn([24, 24], |i| unit(17 * i + 2) * 0.2));
        p
    }

    /// Records both layers on positive and negative data with their local losses; returns the
    /// goodness `(g⁺, g⁻)` per layer.
    fn record(&self, tape: &mut Tape<f64>, p: &ParamStore<f64>) -> Vec<(Var, Var)> {
        tape.clear();
        let mut inputs = [
            tape.constant(self.pos.clone()),
            tape.constant(self.neg.clone()),
        ];
        let mut out = Vec::new();
        for (k, scope) in ["l1", "l2"].into_iter().enumerate() {
            tape.enter_scope(scope);
            let w = p.var(tape, ParamId(k as u32));
            let mut g = [inputs[0]; 2];
            for (j, x) in inputs.iter_mut().enumerate() {
                if k > 0 {
                    // Hinton: the next layer sees only the direction of this layer's activity.
                    let sq = tape.square(*x);
                    let ms = tape.mean_axes(sq, &[1], true);
                    let ms = tape.add_scalar(ms, 1e-6);
                    let rms = tape.sqrt(ms);
                    let rms = tape.broadcast_to(rms, tape.shape(*x));
                    *x = tape.div(*x, rms);
                }
                let h = tape.matmul(*x, w);
                *x = tape.relu(h);
                let sq = tape.square(*x);
                g[j] = tape.mean_axes(sq, &[1], false);
            }
            let loss = threshold_goodness_loss(tape, g[0], g[1], 1.0);
            tape.declare_local_loss(scope, loss);
            out.push((g[0], g[1]));
        }
        out
    }

    /// Mean goodness of positive minus negative data, summed over the layers.
    fn gap(tape: &Tape<f64>, goodness: &[(Var, Var)]) -> f64 {
        let mean = |v: Var| {
            let t = tape.value(v);
            t.data().iter().sum::<f64>() / t.numel() as f64
        };
        goodness.iter().map(|&(p, n)| mean(p) - mean(n)).sum()
    }
}

#[test]
fn forward_forward_separates_positive_from_negative_data() {
    let task = Labelled::new();
    let mut p = Labelled::params();
    let mut opt = Optimizer::new(Adam::default());
    let mut tape = Tape::new();
    let first = {
        let g = task.record(&mut tape, &p);
        Labelled::gap(&tape, &g)
    };
    for _ in 0..300 {
        let g = task.record(&mut tape, &p);
        let loss = g[0].0; // not used by the rule
        let grads = ForwardForward::default().assign_credit(&mut tape, loss.into(), &p);
        opt.step(0.01, &mut p, &grads).unwrap();
    }
    let g = task.record(&mut tape, &p);
    let last = Labelled::gap(&tape, &g);
    eprintln!("forward-forward goodness gap {first:.5} → {last:.4}");
    assert!(
        last >= 10.0 * first.abs() && last > 0.0,
        "goodness gap {first} → {last}"
    );
}

#[test]
fn forward_forward_is_not_backprop_of_its_own_objectives() {
    let task = Labelled::new();
    let p = Labelled::params();
    let mut tape = Tape::new();
    let g = task.record(&mut tape, &p);
    let ff = ForwardForward::default().assign_credit(&mut tape, g[0].0.into(), &p);
    // backprop of the same objectives, summed, reaches layer 1 through layer 2's loss too
    let g = task.record(&mut tape, &p);
    assert_eq!(g.len(), 2);
    let losses: Vec<Var> = tape.local_losses().iter().map(|x| x.1).collect();
    let total = tape.add(losses[0], losses[1]);
    let bp = Backprop.assign_credit(&mut tape, total.into(), &p);
    let r = rel_diff(ff.get(ParamId(0)).unwrap(), bp.get(ParamId(0)).unwrap());
    assert!(
        r > 0.01,
        "forward-forward's layer-1 update differs by only {r}"
    );
    let r = rel_diff(ff.get(ParamId(1)).unwrap(), bp.get(ParamId(1)).unwrap());
    assert!(r < 1e-12, "layer 2's own objective: differs by {r}");
}
