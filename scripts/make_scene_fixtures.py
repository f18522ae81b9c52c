#!/usr/bin/env python3
"""Writes the spectral scene fixtures of retina/tests/fixtures/scenes/ with an independent
writer (h5py over libhdf5), shaped like MATLAB's own v7.3 output.

Development step only: the committed fixtures are what the tests read; the tests never run
Python. Usage (numpy, h5py and Pillow): python3 scripts/make_scene_fixtures.py [OUT_DIR]

A MATLAB v7.3 .mat file is HDF5 behind a 512-byte user block that starts with MATLAB's
116-byte header text; MATLAB writes arrays in column-major order, so an H x W x B cube appears
in HDF5 as (B, W, H), and every variable carries a `MATLAB_class` attribute. ARAD_1K
(NTIRE 2022) cubes are `single` 482 x 512 x 31 with `bands` a 1 x 31 `double` (400:10:700).

Fixtures:
- arad_like.mat: cube(y, x, b) = (y + 16 x + 256 b) / 1024 as single (exact in f32), H 5,
  W 7, 31 bands 400..700 nm; chunked (8, 4, 3) with gzip 3 (MATLAB's level) so several chunks
  cross each edge. Every value differs, so a transposed, flipped or band-reversed read fails.
- arad_uint16.mat: the same cube as uint16 (value * 1024), bands stored as a column 31 x 1.
- arad_nan.mat: arad_like with cube(2, 3, 4) (1-based: row 3, column 4, band 5) = NaN.
- band_first.mat: the same cube stored by MATLAB as B x H x W (HDF5 (W, H, B)), bands
  decreasing 700..400 with the planes in that order.
- row_major.h5: the same cube written by NumPy as H x W x B (C order), no user block, no
  MATLAB attributes, wavelengths in `wavelengths`.
- wrong_dataset.mat: a `radiance` variable and no `cube`.
- narrow_bands.mat: 450..650 nm, which does not cover a 400..700 nm eye.
- truncated.mat: arad_like cut to its first 2/3 of bytes.
- not_hdf5.mat: a MATLAB v5 style header with no HDF5 inside.
- cave/pattern_ms/pattern_ms/pattern_ms_NN.png, NN = 01..31: the cube of arad_like as CAVE
  ships a scene (one 16-bit grey PNG per band, 400..700 nm, CAVE's nested folders), samples
  y + 16 x + 256 b.
- envi/pattern_bil.hdr + pattern_bil.img: the cube of arad_like in ENVI, band-interleaved by
  line, big-endian float32, wavelengths in micrometers; envi/pattern_bip.hdr + pattern_bip (no
  extension): band-interleaved by pixel, little-endian uint16 (value * 1024) with a reflectance
  scale factor of 1024, wavelengths listed 700..400; envi/short.hdr + short.img: the bil header
  over a cube cut in half.
- scenes/: three 40 x 48 ARAD-like scenes (smooth reflectance spectra in coloured discs and
  bars under a daylight-like illuminant; chunks (31, 16, 16)), for an end-to-end training run.
"""

import os
import sys

import h5py
import numpy as np

BANDS = np.arange(400.0, 701.0, 10.0)


def matlab_header():
    text = (
        "MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  6 12:00:00 2025 "
        "HDF5 schema 1.00 ."
    )
    head = text.ljust(116).encode("ascii")
    # Subsystem data offset (8 bytes), version 0x0200, endian indicator "IM".
    head += b"\x00" * 8 + b"\x00\x02" + b"IM"
    return head.ljust(512, b"\x00")


def write_mat(path, variables, chunks3=(8, 4, 3)):
    """variables: name -> (numpy array in MATLAB's (rows, cols, ...) order, MATLAB class);
    3-D arrays chunked by `chunks3` (in HDF5's order) with gzip level 3."""
    with h5py.File(path, "w", userblock_size=512, libver="earliest") as f:
        for name, (array, cls) in variables.items():
            # Column-major: MATLAB's dims reversed.
            data = np.ascontiguousarray(np.transpose(array))
            chunks = None
            if data.ndim == 3:
                chunks = tuple(min(c, s) for c, s in zip(chunks3, data.shape))
            ds = f.create_dataset(
                name,
                data=data,
                chunks=chunks,
                compression="gzip" if chunks else None,
                compression_opts=3 if chunks else None,
            )
            ds.attrs.create("MATLAB_class", np.bytes_(cls))
    with open(path, "r+b") as f:
        f.write(matlab_header())


def pattern_cube(h=5, w=7, bands=31):
    y, x, b = np.meshgrid(np.arange(h), np.arange(w), np.arange(bands), indexing="ij")
    return ((y + 16 * x + 256 * b) / 1024.0).astype(np.float32)


def bands_row(bands=BANDS):
    return bands.reshape(1, -1).astype(np.float64)


def natural_scene(seed, h=40, w=48):
    """Discs and bars of smooth random reflectances on a background, under a warm daylight-like
    illuminant, with a shading gradient: H x W x 31 single, in steps of 1/4096 (so the file
    compresses)."""
    rng = np.random.default_rng(seed)
    lam = (BANDS - 400.0) / 300.0

    def reflectance():
        centres = rng.uniform(0.0, 1.0, 3)
        weights = rng.uniform(0.0, 1.0, 3)
        r = 0.05 + sum(wt * np.exp(-0.5 * ((lam - c) / 0.15) ** 2) for wt, c in zip(weights, centres))
        return np.clip(r / max(r.max(), 1e-6) * rng.uniform(0.3, 0.9), 0.02, 1.0)

    labels = np.zeros((h, w), dtype=np.int64)
    yy, xx = np.mgrid[0:h, 0:w]
    for k in range(1, 9):
        if rng.uniform() < 0.5:
            cy, cx, rad = rng.uniform(0, h), rng.uniform(0, w), rng.uniform(4, 14)
            labels[(yy - cy) ** 2 + (xx - cx) ** 2 < rad**2] = k
        else:
            y0, x0 = rng.integers(0, h - 4), rng.integers(0, w - 4)
            labels[y0 : y0 + rng.integers(4, 20), x0 : x0 + rng.integers(4, 30)] = k
    refl = np.stack([reflectance() for _ in range(9)])
    illuminant = 0.6 + 0.4 * lam
    shading = 0.6 + 0.4 * (xx / (w - 1))
    cube = refl[labels] * illuminant[None, None, :] * shading[:, :, None]
    return (np.round(cube * 4096) / 4096).astype(np.float32)


def envi_header(h, w, bands, data_type, interleave, byte_order, wavelengths, extra=""):
    wl = ",\n ".join(f"{v:g}" for v in wavelengths)
    return (
        "ENVI\ndescription = {fixture written by make_scene_fixtures.py}\n"
        f"samples = {w}\nlines = {h}\nbands = {bands}\nheader offset = 0\n"
        f"file type = ENVI Standard\ndata type = {data_type}\ninterleave = {interleave}\n"
        f"byte order = {byte_order}\n{extra}wavelength = {{\n {wl}}}\n"
    )


def write_envi(out, cube):
    """cube: H x W x B (rows, columns, bands)."""
    os.makedirs(out, exist_ok=True)
    h, w, nb = cube.shape
    bil = np.transpose(cube, (0, 2, 1)).astype(">f4")  # line, band, sample
    head = envi_header(h, w, nb, 4, "bil", 1, BANDS / 1000.0, "wavelength units = Micrometers\n")
    with open(os.path.join(out, "pattern_bil.hdr"), "w") as f:
        f.write(head)
    bil.tofile(os.path.join(out, "pattern_bil.img"))
    with open(os.path.join(out, "short.hdr"), "w") as f:
        f.write(head)
    raw = bil.tobytes()
    with open(os.path.join(out, "short.img"), "wb") as f:
        f.write(raw[: len(raw) // 2])
    bip = np.round(cube[:, :, ::-1] * 1024).astype("<u2")  # line, sample, band (700..400)
    head = envi_header(h, w, nb, 12, "bip", 0, BANDS[::-1], "reflectance scale factor = 1024\n")
    with open(os.path.join(out, "pattern_bip.hdr"), "w") as f:
        f.write(head)
    bip.tofile(os.path.join(out, "pattern_bip"))


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(__file__), "..", "retina", "tests", "fixtures", "scenes"
    )
    os.makedirs(os.path.join(out, "scenes"), exist_ok=True)
    cube = pattern_cube()
    write_mat(os.path.join(out, "arad_like.mat"), {
        "cube": (cube, "single"),
        "bands": (bands_row(), "double"),
    })
    write_mat(os.path.join(out, "arad_uint16.mat"), {
        "cube": ((cube * 1024).astype(np.uint16), "uint16"),
        "bands": (BANDS.reshape(-1, 1), "double"),
    })
    write_mat(os.path.join(out, "band_first.mat"), {
        "cube": (np.ascontiguousarray(np.transpose(cube, (2, 0, 1))[::-1]), "single"),
        "bands": (bands_row(BANDS[::-1].copy()), "double"),
    })
    with h5py.File(os.path.join(out, "row_major.h5"), "w") as f:
        f.create_dataset("cube", data=cube, chunks=(2, 3, 8), compression="gzip")
        f.create_dataset("wavelengths", data=BANDS)
    bad = cube.copy()
    bad[2, 3, 4] = np.nan
    write_mat(os.path.join(out, "arad_nan.mat"), {
        "cube": (bad, "single"),
        "bands": (bands_row(), "double"),
    })
    write_mat(os.path.join(out, "wrong_dataset.mat"), {
        "radiance": (cube, "single"),
        "bands": (bands_row(), "double"),
    })
    narrow = np.arange(450.0, 651.0, 10.0)
    write_mat(os.path.join(out, "narrow_bands.mat"), {
        "cube": (pattern_cube(bands=len(narrow)), "single"),
        "bands": (bands_row(narrow), "double"),
    })
    with open(os.path.join(out, "arad_like.mat"), "rb") as f:
        whole = f.read()
    with open(os.path.join(out, "truncated.mat"), "wb") as f:
        f.write(whole[: len(whole) * 2 // 3])
    with open(os.path.join(out, "not_hdf5.mat"), "wb") as f:
        f.write(b"MATLAB 5.0 MAT-file, Platform: GLNXA64".ljust(128, b" ") + bytes(64))
    for i in range(3):
        write_mat(os.path.join(out, "scenes", f"ARAD_1K_{i + 1:04d}.mat"), {
            "cube": (natural_scene(i), "single"),
            "bands": (bands_row(), "double"),
        }, chunks3=(31, 16, 16))
    stack = os.path.join(out, "cave", "pattern_ms", "pattern_ms")
    os.makedirs(stack, exist_ok=True)
    from PIL import Image

    for b in range(31):
        band = np.round(cube[:, :, b] * 1024).astype(np.uint16)
        Image.fromarray(band).save(os.path.join(stack, f"pattern_ms_{b + 1:02d}.png"))
        assert np.array_equal(np.asarray(Image.open(os.path.join(stack, f"pattern_ms_{b + 1:02d}.png"))), band)
    write_envi(os.path.join(out, "envi"), cube)
    # Self-check with the same library: the MATLAB orientation survives the round trip.
    with h5py.File(os.path.join(out, "arad_like.mat"), "r") as f:
        stored = f["cube"][()]
        assert stored.shape == (31, 7, 5), stored.shape
        assert np.array_equal(np.transpose(stored), cube)
        assert f["cube"].chunks == (8, 4, 3) and f["cube"].compression == "gzip"
        assert f.userblock_size == 512
    print(f"wrote fixtures into {out}")


if __name__ == "__main__":
    main()
