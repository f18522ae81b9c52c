"""The eye from Python: settings as the command line resolves them, ONS of scenes, batches,
the truth kept apart."""

import numpy as np
import pytest

import colorvision as cv

from conftest import cli


@pytest.fixture(scope="module")
def eye():
    return cv.Eye("tiny", cones="LMS", seed=0)


def test_settings_resolve_like_the_command_line(eye):
    assert (eye.preset, eye.cones, eye.seed, eye.n_cones, eye.field_px) == ("tiny", "LMS", 0, 32, 64)
    tuned = cv.Eye("tiny", steps=123, settings={"observer.noise_ratio": 0.25}, cmf_sim__sets_per_k=7)
    text = tuned.config_toml
    assert "steps = 123" in text and "noise_ratio = 0.25" in text and "sets_per_k = 7" in text


@pytest.mark.parametrize(
    "kwargs, flag",
    [
        ({"settings": {"observer.noise_ratio": -1.0}}, "observer.noise_ratio=-1.0"),
        ({"settings": {"observer.nosie_ratio": 0.1}}, "observer.nosie_ratio=0.1"),
        ({"settings": {"cmf_sim.sets_per_k": "many"}}, 'cmf_sim.sets_per_k="many"'),
    ],
)
def test_a_bad_setting_is_a_value_error_in_the_command_lines_words(colorvision_bin, kwargs, flag):
    with pytest.raises(ValueError) as python:
        cv.Eye("tiny", **kwargs)
    said = cli(colorvision_bin, "cmf-sim", "--observer", "identity", "--preset", "tiny", "--set", flag, check=False)
    assert said.returncode != 0
    assert said.stderr.strip() == f"colorvision: error: {python.value}"


def test_a_bad_preset_or_cone_spec_is_a_value_error():
    with pytest.raises(ValueError, match="preset"):
        cv.Eye("tinyy")
    with pytest.raises(ValueError):
        cv.Eye("tiny", cones="LMZ")


def test_batches_are_float32_pairs_with_the_shift_and_repeat_with_the_seed(eye):
    ons_t, ons_t1, shift = eye.batch(4)
    assert ons_t.shape == ons_t1.shape == (4, 32, 32) and shift.shape == (4, 2)
    assert ons_t.dtype == ons_t1.dtype == shift.dtype == np.float32
    assert np.isfinite(ons_t).all() and not np.array_equal(ons_t, ons_t1)
    again = cv.Eye("tiny", cones="LMS", seed=0).batch(4)
    np.testing.assert_array_equal(again[0], ons_t)
    other = cv.Eye("tiny", cones="LMS", seed=1).batch(4)
    assert not np.array_equal(other[0], ons_t)
    batches = list(eye.batches(batch_size=2, count=3))
    assert len(batches) == 3 and all(b[0].shape == (2, 32, 32) for b in batches)


def test_the_ons_of_a_scene_cube_is_linear_in_its_radiance(eye):
    rng = np.random.default_rng(0)
    wavelengths = np.linspace(380.0, 780.0, 41)
    cube = rng.uniform(0.0, 1.0, size=(64, 80, 41))
    ons = eye.ons(cube, wavelengths)
    assert ons.shape == (32, 32) and ons.dtype == np.float32 and np.abs(ons).max() > 0
    np.testing.assert_allclose(eye.ons(2.0 * cube, wavelengths), 2.0 * ons, rtol=1e-4, atol=1e-6)
    with pytest.raises(ValueError, match="field_px"):
        eye.ons(cube[:32], wavelengths)
    with pytest.raises(ValueError, match="radiance"):
        eye.ons(-cube, wavelengths)
    with pytest.raises(ValueError, match="H, W, wavelengths"):
        eye.ons(cube[..., 0], wavelengths)


def test_built_in_scenes_give_an_ons_frame(eye):
    ons = eye.scene_ons(tile=1)
    assert ons.shape == (32, 32) and np.abs(ons).max() > 0
    with pytest.raises(ValueError, match="tiles"):
        eye.scene_ons(tile=10_000)


def test_the_truth_is_kept_apart_and_describes_the_mosaic(eye):
    truth = eye.truth
    assert truth["cone_classes"] == ["L", "M", "S"]
    assert truth["weights"].shape == (32, 32, 3) and truth["positions_px"].shape == (32, 32, 2)
    np.testing.assert_allclose(truth["weights"].sum(axis=-1), 1.0, rtol=1e-6)
    assert 0 <= truth["positions_px"].min() and truth["positions_px"].max() < eye.field_px
