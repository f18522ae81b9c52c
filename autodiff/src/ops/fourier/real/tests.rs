//! The real-input / real-output transforms against the complex ones around them, at sizes
//! with several column blocks, in f64 and f32, values and gradients.

use crate::{Float, Tape, Tensor, Var};

/// Values and gradients (for a fixed cotangent) of `real` against `complex`, both applied
/// to `x`, in the precision `T`.
fn agree<T: Float>(
    x: &Tensor<f64>,
    dy_shape: &[usize],
    real: impl Fn(&mut Tape<T>, Var) -> Var,
    complex: impl Fn(&mut Tape<T>, Var) -> Var,
    tol: f64,
) {
    let dy = Tensor::from_fn(crate::Shape::new(dy_shape), |i| {
        ((i as f64) * 0.77 + 0.3).sin()
    })
    .cast::<T>();
    let run = |f: &dyn Fn(&mut Tape<T>, Var) -> Var| {
        let mut tape = Tape::<T>::new();
        let v = tape.leaf(x.cast());
        let y = f(&mut tape, v);
        tape.backward_from(&[(y, dy.clone())], &mut crate::NoHooks);
        (
            tape.value(y).cast::<f64>(),
            tape.grad(v).unwrap().cast::<f64>(),
        )
    };
    let (ya, ga) = run(&real);
    let (yb, gb) = run(&complex);
    let scale = 1.0 + yb.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        ya.max_abs_diff(&yb) <= tol * scale,
        "values differ by {}",
        ya.max_abs_diff(&yb)
    );
    let scale = 1.0 + gb.data().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        ga.max_abs_diff(&gb) <= tol * scale,
        "gradients differ by {}",
        ga.max_abs_diff(&gb)
    );
}

/// Sizes with several column blocks, odd and even `W` and `H`, `H = 1` and `W = 1`.
const SIZES: [(usize, usize, usize); 6] = [
    (2, 17, 33),
    (1, 40, 34),
    (3, 9, 16),
    (2, 1, 21),
    (2, 12, 1),
    (1, 64, 64),
];

fn check_sizes<T: Float>(tol: f64) {
    for (b, h, w) in SIZES {
        let img = Tensor::from_fn([b, h, w], |i| ((i as f64) * 1.913).sin());
        agree::<T>(
            &img,
            &[b, h, w, 2],
            |t, v| t.fft2_real(v),
            |t, v| {
                let c = t.to_complex(v);
                t.fft2(c)
            },
            tol,
        );
        let spec = Tensor::from_fn([b, h, w, 2], |i| ((i as f64) * 0.531).cos());
        agree::<T>(
            &spec,
            &[b, h, w],
            |t, v| t.ifft2_real(v),
            |t, v| {
                let y = t.ifft2(v);
                t.real_part(y)
            },
            tol,
        );
    }
}

#[test]
fn real_paths_match_complex_paths_f64() {
    check_sizes::<f64>(1e-12);
}

#[test]
fn real_paths_match_complex_paths_f32() {
    check_sizes::<f32>(1e-5);
}
