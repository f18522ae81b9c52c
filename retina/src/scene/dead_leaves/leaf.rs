//! One leaf of a dead-leaves scene ([`super`]): its size law, its random shape, pose and
//! shading, and its painting under occlusion. Units: pixels; angles in radians.

use rand::Rng;

use super::DeadLeavesConfig;

/// Label of a pixel no leaf covers yet.
pub(super) const UNSET: u32 = u32::MAX;

/// A value drawn uniformly from `[r[0], r[1])`.
pub(super) fn uniform<R: Rng + ?Sized>(rng: &mut R, r: [f64; 2]) -> f64 {
    r[0] + (r[1] - r[0]) * rng.random::<f64>()
}

/// Leaf radius density ∝ r^(−α) on `[radius_min_px, radius_max_fraction·size]`, sampled by
/// inverting its cumulative distribution.
pub(super) struct SizeLaw {
    /// α − 1.
    e: f64,
    /// `r_min^(−e)`.
    a0: f64,
    /// `r_max^(−e)`.
    a1: f64,
}

impl SizeLaw {
    pub(super) fn new(cfg: &DeadLeavesConfig) -> SizeLaw {
        let (rmin, rmax) = (
            cfg.radius_min_px,
            (cfg.radius_max_fraction * cfg.size_px as f64).max(cfg.radius_min_px),
        );
        let e = cfg.size_exponent - 1.0;
        SizeLaw {
            e,
            a0: rmin.powf(-e),
            a1: rmax.powf(-e),
        }
    }

    /// One radius, px.
    fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> f64 {
        (self.a0 - rng.random::<f64>() * (self.a0 - self.a1)).powf(-1.0 / self.e)
    }
}

/// One leaf: an ellipse or rectangle with its brightness and shading ramp, in pixel units.
pub(super) struct Leaf {
    /// Centre, px (may lie outside the scene).
    cx: f64,
    cy: f64,
    /// cos θ, sin θ of the orientation.
    c: f64,
    s: f64,
    /// Rectangle (else ellipse).
    rect: bool,
    /// Ellipse semi-axes, px.
    ax: f64,
    ay: f64,
    /// Rectangle half-sides, px (equal to the semi-axes for an ellipse).
    hx: f64,
    hy: f64,
    /// Brightness factor at the centre.
    bright: f64,
    /// Shading slope per px along x and y.
    gx: f64,
    gy: f64,
}

impl Leaf {
    /// Draws size, shape, orientation, position (anywhere it can touch the scene), brightness
    /// and shading ramp, in that order from `rng`.
    pub(super) fn draw<R: Rng + ?Sized>(
        cfg: &DeadLeavesConfig,
        sizes: &SizeLaw,
        rng: &mut R,
    ) -> Leaf {
        let n = cfg.size_px;
        // square of area πr² has half-side r·√π/2
        let half_side = std::f64::consts::PI.sqrt() / 2.0;
        let r = sizes.sample(rng);
        let aspect = uniform(rng, [1.0, cfg.max_aspect]);
        let (ax, ay) = (r * aspect.sqrt(), r / aspect.sqrt());
        let theta = rng.random::<f64>() * std::f64::consts::PI;
        let (c, s) = (theta.cos(), theta.sin());
        let rect = rng.random::<f64>() < cfg.rectangle_fraction;
        let (hx, hy) = if rect {
            (ax * half_side, ay * half_side)
        } else {
            (ax, ay)
        };
        let reach = hx.hypot(hy);
        let cx = -reach + rng.random::<f64>() * (n as f64 + 2.0 * reach);
        let cy = -reach + rng.random::<f64>() * (n as f64 + 2.0 * reach);
        let bright = uniform(rng, cfg.leaf_brightness_range);
        let phi = rng.random::<f64>() * std::f64::consts::TAU;
        let slope = cfg.leaf_shading_gradient * rng.random::<f64>() / r.max(1.0);
        let (gx, gy) = (slope * phi.cos(), slope * phi.sin());
        Leaf {
            cx,
            cy,
            c,
            s,
            rect,
            ax,
            ay,
            hx,
            hy,
            bright,
            gx,
            gy,
        }
    }

    /// Paints the leaf as `id` onto the pixels of the `n × n` scene it covers that no earlier
    /// leaf covers (occlusion); returns how many pixels it painted.
    pub(super) fn paint(&self, id: u32, n: usize, label: &mut [u32], shading: &mut [f32]) -> usize {
        let reach = self.hx.hypot(self.hy);
        let (cx, cy) = (self.cx, self.cy);
        let y0 = (cy - reach).floor().max(0.0) as usize;
        let y1 = ((cy + reach).ceil().max(0.0) as usize).min(n);
        let x0 = (cx - reach).floor().max(0.0) as usize;
        let x1 = ((cx + reach).ceil().max(0.0) as usize).min(n);
        let mut painted = 0;
        for y in y0..y1 {
            let dy = y as f64 - cy;
            for x in x0..x1 {
                let p = y * n + x;
                if label[p] != UNSET {
                    continue;
                }
                let dx = x as f64 - cx;
                let (u, v) = (dx * self.c + dy * self.s, -dx * self.s + dy * self.c);
                let inside = if self.rect {
                    u.abs() <= self.hx && v.abs() <= self.hy
                } else {
                    (u / self.ax).powi(2) + (v / self.ay).powi(2) <= 1.0
                };
                if inside {
                    label[p] = id;
                    shading[p] =
                        (self.bright * (1.0 + self.gx * dx + self.gy * dy)).max(0.02) as f32;
                    painted += 1;
                }
            }
        }
        painted
    }
}
