//! Arrays of `f64` whose first value lies on a 64-byte boundary (a cache line): the exact
//! kernel's whole-vector loads and stores of per-bin values then never straddle two lines.
//! Where the allocator places a plain `Vec<f64>` at 16 bytes past a line, every such access
//! touches two, at a cost that varies with the heap's history.

use std::ops::{Deref, DerefMut};

/// A fixed-length array of `f64` starting on a cache line.
#[derive(Debug)]
pub struct Aligned {
    buf: Vec<f64>,
    off: usize,
    len: usize,
}

impl Aligned {
    /// `len` zeros.
    pub fn zeros(len: usize) -> Aligned {
        let buf = vec![0.0; len + 7];
        // (at most 7 values to the next line; were the offset unknown, 7 is still correct)
        let off = buf.as_ptr().align_offset(64).min(7);
        Aligned { buf, off, len }
    }

    /// A copy of `v`.
    pub fn from_slice(v: &[f64]) -> Aligned {
        let mut a = Aligned::zeros(v.len());
        a.copy_from_slice(v);
        a
    }

    /// The values as a plain vector (no copy).
    pub fn into_vec(mut self) -> Vec<f64> {
        self.buf.drain(..self.off);
        self.buf.truncate(self.len);
        self.buf
    }
}

impl Clone for Aligned {
    /// (a fresh allocation, aligned afresh)
    fn clone(&self) -> Aligned {
        Aligned::from_slice(self)
    }
}

impl Deref for Aligned {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.buf[self.off..self.off + self.len]
    }
}

impl DerefMut for Aligned {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.buf[self.off..self.off + self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_start_on_a_cache_line_and_keep_their_length() {
        for len in [0, 1, 7, 8, 1216] {
            let a = Aligned::from_slice(&(0..len).map(|i| i as f64).collect::<Vec<_>>());
            assert_eq!(a.len(), len);
            assert_eq!(a.as_ptr() as usize % 64, 0);
            let b = a.clone();
            assert_eq!(b.as_ptr() as usize % 64, 0);
            assert_eq!(&b[..], &a[..]);
            let v = b.into_vec();
            assert_eq!(v, (0..len).map(|i| i as f64).collect::<Vec<_>>());
        }
    }
}
