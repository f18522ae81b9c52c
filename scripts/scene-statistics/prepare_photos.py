#!/usr/bin/env python3
"""Photographs at the eyes' scale for `retina/examples/scene_statistics.rs`.

Each photograph is decoded, linearised (sRGB transfer function, IEC 61966-2-1), resized in
linear light so that its short side is 542 px (the authors' preprocessing of ARAD_1K: the
eye's 512-px field plus twice the 15-px eye-motion margin), and written as a 16-bit sRGB PNG.
The manifest `photos.json` gives, per photograph, its source, licence and whether it is held
out of the fit (every third photograph in case-insensitive name order, starting with the
third: a rule fixed before any generator was fitted).

Usage: prepare_photos.py OUT_DIR
Needs numpy, Pillow, scikit-image (for the photographs it ships and for resizing).
Sources: scikit-image 0.26.0 `skimage/data/` (astronaut, chelsea, coffee, rocket,
motorcycle_left), scikit-learn `sklearn/datasets/images/` (china, flower), and Debian's
`mate-backgrounds` 1.26.0 `usr/share/backgrounds/mate/nature/` (extract the .deb with
`apt-get download mate-backgrounds && dpkg-deb -x mate-backgrounds_*.deb DIR`; set MATE_DIR).
"""
import json, os, sys
import numpy as np
from PIL import Image
from skimage.transform import resize
import skimage, sklearn

SHORT_SIDE_PX = 542
SK = os.path.join(os.path.dirname(skimage.__file__), "data")
SL = os.path.join(os.path.dirname(sklearn.__file__), "datasets", "images")
if len(sys.argv) != 2:
    sys.exit("usage: MATE_DIR=DIR prepare_photos.py OUT_DIR")
if "MATE_DIR" not in os.environ:
    sys.exit("prepare_photos.py: set MATE_DIR to the unpacked mate-backgrounds 1.26.0 package "
             "(apt-get download mate-backgrounds && dpkg-deb -x mate-backgrounds_*.deb DIR)")
MATE = os.environ["MATE_DIR"] + "/usr/share/backgrounds/mate/nature"
SOURCES = [
    (SK, ["astronaut.png"], "scikit-image 0.26.0: NASA, public domain"),
    (SK, ["chelsea.png", "coffee.png"], "scikit-image 0.26.0: CC0"),
    (SK, ["rocket.jpg"], "scikit-image 0.26.0: SpaceX, public domain"),
    (SK, ["motorcycle_left.png"], "scikit-image 0.26.0: Middlebury 2014 stereo dataset"),
    (SL, ["china.jpg", "flower.jpg"], "scikit-learn: sample images (public domain / CC-BY, per its docs)"),
    (MATE, sorted(os.listdir(MATE)) if os.path.isdir(MATE) else [], "Debian mate-backgrounds 1.26.0: GPL-2+"),
]

def srgb_decode(v):
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)

def srgb_encode(v):
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)

def main(out):
    os.makedirs(out, exist_ok=True)
    entries = [(d, f, lic) for d, files, lic in SOURCES for f in files]
    entries.sort(key=lambda e: e[1].lower())
    manifest = []
    for i, (d, f, lic) in enumerate(entries):
        rgb = np.asarray(Image.open(os.path.join(d, f)).convert("RGB")).astype(np.float64) / 255.0
        lin = srgb_decode(rgb)
        h, w, _ = lin.shape
        s = SHORT_SIDE_PX / min(h, w)
        lin = resize(lin, (round(h * s), round(w * s)), order=1, anti_aliasing=s < 1)
        png = os.path.splitext(f)[0] + ".png"
        code = np.round(srgb_encode(lin) * 65535).astype(">u2")
        write_png16(os.path.join(out, png), code)
        manifest.append({"file": png, "source": f, "licence": lic, "original_px": [w, h],
                         "held_out": i % 3 == 2})
    json.dump(manifest, open(os.path.join(out, "photos.json"), "w"), indent=1)

def write_png16(path, code):
    """A 16-bit RGB PNG (Pillow cannot write one)."""
    import zlib, struct
    h, w, _ = code.shape
    raw = b"".join(b"\x00" + code[y].tobytes() for y in range(h))
    def chunk(t, data):
        return struct.pack(">I", len(data)) + t + data + struct.pack(">I", zlib.crc32(t + data) & 0xFFFFFFFF)
    ihdr = struct.pack(">IIBBBBB", w, h, 16, 2, 0, 0, 0)
    with open(path, "wb") as fh:
        fh.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))

if __name__ == "__main__":
    main(sys.argv[1])
