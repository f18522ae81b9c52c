//! Step 1 of CMF-SIM: base errors and percept energies.
//!
//! Per (test wavelength λ, location pair (a, b)) three shows in one batched call: the test light
//! at a, black at b, the test light at b, with the noise seeds [`crate::matching::MatchProblem`] gives sides A and
//! B (and a third for the test at b), so that matches at α = 0 reuse the first two and the
//! front-end model ([`crate::matching::FrontEndJacobians`]) the first and third.
//! `base(λ) = mean ‖Φ(t@b) − Φ(t@a)‖²`, `energy(λ) = mean ‖Φ(black@b) − Φ(t@a)‖²`.

use crate::matching::show_seed;
use crate::observer::{Observer, Show, Stimulus};

/// Base errors and energies of step 1.
pub(super) struct Base {
    /// Location pairs per wavelength.
    pub pairs: Vec<Vec<[[f64; 2]; 2]>>,
    /// Seed base of the shows.
    pub seed: u64,
    /// Φ(test at a), Φ(black at b), Φ(test at b), `(wavelengths × pairs × N)`.
    pub at_a: Vec<f64>,
    /// Φ(black at b).
    pub black_b: Vec<f64>,
    /// Φ(test at b).
    pub test_b: Vec<f64>,
    /// Base error per wavelength.
    pub error: Vec<f64>,
    /// Percept energy per wavelength.
    pub energy: Vec<f64>,
}

/// Step 1 (see the module docs).
pub(super) fn base_errors(
    observer: &dyn Observer,
    tests: &[f64],
    intensity: f64,
    pairs: Vec<Vec<[[f64; 2]; 2]>>,
    seed: u64,
) -> Base {
    let n = observer.percept_dim();
    let mut shows = Vec::new();
    for (w, &lambda) in tests.iter().enumerate() {
        for (p, &[a, b]) in pairs[w].iter().enumerate() {
            let t = Stimulus::monochromatic(lambda, intensity);
            for (stimulus, location, side) in
                [(t.clone(), a, 1), (Stimulus::black(), b, 2), (t, b, 3)]
            {
                shows.push(Show {
                    stimulus,
                    location,
                    noise_seed: show_seed(seed, w, p, side),
                });
            }
        }
    }
    let mut out = vec![0.0; shows.len() * n];
    observer.percepts(&shows, &mut out);
    let (mut at_a, mut black_b, mut test_b) = (Vec::new(), Vec::new(), Vec::new());
    let (mut error, mut energy) = (vec![0.0; tests.len()], vec![0.0; tests.len()]);
    let dist = |i: usize, j: usize| -> f64 {
        (0..n)
            .map(|d| (out[i * n + d] - out[j * n + d]).powi(2))
            .sum()
    };
    let mut i = 0;
    for w in 0..tests.len() {
        let np = pairs[w].len() as f64;
        for _ in 0..pairs[w].len() {
            at_a.extend_from_slice(&out[i * n..(i + 1) * n]);
            black_b.extend_from_slice(&out[(i + 1) * n..(i + 2) * n]);
            test_b.extend_from_slice(&out[(i + 2) * n..(i + 3) * n]);
            error[w] += dist(i, i + 2) / np;
            energy[w] += dist(i + 1, i) / np;
            i += 3;
        }
    }
    Base {
        pairs,
        seed,
        at_a,
        black_b,
        test_b,
        error,
        energy,
    }
}
