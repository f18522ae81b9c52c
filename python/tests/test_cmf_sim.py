"""CMF-SIM from Python: the calibration ladder's known answers, a run folder measured as the
command line measures it, and every way a decoder can fail."""

import _thread
import json
import threading
import time

import numpy as np
import pytest

import colorvision as cv

from conftest import ROOT, cli


@pytest.fixture(scope="module")
def lms():
    return cv.Eye("tiny", cones="LMS")


@pytest.mark.parametrize(
    "cones, decoder, dimension",
    [
        ("LMS", cv.identity(), 0),
        ("LMS", cv.cone_activations(), 1),
        ("LMS", cv.oracle(), 3),
        ("MS", cv.oracle(), 2),
    ],
    ids=["identity", "cones", "oracle-LMS", "oracle-MS"],
)
def test_known_answers_of_the_calibration_ladder(cones, decoder, dimension):
    result = cv.cmf_sim(cv.Eye("tiny", cones=cones), decoder)
    assert result.dimension == dimension, result.summary()
    assert result.no_colour_constancy == (decoder.name == "identity")
    if dimension:
        assert result.margins[dimension] < 1.0
        assert all(result.margins[k] >= 1.0 for k in range(1, dimension))


def test_a_python_decoder_is_measured_and_the_identity_has_no_colour_constancy(lms):
    calls = []

    def ons_as_percept(ons):
        calls.append(ons.shape)
        assert ons.dtype == np.float32 and ons.ndim == 3 and ons.shape[1:] == (32, 32)
        return ons[:, None]

    mine = cv.cmf_sim(lms, ons_as_percept, batch_size=64)
    known = cv.cmf_sim(lms, cv.identity())
    assert mine.dimension == 0 and mine.no_colour_constancy
    assert "Python decoder `test_a_python_decoder_is_measured" in mine.observer
    np.testing.assert_allclose(mine.base_error, known.base_error, rtol=1e-5)
    np.testing.assert_allclose(mine.energy, known.energy, rtol=1e-5)
    assert calls[0] == (1, 32, 32), "the probe of one black frame comes first"
    assert max(n for n, _, _ in calls) <= 64


def test_a_nonlinear_python_decoder_is_measured_without_the_linear_shortcut(lms):
    """A decoder that compresses the ONS (a sign-preserving square root, then tanh): CMF-SIM
    must show it every stimulus. Its answer is whatever it is; what is checked is that it is
    measured end to end with finite curves and a dimension CMF-SIM can report."""

    def compressive(ons):
        x = np.sign(ons) * np.sqrt(np.abs(ons))
        return np.stack([x, np.tanh(4.0 * ons)], axis=1)

    result = cv.cmf_sim(lms, compressive, budget="quick", location_seed=3)
    assert 0 <= result.dimension <= 4
    assert all(np.isfinite(c["errors"]).all() for c in result.curves)
    assert result.to_dict()["settings"]["seed"] == 3


def test_a_run_folder_measured_from_python_equals_the_command_line(colorvision_bin, tiny_run, tmp_path):
    cli(colorvision_bin, "cmf-sim", "--run", tiny_run, "--out", tmp_path / "cli")
    said = json.loads((tmp_path / "cli" / "cmf_sim.json").read_text())
    run = cv.load_run(tiny_run)
    result = cv.cmf_sim(run.eye, run)
    mine = result.to_dict()
    for record in (said, mine):
        record.pop("seconds")
        for k in record["per_k"]:
            k.pop("seconds", None)
    assert mine == said, "every figure of cmf_sim.json, to the last digit"
    assert result.dimension == said["dimension"]
    assert result.margins == {k["n_primaries"]: k["converged_worst_ratio"] for k in said["per_k"]}
    result.save(tmp_path / "py")
    assert (tmp_path / "py" / "cmf_sim.json").is_file()
    # The cortex as a plain decoder: (N, n, n) -> (N, C, n, n).
    ons_t, _, _ = run.eye.batch(3)
    assert run(ons_t).shape == (3, run.channels, 32, 32)


def test_a_record_kept_with_its_parameters_only_loads_and_decodes():
    # results/ keeps a record's last checkpoint without the optimiser's state
    # (scripts/record-run.sh): the 4-D quick tetrachromat at 96 000 steps.
    record = ROOT / "results" / "fourth-A2b-seed23"
    checkpoint = record / "checkpoints" / "step_00096000"
    assert not (checkpoint / "optim.safetensors").exists()
    run = cv.load_run(record, checkpoint_step=96000)
    assert run.checkpoint == checkpoint
    ons_t, _, _ = run.eye.batch(2)
    percept = run(ons_t)
    assert percept.shape == (2, run.channels, 64, 64)
    assert np.isfinite(percept).all() and np.abs(percept).max() > 0


def test_a_missing_run_folder_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="config.toml|run folder|not"):
        cv.load_run(tmp_path / "nothing")


class DecoderBroke(RuntimeError):
    pass


def test_an_exception_in_the_decoder_propagates_with_its_traceback(lms):
    seen = []

    def breaks_on_the_second_batch(ons):
        seen.append(len(ons))
        if len(seen) == 2:
            raise DecoderBroke("my model broke")
        return ons[:, None]

    with pytest.raises(DecoderBroke, match="my model broke") as info:
        cv.cmf_sim(lms, breaks_on_the_second_batch)
    assert any(entry.name == "breaks_on_the_second_batch" for entry in info.traceback)
    assert len(seen) == 2, "no call after the failure"


def test_a_wrong_shape_or_a_nan_is_a_value_error(lms):
    with pytest.raises(ValueError, match=r"shape \(1, 32, 32\).*expected"):
        cv.cmf_sim(lms, lambda ons: ons)
    with pytest.raises(ValueError, match=r"shape \(16, 2, 32, 32\).*expected \(16, 1, 32, 32\)"):
        cv.cmf_sim(lms, lambda ons: np.repeat(ons[:, None], 1 if len(ons) == 1 else 2, axis=1), batch_size=16)

    def sqrt_of_the_ons(ons):
        return np.sqrt(ons)[:, None]  # the ONS is signed: NaN wherever it is negative

    with np.errstate(invalid="ignore"):
        with pytest.raises(ValueError, match=r"NaN at index \(.*\): percepts must be finite"):
            cv.cmf_sim(lms, sqrt_of_the_ons)
    with pytest.raises(ValueError, match="cannot be read as a float32 array"):
        cv.cmf_sim(lms, lambda ons: "not an array")
    with pytest.raises(TypeError, match="not callable"):
        cv.cmf_sim(lms, 42)
    with pytest.raises(ValueError, match="budget"):
        cv.cmf_sim(lms, cv.identity(), budget="huge")
    with pytest.raises(ValueError, match="decoder `oracel`"):
        cv.KnownDecoder("oracel")


def test_progress_reaches_the_callback_and_ctrl_c_interrupts_within_seconds():
    # A measurement of minutes in Rust alone: the LMS oracle fails K = 1 and 2, here with
    # thousands of sets per K.
    eye = cv.Eye("tiny", cones="LMS", settings={"cmf_sim.sets_per_k": 5000})
    reports = []
    timer = threading.Timer(1.0, _thread.interrupt_main)
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            cv.cmf_sim(eye, cv.oracle(), progress=reports.append)
    finally:
        timer.cancel()
    assert time.monotonic() - start < 3.0  # the interrupt at 1 s, seen within about a second
    assert reports and {"message", "n_primaries", "sets_tried", "best_worst_ratio"} <= set(reports[0])
