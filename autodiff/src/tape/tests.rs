//! Tests of the tape: stale and foreign handles, the buffer pool, and gradient accumulation.

use super::*;

#[test]
#[should_panic(expected = "stale")]
fn stale_var_panics() {
    let mut tape = Tape::<f32>::new();
    let x = tape.constant(Tensor::scalar(1.0));
    tape.clear();
    tape.value(x);
}

#[test]
#[should_panic(expected = "belongs to tape")]
fn foreign_var_panics() {
    let mut a = Tape::<f32>::new();
    let b = Tape::<f32>::new();
    let x = a.constant(Tensor::scalar(1.0));
    b.value(x);
}

#[test]
fn pool_reuses_buffers_after_clear() {
    let mut tape = Tape::<f32>::new();
    for _ in 0..3 {
        tape.clear();
        let x = tape.leaf(Tensor::full([4, 4], 2.0));
        let _ = tape.detach(x);
    }
    // First iteration allocates two 16-element buffers; later iterations reuse them.
    assert_eq!(tape.pool().fresh_allocations, 1);
}

/// Pooled tensors start on a cache line whatever their length, keep their values through
/// `put` and reuse, compare and clone by their elements only, and `into_vec` hands back
/// exactly their elements.
#[test]
fn pooled_tensors_are_cache_line_aligned() {
    fn check<T: Float>() {
        let aligned = |t: &Tensor<T>| (t.data().as_ptr() as usize).is_multiple_of(64);
        let mut pool = BufferPool::<T>::default();
        for n in [1, 3, 17, 1000] {
            let shape = Shape::new(&[n]);
            let src: Vec<T> = (0..n).map(|i| T::of(i as f64 + 1.0)).collect();
            let a = pool.copy_of(shape, &src);
            assert!(aligned(&a) && a.data() == &src[..], "copy_of, n = {n}");
            pool.put(a);
            let z = pool.zeros(shape);
            assert!(aligned(&z), "zeros, n = {n}");
            assert!(z.data().iter().all(|&v| v == T::zero()));
            let b = pool.copy_of(shape, &src);
            assert_eq!(b.clone(), Tensor::from_vec([n], src.clone()));
            assert_eq!(b.into_vec(), src);
        }
        // A tensor made from a caller's Vec (no room to align) is pooled and reused too.
        pool.put(Tensor::from_vec([5], vec![T::one(); 5]));
        let before = pool.fresh_allocations;
        let u = pool.zeros(Shape::new(&[5]));
        assert_eq!(pool.fresh_allocations, before);
        assert_eq!(u.data(), &[T::zero(); 5][..]);
    }
    check::<f32>();
    check::<f64>();
}

/// An op that hands its input an owned gradient ([`GradSlots::give`]).
struct Give(Tensor<f32>);

impl Op<f32> for Give {
    fn name(&self) -> &'static str {
        "give"
    }
    fn output_shape(&self, _inputs: &[&Tensor<f32>]) -> Shape {
        Shape::scalar()
    }
    fn forward(&mut self, _inputs: &[&Tensor<f32>], _out: &mut Tensor<f32>) {}
    fn backward(&self, _cx: &crate::BackwardCx<'_, f32>, dx: &mut crate::GradSlots<'_, f32>) {
        dx.give(0, self.0.clone());
    }
}

/// The first gradient handed over becomes the accumulator as is; a second one is added.
#[test]
fn give_installs_then_adds() {
    let mut tape = Tape::<f32>::new();
    let x = tape.leaf(Tensor::full([3], 0.0));
    let a = tape.apply(Give(Tensor::from_fn([3], |i| i as f32)), &[x]);
    let b = tape.apply(Give(Tensor::full([3], 10.0)), &[x]);
    let s = tape.add(a, b);
    tape.backward(s);
    assert_eq!(tape.grad(x).unwrap().data(), &[10.0, 11.0, 12.0]);
    let one = tape.apply(Give(Tensor::from_fn([3], |i| i as f32)), &[x]);
    tape.backward(one);
    assert_eq!(tape.grad(x).unwrap().data(), &[0.0, 1.0, 2.0]);
}

/// Repeated `backward` calls on one recording reuse the pooled seed and gradients: no
/// fresh allocation after the first call (the seed used to be dropped, not returned).
#[test]
fn backward_returns_its_seed_to_the_pool() {
    let mut tape = Tape::<f32>::new();
    let x = tape.leaf(Tensor::full([3], 2.0));
    let y = tape.square(x);
    let s = tape.sum(y);
    tape.backward(s);
    let after_first = tape.pool().fresh_allocations;
    for _ in 0..5 {
        tape.backward(s);
    }
    assert_eq!(tape.pool().fresh_allocations, after_first);
    assert_eq!(tape.grad(x).unwrap().data(), &[4.0; 3]);
}

/// A NaN made by an op's forward is traced to that op and its scope; one made only by a VJP
/// (`sqrt` at 0: value 0, derivative ∞) to that op's backward; a finite step to nothing.
#[test]
fn non_finite_values_are_traced_to_the_op_that_made_them() {
    let mut tape = Tape::<f64>::new();
    let x = tape.leaf(Tensor::from_vec([3], vec![1.0, -1.0, 4.0]));
    tape.enter_scope("S");
    let r = tape.sqrt(x);
    tape.close_scope();
    let loss = tape.sum(r);
    let site = tape.trace_non_finite(loss).expect("sqrt(−1) is NaN");
    assert_eq!(
        (site.op, site.scope, site.pass),
        ("sqrt", Some("S"), Pass::Forward)
    );
    assert_eq!(site.index, r.index());

    tape.clear();
    let x = tape.leaf(Tensor::from_vec([2], vec![0.0, 4.0]));
    let r = tape.sqrt(x);
    let loss = tape.sum(r);
    assert!(tape.first_non_finite_value().is_none());
    let site = tape.trace_non_finite(loss).expect("d sqrt/dx at 0 is ∞");
    assert_eq!((site.op, site.pass), ("sqrt", Pass::Backward));

    tape.clear();
    let x = tape.leaf(Tensor::from_vec([2], vec![1.0, 4.0]));
    let r = tape.sqrt(x);
    let loss = tape.sum(r);
    assert_eq!(tape.trace_non_finite(loss), None);
}
