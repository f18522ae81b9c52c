//! Decoders from outside the workspace: a batch function from ONS frames to percept images
//! (a Python model through the `colorvision` Python package, or any Rust closure).
//!
//! Conventions of the batch function `decode(ons, shows, percepts)`:
//! - `ons`: `(shows, n, n)` row-major f32, the optic nerve signal of each show on the cone
//!   lattice (row = lattice row, top to bottom; column = lattice column, left to right; the
//!   same order as [`retina::foveation::ConeLayout::positions_px`]).
//! - `percepts`: `(shows, dim, n, n)` row-major f32, arriving zeroed; every value must be
//!   finite.
//! - It returns `Err(why)` when it cannot decode; the observer then records the first failure,
//!   sets the stop flag it was given (CMF-SIM ends before its next primary set) and answers every
//!   later show with zeros without calling it again.
//!
//! The observer renders a batch's ONS in parallel (rayon), calls the function once per batch of
//! at most `batch_shows` shows on the thread that asked for the percepts — never from a rayon
//! worker — and reads the percepts out in parallel. Nothing is assumed of the function: it is
//! a nonlinear observer (no cached readouts, no linear front end).

use super::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// The batch function of an [`ExternalDecoder`] (module docs for the layouts).
pub type BatchDecodeFn<'a> =
    dyn Fn(&[f32], usize, &mut [f32]) -> Result<(), String> + Send + Sync + 'a;

/// A decoder from outside: a batch function with its channel count (module docs).
pub struct ExternalDecoder<'a> {
    name: String,
    dim: usize,
    batch_shows: usize,
    stop: &'a AtomicBool,
    decode: Box<BatchDecodeFn<'a>>,
    failure: Mutex<Option<String>>,
}

impl<'a> ExternalDecoder<'a> {
    /// `decode` producing `dim` channels, called with at most `batch_shows` shows at a time;
    /// `stop` is set at its first failure (pass CMF-SIM's stop flag). `name` describes it in
    /// CMF-SIM's record.
    pub fn new(
        name: impl Into<String>,
        dim: usize,
        batch_shows: usize,
        stop: &'a AtomicBool,
        decode: Box<BatchDecodeFn<'a>>,
    ) -> Self {
        ExternalDecoder {
            name: name.into(),
            dim: dim.max(1),
            batch_shows: batch_shows.max(1),
            stop,
            decode,
            failure: Mutex::new(None),
        }
    }

    /// Channels of the percept image.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Its description.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The first failure, if one happened.
    pub fn failure(&self) -> Option<String> {
        self.failure.lock().expect("failure lock").clone()
    }

    fn fail(&self, why: String) {
        let mut failure = self.failure.lock().expect("failure lock");
        failure.get_or_insert(why);
        self.stop.store(true, Ordering::SeqCst);
    }

    /// Decodes one batch into `percepts`, checking every value is finite.
    fn decode_checked(
        &self,
        ons: &[f32],
        shows: usize,
        percepts: &mut [f32],
    ) -> Result<(), String> {
        (self.decode)(ons, shows, percepts)?;
        let nn = ons.len() / shows.max(1);
        match percepts.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => {
                let (s, c, j) = (i / (self.dim * nn), i / nn % self.dim, i % nn);
                let side = (nn as f64).sqrt().round() as usize;
                Err(format!(
                    "the decoder's percept is {} at show {s}, channel {c}, cone row {}, column {} \
                     (percepts must be finite)",
                    percepts[i],
                    j / side.max(1),
                    j % side.max(1)
                ))
            }
        }
    }
}

impl EyeObserver<'_> {
    /// The ONS `(n·n)` of one show: from the location's unit-disc responses when noise-free
    /// (the eye is linear), else rendered.
    fn show_ons(&self, show: &Show, entry: &LocationEntry, out: &mut [f32]) {
        let nn = out.len();
        if entry.ons_basis.is_empty() {
            out.copy_from_slice(&self.render(show).1);
            return;
        }
        out.fill(0.0);
        for (c, &v) in self.values(show).iter().enumerate() {
            let b = &entry.ons_basis[c * nn..(c + 1) * nn];
            out.iter_mut().zip(b).for_each(|(x, b)| *x += v as f32 * b);
        }
    }

    /// The readouts of `shows` through an external decoder (module docs), into `out`.
    pub(in crate::observer) fn external_percepts(
        &self,
        decoder: &ExternalDecoder,
        shows: &[Show],
        out: &mut [f64],
    ) {
        let (dim, nn) = (decoder.dim, self.retina.n() * self.retina.n());
        let len = self.readout.len(dim);
        for (shows, out) in shows
            .chunks(decoder.batch_shows)
            .zip(out.chunks_mut(decoder.batch_shows * len))
        {
            out.fill(0.0);
            if decoder.failure().is_some() {
                continue;
            }
            let entries: Vec<Arc<LocationEntry>> = shows
                .par_iter()
                .map(|s| self.location_entry(s.location))
                .collect();
            let mut ons = vec![0f32; shows.len() * nn];
            ons.par_chunks_mut(nn)
                .zip(shows.par_iter().zip(&entries))
                .for_each(|(o, (show, entry))| self.show_ons(show, entry, o));
            let mut percepts = vec![0f32; shows.len() * dim * nn];
            if let Err(why) = decoder.decode_checked(&ons, shows.len(), &mut percepts) {
                decoder.fail(why);
                continue;
            }
            out.par_chunks_mut(len)
                .zip(percepts.par_chunks(dim * nn).zip(&entries))
                .for_each(|(o, (planes, entry))| self.readout.read(planes, dim, &entry.cells, o));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::RunConfig;
    use colorimetry::observer::Stimulus;

    fn tiny_eye() -> (RunConfig, Retina) {
        let mut config = RunConfig::preset("tiny", "LMS").unwrap();
        config.retina.scenes.tiles = 1;
        let retina = Retina::new(config.retina.clone()).unwrap();
        (config, retina)
    }

    fn shows() -> Vec<Show> {
        let stimuli = [
            Stimulus::monochromatic(455.5, 0.8),
            Stimulus::Lines(vec![(530.0, 0.3), (612.7, 1.1)]),
            Stimulus::black(),
        ];
        let locations = [[0.1, -0.2], [-0.35, 0.3], [0.0, 0.0]];
        stimuli
            .into_iter()
            .zip(locations)
            .map(|(stimulus, location)| Show {
                stimulus,
                location,
                noise_seed: 3,
            })
            .collect()
    }

    #[test]
    fn a_nonlinear_decoder_sees_every_show_rendered_and_no_linear_shortcut() {
        let (config, retina) = tiny_eye();
        let nn = retina.n() * retina.n();
        let never = AtomicBool::new(false);
        let squared = |ons: &[f32], shows: usize, out: &mut [f32]| -> Result<(), String> {
            for s in 0..shows {
                let frame = &ons[s * nn..(s + 1) * nn];
                let (plain, sq) = out[s * 2 * nn..(s + 1) * 2 * nn].split_at_mut(nn);
                plain.copy_from_slice(frame);
                sq.iter_mut().zip(frame).for_each(|(q, v)| *q = v * v);
            }
            Ok(())
        };
        let external = ExternalDecoder::new("square", 2, 2, &never, Box::new(squared));
        let observer = EyeObserver::new(
            &retina,
            Decoder::External(external),
            config.observer.clone(),
        );
        assert!(observer.linear_front_end().is_none());
        let shows = shows();
        let len = observer.percept_dim();
        let mut got = vec![0.0; shows.len() * len];
        observer.percepts(&shows, &mut got);
        // The same percepts by hand: each show rendered directly, squared, read out.
        let cells = |l: [f64; 2]| {
            observer
                .readout
                .cells(&retina.layout, observer.disc(l).centre_px)
        };
        for (s, show) in shows.iter().enumerate() {
            let ons = observer.render(show).1;
            let mut planes = ons.clone();
            planes.extend(ons.iter().map(|v| v * v));
            let mut want = vec![0.0; len];
            observer
                .readout
                .read(&planes, 2, &cells(show.location), &mut want);
            let scale = want.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            for (i, (a, b)) in got[s * len..(s + 1) * len].iter().zip(&want).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-5 * scale,
                    "show {s} value {i}: {a} vs {b}"
                );
            }
        }
        assert!(observer.decoder_failure().is_none());
        assert!(!never.load(Ordering::SeqCst));
    }

    #[test]
    fn a_non_finite_percept_or_a_decoder_error_stops_cmf_sim_with_its_reason() {
        let (config, retina) = tiny_eye();
        let nn = retina.n() * retina.n();
        let stop = AtomicBool::new(false);
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let sqrt_of_bright = |ons: &[f32], shows: usize, out: &mut [f32]| {
            calls.fetch_add(1, Ordering::SeqCst);
            for s in 0..shows {
                let frame = &ons[s * nn..(s + 1) * nn];
                let bright = frame.iter().fold(0f32, |m, v| m.max(v.abs())) > 0.0;
                // A compressive decoder that forgets the ONS is signed (LI's surround).
                out[s * nn..(s + 1) * nn]
                    .iter_mut()
                    .zip(frame)
                    .for_each(|(o, v)| *o = if bright { v.sqrt() } else { *v });
            }
            Ok(())
        };
        let external = ExternalDecoder::new("sqrt", 1, 64, &stop, Box::new(sqrt_of_bright));
        let e = crate::measure::measure_decoder_until(
            &retina,
            Decoder::External(external),
            &config,
            &mut |_| {},
            &stop,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("`decoder`") && e.contains("NaN") && e.contains("must be finite"),
            "{e}"
        );
        assert!(stop.load(Ordering::SeqCst));
        assert_eq!(
            calls.load(Ordering::SeqCst),
            1,
            "no call after the first failure"
        );

        let stop = AtomicBool::new(false);
        let refuses = |_: &[f32], _: usize, _: &mut [f32]| Err("out of memory".to_string());
        let external = ExternalDecoder::new("refuses", 1, 64, &stop, Box::new(refuses));
        let e = crate::measure::measure_decoder_until(
            &retina,
            Decoder::External(external),
            &config,
            &mut |_| {},
            &stop,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("`decoder`: out of memory"), "{e}");
    }
}
