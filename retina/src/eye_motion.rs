//! Eye motion: integer shifts of the field across the scene (authors' code, docs/references.md#eye-motion; paper S-02).
//!
//! Training samples are two frames: frame 0 is the field at the centre of a crop that is
//! `field_px + 2·max_shift_px` wide, frame 1 is the field moved by d = (dx, dy), each component
//! drawn uniformly from the integers in `[−max_shift_px, max_shift_px − 1]` (the official
//! `torch.randint(−MSS, MSS)`, upper bound exclusive; the paper says ±15). The official eye
//! samples a 512-px field with 256 cones per side (2 px per cone) and shifts by MSS = 15 px,
//! i.e. **7.5 mean cone spacings**. What the cortex sees is the shift in cones, so every eye
//! keeps that: `max_shift_px = round(7.5 · field_px / cones_per_side)`, at least 1
//! ([`EyeMotionConfig::official_for`]). The sandbox preset sets its own value, 5 px = 5 cones,
//! as the official sandbox does.
//!
//! Sign convention: frame 1 samples the scene at `x + d`, i.e. the eye moved by +d and the image
//! content moved by −d on the retina. `d` is returned in px as `[dx, dy]` (dx along columns, dy
//! along rows) and normalised as `d / (field_px / 2)`, the official units of the [−1, 1] field.
//!
//! Movies: a random walk — i.i.d. steps drawn as above, positions accumulated and clamped to the
//! allowed range (official: no notion of dt).

use rand::Rng;
use serde::{Deserialize, Serialize};

/// Official maximum shift in mean cone spacings: 15 px of a 512-px field sampled by 256 cones
/// per side (authors' code, docs/references.md#eye-motion and #foveation; paper S-02 "±15 pixels").
pub const OFFICIAL_MAX_SHIFT_CONES: f64 = 7.5;

/// Eye-motion settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EyeMotionConfig {
    /// Shifts are drawn from `[−max_shift_px, max_shift_px − 1]` per axis, px of the field.
    pub max_shift_px: i32,
}

impl EyeMotionConfig {
    /// The official shift in cone spacings, in px of a `field_px` field sampled by
    /// `cones_per_side` cones per side: `round(7.5 · field_px / cones_per_side)`, at least 1.
    pub fn official_for(field_px: usize, cones_per_side: usize) -> Self {
        let px_per_cone = field_px as f64 / cones_per_side.max(1) as f64;
        let m = (OFFICIAL_MAX_SHIFT_CONES * px_per_cone).round().max(1.0) as i32;
        EyeMotionConfig { max_shift_px: m }
    }

    /// One shift `[dx, dy]`, each uniform in `[−max, max − 1]`.
    pub fn draw_shift<R: Rng + ?Sized>(&self, rng: &mut R) -> [i32; 2] {
        let m = self.max_shift_px;
        [rng.random_range(-m..m), rng.random_range(-m..m)]
    }

    /// Margin (px) around the field that a crop needs for every shift: `max_shift_px`.
    pub fn margin_px(&self) -> usize {
        self.max_shift_px as usize
    }

    /// A random walk of `frames` positions starting at `[0, 0]`: i.i.d. steps from
    /// [`EyeMotionConfig::draw_shift`], each position clamped to `[−limit_px, limit_px]`.
    pub fn random_walk<R: Rng + ?Sized>(
        &self,
        rng: &mut R,
        frames: usize,
        limit_px: i32,
    ) -> Vec<[i32; 2]> {
        let mut pos = [0i32; 2];
        let mut out = Vec::with_capacity(frames);
        for f in 0..frames {
            if f > 0 {
                let d = self.draw_shift(rng);
                pos = [
                    (pos[0] + d[0]).clamp(-limit_px, limit_px),
                    (pos[1] + d[1]).clamp(-limit_px, limit_px),
                ];
            }
            out.push(pos);
        }
        out
    }
}

/// `d / (field_px / 2)` — the official normalised shift.
pub fn normalise_shift(shift_px: [i32; 2], field_px: usize) -> [f32; 2] {
    let h = field_px as f32 / 2.0;
    [shift_px[0] as f32 / h, shift_px[1] as f32 / h]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    #[test]
    fn shifts_cover_exactly_the_official_range() {
        let e = EyeMotionConfig::official_for(512, 256);
        assert_eq!(e.max_shift_px, 15);
        let mut rng = StdRng::seed_from_u64(0);
        let mut seen = [0usize; 30];
        for _ in 0..30_000 {
            for v in e.draw_shift(&mut rng) {
                assert!((-15..=14).contains(&v));
                seen[(v + 15) as usize] += 1;
            }
        }
        // Uniform: every value about 2000 times.
        assert!(seen.iter().all(|&c| (1700..2300).contains(&c)), "{seen:?}");
        assert_eq!(
            normalise_shift([-15, 14], 512),
            [-15.0 / 256.0, 14.0 / 256.0]
        );
        // Every foveated preset has 2 px per cone: the same 7.5 cones, 15 px.
        assert_eq!(EyeMotionConfig::official_for(128, 64).max_shift_px, 15);
        assert_eq!(EyeMotionConfig::official_for(64, 32).max_shift_px, 15);
        assert_eq!(EyeMotionConfig::official_for(64, 64).max_shift_px, 8);
        assert_eq!(EyeMotionConfig::official_for(1, 64).max_shift_px, 1);
    }

    #[test]
    fn random_walk_accumulates_and_clamps() {
        let e = EyeMotionConfig { max_shift_px: 5 };
        let mut rng = StdRng::seed_from_u64(1);
        let w = e.random_walk(&mut rng, 500, 7);
        assert_eq!(w[0], [0, 0]);
        for p in w.windows(2) {
            for a in 0..2 {
                assert!(p[1][a].abs() <= 7);
                assert!((p[1][a] - p[0][a]).abs() <= 5);
            }
        }
        assert!(w.iter().any(|p| p[0].abs() == 7));
    }
}
