//! [`Digest`]: FNV-1a over 64 bits, the fingerprint the parity tests compare between targets.
//!
//! A head, the C example and the QEMU tests fold their outputs into one (f32 bits with the NaN
//! made canonical, little-endian), so that two targets' rows compare as one number. It is not a
//! checksum for transfers (the wire uses CRC-32C) and not cryptographic.

use crate::math::canonical;

/// FNV-1a, 64 bits.
#[derive(Clone, Copy, Debug)]
pub struct Digest(pub u64);

impl Default for Digest {
    fn default() -> Self {
        Digest(0xcbf2_9ce4_8422_2325)
    }
}

impl Digest {
    /// Fold bytes in.
    pub fn bytes(&mut self, b: &[u8]) {
        for x in b {
            self.0 ^= *x as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
    /// Fold f32 values in (bits, NaN canonical, little-endian).
    pub fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.bytes(&canonical(*x).to_bits().to_le_bytes());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Digest;

    #[test]
    fn fnv1a_64_of_known_strings() {
        // The published FNV-1a 64 test values (Fowler, Noll, Vo: "FNV test vectors").
        let of = |s: &[u8]| {
            let mut d = Digest::default();
            d.bytes(s);
            d.0
        };
        assert_eq!(of(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(of(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(of(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn every_nan_folds_as_the_canonical_one() {
        let (mut a, mut b) = (Digest::default(), Digest::default());
        a.f32s(&[f32::NAN, 1.0]);
        b.f32s(&[f32::from_bits(0xffc0_1234), 1.0]);
        assert_eq!(a.0, b.0);
    }
}
