//! Psychophysical stimuli through the eye: a uniform disc of light on a black field, as the
//! patches of a colour-matching experiment (paper S-04; the disc on black follows the proposal
//! that edges carry the signal after lateral inhibition, whose DC gain is 0.09).
//!
//! Stage `Retina::encode_disc(disc, values, noise, act, ons)`:
//! - input: a [`Disc`] (centre and radius in field px; x = column, y = row, pixel centres at
//!   integers as in [`crate::foveation::ConeLayout`]), the stimulus's class-plane values `(k)`
//!   (one per plane of the scene projection, from [`Retina::class_values`]), an optional noise
//!   draw;
//! - output: the cone activations `act (n, n)` and the ONS `ons (n, n)` of one frame, no eye
//!   motion.
//!
//! The disc edge is anti-aliased over one pixel; the field is mip-mapped and sampled at the
//! cones exactly as in training. **Linearity**: without noise, every stage — the disc render,
//! the mip stack, cone sampling and lateral inhibition — is linear, so the output for values
//! `a·u + b·v` is `a·out(u) + b·out(v)` (tested below). Observers rely on it to render a
//! location once per class plane and combine. [`Retina::class_values`] is linear in the spectrum
//! (also tested below), so observers may build the eye's front end from unit spectra.

use rand::rngs::SmallRng;
use rand::SeedableRng;

use crate::foveation::MipStack;
use crate::retina::Retina;

/// A disc of light in the field, px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// Centre `[x, y]`, field px.
    pub centre_px: [f64; 2],
    /// Radius, field px.
    pub radius_px: f64,
}

/// One draw of the eye's noise for a stimulus: ratio r and the seed of the draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseDraw {
    /// Noise ratio r (photon and LI noise scale with it; 0 is noise-free).
    pub ratio: f32,
    /// Seed of the noise sample (equal seeds give equal samples for equal stimuli).
    pub seed: u64,
}

impl Retina {
    /// Values of a spectrum `(g)` on the eye's wavelength grid on every plane of the scene
    /// projection (the mosaic's classes first, then the reference planes). Linear.
    pub fn class_values(&self, spectrum: &[f64]) -> Vec<f64> {
        self.pool.projection.projector.project_spectrum(spectrum)
    }

    /// The wavelength grid the eye's spectra live on.
    pub fn grid(&self) -> &colorimetry::WavelengthGrid {
        &self.pool.projection.grid
    }

    /// Number of class planes the cones read (the mosaic's classes).
    pub fn classes_read(&self) -> usize {
        self.mosaic.n_classes()
    }

    /// Render `disc` with class-plane `values` through the eye (module docs).
    pub fn encode_disc(
        &self,
        disc: Disc,
        values: &[f64],
        noise: Option<NoiseDraw>,
        act: &mut [f32],
        ons: &mut [f32],
    ) {
        let n_planes = self.pool.projection.n_planes();
        assert!(
            values.len() <= n_planes,
            "Retina::encode_disc: {} values for {n_planes} planes",
            values.len()
        );
        let f = self.config.field_px;
        let mut planes = vec![0f32; n_planes * f * f];
        for y in 0..f {
            for x in 0..f {
                let d = ((x as f64 - disc.centre_px[0]).powi(2)
                    + (y as f64 - disc.centre_px[1]).powi(2))
                .sqrt();
                let cover = (disc.radius_px + 0.5 - d).clamp(0.0, 1.0) as f32;
                if cover > 0.0 {
                    for (p, &v) in values.iter().enumerate() {
                        planes[(p * f + y) * f + x] = cover * v as f32;
                    }
                }
            }
        }
        let stack = MipStack::compute(&planes, n_planes, f, f, self.cones.sampler.levels_needed());
        match noise {
            Some(draw) if draw.ratio > 0.0 => {
                let mut rng = SmallRng::seed_from_u64(draw.seed);
                self.encode_frame_noisy(&mut rng, draw.ratio, &stack, [0, 0], act, ons);
            }
            _ => self.encode_frame(&stack, [0, 0], act, ons),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RetinaConfig;

    fn eye() -> Retina {
        let mut c = RetinaConfig::tiny();
        c.scenes.tiles = 1;
        Retina::new(c).unwrap()
    }

    fn render(eye: &Retina, disc: Disc, values: &[f64], noise: Option<NoiseDraw>) -> [Vec<f32>; 2] {
        let nn = eye.n() * eye.n();
        let (mut act, mut ons) = (vec![0f32; nn], vec![0f32; nn]);
        eye.encode_disc(disc, values, noise, &mut act, &mut ons);
        [act, ons]
    }

    fn worst(a: &[f32], b: &[f32]) -> f32 {
        a.iter()
            .zip(b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f32::max)
    }

    #[test]
    fn noise_free_rendering_is_linear_in_the_class_values() {
        let eye = eye();
        let disc = Disc {
            centre_px: [30.3, 25.8],
            radius_px: 7.5,
        };
        let (u, v) = (vec![0.3, 0.0, 0.9], vec![0.0, 0.7, 0.2]);
        let (a, b) = (1.7, -0.4);
        let combined: Vec<f64> = u.iter().zip(&v).map(|(x, y)| a * x + b * y).collect();
        let [act_u, ons_u] = render(&eye, disc, &u, None);
        let [act_v, ons_v] = render(&eye, disc, &v, None);
        let [act_c, ons_c] = render(&eye, disc, &combined, None);
        let mix = |p: &[f32], q: &[f32]| -> Vec<f32> {
            p.iter()
                .zip(q)
                .map(|(x, y)| a as f32 * x + b as f32 * y)
                .collect()
        };
        let scale = act_c.iter().fold(0f32, |m, x| m.max(x.abs()));
        assert!(scale > 0.1, "the disc must excite the cones ({scale})");
        assert!(worst(&act_c, &mix(&act_u, &act_v)) < 1e-5 * scale);
        assert!(worst(&ons_c, &mix(&ons_u, &ons_v)) < 1e-5 * scale);
        // With noise the eye is not linear: the property is specific to the noise-free eye.
        let draw = Some(NoiseDraw {
            ratio: 5.0,
            seed: 1,
        });
        let [act_n, _] = render(&eye, disc, &combined, draw);
        assert!(worst(&act_n, &act_c) > 1e-3 * scale);
    }

    #[test]
    fn class_values_are_linear_in_the_spectrum() {
        // Observers build the eye's front end from unit spectra, one per wavelength, and
        // combine them: this holds only if the projection is linear.
        let eye = eye();
        let g = eye.grid().len();
        let s: Vec<f64> = (0..g)
            .map(|i| 0.2 + (i as f64 * 0.37).sin().abs())
            .collect();
        let t: Vec<f64> = (0..g).map(|i| ((i * 7 % 11) as f64) / 11.0).collect();
        let (a, b) = (2.3, -0.6);
        let combined: Vec<f64> = s.iter().zip(&t).map(|(x, y)| a * x + b * y).collect();
        let (vs, vt, vc) = (
            eye.class_values(&s),
            eye.class_values(&t),
            eye.class_values(&combined),
        );
        assert_eq!(vc.len(), vs.len());
        let scale = vc.iter().fold(0f64, |m, x| m.max(x.abs()));
        assert!(
            scale > 1e-3,
            "the spectrum must reach the classes ({scale})"
        );
        for ((c, x), y) in vc.iter().zip(&vs).zip(&vt) {
            assert!(
                (c - (a * x + b * y)).abs() <= 1e-12 * scale,
                "{c} vs {}",
                a * x + b * y
            );
        }
    }

    #[test]
    fn a_disc_excites_the_cones_inside_it_only() {
        let eye = eye();
        let disc = Disc {
            centre_px: [20.0, 40.0],
            radius_px: 6.0,
        };
        let [act, _] = render(&eye, disc, &[1.0, 1.0, 1.0], None);
        for (i, p) in eye.layout.positions_px.iter().enumerate() {
            let d = ((p[0] as f64 - 20.0).powi(2) + (p[1] as f64 - 40.0).powi(2)).sqrt();
            if d < 2.0 {
                assert!(
                    (act[i] - 1.0).abs() < 1e-3,
                    "cone {i} at {d:.1} px: {}",
                    act[i]
                );
            }
            if d > 14.0 {
                assert!(act[i].abs() < 1e-3, "cone {i} at {d:.1} px: {}", act[i]);
            }
        }
    }
}
