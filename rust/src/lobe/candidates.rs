//! A pose's candidate leaves: the stored indices that the lobe query could not rule out, in a
//! thread-independent order, kept as runs `[lo, hi)` of consecutive indices. A scene is stored
//! in its BVH's depth-first order, so a subtree inside the lobe is one run: a beam that takes
//! in a million leaves gives a handful of runs, not a 4 MB list of indices built serially per
//! pulse.

use std::ops::Range;

use crate::lobe::CB;

/// Candidate leaves as ordered runs of stored indices.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Candidates {
    runs: Vec<(u32, u32)>,
    /// The number of candidates before each run.
    before: Vec<usize>,
    len: usize,
}

impl Candidates {
    /// Every leaf of an `n`-leaf scene, in storage order.
    pub fn all(n: usize) -> Candidates {
        let mut c = Candidates::default();
        c.push_run(0, n as u32);
        c
    }

    /// Append the indices `lo..hi` (joined to the last run where they continue it).
    pub fn push_run(&mut self, lo: u32, hi: u32) {
        if lo >= hi {
            return;
        }
        match self.runs.last_mut() {
            Some(last) if last.1 == lo => last.1 = hi,
            _ => {
                self.runs.push((lo, hi));
                self.before.push(self.len);
            }
        }
        self.len += (hi - lo) as usize;
    }

    /// Append indices in the given order.
    pub fn push_ids(&mut self, ids: &[u32]) {
        for &i in ids {
            self.push_run(i, i + 1);
        }
    }

    /// Append `other`'s candidates, in order (as if its runs were pushed here one by one).
    pub fn append(&mut self, other: &Candidates) {
        for &(lo, hi) in &other.runs {
            self.push_run(lo, hi);
        }
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The run holding position `pos` (`pos < len`) and the candidate there.
    fn locate(&self, pos: usize) -> (usize, u32) {
        assert!(pos < self.len, "candidate {pos} of {}", self.len);
        let r = self.before.partition_point(|&b| b <= pos) - 1;
        (r, self.runs[r].0 + (pos - self.before[r]) as u32)
    }

    /// The candidate at position `pos` (`pos < len`).
    pub fn get(&self, pos: usize) -> u32 {
        self.locate(pos).1
    }

    /// All candidates, in order.
    pub fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.runs.iter().flat_map(|&(lo, hi)| lo..hi)
    }

    /// All candidates, in order, as a list of indices.
    pub fn to_vec(&self) -> Vec<u32> {
        let mut v = Vec::with_capacity(self.len);
        for &(lo, hi) in &self.runs {
            v.extend(lo..hi);
        }
        v
    }

    /// The candidates at positions `span`, in blocks of [`CB`] (the last one shorter): the
    /// same blocks as `ids[span].chunks(CB)` of the list of indices.
    pub fn blocks(&self, span: Range<usize>) -> Blocks<'_> {
        assert!(span.start <= span.end && span.end <= self.len);
        let (run, next) = if span.start < span.end {
            self.locate(span.start)
        } else {
            (self.runs.len(), 0)
        };
        Blocks {
            runs: &self.runs,
            run,
            next,
            left: span.end - span.start,
            buf: [0; CB],
        }
    }
}

/// Blocks of candidates (see [`Candidates::blocks`]):
/// `while let Some((ids, consecutive)) = blocks.next_block() { ... }`.
pub struct Blocks<'a> {
    runs: &'a [(u32, u32)],
    run: usize,
    next: u32,
    left: usize,
    buf: [u32; CB],
}

impl Blocks<'_> {
    /// The next block, and whether its indices are consecutive.
    #[inline]
    pub fn next_block(&mut self) -> Option<(&[u32], bool)> {
        let n = self.left.min(CB);
        if n == 0 {
            return None;
        }
        let hi = self.runs[self.run].1;
        if n == CB && (hi - self.next) as usize >= CB {
            // a whole block inside the run (the lobe test then loads its leaves without a
            // gather)
            let first = self.next;
            self.buf = std::array::from_fn(|j| first + j as u32);
            self.next += CB as u32;
            self.left -= CB;
            return Some((&self.buf, true));
        }
        let mut filled = 0;
        while filled < n {
            let hi = self.runs[self.run].1;
            let take = ((hi - self.next) as usize).min(n - filled);
            for (j, slot) in self.buf[filled..filled + take].iter_mut().enumerate() {
                *slot = self.next + j as u32;
            }
            filled += take;
            self.next += take as u32;
            if self.next == hi && self.run + 1 < self.runs.len() {
                self.run += 1;
                self.next = self.runs[self.run].0;
            }
        }
        self.left -= n;
        let ids = &self.buf[..n];
        let consecutive = ids.windows(2).all(|w| w[1] == w[0] + 1);
        Some((ids, consecutive))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs of random lengths with random gaps (some adjacent, so joined), and their list.
    fn random_runs(seed: u64) -> (Candidates, Vec<u32>) {
        let mut u = crate::test_util::uniforms(seed);
        let (mut c, mut ids, mut at) = (Candidates::default(), Vec::new(), 0u32);
        for _ in 0..200 {
            at += (u() * 3.0) as u32 * (u() * 50.0) as u32;
            let len = (u() * u() * 700.0) as u32;
            c.push_run(at, at + len);
            ids.extend(at..at + len);
            at += len;
        }
        (c, ids)
    }

    #[test]
    fn blocks_are_the_chunks_of_the_index_list_for_any_span() {
        let mut u = crate::test_util::uniforms(3);
        for seed in 0..20 {
            let (c, ids) = random_runs(seed);
            assert_eq!(c.len(), ids.len());
            assert!(c.iter().eq(ids.iter().copied()));
            assert_eq!(c.to_vec(), ids);
            for _ in 0..50 {
                let a = (u() * (ids.len() + 1) as f64) as usize;
                let b = a + (u() * (ids.len() - a + 1) as f64) as usize;
                let mut blocks = c.blocks(a..b);
                let mut got = Vec::new();
                while let Some((bl, consecutive)) = blocks.next_block() {
                    assert_eq!(consecutive, bl.windows(2).all(|w| w[1] == w[0] + 1));
                    got.push(bl.to_vec());
                }
                let want: Vec<Vec<u32>> = ids[a..b].chunks(CB).map(|x| x.to_vec()).collect();
                assert_eq!(got, want, "seed {seed} span {a}..{b}");
            }
        }
    }

    #[test]
    fn get_returns_the_index_at_each_position() {
        let (c, ids) = random_runs(7);
        assert!(ids.iter().enumerate().all(|(p, &i)| c.get(p) == i));
    }

    #[test]
    fn adjacent_runs_are_joined_and_empty_ones_dropped() {
        let mut c = Candidates::default();
        c.push_run(5, 9);
        c.push_run(9, 12);
        c.push_run(20, 20);
        c.push_ids(&[12, 13, 30]);
        assert_eq!(c.runs, vec![(5, 14), (30, 31)]);
        assert_eq!(c.len(), 10);
        assert!(Candidates::default().blocks(0..0).next_block().is_none());
    }
}
