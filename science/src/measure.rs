//! CMF-SIM of one observer through a simulated eye: the learned cortex, a decoder whose answer
//! is known (identity, cone activations, the oracle with or without demosaicking, an eye's own
//! cone fundamentals), or an external one (`Decoder::External`, e.g. a Python callable).
//!
//! Every function here builds the eye of `config.retina` (one scene tile when no cortex needs
//! scenes: the stimuli are discs), wraps the decoder in an [`EyeObserver`] with
//! `config.observer`, and runs CMF-SIM with `config.cmf_sim`. A set `stop` flag ends the
//! measurement with a stop error ([`Error::stopped_stage`]); a decoder's failure (an error it
//! returned, a non-finite percept) is the measurement's error, never a failed match.

use crate::config::RunConfig;
use crate::observer::{Decoder, EyeObserver, ObserverKind, OracleDecoder};
use crate::Error;
use colorimetry::analytic::ConeObserver;
use colorimetry::cmf_sim::CmfSimProgress;
use colorimetry::{run_cmf_sim_until, CmfSimResult};
use cortex::{Cortex, Trainer};
use retina::Retina;
use std::sync::atomic::AtomicBool;

/// The oracle decoder of `retina` (with or without per-class interpolation), its embedding
/// drawn from CMF-SIM's seed.
pub fn oracle_decoder(
    retina: &Retina,
    config: &RunConfig,
    interpolate: bool,
) -> Result<OracleDecoder, Error> {
    OracleDecoder::new(retina, interpolate, config.cmf_sim.seed)
        .map_err(|e| Error::invalid("cones", e.to_string()))
}

/// This eye's own cone fundamentals (the classes of its mosaic, its template and lens) as an
/// observer whose percept is the cone excitations: no mosaic, no noise.
pub fn own_fundamentals(retina: &Retina, config: &RunConfig) -> Result<ConeObserver, Error> {
    let grid = config.retina.grid.grid()?;
    Ok(ConeObserver::new(
        &retina.mosaic.classes,
        &config.retina.template,
        &grid,
    )?)
}

/// The settings a measurement builds its eye with: `config` with one scene tile. CMF-SIM
/// shows discs of light, never scenes, so the scene pool (the larger part of building a
/// trained run's eye, in time and memory) is not drawn; every other part of the eye is the
/// same (the scenes are drawn from their own seed, after the mosaic and the layout).
pub fn measurement_config(config: &RunConfig) -> RunConfig {
    let mut c = config.clone();
    c.retina.scenes.tiles = 1;
    c
}

/// CMF-SIM of one observer through the eye of `config` (the cortex from `trainer`).
pub fn measure_observer(
    config: &RunConfig,
    kind: ObserverKind,
    trainer: Option<&Trainer>,
) -> Result<CmfSimResult, Error> {
    measure_observer_until(config, kind, trainer, &AtomicBool::new(false))
}

/// [`measure_observer`] that ends with a stop error ([`Error::stopped_stage`]) once `stop` is
/// set (checked while scenes are drawn and before every primary set).
pub fn measure_observer_until(
    config: &RunConfig,
    kind: ObserverKind,
    trainer: Option<&Trainer>,
    stop: &AtomicBool,
) -> Result<CmfSimResult, Error> {
    measure_observer_with(config, kind, trainer.map(|t| &t.cortex), &mut |_| {}, stop)
}

/// [`measure_observer_until`] with the learned cortex given directly and CMF-SIM's progress
/// reported (after every primary set).
pub fn measure_observer_with(
    config: &RunConfig,
    kind: ObserverKind,
    cortex: Option<&Cortex>,
    progress: &mut dyn FnMut(&CmfSimProgress),
    stop: &AtomicBool,
) -> Result<CmfSimResult, Error> {
    let eye = measurement_config(config).retina;
    let retina = Retina::with_progress_until(eye, &|_| {}, stop)?;
    let oracle = |interpolate: bool| oracle_decoder(&retina, config, interpolate);
    let decoder = match (kind, cortex) {
        (ObserverKind::Cortex, Some(c)) => Decoder::Cortex(c),
        (ObserverKind::Cortex, None) => {
            return Err(Error::invalid(
                "observer",
                "`cortex` needs a trained cortex (a run folder's checkpoint)",
            ))
        }
        (ObserverKind::Identity, _) => Decoder::Ons,
        (ObserverKind::Cones, _) => Decoder::Cones,
        (ObserverKind::Oracle, _) => Decoder::Oracle(oracle(true)?),
        (ObserverKind::OracleMosaic, _) => Decoder::Oracle(oracle(false)?),
        (ObserverKind::Analytic, _) => {
            let observer = own_fundamentals(&retina, config)?;
            return Ok(run_cmf_sim_until(
                &observer,
                &config.cmf_sim,
                progress,
                stop,
            )?);
        }
    };
    measure_decoder_until(&retina, decoder, config, progress, stop)
}

/// CMF-SIM (`config.cmf_sim`) of `retina` followed by `decoder` (`config.observer`). An
/// external decoder's failure — an error it returned, a non-finite percept — is the error,
/// not a failed match.
pub fn measure_decoder_until(
    retina: &Retina,
    decoder: Decoder<'_>,
    config: &RunConfig,
    progress: &mut dyn FnMut(&CmfSimProgress),
    stop: &AtomicBool,
) -> Result<CmfSimResult, Error> {
    let observer = EyeObserver::new(retina, decoder, config.observer.clone());
    let result = run_cmf_sim_until(&observer, &config.cmf_sim, progress, stop);
    if let Some(why) = observer.decoder_failure() {
        return Err(Error::invalid("decoder", why));
    }
    Ok(result?)
}
