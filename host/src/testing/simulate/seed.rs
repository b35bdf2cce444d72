//! What a seed means: generator v1, pinned here so that a seed names the
//! same run on every machine and in later versions of Radar.
//!
//! A seed does not feed one stream that every choice draws from in turn
//! (then a new kind of choice, or one more input, would shift every draw
//! after it). Each choice draws from a *stream of its own*, named by a
//! label (`"jitter"`, `"faults"`, `"compute Avoid"`, ...): the stream's
//! state is the seed mixed with the label's FNV-1a hash, and its numbers
//! come from SplitMix64. So a later version that adds a kind of choice
//! adds a label and leaves every existing draw as it was; changing what
//! an existing label draws is a new generator version, and
//! `[simulate] generator` pins the old one. `tests::generator_v1_is_pinned`
//! fails if any of this moves.

/// The generator this version of Radar uses when a scenario pins none.
pub const GENERATOR: u32 = 1;

/// A stream of pseudo-random numbers, one per kind of choice.
#[derive(Clone, Debug)]
pub struct Stream {
    state: u64,
}

/// 64-bit FNV-1a: a label's hash.
fn fnv1a(label: &str) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for byte in label.bytes() {
        hash ^= u64::from(byte);
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
    hash
}

/// SplitMix64's output function.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Stream {
    /// The stream of `label` under `seed`.
    pub fn new(seed: u64, label: &str) -> Self {
        Self {
            state: mix(seed ^ fnv1a(label)),
        }
    }

    /// The next 64 bits (SplitMix64).
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        mix(self.state)
    }

    /// A number in `0..n` (0 when `n` is 0), by rejection so that every
    /// value is equally likely.
    pub fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            return 0;
        }
        // The largest multiple of n that fits: draws above it are redrawn.
        let zone = u64::MAX - (u64::MAX % n);
        loop {
            let x = self.next_u64();
            if x < zone {
                return x % n;
            }
        }
    }

    /// A number in `lo..=hi`.
    pub fn between(&mut self, lo: u64, hi: u64) -> u64 {
        if hi <= lo {
            return lo;
        }
        match (hi - lo).checked_add(1) {
            Some(span) => lo + self.below(span),
            None => self.next_u64(),
        }
    }

    /// A signed offset in `-limit..=limit`.
    pub fn offset(&mut self, limit: u64) -> i64 {
        let limit = limit.min(i64::MAX as u64 / 2);
        self.between(0, 2 * limit) as i64 - limit as i64
    }

    /// One of `items` (`None` when there are none).
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> Option<&'a T> {
        items.get(self.below(items.len() as u64) as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The numbers of generator v1 for a few seeds and labels: if this
    /// test fails, seeds printed by earlier versions no longer replay.
    /// Change the generator only with a new [`GENERATOR`] version.
    #[test]
    fn generator_v1_is_pinned() {
        assert_eq!(fnv1a(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a("a"), 0xaf63_dc4c_8601_ec8c);
        let mut s = Stream::new(0, "jitter");
        let first: Vec<u64> = (0..3).map(|_| s.next_u64()).collect();
        let mut again = Stream::new(0, "jitter");
        assert_eq!(first, (0..3).map(|_| again.next_u64()).collect::<Vec<_>>());
        assert_eq!(first, PINNED_JITTER_0);
        let mut s = Stream::new(17, "faults");
        assert_eq!(
            (0..4).map(|_| s.between(1, 10)).collect::<Vec<_>>(),
            PINNED_FAULT_17
        );
        // Another label, another stream.
        assert_ne!(Stream::new(0, "faults").next_u64(), first[0]);
    }

    // Computed by an independent implementation (Python) of the same steps.
    const PINNED_JITTER_0: [u64; 3] = [
        10_122_304_170_793_737_484,
        17_918_272_262_523_816_669,
        8_710_425_914_053_622_162,
    ];
    const PINNED_FAULT_17: [u64; 4] = [8, 10, 2, 4];

    #[test]
    fn draws_stay_in_their_ranges() {
        let mut s = Stream::new(5, "range");
        for _ in 0..1000 {
            assert!((3..=9).contains(&s.between(3, 9)));
            assert!((-4..=4).contains(&s.offset(4)));
            assert!(s.below(7) < 7);
        }
        assert_eq!(s.below(0), 0);
        assert_eq!(s.between(4, 4), 4);
        assert!(s.pick::<u8>(&[]).is_none());
    }
}
