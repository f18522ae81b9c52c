"""Type stubs of colorvision's Rust extension (see colorvision/__init__.py and docs/python.md)."""

import os
from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
Batch = Tuple[F32, F32, F32]
Decoder = Union[Callable[[F32], Any], "KnownDecoder", "Run"]

class Eye:
    """The simulated eye. Settings are resolved as `--preset/--cones/--seed/--set` are:
    ``settings`` maps dotted keys to values, keywords give top-level keys or use ``__`` for
    dots (``observer__noise_ratio=0.1``). A bad setting raises ValueError."""

    def __init__(
        self,
        preset: str = "quick",
        cones: str = "LMS",
        seed: int = 0,
        settings: Optional[Dict[str, Any]] = None,
        **more: Any,
    ) -> None: ...
    @property
    def n_cones(self) -> int:
        """Cones per side n: an ONS frame is (n, n)."""
    @property
    def field_px(self) -> int:
        """Side of the scene field the cones sample, px."""
    @property
    def wavelengths_nm(self) -> F64:
        """The eye's wavelength grid, nm."""
    @property
    def preset(self) -> str: ...
    @property
    def cones(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def batch_size_default(self) -> int:
        """The preset's training batch size (default of batch/batches)."""
    @property
    def config_toml(self) -> str:
        """Every resolved setting as TOML (a run's config.toml)."""
    @property
    def truth(self) -> Dict[str, Any]:
        """Evaluation only: cone_classes, cone_peaks_nm, weights (n, n, K), positions_px
        (n, n, 2) as [x, y], field_px."""
    def ons(self, scene: npt.ArrayLike, wavelengths_nm: List[float]) -> F32:
        """Noise-free ONS (n, n) of a radiance cube (H, W, L) at wavelengths_nm (L,); the
        field's top-left is the cube's; H, W >= field_px."""
    def scene_ons(self, tile: int = 0, origin_px: Optional[Tuple[int, int]] = None) -> F32:
        """Noise-free ONS (n, n) of built-in scene tile `tile`, field top-left at origin_px
        (default centred)."""
    def batch(self, batch_size: Optional[int] = None) -> Batch:
        """(ons_t (B, n, n), ons_t1 (B, n, n), shift (B, 2)) float32, as training draws them."""
    def batches(self, batch_size: Optional[int] = None, count: Optional[int] = None) -> "Batches":
        """`count` batches (endless when None)."""

class Batches(Iterator[Batch]):
    def __iter__(self) -> "Batches": ...
    def __next__(self) -> Batch: ...

class KnownDecoder:
    """identity (undefined, 0), cones (1), oracle (the number of independent cone kinds),
    oracle-mosaic (the oracle without interpolation)."""

    def __init__(self, name: str) -> None: ...
    @property
    def name(self) -> str: ...

class Run:
    """A trained run folder (load_run): its eye and its cortex as a decoder."""

    @property
    def eye(self) -> Eye: ...
    @property
    def checkpoint(self) -> str: ...
    @property
    def channels(self) -> int: ...
    @property
    def config_toml(self) -> str: ...
    def __call__(self, ons: npt.ArrayLike) -> F32:
        """Percepts (N, C, n, n) of ONS frames (N, n, n)."""

def load_run(path: Union[str, "os.PathLike[str]"], checkpoint_step: Optional[int] = None) -> Run:
    """A run folder written by `colorvision run`/`train`, checked as `cmf-sim --run` checks it."""

class CmfSimResult:
    @property
    def dimension(self) -> int:
        """First K with a passing primary set; 0 when undefined."""
    @property
    def verdict(self) -> str: ...
    @property
    def no_colour_constancy(self) -> bool: ...
    @property
    def observer(self) -> str: ...
    @property
    def margins(self) -> Dict[int, float]:
        """K -> converged worst error / threshold (< 1 passes)."""
    @property
    def base_over_energy(self) -> float: ...
    @property
    def test_wavelengths_nm(self) -> F64: ...
    @property
    def base_error(self) -> F64: ...
    @property
    def energy(self) -> F64: ...
    @property
    def threshold(self) -> F64: ...
    @property
    def curves(self) -> List[Dict[str, Any]]: ...
    @property
    def seconds(self) -> float: ...
    @property
    def shows(self) -> int: ...
    def json(self) -> str:
        """cmf_sim.json as `colorvision cmf-sim` writes it."""
    def to_dict(self) -> Dict[str, Any]: ...
    def save(self, folder: Union[str, "os.PathLike[str]"]) -> List[str]: ...
    def summary(self) -> str:
        """The lines `colorvision cmf-sim` prints."""

def cmf_sim(
    eye: Eye,
    decoder: Decoder,
    budget: str = "full",
    location_seed: Optional[int] = None,
    batch_size: int = 256,
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
) -> CmfSimResult:
    """CMF-SIM of the eye followed by `decoder`: a callable (N, n, n) float32 -> (N, C, n, n),
    a KnownDecoder, or a Run (then eye must be run.eye). budget: "full" (as colorvision
    cmf-sim) or "quick" (the budget during training)."""

def hidden(eye: Eye, decoder: Decoder, scenes: Optional[int] = None) -> Dict[str, Any]:
    """What the decoder's percept carries of each cone class's own signal at the other
    classes' cones (held-out R² per class: "unique_r2", with "unique_share", "sites",
    "classes", "scenes"), and which colour directions it carries ("directions"), on the first
    `scenes` held-out scenes of the eye (2 to 4096, rounded up to whole batches of 4; by
    default 1024, converged), a fresh scene tile every batch: the figures a run's summary.json
    holds (invariants.recovery.hidden, .directions) on its "scenes" (schedule.held_out_scenes:
    1024; a tiny run, or a run whose config predates the setting, 32). A figure with no value (a one-class eye) is None. decoder: as for cmf_sim."""

def own_image(eye: Eye, decoder: Decoder, scenes: Optional[int] = None) -> Optional[Dict[str, Any]]:
    """The eye's last class's own signal (S for LMS, Q for LMSQ) on the last held-out scene
    beside the decoder's reading of it, on `scenes` held-out scenes (2 to 4096, rounded up to
    whole batches of 4; by default 1024) after the schedule.held_out_scenes that a run's
    summary reads (1024; a tiny run 32), as a run's pictures draw them (at that count a run's
    held_out_r2 is its summary.json's): "truth" and
    "reading" (side, side) float64 inside the loss border, "held_out_r2" over the scoring half
    of the scenes, "scene_srgb" (3, n, n) float32 linear sRGB at each cone, "class",
    "class_range" (the class's excitation range over that scene: the scale its own signal is
    small against), "n", "border"; None for an eye of one class. decoder: as for cmf_sim."""
