//! Radial cone-density profile and the area-preserving radial map from lattice to retina.
//!
//! The Curcio (1990) tables are not available as a data package, so the profile is built from
//! the facts in docs/references.md#cone-density-formulas:
//!
//! ```text
//! d(r) = dc0 · (1 + r / r_c)^(−2)        cones/deg², r = eccentricity in degrees
//! ```
//!
//! - `dc0` = 14 804.6 cones/deg², Watson (2014)'s peak cone density from the Curcio data;
//! - the form `(1 + r/r₂)^(−2)` is the dominant term of Watson (2014)'s density formula;
//! - `r_c` = 1.669° makes the density 1 mm (3.609°, Watson's Drasdo–Fowler conversion) from the
//!   centre an order of magnitude below the peak, as Curcio et al. (1990) report:
//!   `r_c = 3.609 / (√10 − 1)`.
//!
//! The official layout uses only the temporal Curcio meridian for every direction, so its map is
//! radially symmetric too (authors' code, docs/references.md#foveation).
//!
//! Lattice → retina: lattice cell (i, j) sits at lattice coordinates (u, v) in cells from the
//! lattice centre, radius ρ = √(u² + v²). Each cell holds one cone, so the disc of lattice radius
//! ρ holds πρ² cones; the map sends it to the retinal disc of eccentricity r(ρ) that holds as
//! many cones at density d: `N(r) = ∫₀ʳ d(s)·2πs ds = κ·πρ²`. With T = 1 + r/r_c,
//! `N(r) = 2π·dc0·r_c²·(ln T + 1/T − 1)`. The constant κ (cones per cell) is 1 for the physical
//! scale, or is chosen so that the middle of the lattice edge lands at a given eccentricity. The
//! map is smooth and strictly increasing in ρ, and its Jacobian determinant is
//! `r'(ρ)·r(ρ)/ρ > 0` everywhere, so the lattice never folds (retinotopy).

/// Watson (2014) peak cone density from the Curcio (1990) data, cones/deg² (docs/references.md#cone-density-formulas).
pub const WATSON_PEAK_CONE_DENSITY_PER_DEG2: f64 = 14_804.6;
/// Eccentricity (deg) of 1 mm on the retina, Watson (2014) polynomial
/// `r_deg = 3.556·r_mm + 0.05993·r_mm² − 0.007358·r_mm³ + 0.0003027·r_mm⁴` at 1 mm.
pub const ONE_MM_ECCENTRICITY_DEG: f64 = 3.556 + 0.05993 - 0.007358 + 0.0003027;
/// Density ratio peak / (1 mm) — "an order of magnitude lower" (Curcio et al. 1990).
pub const CURCIO_PEAK_TO_1MM_DENSITY_RATIO: f64 = 10.0;

/// `d(r) = peak · (1 + r/scale)^(−2)` (module docs).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadialDensity {
    /// Density at the centre, cones/deg².
    pub peak_density_per_deg2: f64,
    /// Eccentricity scale r_c, deg.
    pub scale_eccentricity_deg: f64,
}

impl Default for RadialDensity {
    /// The Curcio/Watson profile of the module docs (dc0 = 14 804.6/deg², r_c = 1.669°).
    fn default() -> Self {
        RadialDensity {
            peak_density_per_deg2: WATSON_PEAK_CONE_DENSITY_PER_DEG2,
            scale_eccentricity_deg: ONE_MM_ECCENTRICITY_DEG
                / (CURCIO_PEAK_TO_1MM_DENSITY_RATIO.sqrt() - 1.0),
        }
    }
}

/// `ln T + 1/T − 1`, the normalised cone count inside T = 1 + r/r_c.
fn count_shape(t: f64) -> f64 {
    t.ln() + 1.0 / t - 1.0
}

impl RadialDensity {
    /// Density at eccentricity `r_deg`, cones/deg².
    pub fn density_per_deg2(&self, r_deg: f64) -> f64 {
        self.peak_density_per_deg2 * (1.0 + r_deg / self.scale_eccentricity_deg).powi(-2)
    }

    /// Number of cones within eccentricity `r_deg`.
    pub fn cones_within(&self, r_deg: f64) -> f64 {
        let rc = self.scale_eccentricity_deg;
        2.0 * std::f64::consts::PI
            * self.peak_density_per_deg2
            * rc
            * rc
            * count_shape(1.0 + r_deg / rc)
    }

    /// Eccentricity (deg) of the circle holding `cones` cones (inverse of
    /// [`RadialDensity::cones_within`]; Newton on a convex increasing function).
    pub fn eccentricity_holding(&self, cones: f64) -> f64 {
        if cones <= 0.0 {
            return 0.0;
        }
        let rc = self.scale_eccentricity_deg;
        let y = cones / (2.0 * std::f64::consts::PI * self.peak_density_per_deg2 * rc * rc);
        // Safeguarded Newton: count_shape is increasing on T ≥ 1 (convex below T = 2, concave
        // above), so keep a bracket [lo, hi] and bisect whenever Newton leaves it.
        let (mut lo, mut hi) = (1.0, 2.0);
        while count_shape(hi) < y {
            lo = hi;
            hi *= 2.0;
        }
        let mut t = (1.0 + (2.0 * y).sqrt()).clamp(lo, hi);
        for _ in 0..100 {
            let f = count_shape(t) - y;
            if f > 0.0 {
                hi = t;
            } else {
                lo = t;
            }
            let df = (t - 1.0) / (t * t);
            let mut next = if df > 0.0 {
                t - f / df
            } else {
                0.5 * (lo + hi)
            };
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - t).abs() <= 1e-15 * t {
                t = next;
                break;
            }
            t = next;
        }
        rc * (t - 1.0)
    }
}

/// The area-preserving radial map lattice → retina (module docs), for a lattice whose
/// edge-middle is at lattice radius `edge_radius_cells`.
#[derive(Debug, Clone, Copy)]
pub struct RadialMap {
    density: RadialDensity,
    /// Cones per lattice cell area (κ).
    cones_per_cell: f64,
}

impl RadialMap {
    /// Physical scale: one cone per lattice cell at the profile's absolute density.
    pub fn physical(density: RadialDensity) -> Self {
        RadialMap {
            density,
            cones_per_cell: 1.0,
        }
    }

    /// Scale chosen so that lattice radius `edge_radius_cells` maps to eccentricity
    /// `edge_eccentricity_deg` (only the relative profile then matters, as in the official
    /// layout, whose positions are rescaled to the field afterwards).
    pub fn with_edge(
        density: RadialDensity,
        edge_radius_cells: f64,
        edge_eccentricity_deg: f64,
    ) -> Self {
        let cones = density.cones_within(edge_eccentricity_deg);
        RadialMap {
            density,
            cones_per_cell: cones / (std::f64::consts::PI * edge_radius_cells.powi(2)),
        }
    }

    /// Retinal position (deg) of lattice coordinates `(u, v)` (cells from the centre).
    pub fn map(&self, u: f64, v: f64) -> (f64, f64) {
        let rho = u.hypot(v);
        let gain = if rho < 1e-9 {
            // r(ρ) ≈ ρ·√(κ/dc0) near the centre.
            (self.cones_per_cell / self.density.peak_density_per_deg2).sqrt()
        } else {
            let r = self
                .density
                .eccentricity_holding(self.cones_per_cell * std::f64::consts::PI * rho * rho);
            r / rho
        };
        (u * gain, v * gain)
    }

    /// The density profile.
    pub fn density(&self) -> &RadialDensity {
        &self.density
    }

    /// Cones per lattice cell area (κ); 1 at the physical scale.
    pub fn cones_per_cell(&self) -> f64 {
        self.cones_per_cell
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_matches_the_curcio_facts_it_was_built_from() {
        let d = RadialDensity::default();
        assert_eq!(d.density_per_deg2(0.0), WATSON_PEAK_CONE_DENSITY_PER_DEG2);
        let ratio = d.density_per_deg2(0.0) / d.density_per_deg2(ONE_MM_ECCENTRICITY_DEG);
        assert!((ratio - 10.0).abs() < 1e-9, "{ratio}");
        assert!((d.scale_eccentricity_deg - 1.669).abs() < 1e-3);
    }

    #[test]
    fn cone_count_inverts_and_matches_numeric_integral() {
        let d = RadialDensity::default();
        for r in [0.01, 0.3, 1.0, 2.5, 10.0] {
            let n = d.cones_within(r);
            // Midpoint rule for ∫ d(s)·2πs ds.
            let steps = 20_000;
            let h = r / steps as f64;
            let num: f64 = (0..steps)
                .map(|i| {
                    let s = (i as f64 + 0.5) * h;
                    d.density_per_deg2(s) * 2.0 * std::f64::consts::PI * s * h
                })
                .sum();
            assert!((n - num).abs() / num < 1e-6, "r {r}: {n} vs {num}");
            assert!(
                (d.eccentricity_holding(n) - r).abs() < 1e-9 * r.max(1.0),
                "r {r}"
            );
        }
    }

    #[test]
    fn map_preserves_counts_and_is_monotone() {
        let m = RadialMap::with_edge(RadialDensity::default(), 127.5, 1.5);
        let (x, _) = m.map(127.5, 0.0);
        assert!((x - 1.5).abs() < 1e-9);
        let mut last = 0.0;
        for k in 1..200 {
            let (x, y) = m.map(k as f64, 0.0);
            assert!(x > last && y == 0.0);
            last = x;
        }
        // Near the centre the map is linear with gain √(κ/dc0).
        let (a, _) = m.map(1e-3, 0.0);
        let (b, _) = m.map(0.0, 0.0);
        assert_eq!(b, 0.0);
        let g = (m.cones_per_cell() / WATSON_PEAK_CONE_DENSITY_PER_DEG2).sqrt();
        assert!((a / 1e-3 - g).abs() / g < 1e-3);
    }
}
