//! Content keys: a running hash over the values that define a result (never addresses or
//! debug text), for caches and for telling whether something changed.

/// A running 64-bit FNV-1a hash of a key's parts.
#[derive(Clone, Copy, Debug)]
pub struct KeyHasher(u64);

impl Default for KeyHasher {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl KeyHasher {
    /// Mixes in bytes.
    pub fn bytes(mut self, b: &[u8]) -> Self {
        for &x in b {
            self.0 = (self.0 ^ u64::from(x)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }
    /// Mixes in a string (with its length, so parts cannot run together).
    pub fn str(self, s: &str) -> Self {
        self.u64(s.len() as u64).bytes(s.as_bytes())
    }
    /// Mixes in an integer.
    pub fn u64(self, v: u64) -> Self {
        self.bytes(&v.to_le_bytes())
    }
    /// Mixes in floats, bit for bit.
    pub fn f32s(self, v: &[f32]) -> Self {
        v.iter().fold(self, |h, x| h.bytes(&x.to_le_bytes()))
    }
    /// Mixes in 32-bit words a word at a time (for bulk data such as meshes): a multiply by
    /// the golden-ratio constant and a fold of the high half into the low half per word.
    pub fn words(mut self, v: &[u32]) -> Self {
        self = self.u64(v.len() as u64);
        for &w in v {
            let h = (self.0 ^ u64::from(w)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            self.0 = h ^ (h >> 32);
        }
        self
    }
    /// The hash.
    pub fn finish(self) -> u64 {
        self.0
    }
}
