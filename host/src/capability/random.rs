//! WASI's random sources under the virtual clock: a seeded splitmix64
//! stream, so that a run's randomness is a function of its seed and the
//! plugin's name. It is generated as it is read (16 bytes of state), not
//! kept as a buffer: a robot with 10,000 plugins holds 10,000 of them.

use std::convert::Infallible;

use rand_core::TryRng;

/// A deterministic stream of random bytes (not for cryptography: WASI's
/// "secure" random is seeded too, so that runs repeat).
pub(crate) struct SeededRandom {
    state: u64,
    /// The current word's bytes not yet read, little-endian order.
    word: [u8; 8],
    used: usize,
}

impl SeededRandom {
    pub(crate) fn new(seed: u64) -> Self {
        Self {
            state: seed,
            word: [0; 8],
            used: 8,
        }
    }

    fn next_byte(&mut self) -> u8 {
        if self.used == 8 {
            self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            self.word = (z ^ (z >> 31)).to_le_bytes();
            self.used = 0;
        }
        let byte = self.word[self.used];
        self.used += 1;
        byte
    }
}

impl TryRng for SeededRandom {
    type Error = Infallible;

    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        let bytes = [(); 4].map(|()| self.next_byte());
        Ok(u32::from_be_bytes(bytes))
    }

    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        let high = u64::from(self.try_next_u32()?);
        let low = u64::from(self.try_next_u32()?);
        Ok(high << 32 | low)
    }

    fn try_fill_bytes(&mut self, dest: &mut [u8]) -> Result<(), Infallible> {
        dest.iter_mut().for_each(|b| *b = self.next_byte());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_stream_and_the_stream_does_not_cycle() {
        let read = |seed| {
            let mut random = SeededRandom::new(seed);
            let mut bytes = vec![0u8; 3 * 4096];
            random.try_fill_bytes(&mut bytes).unwrap();
            (bytes, random.try_next_u64().unwrap())
        };
        let (a, next_a) = read(7);
        let (b, next_b) = read(7);
        assert_eq!((&a, next_a), (&b, next_b));
        assert_ne!(a, read(8).0);
        // No 4 KiB (or 8-byte) period.
        assert_ne!(a[..4096], a[4096..8192]);
        assert_ne!(a[..8], a[8..16]);
    }

    #[test]
    fn words_are_read_from_the_byte_stream_in_order() {
        let mut bytes = SeededRandom::new(1);
        let mut words = SeededRandom::new(1);
        let mut first = [0u8; 8];
        bytes.try_fill_bytes(&mut first).unwrap();
        let [a, b, c, d, e, f, g, h] = first;
        let (high, low) = (
            u32::from_be_bytes([a, b, c, d]),
            u32::from_be_bytes([e, f, g, h]),
        );
        assert_eq!(
            words.try_next_u64().unwrap(),
            u64::from(high) << 32 | u64::from(low)
        );
    }
}
