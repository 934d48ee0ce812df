//! splitmix64 dice: the random kills' randomness.

/// splitmix64: the kills' randomness (no state worth a crate).
pub(crate) struct Dice(pub(crate) u64);

impl Dice {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub(crate) fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Exponential with mean `mean`.
    pub(crate) fn exp(&mut self, mean: f64) -> f64 {
        -mean * (1.0 - self.unit()).ln()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dice_are_uniform_enough_and_exponential_has_its_mean() {
        let mut d = Dice(3);
        let n = 20_000;
        let mean = (0..n).map(|_| d.exp(60.0)).sum::<f64>() / n as f64;
        assert!((mean - 60.0).abs() < 3.0, "{mean}");
        assert!((0..1000).all(|_| (0.0..1.0).contains(&d.unit())));
    }
}
