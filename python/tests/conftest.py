"""Shared fixtures: the `colorvision` command-line binary (for answers to compare against) and
a tiny trained run folder, made once per session."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# One rayon thread: the figures compared across the two interfaces do not depend on it, and CI
# machines are small.
os.environ.setdefault("RAYON_NUM_THREADS", "1")


@pytest.fixture(scope="session")
def colorvision_bin() -> pathlib.Path:
    """The command-line program of this checkout (`cargo test --release` builds it; built here
    if it is missing)."""
    exe = ROOT / "target" / "release" / "colorvision"
    if not exe.is_file():
        subprocess.run(["cargo", "build", "--release", "--bin", "colorvision"], cwd=ROOT, check=True)
    return exe


def cli(colorvision_bin, *args, check=True):
    """Runs `colorvision ARGS…`, returning the completed process."""
    return subprocess.run(
        [str(colorvision_bin), *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=check,
    )


@pytest.fixture(scope="session")
def tiny_run(colorvision_bin, tmp_path_factory) -> pathlib.Path:
    """A `tiny` LMS cortex trained 20 steps by the command line."""
    out = tmp_path_factory.mktemp("runs") / "tiny-LMS"
    cli(colorvision_bin, "train", "--preset", "tiny", "--cones", "LMS", "--steps", 20, "--out", out)
    return out
