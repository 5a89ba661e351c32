//! The symbolic structure, built once per topology: chains, border, and the
//! order in which the chains are walked.

use std::cmp::Reverse;

use super::MAX_BORDER;

/// Structure of a bordered block-tridiagonal matrix (see the [module
/// doc](super)): independent chains of blocks of one size, and `k` dense
/// border rows of which the first `k_primal` are primal unknowns.
///
/// Unknowns are numbered chain after chain, block after block: chain `c`
/// holds blocks `chain_blocks(c)`, block `j` holds unknowns `B j .. B j + B`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pattern {
    block_size: usize,
    /// First block of each chain, and the total number of blocks last.
    offsets: Vec<usize>,
    border_rows: usize,
    primal_rows: usize,
    schedule: Vec<Segment>,
    /// Per chain `c` and border row `r`, at `c * MAX_BORDER + r`: the first
    /// block of the chain (counted from its start) where the row may be
    /// nonzero; the chain's length or more when it is zero on the whole chain.
    starts: Vec<usize>,
}

/// Which lanes a segment of the walk advances.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Lanes {
    Both,
    First,
    Second,
}

/// A stretch of the walk over which the lanes advance block by block in
/// lockstep: lane `l` walks blocks `start[l] .. start[l] + len`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Segment {
    pub start: [usize; 2],
    /// Whether the lane's first block starts a chain (its recurrence restarts).
    pub fresh: [bool; 2],
    pub len: usize,
    pub lanes: Lanes,
}

/// One pass over the blocks: what a lane does at one block. `FRESH` is true
/// at the first block of a chain, which has no predecessor.
pub(super) trait Sweep {
    /// State carried by one lane from block to block.
    type Lane;
    fn step<const FRESH: bool>(&mut self, lane: &mut Self::Lane, block: usize);
}

impl Pattern {
    /// The structure of chains of `chain_lengths[c]` blocks of
    /// `block_size x block_size` (1 or 3), bordered by `border_rows` dense
    /// rows (at most [`MAX_BORDER`]) of which the first `primal_rows` are
    /// primal unknowns (shifted like the chains).
    ///
    /// # Panics
    /// On a block size other than 1 or 3, more than [`MAX_BORDER`] border
    /// rows, or more primal rows than border rows.
    pub fn new(block_size: usize, chain_lengths: &[usize], border_rows: usize, primal_rows: usize) -> Pattern {
        assert!(block_size == 1 || block_size == 3, "block size {block_size}: 1 or 3 expected");
        assert!(border_rows <= MAX_BORDER, "{border_rows} border rows: at most {MAX_BORDER}");
        assert!(primal_rows <= border_rows, "{primal_rows} primal rows among {border_rows} border rows");
        let mut offsets = Vec::with_capacity(chain_lengths.len() + 1);
        let mut total = 0;
        for &len in chain_lengths {
            offsets.push(total);
            total += len;
        }
        offsets.push(total);
        let schedule = schedule(&offsets);
        let starts = vec![0; chain_lengths.len() * MAX_BORDER];
        Pattern { block_size, offsets, border_rows, primal_rows, schedule, starts }
    }

    /// Declares that border row `row` is zero on chain `c`'s blocks before
    /// its block `first` (counted from the chain's start; the chain's length
    /// or more: zero on the whole chain). The entries declared zero must be
    /// exactly zero: the factorization of 3 x 3 blocks skips them (its work
    /// per block is quadratic in the rows present there, so a border whose
    /// rows each touch a few chains, or only a chain's end, costs little);
    /// the scalar paths read them. By default every row may be nonzero
    /// everywhere.
    ///
    /// # Panics
    /// If `c` is not a chain or `row` is at least [`MAX_BORDER`].
    pub fn set_border_start(&mut self, c: usize, row: usize, first: usize) {
        assert!(c < self.chains() && row < MAX_BORDER, "chain {c}, border row {row}: out of the pattern");
        self.starts[c * MAX_BORDER + row] = first;
    }

    /// The first block of chain `c` (from its start) where border row `row`
    /// may be nonzero ([`Pattern::set_border_start`]).
    pub fn border_start(&self, c: usize, row: usize) -> usize {
        self.starts[c * MAX_BORDER + row]
    }

    /// Size of the diagonal blocks.
    pub fn block_size(&self) -> usize {
        self.block_size
    }

    /// Number of chains.
    pub fn chains(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Blocks of chain `c`, numbered over all chains.
    pub fn chain_blocks(&self, c: usize) -> std::ops::Range<usize> {
        self.offsets[c]..self.offsets[c + 1]
    }

    /// Number of blocks of all chains.
    pub fn blocks(&self) -> usize {
        self.offsets[self.offsets.len() - 1]
    }

    /// Number of sparse unknowns `n` (blocks times block size).
    pub fn unknowns(&self) -> usize {
        self.blocks() * self.block_size
    }

    /// Number of border rows `k`.
    pub fn border_rows(&self) -> usize {
        self.border_rows
    }

    /// Changes the number of border rows (the chains and the primal rows stay).
    ///
    /// # Panics
    /// On more than [`MAX_BORDER`] rows or fewer than the primal rows.
    pub fn set_border_rows(&mut self, rows: usize) {
        assert!(rows <= MAX_BORDER, "{rows} border rows: at most {MAX_BORDER}");
        assert!(self.primal_rows <= rows, "{} primal rows among {rows} border rows", self.primal_rows);
        self.border_rows = rows;
    }

    /// Number of border rows that are primal unknowns (`k_primal`).
    pub fn primal_rows(&self) -> usize {
        self.primal_rows
    }

    /// Order `n + k` of the whole matrix.
    pub fn dimension(&self) -> usize {
        self.unknowns() + self.border_rows
    }

    /// Walks every block once, each lane in its chains' order. Each segment's
    /// first block is peeled so that the steady loop has no restart test.
    #[inline(always)]
    pub(super) fn forward<S: Sweep>(&self, sweep: &mut S, lane0: &mut S::Lane, lane1: &mut S::Lane) {
        for segment in &self.schedule {
            let ([a, b], len) = (segment.start, segment.len);
            match segment.lanes {
                Lanes::Both => {
                    begin(sweep, lane0, a, segment.fresh[0]);
                    begin(sweep, lane1, b, segment.fresh[1]);
                    for t in 1..len {
                        sweep.step::<false>(lane0, a + t);
                        sweep.step::<false>(lane1, b + t);
                    }
                }
                // Two calls instead of a selected reference keep both lanes
                // out of memory.
                Lanes::First => run_forward(sweep, lane0, a, len, segment.fresh[0]),
                Lanes::Second => run_forward(sweep, lane1, b, len, segment.fresh[1]),
            }
        }
    }

    /// Walks every block once in the exact reverse of [`Pattern::forward`]'s
    /// order per lane. Steps are never fresh: the backward recurrences cross
    /// chain ends through a zero multiplier instead.
    #[inline(always)]
    pub(super) fn backward<S: Sweep>(&self, sweep: &mut S, lane0: &mut S::Lane, lane1: &mut S::Lane) {
        for segment in self.schedule.iter().rev() {
            let ([a, b], len) = (segment.start, segment.len);
            match segment.lanes {
                Lanes::Both => {
                    for t in (0..len).rev() {
                        sweep.step::<false>(lane0, a + t);
                        sweep.step::<false>(lane1, b + t);
                    }
                }
                Lanes::First => (0..len).rev().for_each(|t| sweep.step::<false>(lane0, a + t)),
                Lanes::Second => (0..len).rev().for_each(|t| sweep.step::<false>(lane1, b + t)),
            }
        }
    }
}

#[inline(always)]
fn begin<S: Sweep>(sweep: &mut S, lane: &mut S::Lane, block: usize, fresh: bool) {
    if fresh {
        sweep.step::<true>(lane, block);
    } else {
        sweep.step::<false>(lane, block);
    }
}

#[inline(always)]
fn run_forward<S: Sweep>(sweep: &mut S, lane: &mut S::Lane, start: usize, len: usize, fresh: bool) {
    begin(sweep, lane, start, fresh);
    for t in 1..len {
        sweep.step::<false>(lane, start + t);
    }
}

/// The walk: chains dealt to two lanes, longest first to the lane with less
/// work, then cut into segments where both lanes advance together.
fn schedule(offsets: &[usize]) -> Vec<Segment> {
    let length = |c: usize| offsets[c + 1] - offsets[c];
    let mut order: Vec<usize> = (0..offsets.len() - 1).filter(|&c| length(c) > 0).collect();
    order.sort_by_key(|&c| Reverse(length(c)));
    let mut queues: [Vec<(usize, usize)>; 2] = [Vec::new(), Vec::new()];
    let mut work = [0, 0];
    for c in order {
        let lane = usize::from(work[1] < work[0]);
        queues[lane].push((offsets[c], length(c)));
        work[lane] += length(c);
    }
    // Position in each lane: which chain of its queue, and blocks done in it.
    let (mut chain, mut done) = ([0, 0], [0, 0]);
    let mut segments = Vec::new();
    loop {
        let current = [queues[0].get(chain[0]), queues[1].get(chain[1])];
        let (lanes, len) = match current {
            [Some(&(_, l0)), Some(&(_, l1))] => (Lanes::Both, (l0 - done[0]).min(l1 - done[1])),
            [Some(&(_, l0)), None] => (Lanes::First, l0 - done[0]),
            [None, Some(&(_, l1))] => (Lanes::Second, l1 - done[1]),
            [None, None] => return segments,
        };
        let mut segment = Segment { start: [0, 0], fresh: [false, false], len, lanes };
        // Every lane that still has a chain takes part in the segment.
        for lane in 0..2 {
            if let Some(&(start, chain_len)) = current[lane] {
                segment.start[lane] = start + done[lane];
                segment.fresh[lane] = done[lane] == 0;
                done[lane] += len;
                if done[lane] == chain_len {
                    (chain[lane], done[lane]) = (chain[lane] + 1, 0);
                }
            }
        }
        segments.push(segment);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records the blocks each lane visits and whether the step was fresh.
    struct Trace(Vec<(usize, usize, bool)>);

    impl Sweep for Trace {
        type Lane = usize;
        fn step<const FRESH: bool>(&mut self, lane: &mut usize, block: usize) {
            self.0.push((*lane, block, FRESH));
        }
    }

    fn walk(pattern: &Pattern, backward: bool) -> Vec<(usize, usize, bool)> {
        let mut trace = Trace(Vec::new());
        let (mut lane0, mut lane1) = (0, 1);
        if backward {
            pattern.backward(&mut trace, &mut lane0, &mut lane1);
        } else {
            pattern.forward(&mut trace, &mut lane0, &mut lane1);
        }
        trace.0
    }

    #[test]
    fn two_equal_chains_walk_side_by_side() {
        let pattern = Pattern::new(1, &[3, 3], 3, 0);
        let steps = walk(&pattern, false);
        let expected = [(0, 0, true), (1, 3, true), (0, 1, false), (1, 4, false), (0, 2, false), (1, 5, false)];
        assert_eq!(steps, expected);
    }

    #[test]
    fn every_block_once_in_chain_order_and_reversed_backward() {
        for lengths in [vec![5], vec![4, 1, 7], vec![5, 4, 4], vec![0, 3, 3, 2, 9], vec![2, 2, 2, 2], vec![]] {
            let pattern = Pattern::new(3, &lengths, 0, 0);
            let forward = walk(&pattern, false);
            assert_eq!(forward.len(), pattern.blocks());
            for c in 0..pattern.chains() {
                let blocks = pattern.chain_blocks(c);
                // One lane walks the whole chain in order, fresh at its start only.
                let visits: Vec<_> = forward.iter().filter(|s| blocks.contains(&s.1)).collect();
                assert!(visits.iter().all(|s| s.0 == visits[0].0));
                for (t, s) in visits.iter().enumerate() {
                    assert_eq!((s.1, s.2), (blocks.start + t, t == 0), "chains {lengths:?}");
                }
            }
            for lane in 0..2 {
                let ours = |steps: &[(usize, usize, bool)]| -> Vec<usize> {
                    steps.iter().filter(|s| s.0 == lane).map(|s| s.1).collect()
                };
                let mut reversed = ours(&walk(&pattern, true));
                reversed.reverse();
                assert_eq!(ours(&forward), reversed);
            }
        }
    }

    #[test]
    fn second_lane_finishes_alone() {
        // Lane 0 takes the 5, lane 1 both 4s: its last 3 blocks run alone.
        let pattern = Pattern::new(1, &[5, 4, 4], 0, 0);
        assert_eq!(pattern.schedule.last().map(|s| (s.lanes, s.len)), Some((Lanes::Second, 3)));
    }

    #[test]
    fn lanes_share_the_work() {
        let pattern = Pattern::new(1, &[10, 4, 3, 3], 0, 0);
        let steps = walk(&pattern, false);
        let lane0 = steps.iter().filter(|s| s.0 == 0).count();
        assert_eq!((lane0, steps.len() - lane0), (10, 10));
    }
}
