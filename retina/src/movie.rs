//! Movies: ONS frame sequences under eye motion, and the spiking path over them.
//!
//! Stage `Retina::movie(rng, config) -> Movie`:
//! - picks a pool tile, starts the field at the tile's centre and moves it by a random walk
//!   (official tutorial: T = 120 frames; `eye_motion` module for the step law) clamped so the
//!   field stays inside the tile, or holds it still (`motion: None`);
//! - per frame: the noise-free analog ONS and the noisy ONS (noise ratio drawn once per movie,
//!   as once per batch in training, unless given), each `(n, n)`.
//!
//! `Retina::spikes(movie) -> SpikeTrain` runs ON/OFF rectification and the LIF ganglion cells
//! over the noisy frames ([`crate::spikes`]), and keeps the running ON − OFF average — the
//! cortex's time-averaged signal (paper S-03).

use rand::Rng;

use crate::eye_motion::EyeMotionConfig;
use crate::retina::Retina;
use crate::spikes::{Lif, SpikeAverager};

/// Movie settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovieConfig {
    /// Number of frames.
    pub frames: usize,
    /// Random-walk step law; `None` holds the eye still.
    pub motion: Option<EyeMotionConfig>,
    /// Noise ratio r; `None` draws it like a training batch.
    pub noise_ratio: Option<f32>,
}

/// An ONS frame sequence (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Movie {
    /// Cones per side.
    pub n: usize,
    /// Pool tile shown.
    pub tile: usize,
    /// Field origin `[x, y]` of each frame in the tile, px.
    pub origins_px: Vec<[i32; 2]>,
    /// Noise-free ONS per frame, `(n, n)` each.
    pub analog: Vec<Vec<f32>>,
    /// Noisy ONS per frame, `(n, n)` each.
    pub ons: Vec<Vec<f32>>,
    /// Noise ratio used.
    pub noise_ratio: f32,
}

/// ON and OFF spikes per frame plus the running average.
#[derive(Debug, Clone, PartialEq)]
pub struct SpikeTrain {
    /// ON spikes (0/1) per frame, `(n, n)` each.
    pub on: Vec<Vec<f32>>,
    /// OFF spikes (0/1) per frame.
    pub off: Vec<Vec<f32>>,
    /// Mean ON − OFF over all frames, `(n, n)`.
    pub mean_on_minus_off: Vec<f32>,
}

impl Retina {
    /// A movie (module docs).
    pub fn movie<R: Rng + ?Sized>(&self, rng: &mut R, config: MovieConfig) -> Movie {
        let n = self.n();
        let nn = n * n;
        let tile = rng.random_range(0..self.pool.len());
        let stack = self.pool.tile(tile);
        let room = (self.config.scenes.tile_px - self.config.field_px) as i32;
        let centre = room / 2;
        let walk = match config.motion {
            Some(m) => m.random_walk(rng, config.frames, room / 2),
            None => vec![[0, 0]; config.frames],
        };
        let r = config
            .noise_ratio
            .unwrap_or_else(|| self.config.noise.draw_ratio(rng));
        let mut act = vec![0.0; nn];
        let mut movie = Movie {
            n,
            tile,
            origins_px: Vec::with_capacity(config.frames),
            analog: Vec::with_capacity(config.frames),
            ons: Vec::with_capacity(config.frames),
            noise_ratio: r,
        };
        for p in walk {
            let o = [centre + p[0], centre + p[1]];
            let mut clean = vec![0.0; nn];
            self.encode_frame(stack, o, &mut act, &mut clean);
            let mut noisy = vec![0.0; nn];
            self.encode_frame_noisy(rng, r, stack, o, &mut act, &mut noisy);
            movie.origins_px.push(o);
            movie.analog.push(clean);
            movie.ons.push(noisy);
        }
        movie
    }

    /// ON/OFF LIF spikes over a movie's noisy frames (module docs).
    pub fn spikes(&self, movie: &Movie) -> SpikeTrain {
        let nn = movie.n * movie.n;
        let mut lif = Lif::new(self.config.lif, nn);
        let mut avg = SpikeAverager::new(nn);
        let mut train = SpikeTrain {
            on: Vec::with_capacity(movie.ons.len()),
            off: Vec::with_capacity(movie.ons.len()),
            mean_on_minus_off: vec![],
        };
        for frame in &movie.ons {
            let (mut on, mut off) = (vec![0.0; nn], vec![0.0; nn]);
            lif.step(frame, &mut on, &mut off);
            avg.add(&on, &off);
            train.on.push(on);
            train.off.push(off);
        }
        train.mean_on_minus_off = avg.mean();
        train
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::pearson;
    use crate::config::RetinaConfig;
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    #[test]
    fn time_averaged_spikes_track_the_analog_signal() {
        // ≥ 100 frames of a still eye with full photon and LI noise.
        // Four movies (different tiles) per preset; every one must reach 0.9.
        for preset in ["tiny", "quick"] {
            let r = Retina::new(RetinaConfig::preset(preset).unwrap()).unwrap();
            for seed in 0..4 {
                let mut rng = StdRng::seed_from_u64(seed);
                let cfg = MovieConfig {
                    frames: 200,
                    motion: None,
                    noise_ratio: Some(1.0),
                };
                let movie = r.movie(&mut rng, cfg);
                let train = r.spikes(&movie);
                let corr = pearson(&train.mean_on_minus_off, &movie.analog[0]);
                let rate = train.on.iter().chain(&train.off).flatten().sum::<f32>()
                    / (2 * 200 * movie.n * movie.n) as f32;
                eprintln!(
                    "{preset} movie {seed}: corr(time-averaged ON − OFF spikes over 200 frames, \
                     analog ONS) = {corr:.4}; spike probability per channel and frame {rate:.3}"
                );
                assert!(corr >= 0.9, "{preset} movie {seed}: {corr}");
            }
        }
    }

    #[test]
    fn movie_walks_inside_the_tile_and_noise_free_frames_are_clean() {
        let r = Retina::new(RetinaConfig::tiny()).unwrap();
        let mut rng = StdRng::seed_from_u64(3);
        let m = r.movie(
            &mut rng,
            MovieConfig {
                frames: 50,
                motion: Some(r.config.eye_motion),
                noise_ratio: Some(0.0),
            },
        );
        assert_eq!(m.ons.len(), 50);
        let room = (r.config.scenes.tile_px - r.config.field_px) as i32;
        assert!(m
            .origins_px
            .iter()
            .all(|o| o.iter().all(|v| (0..=room).contains(v))));
        assert!(m.origins_px.windows(2).any(|w| w[0] != w[1]));
        assert_eq!(m.ons, m.analog);
    }
}
