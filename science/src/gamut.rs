//! How far each CMF-SIM test light lies from the colours the eye sees in training. Evaluation
//! only: this reads the scenes' true cone excitations; nothing here feeds learning.
//!
//! The cortex's decoder is positively homogeneous (W and C are linear, the U-Net is bias-free
//! with ReLUs: Φ(a·x) = a·Φ(x) for a > 0), so what a light is to it, beyond its place, is the
//! *direction* of its excitation vector `e = (e_1 … e_K)` over the eye's K cone classes — its
//! chromaticity in the eye's own terms. For each test wavelength λ the light's direction
//! `e(λ)` (exactly the class values CMF-SIM renders it with) is compared with the directions of
//! the training scenes' colours, one per cone position of every sampled frame. The frames are
//! [`GAMUT_FRAMES`] spread evenly over the batches a training draws: the scene pool replaces a
//! tile every few batches, so a rare kind of tile (a tenth of a tetrachromatic environment's
//! patches) is seen at the rate training sees it, not only among the pool's first tiles:
//! - **nearest angle**: the angle, in degrees, from `e(λ)` to the closest scene colour (0° when
//!   some scene colour has the same chromaticity; large when the light lies beyond every colour
//!   the cortex learned from);
//! - **share within [`NEAR_DEG`]**: the fraction of scene colours that close to `e(λ)`.
//!
//! A cortex is tested by CMF-SIM on every light of the spectrum, while it learned only from
//! its scenes: where the test lights leave the scenes' gamut its percept is an extrapolation.

use crate::source::RetinaSource;
use colorimetry::Stimulus;
use serde::{Deserialize, Serialize};

/// Angle below which a scene colour counts as near a test light, degrees.
pub const NEAR_DEG: f64 = 5.0;
/// Frames sampled over the training's batches (one sample each).
pub const GAMUT_FRAMES: u64 = 256;

/// The test lights against the scenes' colours (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gamut {
    /// Cone classes of the eye, in the order of the excitation vectors.
    pub classes: Vec<String>,
    /// Test wavelengths, nm.
    pub wavelengths_nm: Vec<f64>,
    /// Per wavelength, the angle to the nearest scene colour, degrees.
    pub nearest_deg: Vec<f64>,
    /// Per wavelength, the share of scene colours within [`NEAR_DEG`].
    pub share_near: Vec<f64>,
    /// Scene colours compared (cone positions × frames, zero excitations left out).
    pub scene_colours: usize,
    /// Frames sampled, spread evenly over `batches`.
    #[serde(default)]
    pub frames: u64,
    /// Batches of the training whose scenes were sampled.
    #[serde(default)]
    pub batches: u64,
}

/// Unit vectors of the rows of `x (rows, k)`; rows with no excitation are left out.
fn directions(x: &[f64], k: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(x.len());
    for row in x.chunks_exact(k) {
        let norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.0 {
            out.extend(row.iter().map(|v| v / norm));
        }
    }
    out
}

/// Per light row of `lights (m, k)`: the angle to the nearest row of `colours (rows, k)`
/// (degrees) and the share of those rows within `near_deg`. Both sets are excitation vectors;
/// only their directions count.
pub fn compare(lights: &[f64], colours: &[f64], k: usize, near_deg: f64) -> (Vec<f64>, Vec<f64>) {
    assert!(
        k > 0 && lights.len().is_multiple_of(k) && colours.len().is_multiple_of(k),
        "gamut::compare: {} light and {} colour values for {k} classes",
        lights.len(),
        colours.len()
    );
    let colours = directions(colours, k);
    let count = colours.len() / k;
    let cos_near = near_deg.to_radians().cos();
    let mut nearest = Vec::new();
    let mut share = Vec::new();
    for light in directions(lights, k).chunks_exact(k) {
        let (mut best, mut within) = (-1.0f64, 0usize);
        for c in colours.chunks_exact(k) {
            let cos: f64 = light.iter().zip(c).map(|(a, b)| a * b).sum();
            best = best.max(cos);
            within += usize::from(cos >= cos_near);
        }
        nearest.push(best.clamp(-1.0, 1.0).acos().to_degrees());
        share.push(within as f64 / count.max(1) as f64);
    }
    (nearest, share)
}

/// The test lights at `wavelengths_nm` against the scenes of a training of `batches` batches
/// from a fresh `source`: [`GAMUT_FRAMES`] frames at evenly spaced batches (all of them when
/// fewer). The batches between are passed over ([`RetinaSource::replay_to`]), which rebuilds the
/// scene pool exactly as training leaves it.
pub fn measure(source: &mut RetinaSource, wavelengths_nm: &[f64], batches: u64) -> Gamut {
    let retina = &source.retina;
    let k = retina.mosaic.n_classes();
    let nn = retina.n() * retina.n();
    let mut lights = Vec::with_capacity(wavelengths_nm.len() * k);
    for &w in wavelengths_nm {
        lights.extend(retina.class_values(&Stimulus::monochromatic(w, 1.0).to_grid(retina.grid())));
    }
    let span = batches.max(1);
    let frames = GAMUT_FRAMES.min(span);
    let mut colours = Vec::with_capacity(frames as usize * nn * k);
    for f in 0..frames {
        source.replay_to(f * span / frames);
        let batch = source.next_eye_batch(1).clone();
        let planes = source.retina.class_excitations_at_cones(&batch.truth, 0);
        for i in 0..nn {
            colours.extend((0..k).map(|c| planes[c * nn + i] as f64));
        }
    }
    let (nearest_deg, share_near) = compare(&lights, &colours, k, NEAR_DEG);
    Gamut {
        classes: source.retina.mosaic.class_names(),
        wavelengths_nm: wavelengths_nm.to_vec(),
        nearest_deg,
        share_near,
        scene_colours: directions(&colours, k).len() / k,
        frames,
        batches,
    }
}

impl Gamut {
    /// The wavelength ranges (nm) whose lights lie more than `deg` from every scene colour.
    pub fn beyond(&self, deg: f64) -> Vec<(f64, f64)> {
        let mut ranges: Vec<(f64, f64)> = Vec::new();
        let mut previous_out = false;
        for (&w, &a) in self.wavelengths_nm.iter().zip(&self.nearest_deg) {
            let out = a > deg;
            match (out, previous_out, ranges.last_mut()) {
                (true, true, Some(r)) => r.1 = w,
                (true, _, _) => ranges.push((w, w)),
                _ => {}
            }
            previous_out = out;
        }
        ranges
    }

    /// A Markdown table, one row per `every`-th wavelength.
    pub fn markdown(&self, every: usize) -> String {
        let mut md = format!(
            "| λ nm | nearest scene colour, ° | share of scene colours within {NEAR_DEG}° |\n|---|---|---|\n"
        );
        for i in (0..self.wavelengths_nm.len()).step_by(every.max(1)) {
            md.push_str(&format!(
                "| {:.0} | {:.1} | {:.4} |\n",
                self.wavelengths_nm[i], self.nearest_deg[i], self.share_near[i]
            ));
        }
        md
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_light_among_the_scene_colours_is_at_zero_and_one_beyond_them_is_far() {
        // Scene colours: L and M in any mix, never any S.
        let colours: Vec<f64> = (0..=50)
            .flat_map(|i| {
                let t = i as f64 / 50.0;
                [t, 1.0 - t, 0.0]
            })
            .collect();
        let lights = [
            0.5, 0.5, 0.0, // inside (scaled: only the direction counts)
            0.0, 0.0, 2.0, // pure S: orthogonal to every scene colour
            1.0, 1.0, 1.0, // equal parts: 35.3° from (1, 1, 0)
        ];
        let (nearest, share) = compare(&lights, &colours, 3, 5.0);
        assert!(nearest[0] < 1e-4, "{nearest:?}");
        assert!((nearest[1] - 90.0).abs() < 1e-9, "{nearest:?}");
        let expected = (2.0f64 / 6.0f64.sqrt()).acos().to_degrees();
        assert!(
            (nearest[2] - expected).abs() < 0.5,
            "{nearest:?} vs {expected}"
        );
        assert!(
            share[0] > 0.0 && share[1] == 0.0 && share[2] == 0.0,
            "{share:?}"
        );
    }

    #[test]
    fn zero_colours_are_left_out_and_ranges_beyond_are_merged() {
        let (nearest, share) = compare(&[1.0, 0.0], &[0.0, 0.0, 1.0, 0.0], 2, 5.0);
        assert_eq!(
            (nearest[0], share[0]),
            (0.0, 1.0),
            "the zero colour does not count"
        );
        let g = Gamut {
            classes: vec!["L".into(), "S".into()],
            wavelengths_nm: vec![400.0, 410.0, 420.0, 430.0, 440.0],
            nearest_deg: vec![20.0, 15.0, 2.0, 12.0, 1.0],
            share_near: vec![0.0; 5],
            scene_colours: 1,
            frames: 1,
            batches: 1,
        };
        assert_eq!(g.beyond(10.0), vec![(400.0, 410.0), (430.0, 430.0)]);
    }
}
