//! Seeded pseudo-random numbers for the random excitation (§5.2): xoshiro128++
//! seeded through SplitMix64, with uniform, Gaussian (Box–Muller) and exponential
//! (Poisson inter-arrival) draws. Deterministic for a seed on every target.

use crate::math;

/// xoshiro128++ (Blackman & Vigna), 128-bit state, period 2^128 − 1.
#[derive(Debug, Clone)]
pub struct Xoshiro128pp {
    s: [u32; 4],
    spare_normal: Option<f64>,
}

impl Xoshiro128pp {
    /// Seed from a 64-bit value through SplitMix64 (never yields the all-zero state).
    pub fn seed_from_u64(seed: u64) -> Self {
        let mut z = seed;
        let mut next = || {
            z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut x = z;
            x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            x ^ (x >> 31)
        };
        let a = next();
        let b = next();
        let mut s = [a as u32, (a >> 32) as u32, b as u32, (b >> 32) as u32];
        if s == [0; 4] {
            s[0] = 1;
        }
        Self {
            s,
            spare_normal: None,
        }
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(7).wrapping_add(s[0]);
        let t = s[1] << 9;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(11);
        result
    }

    /// Uniform in [0, 1) with 53 bits of resolution.
    pub fn uniform(&mut self) -> f64 {
        let hi = u64::from(self.next_u32() >> 5); // 27 bits
        let lo = u64::from(self.next_u32() >> 6); // 26 bits
        ((hi << 26) | lo) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal draw (Box–Muller, both values used).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        // u1 in (0, 1] so ln is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = math::sqrt(-2.0 * math::ln(u1));
        let phi = 2.0 * math::PI * u2;
        self.spare_normal = Some(r * math::sin(phi));
        r * math::cos(phi)
    }

    /// Exponential draw with the given rate (the gap of a Poisson process), in 1/rate units.
    pub fn exponential(&mut self, rate: f64) -> f64 {
        -math::ln(1.0 - self.uniform()) / rate
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_for_a_seed() {
        let mut a = Xoshiro128pp::seed_from_u64(42);
        let mut b = Xoshiro128pp::seed_from_u64(42);
        for _ in 0..100 {
            assert_eq!(a.next_u32(), b.next_u32());
        }
        let mut c = Xoshiro128pp::seed_from_u64(43);
        assert_ne!(a.next_u32(), c.next_u32());
    }

    #[test]
    fn moments_of_draws() {
        let mut r = Xoshiro128pp::seed_from_u64(7);
        let n = 200_000;
        let (mut s1, mut s2, mut su, mut se) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..n {
            let z = r.normal();
            s1 += z;
            s2 += z * z;
            su += r.uniform();
            se += r.exponential(4.0);
        }
        let n = n as f64;
        assert!((s1 / n).abs() < 0.01);
        assert!((s2 / n - 1.0).abs() < 0.02);
        assert!((su / n - 0.5).abs() < 0.005);
        assert!((se / n - 0.25).abs() < 0.005);
    }
}
