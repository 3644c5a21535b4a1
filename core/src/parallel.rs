//! Communication between the processes (ranks) of one run: the [`Comm`] trait, its serial
//! implementation [`Serial`] (one rank: every call a copy or nothing) and [`fake`], P ranks
//! as threads of one process for the tests.
//!
//! The core knows no MPI (docs/design/mpi.md §1): the rsmpi implementation is `MpiComm` in
//! the root package behind its cargo feature `mpi`. Every collective here gives the same
//! result on every rank, and a result that depends only on the ranks' contributions, never
//! on the order in which they arrive: sums are of integers ([`Comm::sum_words`], the words
//! of [`crate::exact::ExactSum`]); maxima and minima fold the gathered values in rank order
//! with `f64::max`/`f64::min` (which ignore NaN, a rule `MPI_MAX` does not promise).

/// A message's tag: which of a pair's messages it is (the halo exchange uses one tag per
/// direction, so that two ranks that are each other's neighbour on both sides of a
/// periodic axis tell the two messages apart).
pub type Tag = u16;

/// The ranks of one run and the collective operations between them.
pub trait Comm: Send + Sync {
    /// This process's rank, 0 ≤ rank < size.
    fn rank(&self) -> usize;
    /// The number of ranks.
    fn size(&self) -> usize;
    /// Point-to-point exchange: sends every `(peer, tag, bytes)` of `sends` and returns, in
    /// the order of `receives`, the bytes of the message from each `(peer, tag)` (of any
    /// length). Every send must be matched by a receive on its peer within the same call;
    /// a rank may be its own peer.
    fn exchange(&self, sends: &[(usize, Tag, &[u8])], receives: &[(usize, Tag)]) -> Vec<Vec<u8>>;
    /// Element-wise sum over the ranks of integer words (the words of
    /// [`crate::exact::ExactSum`]): exact, so independent of the order of the ranks.
    fn sum_words(&self, words: &mut [i64]);
    /// Every rank's `mine`, by rank (the same on every rank).
    fn gather_all(&self, mine: &[u8]) -> Vec<Vec<u8>>;
    /// Waits until every rank has called it.
    fn barrier(&self);
    /// Names the phase of the step the next calls belong to (for the counters of
    /// [`Counted`]; nothing otherwise).
    fn phase(&self, _name: &'static str) {}

    /// [`Comm::exchange`] of `f64` values (as their little-endian bytes).
    fn exchange_f64(&self, sends: &[(usize, Tag, &[f64])], receives: &[(usize, Tag)]) -> Vec<Vec<f64>> {
        let bytes: Vec<Vec<u8>> = sends.iter().map(|s| s.2.iter().flat_map(|v| v.to_le_bytes()).collect()).collect();
        let sends: Vec<(usize, Tag, &[u8])> = sends.iter().zip(&bytes).map(|(s, b)| (s.0, s.1, &b[..])).collect();
        self.exchange(&sends, receives).iter().map(|b| f64_from_bytes(b)).collect()
    }
    /// Every rank's `mine`, by rank.
    fn gather_all_f64(&self, mine: &[f64]) -> Vec<Vec<f64>> {
        let bytes: Vec<u8> = mine.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.gather_all(&bytes).iter().map(|b| f64_from_bytes(b)).collect()
    }
    /// Element-wise maximum over the ranks, folded in rank order with `f64::max` (a NaN
    /// loses against a number, as in the serial code).
    fn max(&self, values: &mut [f64]) {
        fold(self, values, f64::max);
    }
    /// Element-wise minimum over the ranks, folded in rank order with `f64::min`.
    fn min(&self, values: &mut [f64]) {
        fold(self, values, f64::min);
    }
    /// Whether `flag` is true on any rank (the agreement on errors and stops).
    fn any(&self, flag: bool) -> bool {
        let mut w = [flag as i64];
        self.sum_words(&mut w);
        w[0] > 0
    }
}

fn fold<C: Comm + ?Sized>(comm: &C, values: &mut [f64], op: fn(f64, f64) -> f64) {
    let all = comm.gather_all_f64(values);
    for (k, v) in values.iter_mut().enumerate() {
        *v = all.iter().map(|r| r[k]).reduce(op).expect("at least one rank");
    }
}

/// `f64` values from their little-endian bytes.
pub fn f64_from_bytes(bytes: &[u8]) -> Vec<f64> {
    bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect()
}

/// One rank: the default of every run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serial;

impl Comm for Serial {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn exchange(&self, sends: &[(usize, Tag, &[u8])], receives: &[(usize, Tag)]) -> Vec<Vec<u8>> {
        let mut sent: Vec<Option<&(usize, Tag, &[u8])>> = sends.iter().map(Some).collect();
        receives
            .iter()
            .map(|&(peer, tag)| {
                assert_eq!(peer, 0, "rank {peer} of a serial run");
                // the first unreceived message of that tag: messages of one tag arrive in order
                let m = sent.iter_mut().find(|s| s.is_some_and(|s| s.1 == tag)).expect("a receive without its send");
                m.take().expect("found").2.to_vec()
            })
            .collect()
    }
    fn sum_words(&self, _words: &mut [i64]) {}
    fn gather_all(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        vec![mine.to_vec()]
    }
    fn barrier(&self) {}
    fn max(&self, _values: &mut [f64]) {}
    fn min(&self, _values: &mut [f64]) {}
    fn any(&self, flag: bool) -> bool {
        flag
    }
}

/// What one rank sent through a communicator: its own point-to-point messages and the
/// collectives it took part in (docs/design/mpi.md §9's B, X and R, measured).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Traffic {
    /// Point-to-point messages sent (a halo exchange sends one to each neighbour and axis).
    pub messages: u64,
    /// Bytes of those messages.
    pub bytes: u64,
    /// Exchanges (calls of [`Comm::exchange`]).
    pub exchanges: u64,
    /// Reductions (calls of [`Comm::sum_words`]: exact sums and agreements).
    pub reductions: u64,
    /// Words those reductions summed (8 bytes each).
    pub reduced_words: u64,
    /// Gathers (calls of [`Comm::gather_all`]: maxima, minima, gathered residuals, points).
    pub gathers: u64,
    /// Bytes this rank contributed to those gathers.
    pub gathered_bytes: u64,
}

impl Traffic {
    /// The traffic since `before`.
    pub fn since(&self, before: &Traffic) -> Traffic {
        Traffic {
            messages: self.messages - before.messages,
            bytes: self.bytes - before.bytes,
            exchanges: self.exchanges - before.exchanges,
            reductions: self.reductions - before.reductions,
            reduced_words: self.reduced_words - before.reduced_words,
            gathers: self.gathers - before.gathers,
            gathered_bytes: self.gathered_bytes - before.gathered_bytes,
        }
    }
}

impl std::ops::AddAssign for Traffic {
    fn add_assign(&mut self, o: Traffic) {
        self.messages += o.messages;
        self.bytes += o.bytes;
        self.exchanges += o.exchanges;
        self.reductions += o.reductions;
        self.reduced_words += o.reduced_words;
        self.gathers += o.gathers;
        self.gathered_bytes += o.gathered_bytes;
    }
}

/// A communicator that counts this rank's [`Traffic`] through another, by phase
/// ([`Comm::phase`]; "other" before the first).
pub struct Counted {
    inner: std::sync::Arc<dyn Comm>,
    counts: std::sync::Mutex<Counts>,
}

#[derive(Default)]
struct Counts {
    phase: &'static str,
    by_phase: std::collections::BTreeMap<&'static str, Traffic>,
}

impl Counted {
    /// Counts the traffic through `inner`.
    pub fn new(inner: std::sync::Arc<dyn Comm>) -> Self {
        Self { inner, counts: std::sync::Mutex::new(Counts { phase: "other", by_phase: Default::default() }) }
    }
    /// The traffic so far.
    pub fn traffic(&self) -> Traffic {
        let mut total = Traffic::default();
        for t in self.lock().by_phase.values() {
            total += *t;
        }
        total
    }
    /// The traffic so far by phase, in the phases' alphabetical order.
    pub fn by_phase(&self) -> Vec<(&'static str, Traffic)> {
        self.lock().by_phase.iter().map(|(k, v)| (*k, *v)).collect()
    }
    fn lock(&self) -> std::sync::MutexGuard<'_, Counts> {
        // counters only: a panic elsewhere leaves them usable
        self.counts.lock().unwrap_or_else(|e| e.into_inner())
    }
    fn count(&self, add: impl FnOnce(&mut Traffic)) {
        let mut c = self.lock();
        let phase = c.phase;
        add(c.by_phase.entry(phase).or_default());
    }
}

impl Comm for Counted {
    fn rank(&self) -> usize {
        self.inner.rank()
    }
    fn size(&self) -> usize {
        self.inner.size()
    }
    fn exchange(&self, sends: &[(usize, Tag, &[u8])], receives: &[(usize, Tag)]) -> Vec<Vec<u8>> {
        self.count(|t| {
            t.exchanges += 1;
            t.messages += sends.len() as u64;
            t.bytes += sends.iter().map(|s| s.2.len() as u64).sum::<u64>();
        });
        self.inner.exchange(sends, receives)
    }
    fn sum_words(&self, words: &mut [i64]) {
        self.count(|t| {
            t.reductions += 1;
            t.reduced_words += words.len() as u64;
        });
        self.inner.sum_words(words)
    }
    fn gather_all(&self, mine: &[u8]) -> Vec<Vec<u8>> {
        self.count(|t| {
            t.gathers += 1;
            t.gathered_bytes += mine.len() as u64;
        });
        self.inner.gather_all(mine)
    }
    fn barrier(&self) {
        self.inner.barrier()
    }
    fn phase(&self, name: &'static str) {
        self.lock().phase = name;
    }
}

/// P ranks as threads of one process, with channels for messages: the tests of the
/// decomposition and the halo exchange run on it without MPI.
pub mod fake {
    use super::{Comm, Tag};
    use std::sync::mpsc::{channel, Receiver, Sender};
    use std::sync::Mutex;

    /// Tag of the collectives' messages (above every point-to-point tag a caller uses).
    const COLLECTIVE: u32 = 1 << 16;

    struct Message {
        from: usize,
        tag: u32,
        data: Vec<u8>,
    }

    struct Inbox {
        receiver: Receiver<Message>,
        /// Messages that arrived before the receive that wants them, in arrival order.
        early: Vec<Message>,
    }

    /// One rank of a [`world`].
    pub struct FakeComm {
        rank: usize,
        peers: Vec<Sender<Message>>,
        inbox: Mutex<Inbox>,
    }

    /// The P ranks of a world, rank r at index r.
    pub fn world(size: usize) -> Vec<FakeComm> {
        assert!(size > 0, "a world of 0 ranks");
        let (senders, receivers): (Vec<_>, Vec<_>) = (0..size).map(|_| channel()).unzip();
        receivers
            .into_iter()
            .enumerate()
            .map(|(rank, receiver)| FakeComm {
                rank,
                peers: senders.clone(),
                inbox: Mutex::new(Inbox { receiver, early: Vec::new() }),
            })
            .collect()
    }

    /// Runs `f` on each of P ranks, one thread each, and returns their results by rank.
    pub fn run<R: Send>(size: usize, f: impl Fn(&FakeComm) -> R + Sync) -> Vec<R> {
        let comms = world(size);
        std::thread::scope(|s| {
            let handles: Vec<_> = comms.iter().map(|c| s.spawn(|| f(c))).collect();
            handles.into_iter().map(|h| h.join().expect("a rank panicked")).collect()
        })
    }

    impl FakeComm {
        fn send(&self, to: usize, tag: u32, data: Vec<u8>) {
            self.peers[to].send(Message { from: self.rank, tag, data }).expect("the peer's thread ended");
        }
        /// The first message from `from` with `tag` (messages of one pair and tag keep their order).
        fn receive(&self, from: usize, tag: u32) -> Vec<u8> {
            let mut inbox = self.inbox.lock().expect("inbox");
            if let Some(k) = inbox.early.iter().position(|m| m.from == from && m.tag == tag) {
                return inbox.early.remove(k).data;
            }
            loop {
                let m = inbox.receiver.recv().expect("every peer's thread ended");
                if m.from == from && m.tag == tag {
                    return m.data;
                }
                inbox.early.push(m);
            }
        }
    }

    impl Comm for FakeComm {
        fn rank(&self) -> usize {
            self.rank
        }
        fn size(&self) -> usize {
            self.peers.len()
        }
        fn exchange(&self, sends: &[(usize, Tag, &[u8])], receives: &[(usize, Tag)]) -> Vec<Vec<u8>> {
            for &(to, tag, data) in sends {
                self.send(to, tag as u32, data.to_vec());
            }
            receives.iter().map(|&(from, tag)| self.receive(from, tag as u32)).collect()
        }
        fn sum_words(&self, words: &mut [i64]) {
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            let all = self.gather_all(&bytes);
            for (k, w) in words.iter_mut().enumerate() {
                *w = all.iter().map(|b| i64::from_le_bytes(b[8 * k..8 * k + 8].try_into().expect("8 bytes"))).sum();
            }
        }
        fn gather_all(&self, mine: &[u8]) -> Vec<Vec<u8>> {
            for to in 0..self.size() {
                self.send(to, COLLECTIVE, mine.to_vec());
            }
            (0..self.size()).map(|from| self.receive(from, COLLECTIVE)).collect()
        }
        fn barrier(&self) {
            self.gather_all(&[]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::ExactSum;

    /// The counters see a halo exchange's messages and bytes as the halo's size gives
    /// them, and every collective once on each rank.
    #[cfg(feature = "dim2")]
    #[test]
    fn counted_traffic_is_the_halo_and_the_collectives() {
        use crate::decomposition::RankGrid;
        use crate::grid::Lattice;
        use crate::halo::{exchange, storage_shape, Layout};
        use std::sync::Arc;
        // 64 × 16 cells, periodic along y only, on 2 × 1 ranks: one neighbour along x each
        let grid = RankGrid::new([64, 16], [false, true], 2, Some([2, 1])).unwrap();
        let traffic: Vec<Traffic> = std::thread::scope(|s| {
            let ranks: Vec<_> = fake::world(2)
                .into_iter()
                .map(|c| {
                    let grid = &grid;
                    s.spawn(move || {
                        let comm = Counted::new(Arc::new(c));
                        let block = grid.block(comm.rank());
                        let mut cells = vec![1.0; storage_shape(&block, Layout::Local, Lattice::Cell).iter().product()];
                        exchange(&comm, &block, Layout::Local, &mut [(Lattice::Cell, &mut cells)]);
                        comm.sum_words(&mut [1, 2, 3]);
                        comm.max(&mut [1.0]);
                        comm.traffic()
                    })
                })
                .collect();
            ranks.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for t in traffic {
            // one message to the neighbour along x: H = 2 columns of the 16 rows, 8 bytes
            // each; the maximum gathers one value of 8 bytes from each rank
            let expected = Traffic {
                messages: 1,
                bytes: 2 * 16 * 8,
                exchanges: 1,
                reductions: 1,
                reduced_words: 3,
                gathers: 1,
                gathered_bytes: 8,
            };
            assert_eq!(t, expected);
        }
    }

    #[test]
    fn serial_collectives_are_the_identity() {
        let s = Serial;
        let mut w = [3, -4];
        s.sum_words(&mut w);
        assert_eq!(w, [3, -4]);
        let mut v = [1.5, f64::NAN];
        s.max(&mut v);
        assert_eq!(v[0], 1.5);
        assert!(s.any(true) && !s.any(false));
        assert_eq!(s.gather_all(b"ab"), vec![b"ab".to_vec()]);
        let got = s.exchange(&[(0, 1, b"high"), (0, 0, b"low")], &[(0, 0), (0, 1)]);
        assert_eq!(got, vec![b"low".to_vec(), b"high".to_vec()]);
    }

    /// An exact sum of terms split across 1–7 fake ranks has the serial sum's bits: the
    /// terms are chosen so that a naive floating-point sum depends on the order (1e16 and
    /// units), so a wrong merge would show.
    #[test]
    fn exact_sum_across_fake_ranks_has_the_serial_bits() {
        let terms: Vec<f64> = (0..1000)
            .map(|k| match k % 4 {
                0 => 1e16,
                1 => 1.0 + k as f64 * 1e-3,
                2 => -1e16,
                _ => 0.1 * k as f64,
            })
            .collect();
        let mut serial = ExactSum::new();
        terms.iter().for_each(|&t| serial.add(t));
        let expected = serial.round();
        assert_ne!(expected, terms.iter().sum::<f64>(), "the naive sum must differ for the test to mean anything");
        for p in 1..=7 {
            let sums = fake::run(p, |c| {
                let mut s = ExactSum::new();
                terms.iter().skip(c.rank()).step_by(c.size()).for_each(|&t| s.add(t));
                let mut w = s.words();
                c.sum_words(&mut w);
                ExactSum::from_words(&w).round()
            });
            for s in sums {
                assert_eq!(s.to_bits(), expected.to_bits(), "{p} ranks");
            }
        }
    }

    #[test]
    fn fake_collectives_agree_on_every_rank() {
        for p in 1..=5 {
            let out = fake::run(p, |c| {
                let r = c.rank() as f64;
                let mut mx = [r, -r, if c.rank() == 0 { f64::NAN } else { r }];
                c.max(&mut mx);
                let mut mn = [r, -r];
                c.min(&mut mn);
                let any = c.any(c.rank() == p - 1);
                let none = c.any(false);
                let gathered = c.gather_all_f64(&vec![r; c.rank() + 1]);
                c.barrier();
                (mx, mn, any, none, gathered)
            });
            let top = (p - 1) as f64;
            for (mx, mn, any, none, gathered) in out {
                assert_eq!(mx[..2], [top, 0.0]);
                // rank 0's NaN loses against the other ranks' numbers (f64::max); alone it stays
                if p > 1 {
                    assert_eq!(mx[2], top);
                } else {
                    assert!(mx[2].is_nan());
                }
                assert_eq!(mn, [0.0, -top]);
                assert!(any && !none);
                assert_eq!(gathered.len(), p);
                for (r, g) in gathered.iter().enumerate() {
                    assert_eq!(g, &vec![r as f64; r + 1]);
                }
            }
        }
    }

    /// Two ranks that are each other's neighbour on both sides of a ring tell the two
    /// messages apart by their tags; a rank may send to itself.
    #[test]
    fn fake_exchange_matches_by_peer_and_tag() {
        for p in 1..=4 {
            let out = fake::run(p, |c| {
                let (r, n) = (c.rank(), c.size());
                let (left, right) = ((r + n - 1) % n, (r + 1) % n);
                let to_right = format!("{r}>");
                let to_left = format!("<{r}");
                c.exchange(&[(right, 1, to_right.as_bytes()), (left, 0, to_left.as_bytes())], &[(left, 1), (right, 0)])
            });
            for (r, got) in out.iter().enumerate() {
                let (left, right) = ((r + p - 1) % p, (r + 1) % p);
                assert_eq!(got[0], format!("{left}>").into_bytes());
                assert_eq!(got[1], format!("<{right}").into_bytes());
            }
        }
    }
}
