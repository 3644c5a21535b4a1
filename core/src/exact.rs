//! Exact summation of `f64` values: a sum that depends only on the set of terms, not on
//! their order or grouping, correctly rounded once at the end.
//!
//! The reduction rule of docs/design/mpi.md §3 needs it: partial sums made on different
//! threads or ranks must merge to the same bits whatever the order. [`ExactSum`] is a
//! fixed-point accumulator over the whole `f64` range, after Neal's "small
//! superaccumulator" (R. M. Neal, *Fast exact summation using small and large
//! superaccumulators*, arXiv:1505.05571, 2015): 67 signed 64-bit words, each holding 32
//! bits of the binary expansion (word `i` weighs 2^(32 i − 1074)), with the upper 32 bits
//! of every word as room for carries, propagated every 2³⁰ additions. Adding a term splits
//! its 53-bit significand over three words; merging two accumulators adds their words;
//! [`ExactSum::words`] gives the canonical words, which another process can add as
//! integers (an `MPI_SUM` of `i64`, exact in any order) and [`ExactSum::from_words`]
//! takes back. [`ExactSum::round`] gives the sum rounded to nearest, ties to even, as an
//! IEEE addition of exact numbers would: an overflow gives ±∞, a NaN or ∞ among the terms
//! gives what an IEEE sum of them gives (NaN for +∞ and −∞ together). An exact zero is
//! `+0.0` (an IEEE sum of negative zeros only would give −0.0).

/// Number of words: 2098 bits from 2^−1074 to 2^1023 in 32-bit pieces (66) and one for
/// the sign and the carries beyond.
pub const WORDS: usize = 67;
/// Words exchanged by [`ExactSum::words`]: the [`WORDS`] digits and three counters (terms
/// that were +∞, −∞ and NaN).
pub const EXPORTED_WORDS: usize = WORDS + 3;
/// Additions between carry propagations: each changes a word by less than 2³², so 2³⁰ of
/// them keep every word within 2⁶².
const PENDING_LIMIT: u32 = 1 << 30;
const LOW: i64 = (1 << 32) - 1;

/// An exact sum of `f64` terms (see the module's documentation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExactSum {
    words: [i64; WORDS],
    /// Additions since the words were last made canonical.
    pending: u32,
    /// Terms that were +∞, −∞, NaN.
    special: [i64; 3],
}

impl Default for ExactSum {
    fn default() -> Self {
        Self::new()
    }
}

impl ExactSum {
    /// The empty sum (0).
    pub fn new() -> Self {
        Self { words: [0; WORDS], pending: 0, special: [0; 3] }
    }

    /// Adds one term, exactly.
    #[inline]
    pub fn add(&mut self, x: f64) {
        let bits = x.to_bits();
        let exponent = ((bits >> 52) & 0x7ff) as u32;
        let fraction = bits & ((1 << 52) - 1);
        if exponent == 0x7ff {
            let k = if fraction != 0 {
                2
            } else if x > 0.0 {
                0
            } else {
                1
            };
            self.special[k] += 1;
            return;
        }
        // x = ± m 2^(p − 1074) with p ≥ 0 the position of m's lowest bit
        let (m, p) = if exponent == 0 { (fraction, 0) } else { (fraction | (1 << 52), exponent - 1) };
        if m == 0 {
            return;
        }
        if self.pending >= PENDING_LIMIT {
            self.propagate();
        }
        self.pending += 1;
        let (c, shift) = ((p / 32) as usize, p % 32);
        let v = (m as u128) << shift;
        // the sign without a branch (terms of random signs would mispredict it): a
        // piece p becomes (p ^ −1) + 1 = −p for a negative term, p otherwise
        let negative = (bits >> 63) as i64;
        let pieces = [(v as i64) & LOW, ((v >> 32) as i64) & LOW, (v >> 64) as i64];
        // c ≤ 63 for a finite term: one bounds check for the three words
        let words = &mut self.words[c..c + 3];
        for (w, piece) in words.iter_mut().zip(pieces) {
            *w += (piece ^ -negative) + negative;
        }
    }

    /// Adds every term of `other` (the same result as adding its terms one by one).
    pub fn merge(&mut self, other: &ExactSum) {
        self.propagate();
        let mut other = other.clone();
        other.propagate();
        for (w, o) in self.words.iter_mut().zip(&other.words) {
            *w += o;
        }
        for (s, o) in self.special.iter_mut().zip(&other.special) {
            *s += o;
        }
        // each word now below 2^33 in magnitude: as after two additions
        self.pending = 2;
    }

    /// Makes the words canonical: 0 ≤ word < 2³² but the last, which carries the sign.
    fn propagate(&mut self) {
        for i in 0..WORDS - 1 {
            let carry = self.words[i] >> 32;
            self.words[i] &= LOW;
            self.words[i + 1] += carry;
        }
        self.pending = 0;
    }

    /// The canonical words and the counters of special terms: equal for equal sums, and
    /// such that the element-wise integer sum of the words of several accumulators (of up
    /// to 2²⁹ of them) is the words of their merged sum.
    pub fn words(&self) -> [i64; EXPORTED_WORDS] {
        let mut s = self.clone();
        s.propagate();
        let mut out = [0; EXPORTED_WORDS];
        out[..WORDS].copy_from_slice(&s.words);
        out[WORDS..].copy_from_slice(&s.special);
        out
    }

    /// The sum whose [`ExactSum::words`] are `words` (or the element-wise sum of several
    /// accumulators' words).
    pub fn from_words(words: &[i64; EXPORTED_WORDS]) -> Self {
        let mut s = Self::new();
        s.words.copy_from_slice(&words[..WORDS]);
        s.special.copy_from_slice(&words[WORDS..]);
        // the words may be sums of many canonical words: propagate at the next addition
        s.pending = PENDING_LIMIT;
        s
    }

    /// The sum rounded to the nearest `f64`, ties to even.
    pub fn round(&self) -> f64 {
        let [pos_inf, neg_inf, nan] = self.special;
        if nan > 0 || (pos_inf > 0 && neg_inf > 0) {
            return f64::NAN;
        } else if pos_inf > 0 {
            return f64::INFINITY;
        } else if neg_inf > 0 {
            return f64::NEG_INFINITY;
        }
        let mut s = self.clone();
        s.propagate();
        let negative = s.words[WORDS - 1] < 0;
        if negative {
            for w in &mut s.words {
                *w = -*w;
            }
            s.propagate();
        }
        let magnitude = s.magnitude();
        if negative {
            -magnitude
        } else {
            magnitude
        }
    }

    /// The value of canonical, non-negative words, rounded.
    fn magnitude(&self) -> f64 {
        let w = &self.words;
        let Some(top) = (0..WORDS).rev().find(|&i| w[i] != 0) else {
            return 0.0;
        };
        if top == WORDS - 1 {
            // at least 2^(32·66 − 1074) = 2^1038
            return f64::INFINITY;
        }
        let (hi, base, sticky) = if top < 2 {
            let v = ((w[1] as u64) << 32) | w[0] as u64;
            if v < 1 << 53 {
                // v 2^−1074 is exactly the double with bits v (subnormal, or the first binade)
                return f64::from_bits(v);
            }
            (v as u128, -1074, false)
        } else {
            let hi = ((w[top] as u128) << 64) | ((w[top - 1] as u128) << 32) | w[top - 2] as u128;
            (hi, 32 * (top as i64 - 2) - 1074, w[..top - 2].iter().any(|&x| x != 0))
        };
        // hi 2^base (+ less than 2^base when sticky), hi of more than 53 bits
        let length = 128 - hi.leading_zeros() as i64;
        let shift = length - 53;
        let mut mantissa = (hi >> shift) as u64;
        let rest = hi & ((1u128 << shift) - 1);
        let half = 1u128 << (shift - 1);
        if rest > half || (rest == half && (sticky || mantissa & 1 == 1)) {
            mantissa += 1;
        }
        let mut exponent = base + shift; // of the mantissa's lowest bit
        if mantissa == 1 << 53 {
            mantissa >>= 1;
            exponent += 1;
        }
        let biased = exponent + 1075;
        if biased >= 0x7ff {
            return f64::INFINITY;
        }
        f64::from_bits(((biased as u64) << 52) | (mantissa & ((1 << 52) - 1)))
    }
}

impl Extend<f64> for ExactSum {
    fn extend<I: IntoIterator<Item = f64>>(&mut self, terms: I) {
        for x in terms {
            self.add(x);
        }
    }
}

impl FromIterator<f64> for ExactSum {
    fn from_iter<I: IntoIterator<Item = f64>>(terms: I) -> Self {
        let mut s = Self::new();
        s.extend(terms);
        s
    }
}

/// The correctly rounded sum of `terms`, whatever their order.
pub fn exact_sum(terms: impl IntoIterator<Item = f64>) -> f64 {
    terms.into_iter().collect::<ExactSum>().round()
}

/// Nodes in a row group of the reduction rule (docs/design/mpi.md §3): W consecutive nodes
/// of one lattice row along x, starting at a multiple of W; cuts between ranks along x
/// fall on multiples of W, so a group never straddles them.
pub const GROUP: usize = 32;

/// The row groups of a lattice row of `len` nodes on a level of `nx` cells along x, as
/// ranges of the row, `width` nodes wide ([`GROUP`] on the fine grid, `GROUP / 2^l` on
/// multigrid level l): `0..width`, `width..2 width`, … up to `nx`, then the high face `nx`
/// alone when the row has `nx + 1` nodes (x-faces).
pub fn row_groups(len: usize, nx: usize, width: usize) -> impl Iterator<Item = std::ops::Range<usize>> + Clone {
    let body = len.min(nx);
    let width = width.max(1);
    (0..body.div_ceil(width))
        .map(move |g| g * width..((g + 1) * width).min(body))
        .chain((body < len).then_some(body..len))
}

/// Σ a b over a group in a fixed order: eight partial sums (vectorisable), added pairwise,
/// then the tail.
#[inline]
pub fn lanes_dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f64 = ca.remainder().iter().zip(cb.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            acc[l] += x[l] * y[l];
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])) + tail
}

/// `K` exact sums made together (e.g. r·z and r·r of one pass), merged together and
/// reduced together by [`reduce`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sums<const K: usize>(pub [ExactSum; K]);

impl<const K: usize> Default for Sums<K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const K: usize> Sums<K> {
    /// `K` empty sums.
    pub fn new() -> Self {
        Self(std::array::from_fn(|_| ExactSum::new()))
    }

    /// Adds one group's values, `values[k]` to sum k.
    #[inline]
    pub fn add(&mut self, values: [f64; K]) {
        for (s, v) in self.0.iter_mut().zip(values) {
            s.add(v);
        }
    }

    /// The sums of both (for rayon's `reduce`: the order of merging does not matter).
    pub fn merge(mut self, other: Self) -> Self {
        self.merge_from(&other);
        self
    }

    /// Adds `other`'s sums into these.
    fn merge_from(&mut self, other: &Self) {
        for (s, o) in self.0.iter_mut().zip(&other.0) {
            s.merge(o);
        }
    }

    /// `K` empty sums on the heap: the accumulator of a rayon `fold`, which passes its
    /// accumulator by value at every item (a box moves 8 bytes, the sums 560 `K`).
    pub fn boxed() -> Box<Self> {
        Box::new(Self::new())
    }

    /// [`Sums::merge`] of boxed sums (the `reduce` after a `fold` from [`Sums::boxed`]).
    // rayon's `reduce` hands both operands as the fold's type
    #[allow(clippy::boxed_local)]
    pub fn merge_boxed(mut a: Box<Self>, b: Box<Self>) -> Box<Self> {
        a.merge_from(&b);
        a
    }
}

/// Stage 3 of the reduction rule: the accumulated sums rounded to `f64`. This is the one
/// place every exact reduction of a step ends; under MPI (docs/design/mpi.md §3, phase
/// P0b) the words of every rank's accumulators are summed here by `Comm::sum_words`
/// (one call for the `K` sums) before rounding. Serially: rounding.
pub fn reduce<const K: usize>(sums: &Sums<K>) -> [f64; K] {
    sums.0.each_ref().map(ExactSum::round)
}

/// Lattices at least this large are reduced in parallel (the result is the same).
pub(crate) const PARALLEL_NODES: usize = 16_384;

/// The reduction rule over a lattice stored row by row (rows of `len` nodes along x, `nx`
/// cells along x, `total` nodes): `group(range)` gives the `K` values of the row group at
/// the flat indices `range`, summed in its own fixed order; the group values are added
/// exactly (rows in parallel for big lattices: any split gives the same sums).
pub fn row_sums<const K: usize>(
    total: usize,
    len: usize,
    nx: usize,
    width: usize,
    group: impl Fn(std::ops::Range<usize>) -> [f64; K] + Sync + Send,
) -> Sums<K> {
    if len == 0 {
        return Sums::new();
    }
    debug_assert_eq!(total % len, 0, "{total} nodes are not rows of {len}");
    crate::part::RowGroups::rows_of(len, total / len, nx, width).sums(group)
}

/// Σ a b over a lattice of rows of `len` nodes (`nx` cells along x) by the reduction rule
/// (row groups of [`GROUP`] in [`lanes_dot`] order, added exactly), rounded once.
pub fn dot(a: &[f64], b: &[f64], len: usize, nx: usize) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    reduce(&row_sums(a.len(), len, nx, GROUP, |g| [lanes_dot(&a[g.clone()], &b[g])]))[0]
}

/// Σ a over a lattice of rows of `len` nodes (`nx` cells along x) by the reduction rule
/// (row groups of [`GROUP`] summed in order, added exactly), rounded once.
pub fn sum(a: &[f64], len: usize, nx: usize) -> f64 {
    reduce(&row_sums(a.len(), len, nx, GROUP, |g| [a[g].iter().sum()]))[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Terms k 2^e with |k| < 2^53 and e in [−40, 0]: their exact sum, times 2^40, is an
    /// i128, whose conversion to f64 Rust rounds to nearest, ties to even.
    fn reference(terms: &[f64]) -> f64 {
        let total: i128 = terms.iter().map(|&x| (x * 2f64.powi(40)) as i128).sum();
        total as f64 * 2f64.powi(-40)
    }

    fn terms(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = fastrand::Rng::with_seed(seed);
        (0..n)
            .map(|_| {
                let k = rng.i64(-(1 << 53) + 1..1 << 53) as f64;
                k * 2f64.powi(-rng.i32(0..=40))
            })
            .collect()
    }

    #[test]
    fn correctly_rounded_against_integer_arithmetic() {
        let mut naive_differs = 0;
        for seed in 0..200 {
            let t = terms(1 + seed as usize * 7, seed);
            let exact = exact_sum(t.iter().copied());
            assert_eq!(exact.to_bits(), reference(&t).to_bits(), "seed {seed}");
            naive_differs += (t.iter().sum::<f64>() != exact) as usize;
        }
        // the test would pass a naive sum otherwise
        assert!(naive_differs > 100, "{naive_differs}");
    }

    #[test]
    fn independent_of_order_and_grouping() {
        let mut t = terms(5000, 7);
        // and terms from the whole range: huge, subnormal, cancelling
        let mut rng = fastrand::Rng::with_seed(11);
        t.extend((0..500).map(|_| (rng.f64() - 0.5) * 2f64.powi(rng.i32(-1074..=1020))));
        t.extend([1e300, -1e300, f64::from_bits(5), -f64::MAX, f64::MAX]);
        let whole = exact_sum(t.iter().copied());
        let mut shuffled = t.clone();
        fastrand::Rng::with_seed(3).shuffle(&mut shuffled);
        assert_eq!(exact_sum(shuffled.iter().copied()).to_bits(), whole.to_bits());
        // in chunks merged backwards, and through the exported words summed as integers
        let parts: Vec<ExactSum> = shuffled.chunks(333).map(|c| c.iter().copied().collect()).collect();
        let mut merged = ExactSum::new();
        for p in parts.iter().rev() {
            merged.merge(p);
        }
        assert_eq!(merged.round().to_bits(), whole.to_bits());
        let mut words = [0i64; EXPORTED_WORDS];
        for p in &parts {
            for (w, x) in words.iter_mut().zip(p.words()) {
                *w += x;
            }
        }
        let from = ExactSum::from_words(&words);
        assert_eq!(from.round().to_bits(), whole.to_bits());
        assert_eq!(from.words(), merged.words());
    }

    #[test]
    fn cancellation_ties_and_the_ends_of_the_range() {
        assert_eq!(exact_sum([1e100, 1.0, -1e100]), 1.0);
        assert_eq!(exact_sum([1e308, 1e308, -1e308]), 1e308);
        let two53 = 2f64.powi(53);
        // a tie goes to the even neighbour; a term below it breaks the tie upwards
        assert_eq!(exact_sum([two53, 1.0]), two53);
        assert_eq!(exact_sum([two53, 3.0]), two53 + 4.0);
        assert_eq!(exact_sum([two53, 1.0, 2f64.powi(-1000)]), two53 + 2.0);
        assert_eq!(exact_sum([two53, 1.0, -(2f64.powi(-1000))]), two53);
        let tiny = f64::from_bits(1);
        assert_eq!(exact_sum([tiny, tiny, tiny]), f64::from_bits(3));
        assert_eq!(exact_sum([f64::MIN_POSITIVE, -tiny]), f64::from_bits((1 << 52) - 1));
        assert_eq!(exact_sum([-tiny, -tiny]), -f64::from_bits(2));
        assert_eq!(exact_sum([f64::MAX, f64::MAX]), f64::INFINITY);
        assert_eq!(exact_sum([-f64::MAX, -f64::MAX]), f64::NEG_INFINITY);
        assert_eq!(exact_sum([f64::MAX, 2f64.powi(969)]), f64::MAX);
        assert_eq!(exact_sum([f64::MAX, 2f64.powi(970)]), f64::INFINITY);
        // the doubles 0.1 + 0.2 − 0.3 sum to 2^−55 exactly (Python: fractions); naively 2^−54
        assert_eq!(exact_sum([0.1, 0.2, -0.3]), 2f64.powi(-55));
        assert_eq!(exact_sum([3.0, -3.0]).to_bits(), 0.0f64.to_bits());
        assert_eq!(exact_sum(std::iter::empty()).to_bits(), 0.0f64.to_bits());
        assert_eq!(exact_sum([1.0, f64::INFINITY]), f64::INFINITY);
        assert!(exact_sum([f64::INFINITY, f64::NEG_INFINITY]).is_nan());
        assert!(exact_sum([1.0, f64::NAN]).is_nan());
    }

    #[test]
    fn carries_over_many_additions() {
        // 2^30 + 5 additions of a value filling a whole word: one propagation on the way
        let mut s = ExactSum::new();
        let x = 2f64.powi(32) - 1.0;
        let n = (1u64 << 30) + 5;
        for _ in 0..n {
            s.add(x);
        }
        let exact = n as i128 * ((1i128 << 32) - 1);
        assert_eq!(s.round(), exact as f64);
        let mut negative = ExactSum::from_words(&s.words().map(|w| -w));
        assert_eq!(negative.round(), -(exact as f64));
        negative.merge(&s);
        assert_eq!(negative.round().to_bits(), 0.0f64.to_bits());
    }

    #[test]
    fn row_groups_follow_the_rule() {
        let g: Vec<_> = row_groups(65, 64, GROUP).collect();
        assert_eq!(g, [0..32, 32..64, 64..65]);
        let g: Vec<_> = row_groups(41, 40, GROUP).collect();
        assert_eq!(g, [0..32, 32..40, 40..41]);
        let g: Vec<_> = row_groups(40, 40, GROUP).collect();
        assert_eq!(g, [0..32, 32..40]);
        // multigrid level 6: one cell a group
        assert_eq!(row_groups(3, 3, GROUP >> 6).count(), 3);
    }

    #[test]
    fn reductions_are_exact_and_independent_of_chunking_and_threads() {
        // naively (1e16 + 1) rounds to 1e16 (a tie, to even): the sum in order is 1, the
        // exact sum 2; as four groups of one term (width 1) the rule gives 2
        let t = [1e16, 1.0, -1e16, 1.0];
        assert_eq!(t.iter().sum::<f64>(), 1.0);
        assert_eq!(reduce(&row_sums(4, 4, 4, 1, |g| [t[g].iter().sum()]))[0], 2.0);
        // a row group is summed in its fixed order: one group of the four gives 1
        assert_eq!(sum(&t, 4, 4), 1.0);

        // x-faces of 64 cells (rows of 65), 400 rows: parallel; values of many magnitudes
        let (len, nx, rows) = (65, 64, 400);
        let mut rng = fastrand::Rng::with_seed(5);
        let a: Vec<f64> = (0..len * rows).map(|_| (rng.f64() - 0.5) * 2f64.powi(rng.i32(-30..=30))).collect();
        let b: Vec<f64> = (0..len * rows).map(|_| rng.f64() - 0.25).collect();
        // the rule by hand: the groups in row order, their values summed exactly
        let groups: Vec<f64> = (0..rows)
            .flat_map(|r| row_groups(len, nx, GROUP).map(move |g| r * len + g.start..r * len + g.end))
            .map(|g| lanes_dot(&a[g.clone()], &b[g]))
            .collect();
        assert_eq!(groups.len(), rows * 3);
        let expected = exact_sum(groups.iter().copied());
        // a naive sum of the same group values differs (so the check below can fail)
        assert_ne!(groups.iter().sum::<f64>().to_bits(), expected.to_bits());
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let d = pool.install(|| dot(&a, &b, len, nx));
            assert_eq!(d.to_bits(), expected.to_bits(), "{threads} threads");
        }
        // the groups accumulated in chunks of rows of several sizes, merged backwards
        for chunk in [1, 7, 64, 399] {
            let parts: Vec<Sums<1>> = (0..rows)
                .collect::<Vec<_>>()
                .chunks(chunk)
                .map(|rs| {
                    let mut s = Sums::new();
                    for &r in rs {
                        for g in row_groups(len, nx, GROUP) {
                            let g = r * len + g.start..r * len + g.end;
                            s.add([lanes_dot(&a[g.clone()], &b[g])]);
                        }
                    }
                    s
                })
                .collect();
            let merged = parts.into_iter().rev().fold(Sums::new(), Sums::merge);
            assert_eq!(reduce(&merged)[0].to_bits(), expected.to_bits(), "chunks of {chunk} rows");
        }
        // two sums of one pass: the same bits as each alone
        let both = reduce(&row_sums(a.len(), len, nx, GROUP, |g| {
            [lanes_dot(&a[g.clone()], &b[g.clone()]), a[g].iter().sum()]
        }));
        assert_eq!(both, [expected, sum(&a, len, nx)]);
    }
}
