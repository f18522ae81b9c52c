//! The numeric side of a gradient check: central differences element by element or along
//! random unit directions, and the judgement of each entry against the tolerances (see the
//! parent module's docs for the error measure).

use super::*;

/// Central differences of `loss` along every element of input `i`, with the step
/// `h = eps·max(1, |x_j|)` per element; `xs` is restored after each probe.
pub(super) fn probe_elements(
    i: usize,
    inputs: &[Tensor<f64>],
    grad: &Tensor<f64>,
    xs: &mut [Tensor<f64>],
    cfg: &CheckConfig,
    loss: &mut impl FnMut(&[Tensor<f64>]) -> f64,
    entries: &mut Vec<Entry>,
) {
    for j in 0..inputs[i].numel() {
        let x0 = inputs[i].data()[j];
        let h = cfg.eps * x0.abs().max(1.0);
        xs[i].data_mut()[j] = x0 + h;
        let lp = loss(xs);
        xs[i].data_mut()[j] = x0 - h;
        let lm = loss(xs);
        xs[i].data_mut()[j] = x0;
        let numeric = (lp - lm) / ((x0 + h) - (x0 - h));
        entries.push(entry(
            i,
            inputs[i].shape(),
            Probe::Element(j),
            grad.data()[j],
            numeric,
        ));
    }
}

/// Central differences of `loss` along `cfg.probes` random unit directions (drawn from `rng`)
/// of input `i`, compared with the analytic directional derivative `u · ∂L/∂x`; `xs` is
/// restored after each probe.
#[allow(clippy::too_many_arguments)]
pub(super) fn probe_directions(
    i: usize,
    inputs: &[Tensor<f64>],
    grad: &Tensor<f64>,
    xs: &mut [Tensor<f64>],
    cfg: &CheckConfig,
    rng: &mut StdRng,
    loss: &mut impl FnMut(&[Tensor<f64>]) -> f64,
    entries: &mut Vec<Entry>,
) {
    let n = inputs[i].numel();
    // The step is relative to ‖x‖₂ (as `h = eps·max(1, |x_j|)` is per element): a
    // unit direction spread over many elements changes L by little, and a step relative
    // to max|x| would drown the difference in the round-off of L's many terms.
    let norm = inputs[i].sum_sq().sqrt();
    let h = cfg.eps * norm.max(1.0);
    for k in 0..cfg.probes {
        let mut u: Vec<f64> = (0..n).map(|_| rng.sample(StandardNormal)).collect();
        let norm = u
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt()
            .max(f64::MIN_POSITIVE);
        u.iter_mut().for_each(|v| *v /= norm);
        let analytic: f64 = u.iter().zip(grad.data()).map(|(a, b)| a * b).sum();
        let shifted =
            |s: f64| Tensor::from_fn(inputs[i].shape(), |j| inputs[i].data()[j] + s * h * u[j]);
        xs[i] = shifted(1.0);
        let lp = loss(xs);
        xs[i] = shifted(-1.0);
        let lm = loss(xs);
        xs[i] = inputs[i].clone();
        entries.push(entry(
            i,
            inputs[i].shape(),
            Probe::Direction(k),
            analytic,
            (lp - lm) / (2.0 * h),
        ));
    }
}

pub(super) fn entry(
    input: usize,
    shape: Shape,
    probe: Probe,
    analytic: f64,
    numeric: f64,
) -> Entry {
    let rel_err = (analytic - numeric).abs() / 1f64.max(analytic.abs()).max(numeric.abs());
    Entry {
        input,
        shape,
        probe,
        analytic,
        numeric,
        rel_err,
    }
}

pub(super) fn finite(data: &[f64], what: &str) -> Result<(), CheckError> {
    match data.iter().position(|v| !v.is_finite()) {
        Some(j) => Err(CheckError::NonFinite {
            what: format!("{what} at flat index {j}: {}", data[j]),
        }),
        None => Ok(()),
    }
}

pub(super) fn judge(mut entries: Vec<Entry>, cfg: &CheckConfig) -> Result<CheckReport, CheckError> {
    let checked = entries.len();
    if let Some(e) = entries
        .iter()
        .find(|e| !e.numeric.is_finite() || !e.analytic.is_finite())
    {
        return Err(CheckError::NonFinite {
            what: format!("value in {e}"),
        });
    }
    let fails = |e: &Entry| {
        let scale = 1f64.max(e.analytic.abs()).max(e.numeric.abs());
        (e.analytic - e.numeric).abs() > cfg.atol + cfg.rtol * scale
    };
    let failed = entries.iter().filter(|e| fails(e)).count();
    entries.sort_by(|a, b| b.rel_err.total_cmp(&a.rel_err));
    if failed > 0 {
        let worst = entries.into_iter().filter(fails).take(10).collect();
        return Err(CheckError::Mismatch {
            failed,
            checked,
            rtol: cfg.rtol,
            atol: cfg.atol,
            worst,
        });
    }
    Ok(CheckReport {
        checked,
        max_rel_err: entries.first().map_or(0.0, |e| e.rel_err),
        worst: entries.into_iter().next(),
    })
}
