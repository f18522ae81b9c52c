"""What a percept carries of each cone class's own signal, from Python (`hidden`, and the last
class's as a picture, `own_image`): known answers (the oracle that interpolates each kind
carries it, the oracle that keeps each cell's own kind and the cone activations do not, the ONS
a little through its surround), a run's
figures equal to its summary.json, and a Python decoder equal to the same decoder known to
Rust."""

import json

import numpy as np
import pytest

import colorvision as cv


@pytest.fixture(scope="module")
def quick():
    return cv.Eye("quick", cones="LMS")


def test_the_interpolating_oracle_carries_every_class_and_the_mosaic_oracle_none(quick):
    # At a cone of another class, only interpolation from a class's own cones can tell what
    # that class caught beyond the others: the oracle without interpolation and the cone
    # activations leave nothing of it (R² at or below 0), the interpolating oracle a clear
    # share.
    interpolating = cv.hidden(quick, cv.oracle())
    assert interpolating["classes"] == ["L", "M", "S"]
    assert all(r2 > 0.25 for r2 in interpolating["unique_r2"]), interpolating
    for decoder in (cv.oracle(interpolate=False), cv.cone_activations()):
        none = cv.hidden(quick, decoder)
        assert all(r2 < 0.05 for r2 in none["unique_r2"]), (decoder, none)
        # the scenes and sites are the same whatever the decoder
        assert none["unique_share"] == interpolating["unique_share"]
        assert none["sites"] == interpolating["sites"]


def test_the_ons_carries_its_neighbours_only_through_the_surround(quick):
    # The ONS at a cone is its centre minus a surround of its neighbours (lateral inhibition),
    # so it holds a little of what neighbouring cones of other classes caught: more than the
    # cone activations (the surround undone), far less than interpolation. Without the
    # surround it is the cone activations' and carries nothing.
    ons = cv.hidden(quick, cv.identity())["unique_r2"]
    cones = cv.hidden(quick, cv.cone_activations())["unique_r2"]
    oracle = cv.hidden(quick, cv.oracle())["unique_r2"]
    assert max(ons) > max(cones) + 0.03, (ons, cones)
    assert all(o < r / 3 for o, r in zip(ons, oracle)), (ons, oracle)
    flat = cv.Eye("quick", cones="LMS", settings={"retina.lateral_inhibition.surround_weight": 0.0})
    assert all(r2 < 0.05 for r2 in cv.hidden(flat, cv.identity())["unique_r2"])


def test_a_python_decoder_equals_the_same_decoder_known_to_rust(quick):
    known = cv.hidden(quick, cv.identity(), scenes=8)
    python = cv.hidden(quick, lambda ons: ons[:, None], scenes=8)
    assert python == known
    # and a decoder that reads more gives other figures
    doubled = cv.hidden(quick, lambda ons: np.stack([ons, ons**2], axis=1), scenes=8)
    assert doubled["unique_r2"] != known["unique_r2"]


def test_a_run_measured_from_python_equals_its_summary(tiny_run):
    run = cv.load_run(tiny_run)
    summary = json.loads((tiny_run / "summary.json").read_text())
    recovery = summary["invariants"]["recovery"]
    want = dict(recovery["hidden"], directions=recovery["directions"])
    got = cv.hidden(run.eye, run, scenes=want["scenes"])
    assert got == want
    # the same cortex as a Python decoder (8 channels, through NumPy) gives the same figures
    assert cv.hidden(run.eye, lambda ons: run(ons), scenes=want["scenes"]) == got


def test_bad_decoders_and_counts_are_refused(quick):
    with pytest.raises(TypeError, match="not callable"):
        cv.hidden(quick, 3)
    for scenes in (1, 10**12):
        with pytest.raises(ValueError, match="scenes must be"):
            cv.hidden(quick, cv.identity(), scenes=scenes)
    with pytest.raises(ValueError, match="shape"):
        cv.hidden(quick, lambda ons: ons)

    class ModelBroke(Exception):
        pass

    raised = ModelBroke("the model broke")

    def fails(ons):
        if ons.shape[0] > 1:
            raise raised
        return ons[:, None]

    with pytest.raises(ModelBroke) as excinfo:
        cv.hidden(quick, fails)
    assert excinfo.value is raised


def test_the_own_image_of_the_last_class_and_its_known_answers(quick):
    oracle = cv.own_image(quick, cv.oracle())
    assert oracle["class"] == "S"
    n, border = oracle["n"], oracle["border"]
    side = n - 2 * border
    assert oracle["truth"].shape == oracle["reading"].shape == (side, side)
    assert oracle["scene_srgb"].shape == (3, n, n)
    assert np.isfinite(oracle["truth"]).all() and oracle["truth"].std() > 0
    assert oracle["held_out_r2"] > 0.4, oracle["held_out_r2"]
    for decoder in (cv.oracle(interpolate=False), cv.identity()):
        none = cv.own_image(quick, decoder)
        assert none["held_out_r2"] < 0.05, (decoder, none["held_out_r2"])
        # the same scene and truth whatever the decoder
        assert np.array_equal(none["truth"], oracle["truth"])
    # the same decoder given as a Python function reads the same
    python = cv.own_image(quick, lambda ons: ons[:, None])
    assert python["held_out_r2"] == cv.own_image(quick, cv.identity())["held_out_r2"]
    # an eye of one class has no own signal to show; a tetrachromat's newest is Q
    assert cv.own_image(cv.Eye("tiny", cones="L"), cv.identity()) is None
    with pytest.raises(TypeError, match="not callable"):  # checked before the eye's classes
        cv.own_image(cv.Eye("tiny", cones="L"), 3)

    def never(ons):
        raise AssertionError("a one-class eye's decoder must not be called")

    assert cv.own_image(cv.Eye("tiny", cones="L"), never) is None
    assert cv.own_image(cv.Eye("tiny", cones="LMSQ"), cv.identity())["class"] == "Q"
    with pytest.raises(ValueError, match="scenes must be"):
        cv.own_image(quick, cv.identity(), scenes=1)
    with pytest.raises(TypeError, match="not callable"):
        cv.own_image(quick, "oracle")


def test_a_runs_own_image_from_python_equals_its_summary(tiny_run):
    run = cv.load_run(tiny_run)
    summary = json.loads((tiny_run / "summary.json").read_text())
    scenes = summary["invariants"]["recovery"]["hidden"]["scenes"]
    got = cv.own_image(run.eye, run, scenes=scenes)
    want = summary["invariants"]["own_image"]
    assert (got["class"], got["held_out_r2"]) == (want["class"], want["held_out_r2"])
    python = cv.own_image(run.eye, lambda ons: run(ons), scenes=scenes)
    assert python["held_out_r2"] == got["held_out_r2"]
    assert np.array_equal(python["reading"], got["reading"])
