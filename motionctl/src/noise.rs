//! A noisy link for testing: wraps a [`Transport`] so every byte, in both directions, is with
//! probability `rate` either corrupted (one random bit flipped) or dropped, 50/50, from a seeded
//! generator. `--noise 0.01 --seed 7` is the "proxy that corrupts or drops 1 % of bytes".

pub use crate::transport::NoiseStats;
use crate::transport::Transport;
use std::io;
use std::time::Duration;

/// xorshift64*: small, fast and reproducible; not for anything but test noise.
#[derive(Clone, Debug)]
pub struct XorShift(u64);

impl XorShift {
    pub fn new(seed: u64) -> Self {
        // Mix the seed so 0, 1, 2 ... give unrelated streams; the state must not be 0.
        let s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
        XorShift(if s == 0 { 1 } else { s })
    }

    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One direction of noise.
#[derive(Clone, Debug)]
pub struct Noise {
    rate: f64,
    rng: XorShift,
    pub stats: NoiseStats,
}

impl Noise {
    /// `rate` is clamped to `0..=1`.
    pub fn new(rate: f64, seed: u64) -> Self {
        let rate = if rate.is_finite() { rate.clamp(0.0, 1.0) } else { 0.0 };
        Noise { rate, rng: XorShift::new(seed), stats: NoiseStats::default() }
    }

    /// `bytes` after the noise.
    pub fn apply(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(bytes.len());
        for &b in bytes {
            self.stats.bytes += 1;
            if self.rate > 0.0 && self.rng.unit() < self.rate {
                let r = self.rng.next_u64();
                if r & 1 == 0 {
                    self.stats.corrupted += 1;
                    out.push(b ^ (1 << ((r >> 1) % 8)));
                } else {
                    self.stats.dropped += 1;
                }
                continue;
            }
            out.push(b);
        }
        out
    }
}

/// A transport whose bytes pass through [`Noise`] both ways.
pub struct Noisy<T> {
    pub inner: T,
    pub to_board: Noise,
    pub from_board: Noise,
}

impl<T: Transport> Noisy<T> {
    pub fn new(inner: T, rate: f64, seed: u64) -> Self {
        Noisy {
            inner,
            to_board: Noise::new(rate, seed),
            from_board: Noise::new(rate, seed ^ 0x5555_5555_5555_5555),
        }
    }
}

impl<T: Transport> Transport for Noisy<T> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        let noisy = self.to_board.apply(bytes);
        self.inner.send(&noisy)
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Vec<u8>> {
        let bytes = self.inner.recv(timeout)?;
        Ok(self.from_board.apply(&bytes))
    }

    fn reconnect(&mut self) -> io::Result<()> {
        self.inner.reconnect()
    }

    fn describe(&self) -> String {
        format!("{} (through a noise proxy)", self.inner.describe())
    }

    fn noise_stats(&self) -> Option<(NoiseStats, NoiseStats)> {
        Some((self.to_board.stats, self.from_board.stats))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_seeded_and_near_its_rate() {
        let data = vec![0x55u8; 100_000];
        let a = Noise::new(0.01, 7).apply(&data);
        let b = Noise::new(0.01, 7).apply(&data);
        assert_eq!(a, b, "same seed, same noise");
        let mut n = Noise::new(0.01, 7);
        let _ = n.apply(&data);
        let hit = n.stats.corrupted + n.stats.dropped;
        assert!((800..1200).contains(&hit), "{hit} of 100000 bytes hit");
        assert!(n.stats.corrupted > 300 && n.stats.dropped > 300, "{:?}", n.stats);
        assert_eq!(Noise::new(0.0, 1).apply(&data), data);
    }
}
