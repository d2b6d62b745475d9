//! Bit-level packing for format version 14's bone motions: numbers as
//! Exp-Golomb codes of order k (H.264's ue(v) generalized, ITU-T H.264
//! section 9.1; Teuhola 1978), which code a two-sided geometric spread of
//! small integers within a few percent of its entropy when k fits the
//! spread, and stay short for the rare large one (a Rice code's unary part
//! would not).

/// Most bits one code may take: a zigzag number below 2⁶⁴ with k = 0.
pub const MAX_CODE_BITS: usize = 2 * 64 + 1;

/// Bits written most significant first into bytes.
#[derive(Default)]
pub struct BitWriter {
    bytes: Vec<u8>,
    used: u32,
}

impl BitWriter {
    pub fn put(&mut self, value: u64, bits: u32) {
        for i in (0..bits).rev() {
            if self.used % 8 == 0 {
                self.bytes.push(0);
            }
            let bit = ((value >> i) & 1) as u8;
            if let Some(last) = self.bytes.last_mut() {
                *last |= bit << (7 - self.used % 8);
            }
            self.used += 1;
        }
    }

    /// `z` as an Exp-Golomb code of order `k` (at most 63): z + 2ᵏ in
    /// binary, after as many zeros as that has bits past k + 1.
    pub fn exp_golomb(&mut self, z: u64, k: u32) {
        debug_assert!(k <= 63);
        let v = u128::from(z) + (1u128 << k);
        let len = 128 - v.leading_zeros();
        self.put(0, len - k - 1);
        // v has at most 65 bits: its top bit is written apart.
        if len > 64 {
            self.put(1, 1);
            self.put(v as u64, 64);
        } else {
            self.put(v as u64, len);
        }
    }

    /// The bytes, the last padded with zero bits.
    pub fn finish(self) -> Vec<u8> {
        self.bytes
    }
}

/// Reads what a [`BitWriter`] wrote; `None` past the end.
pub struct BitReader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> BitReader<'a> {
    pub fn new(bytes: &'a [u8]) -> BitReader<'a> {
        BitReader { bytes, at: 0 }
    }

    pub fn get(&mut self, bits: u32) -> Option<u64> {
        let mut v = 0u64;
        for _ in 0..bits {
            let byte = self.bytes.get(self.at / 8)?;
            v = (v << 1) | u64::from((byte >> (7 - self.at % 8)) & 1);
            self.at += 1;
        }
        Some(v)
    }

    /// An Exp-Golomb code of order `k` (at most 63); `None` if cut off or
    /// past 64 bits.
    pub fn exp_golomb(&mut self, k: u32) -> Option<u64> {
        if k > 63 {
            return None;
        }
        let mut zeros = 0u32;
        while self.get(1)? == 0 {
            zeros += 1;
            if zeros + k > 64 {
                return None;
            }
        }
        let rest = self.get(zeros + k)?;
        let v = (1u128 << (zeros + k)) | u128::from(rest);
        u64::try_from(v - (1u128 << k)).ok()
    }

    /// Whether only the last byte's zero padding is left.
    pub fn at_padding(&self) -> bool {
        let left = self.bytes.len() * 8 - self.at.min(self.bytes.len() * 8);
        left < 8 && self.bytes.last().is_none_or(|b| b & ((1u16 << left) - 1) as u8 == 0)
    }
}

/// Bits [`BitWriter::exp_golomb`] spends on `z` at order `k`.
pub fn exp_golomb_bits(z: u64, k: u32) -> u32 {
    let v = u128::from(z) + (1u128 << k);
    2 * (128 - v.leading_zeros()) - k - 1
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn codes_round_trip_at_every_order_and_their_lengths_are_predicted() {
        let values = [0u64, 1, 2, 3, 7, 8, 100, 65_535, 1 << 40, u64::MAX - 1, u64::MAX];
        for k in [0u32, 1, 3, 7, 15] {
            let mut w = BitWriter::default();
            let mut bits = 0;
            for &z in &values {
                w.exp_golomb(z, k);
                bits += exp_golomb_bits(z, k);
            }
            w.put(5, 3);
            let bytes = w.finish();
            assert_eq!(bytes.len(), (bits as usize + 3).div_ceil(8));
            let mut r = BitReader::new(&bytes);
            for &z in &values {
                assert_eq!(r.exp_golomb(k), Some(z), "k {k}");
            }
            assert_eq!(r.get(3), Some(5));
            assert!(r.at_padding());
        }
        // k = 0: 0 is "1", 1 is "010", 2 is "011" (H.264's ue(v)).
        assert_eq!((exp_golomb_bits(0, 0), exp_golomb_bits(1, 0), exp_golomb_bits(3, 0)), (1, 3, 5));
    }

    #[test]
    fn cut_or_overlong_codes_are_refused() {
        let mut w = BitWriter::default();
        w.exp_golomb(1000, 2);
        let bytes = w.finish();
        assert_eq!(BitReader::new(&bytes[..1]).exp_golomb(2), None);
        // Nothing but zeros: no code ends within 64 bits.
        assert_eq!(BitReader::new(&[0; 20]).exp_golomb(0), None);
        let mut r = BitReader::new(&[0b1000_0001]);
        assert_eq!(r.exp_golomb(0), Some(0));
        assert!(!r.at_padding(), "a set bit after the last code is not padding");
    }
}
