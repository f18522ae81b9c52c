//! Pictures of every stage (the counterpart of the paper's Fig. 2 and Fig. 12).
//!
//! [`write_stage_pictures`] writes, into `out_dir`:
//! - `1_scene_srgb.png` — the field the eye sees (frame 0), sRGB-encoded from the reference
//!   L, M, S through the official LMS → linear sRGB matrix, clipped to [0, 1];
//! - `2_mosaic_lattice.png` — cone classes on the lattice (L red, M green, S blue, Q amber, other
//!   classes from a fixed palette; co-expressing cones mix their colours);
//! - `3_mosaic_field.png` — the same cones drawn at their positions in the field (foveation);
//! - `4_cone_activations.png` — noise-free activations, grey, 0 … max;
//! - `5_bipolar.png` — lateral-inhibition output, diverging map (blue < 0 < red), ± max |x|;
//! - `6_on_spike_rate.png`, `7_off_spike_rate.png` — ON and OFF LIF spikes averaged over 100
//!   frames of a still eye with noise; `8_spikes_frame.png` — one frame (ON red, OFF blue);
//! - `9_ons.png` — one noisy ONS frame (what the cortex receives), diverging map;
//! - `ons_motion/frame_NNN.png` and `ons_motion.png` (an animated PNG) — 30 ONS frames under a
//!   random-walk eye motion, one shared colour scale.
//!
//! Lattice pictures are scaled up by whole pixels (nearest neighbour) to at least 256 px.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use colorimetry::srgb::{encode, to_u8};
use rand::Rng;

use crate::error::{Result, RetinaError};
use crate::foveation::sampler::MipStack;
use crate::movie::{MovieConfig, SpikeTrain};
use crate::retina::Retina;

/// Frames of the still movie behind the spike pictures.
pub const SPIKE_PICTURE_FRAMES: usize = 100;
/// Frames of the eye-motion sequence.
pub const MOTION_PICTURE_FRAMES: usize = 30;
/// Lattice pictures are enlarged to at least this many pixels per side.
pub const MIN_PICTURE_PX: usize = 256;

/// An 8-bit RGB picture.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    /// Columns.
    pub w: usize,
    /// Rows.
    pub h: usize,
    /// Row-major RGB bytes.
    pub rgb: Vec<u8>,
}

impl Picture {
    /// A black picture.
    pub fn new(w: usize, h: usize) -> Self {
        Picture {
            w,
            h,
            rgb: vec![0; 3 * w * h],
        }
    }

    /// Nearest-neighbour enlargement by an integer factor.
    pub fn enlarge(&self, factor: usize) -> Picture {
        let f = factor.max(1);
        let mut out = Picture::new(self.w * f, self.h * f);
        for y in 0..out.h {
            for x in 0..out.w {
                let s = 3 * ((y / f) * self.w + x / f);
                let d = 3 * (y * out.w + x);
                out.rgb[d..d + 3].copy_from_slice(&self.rgb[s..s + 3]);
            }
        }
        out
    }

    /// Write as PNG, atomically ([`atomic_io::write_via`]).
    pub fn write_png(&self, path: &Path) -> Result<()> {
        atomic_io::write_via(path, |tmp| {
            let file = File::create(tmp).map_err(|e| RetinaError::io(tmp, e))?;
            let mut enc = png::Encoder::new(BufWriter::new(file), self.w as u32, self.h as u32);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let err = |e: png::EncodingError| RetinaError::Png {
                path: path.to_path_buf(),
                message: e.to_string(),
            };
            let mut w = enc.write_header().map_err(err)?;
            w.write_image_data(&self.rgb).map_err(err)?;
            w.finish().map_err(err)
        })
    }
}

/// Write equally sized pictures as an animated PNG (`delay_ms` per frame, looping),
/// atomically ([`atomic_io::write_via`]).
pub fn write_apng(frames: &[Picture], delay_ms: u16, path: &Path) -> Result<()> {
    let first = frames
        .first()
        .ok_or_else(|| RetinaError::setting("apng", "no frames"))?;
    atomic_io::write_via(path, |tmp| encode_apng(frames, first, delay_ms, path, tmp))
}

fn encode_apng(
    frames: &[Picture],
    first: &Picture,
    delay_ms: u16,
    path: &Path,
    tmp: &Path,
) -> Result<()> {
    let file = File::create(tmp).map_err(|e| RetinaError::io(tmp, e))?;
    let err = |e: png::EncodingError| RetinaError::Png {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut enc = png::Encoder::new(BufWriter::new(file), first.w as u32, first.h as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_animated(frames.len() as u32, 0).map_err(err)?;
    enc.set_frame_delay(delay_ms, 1000).map_err(err)?;
    let mut w = enc.write_header().map_err(err)?;
    for f in frames {
        w.write_image_data(&f.rgb).map_err(err)?;
    }
    w.finish().map_err(err)
}

/// Grey picture of `(n, n)` values mapped from [0, max] (max > 0; values clipped).
pub fn grey(values: &[f32], n: usize, max: f32) -> Picture {
    let mut p = Picture::new(n, n);
    for (i, &v) in values.iter().enumerate() {
        let g = ((v / max).clamp(0.0, 1.0) * 255.0).round() as u8;
        p.rgb[3 * i..3 * i + 3].copy_from_slice(&[g, g, g]);
    }
    p
}

/// Diverging picture: −scale → blue, 0 → light grey, +scale → red.
pub fn diverging(values: &[f32], n: usize, scale: f32) -> Picture {
    const NEG: [f32; 3] = [0.23, 0.30, 0.75];
    const MID: [f32; 3] = [0.87, 0.87, 0.87];
    const POS: [f32; 3] = [0.71, 0.02, 0.15];
    let mut p = Picture::new(n, n);
    for (i, &v) in values.iter().enumerate() {
        let t = (v / scale).clamp(-1.0, 1.0);
        let (end, a) = if t < 0.0 { (NEG, -t) } else { (POS, t) };
        for c in 0..3 {
            p.rgb[3 * i + c] = ((MID[c] + a * (end[c] - MID[c])) * 255.0).round() as u8;
        }
    }
    p
}

/// Display colour of a cone class.
pub fn class_colour(name: &str, index: usize) -> [f32; 3] {
    const PALETTE: [[f32; 3]; 4] = [
        [0.8, 0.3, 0.9],
        [0.2, 0.8, 0.8],
        [0.6, 0.6, 0.6],
        [0.9, 0.5, 0.6],
    ];
    match name {
        "L" => [0.95, 0.15, 0.15],
        "M" => [0.15, 0.8, 0.2],
        "S" => [0.2, 0.35, 1.0],
        "Q" => [1.0, 0.7, 0.0],
        _ => PALETTE[index % PALETTE.len()],
    }
}

fn to_byte(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn max_abs(v: &[f32]) -> f32 {
    v.iter().fold(0.0f32, |m, x| m.max(x.abs())).max(1e-12)
}

/// Write every stage picture for `retina` (module docs). Returns the files written.
pub fn write_stage_pictures<R: Rng + ?Sized>(
    retina: &Retina,
    rng: &mut R,
    out_dir: &Path,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out_dir).map_err(|e| RetinaError::io(out_dir, e))?;
    let n = retina.n();
    let f = retina.config.field_px;
    let factor = MIN_PICTURE_PX.div_ceil(n);
    let mut written = Vec::new();
    let mut save = |pic: &Picture, name: &str| -> Result<()> {
        let path = out_dir.join(name);
        pic.write_png(&path)?;
        written.push(path);
        Ok(())
    };
    let still = retina.movie(
        rng,
        MovieConfig {
            frames: SPIKE_PICTURE_FRAMES,
            motion: None,
            noise_ratio: None,
        },
    );
    let stack = retina.pool.tile(still.tile);
    let origin = still.origins_px[0];
    save(
        &scene_picture(retina, stack, origin).enlarge(MIN_PICTURE_PX.div_ceil(f)),
        "1_scene_srgb.png",
    )?;
    let (lattice, field) = mosaic_pictures(retina);
    save(&lattice.enlarge(factor), "2_mosaic_lattice.png")?;
    save(&field, "3_mosaic_field.png")?;
    // 4–5. Activations and bipolar signal (noise-free).
    let mut act = vec![0.0f32; n * n];
    retina.cones.compute(stack, origin, &mut act);
    let amax = act.iter().copied().fold(0.0f32, f32::max).max(1e-12);
    save(
        &grey(&act, n, amax).enlarge(factor),
        "4_cone_activations.png",
    )?;
    save(
        &diverging(&still.analog[0], n, max_abs(&still.analog[0])).enlarge(factor),
        "5_bipolar.png",
    )?;
    let [on, off, frame] = spike_pictures(&retina.spikes(&still), n);
    save(&on.enlarge(factor), "6_on_spike_rate.png")?;
    save(&off.enlarge(factor), "7_off_spike_rate.png")?;
    save(&frame.enlarge(factor), "8_spikes_frame.png")?;
    save(
        &diverging(&still.ons[0], n, max_abs(&still.ons[0])).enlarge(factor),
        "9_ons.png",
    )?;
    written.extend(write_ons_motion(retina, rng, out_dir, factor)?);
    Ok(written)
}

/// 1. The scene field in sRGB, from the stack's reference LMS planes at `origin`.
fn scene_picture(retina: &Retina, stack: &MipStack, origin: [i32; 2]) -> Picture {
    let f = retina.config.field_px;
    let proj = &retina.pool.projection;
    let mut scene = Picture::new(f, f);
    for y in 0..f {
        for x in 0..f {
            let i = (y + origin[1] as usize) * stack.w + x + origin[0] as usize;
            let lms: Vec<f64> = proj
                .reference_lms
                .iter()
                .map(|&p| stack.plane(0, p)[i] as f64)
                .collect();
            let rgb = [0, 1, 2].map(|r| {
                (0..3)
                    .map(|c| lms[c] * proj.lms_to_rgb[c][r])
                    .sum::<f64>()
                    .clamp(0.0, 1.0)
            });
            scene.rgb[3 * (y * f + x)..3 * (y * f + x) + 3].copy_from_slice(&to_u8(encode(rgb)));
        }
    }
    scene
}

/// 2–3. The mosaic on the lattice (one pixel per cone, not enlarged) and in the field (each
/// cone a square at its true position).
fn mosaic_pictures(retina: &Retina) -> (Picture, Picture) {
    let n = retina.n();
    let f = retina.config.field_px;
    let k = retina.mosaic.n_classes();
    let colours: Vec<[f32; 3]> = retina
        .mosaic
        .classes
        .iter()
        .enumerate()
        .map(|(i, c)| class_colour(&c.name, i))
        .collect();
    let mut lattice = Picture::new(n, n);
    let mut cone_rgb = vec![[0u8; 3]; n * n];
    for (i, w) in retina.mosaic.weights.chunks(k).enumerate() {
        let mut c = [0.0f32; 3];
        for (wk, col) in w.iter().zip(&colours) {
            for j in 0..3 {
                c[j] += wk * col[j];
            }
        }
        cone_rgb[i] = c.map(to_byte);
        lattice.rgb[3 * i..3 * i + 3].copy_from_slice(&cone_rgb[i]);
    }
    let scale = MIN_PICTURE_PX.div_ceil(f).max(2);
    let mut field = Picture::new(f * scale, f * scale);
    for (i, p) in retina.layout.positions_px.iter().enumerate() {
        let (cx, cy) = (
            (p[0] * scale as f32) as usize,
            (p[1] * scale as f32) as usize,
        );
        for dy in 0..scale.div_ceil(2) {
            for dx in 0..scale.div_ceil(2) {
                let (x, y) = ((cx + dx).min(field.w - 1), (cy + dy).min(field.h - 1));
                field.rgb[3 * (y * field.w + x)..3 * (y * field.w + x) + 3]
                    .copy_from_slice(&cone_rgb[i]);
            }
        }
    }
    (lattice, field)
}

/// 6–8. ON and OFF spike rates (one grey scale for both) and the last frame's spikes (ON red,
/// OFF blue), not enlarged.
fn spike_pictures(train: &SpikeTrain, n: usize) -> [Picture; 3] {
    let nn = n * n;
    let mut on_rate = vec![0.0f32; nn];
    let mut off_rate = vec![0.0f32; nn];
    for (a, b) in train.on.iter().zip(&train.off) {
        for i in 0..nn {
            on_rate[i] += a[i] / train.on.len() as f32;
            off_rate[i] += b[i] / train.on.len() as f32;
        }
    }
    let rmax = on_rate
        .iter()
        .chain(&off_rate)
        .copied()
        .fold(0.0f32, f32::max)
        .max(1e-12);
    let last = train.on.len() - 1;
    let mut frame = Picture::new(n, n);
    for i in 0..nn {
        let c = [train.on[last][i], 0.0, train.off[last][i]].map(to_byte);
        frame.rgb[3 * i..3 * i + 3].copy_from_slice(&c);
    }
    [grey(&on_rate, n, rmax), grey(&off_rate, n, rmax), frame]
}

/// The ONS under eye motion: `ons_motion/frame_<t>.png` (one scale for all frames) and the
/// animated `ons_motion.png`.
fn write_ons_motion<R: Rng + ?Sized>(
    retina: &Retina,
    rng: &mut R,
    out_dir: &Path,
    factor: usize,
) -> Result<Vec<PathBuf>> {
    let n = retina.n();
    let moving = retina.movie(
        rng,
        MovieConfig {
            frames: MOTION_PICTURE_FRAMES,
            motion: Some(retina.config.eye_motion),
            noise_ratio: None,
        },
    );
    let seq_dir = out_dir.join("ons_motion");
    std::fs::create_dir_all(&seq_dir).map_err(|e| RetinaError::io(&seq_dir, e))?;
    let s = moving
        .ons
        .iter()
        .map(|fr| max_abs(fr))
        .fold(0.0f32, f32::max);
    let frames: Vec<Picture> = moving
        .ons
        .iter()
        .map(|fr| diverging(fr, n, s).enlarge(factor))
        .collect();
    let mut written = Vec::new();
    for (t, pic) in frames.iter().enumerate() {
        let path = seq_dir.join(format!("frame_{t:03}.png"));
        pic.write_png(&path)?;
        written.push(path);
    }
    let apng = out_dir.join("ons_motion.png");
    write_apng(&frames, 100, &apng)?;
    written.push(apng);
    Ok(written)
}

#[cfg(test)]
mod tests;
