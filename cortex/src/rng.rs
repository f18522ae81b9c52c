//! A small seedable generator whose whole state is four `u64`s, so checkpoints can store it
//! and a resumed run continues the identical stream (xoshiro256**, Blackman & Vigna 2018;
//! seeded through SplitMix64). It implements `rand::RngCore`, so `rand_distr` works with it.

use serde::{Deserialize, Serialize};

/// xoshiro256** with a serialisable state.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CortexRng {
    s: [u64; 4],
}

impl CortexRng {
    /// A generator from a seed (SplitMix64 expansion, so nearby seeds give unrelated streams).
    pub fn seed_from(seed: u64) -> Self {
        let mut z = seed;
        let mut next = || {
            z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut x = z;
            x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            x ^ (x >> 31)
        };
        CortexRng {
            s: [next(), next(), next(), next()],
        }
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (rand::RngCore::next_u64(self) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// Uniform integer in `lo..=hi`.
    pub fn int_in(&mut self, lo: i64, hi: i64) -> i64 {
        assert!(lo <= hi, "CortexRng::int_in: empty range {lo}..={hi}");
        lo + (self.uniform() * (hi - lo + 1) as f64).floor() as i64
    }
}

impl rand::RngCore for CortexRng {
    fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    fn fill_bytes(&mut self, dst: &mut [u8]) {
        for chunk in dst.chunks_mut(8) {
            let v = self.next_u64().to_le_bytes();
            chunk.copy_from_slice(&v[..chunk.len()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_round_trip_continues_the_stream() {
        let mut a = CortexRng::seed_from(7);
        for _ in 0..10 {
            a.uniform();
        }
        let saved = serde_json::to_string(&a).unwrap();
        let mut b: CortexRng = serde_json::from_str(&saved).unwrap();
        for _ in 0..100 {
            assert_eq!(a.uniform().to_bits(), b.uniform().to_bits());
        }
    }

    #[test]
    fn moments_are_plausible() {
        let mut r = CortexRng::seed_from(1);
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| r.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
        let ints: Vec<i64> = (0..n).map(|_| r.int_in(-15, 14)).collect();
        assert_eq!(*ints.iter().min().unwrap(), -15);
        assert_eq!(*ints.iter().max().unwrap(), 14);
    }
}
