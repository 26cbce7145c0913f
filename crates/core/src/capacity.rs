//! Capacity classes: the solvers' fixed-size buffers come in a few sizes,
//! chosen at run time by the instance's node count.
//!
//! A class is `W` 64-bit words of node set, so `64 · W` nodes. Every type
//! that holds per-node state ([`NodeSet`], [`PerNode`],
//! [`crate::problem::Problem`], [`crate::route::Route`], the decoder and the
//! solvers) takes the class as a `const W: usize` parameter, defaulting to
//! [`DEFAULT_WORDS`] (128 nodes, the paper's study and most tests). Code for
//! each class is compiled separately, so a 40-node problem runs on buffers
//! and loops sized for 64 or 128 nodes, never for 512.
//!
//! [`Class::for_nodes`] is the one place that picks a class; the
//! [`with_class!`](crate::with_class) macro runs generic code on the class
//! it picked.

use core::ops::{BitAnd, BitAndAssign, BitOr, BitOrAssign, Deref, DerefMut, Not, Sub};

/// Words of the default class (128 nodes): the default of every generic type
/// (the Monte Carlo study and most tests run it; the service and the solve
/// commands pick a class by the network's size).
pub const DEFAULT_WORDS: usize = 2;

/// Words of the largest class this build supports.
pub const LARGEST_WORDS: usize = 8;

/// Nodes of the largest class this build supports.
pub const LARGEST_NODES: usize = nodes_of(LARGEST_WORDS);

/// Nodes a class of `W` words holds.
#[inline(always)]
pub const fn nodes_of(words: usize) -> usize {
    64 * words
}

/// Low bits of a decoder key (and of the repair's A* key) that carry a node
/// id for a class of `words` words: 7 up to 128 nodes (so the 64 and 128
/// classes compare priorities at the same precision and give the same
/// routes), else enough for every id.
#[inline(always)]
pub const fn id_bits(words: usize) -> u32 {
    let n = nodes_of(words);
    if n <= 128 { 7 } else { n.trailing_zeros() }
}

/// A capacity class the build supports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Up to 64 nodes.
    N64,
    /// Up to 128 nodes.
    N128,
    /// Up to 256 nodes.
    N256,
    /// Up to 512 nodes.
    N512,
}

/// More nodes than the largest class holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0} nodes exceed the planner's largest capacity class of {LARGEST_NODES}")]
pub struct TooManyNodes(pub usize);

impl Class {
    /// Every class, smallest first.
    pub const ALL: [Self; 4] = [Self::N64, Self::N128, Self::N256, Self::N512];

    /// The smallest class that holds `n` nodes.
    pub fn for_nodes(n: usize) -> Result<Self, TooManyNodes> {
        Self::ALL.into_iter().find(|c| n <= c.nodes()).ok_or(TooManyNodes(n))
    }

    /// Words of node set.
    pub const fn words(self) -> usize {
        match self {
            Self::N64 => 1,
            Self::N128 => 2,
            Self::N256 => 4,
            Self::N512 => 8,
        }
    }

    /// Nodes the class holds.
    pub const fn nodes(self) -> usize {
        nodes_of(self.words())
    }
}

/// Runs `$body` with the const `$w` bound to the words of `$class` (a
/// [`Class`]): `with_class!(class, W => solve::<W>(&inst))`. Every arm is
/// compiled, one per class.
#[macro_export]
macro_rules! with_class {
    ($class:expr, $w:ident => $body:expr) => {
        match $class {
            $crate::capacity::Class::N64 => {
                const $w: usize = 1;
                $body
            }
            $crate::capacity::Class::N128 => {
                const $w: usize = 2;
                $body
            }
            $crate::capacity::Class::N256 => {
                const $w: usize = 4;
                $body
            }
            $crate::capacity::Class::N512 => {
                const $w: usize = 8;
                $body
            }
        }
    };
}

/// A set of node ids below `64 · W`, one bit per node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct NodeSet<const W: usize = DEFAULT_WORDS>(pub [u64; W]);

impl<const W: usize> Default for NodeSet<W> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<const W: usize> NodeSet<W> {
    /// The empty set.
    pub const EMPTY: Self = Self([0; W]);
    /// Every id of the class.
    pub const FULL: Self = Self([u64::MAX; W]);

    /// Ids 0..n (n ≤ 64 · W).
    #[inline]
    pub fn first(n: usize) -> Self {
        let mut s = Self::EMPTY;
        for (w, word) in s.0.iter_mut().enumerate() {
            let lo = 64 * w;
            *word = if n >= lo + 64 {
                u64::MAX
            } else if n > lo {
                (1u64 << (n - lo)) - 1
            } else {
                0
            };
        }
        s
    }

    /// The set holding only `i`.
    #[inline]
    pub fn single(i: usize) -> Self {
        let mut s = Self::EMPTY;
        s.insert(i);
        s
    }

    /// Adds `i`.
    #[inline]
    pub fn insert(&mut self, i: usize) {
        self.0[i >> 6] |= 1u64 << (i & 63);
    }

    /// Removes `i`.
    #[inline]
    pub fn remove(&mut self, i: usize) {
        self.0[i >> 6] &= !(1u64 << (i & 63));
    }

    /// Whether `i` is in the set.
    #[inline]
    pub fn contains(self, i: usize) -> bool {
        self.0[i >> 6] >> (i & 63) & 1 == 1
    }

    /// Number of members.
    #[inline]
    pub fn len(self) -> u32 {
        self.0.iter().map(|w| w.count_ones()).sum()
    }

    /// Whether the set is empty.
    #[inline]
    pub fn is_empty(self) -> bool {
        self.0.iter().all(|&w| w == 0)
    }

    /// Members in increasing order.
    #[inline]
    pub fn iter(self) -> impl Iterator<Item = usize> {
        let mut word = 0;
        let mut bits = if W > 0 { self.0[0] } else { 0 };
        core::iter::from_fn(move || {
            while bits == 0 {
                word += 1;
                if word >= W {
                    return None;
                }
                bits = self.0[word];
            }
            let i = 64 * word + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            Some(i)
        })
    }

    /// The least member ≥ `from`, if any.
    #[inline]
    pub fn first_from(self, from: usize) -> Option<usize> {
        let mut word = from >> 6;
        if word >= W {
            return None;
        }
        let mut bits = self.0[word] & (u64::MAX << (from & 63));
        loop {
            if bits != 0 {
                return Some(64 * word + bits.trailing_zeros() as usize);
            }
            word += 1;
            if word >= W {
                return None;
            }
            bits = self.0[word];
        }
    }

    /// The membership bits of ids `from..from + 8`, lowest id in bit 0
    /// (ids past the set's capacity read as absent).
    #[inline(always)]
    pub fn octet_from(self, from: usize) -> u8 {
        let (word, shift) = (from >> 6, from & 63);
        if word >= W {
            return 0;
        }
        let mut bits = self.0[word] >> shift;
        if shift > 56 && word + 1 < W {
            bits |= self.0[word + 1] << (64 - shift);
        }
        bits as u8
    }

    /// The 16 membership bits of ids `base..base + 16` (`base` a multiple
    /// of 16 below 64 · W), lowest id in bit 0.
    #[inline(always)]
    pub fn block16(self, base: usize) -> u16 {
        (self.0[base >> 6] >> (base & 63)) as u16
    }
}

impl<const W: usize> BitAnd for NodeSet<W> {
    type Output = Self;
    #[inline]
    fn bitand(mut self, rhs: Self) -> Self {
        self &= rhs;
        self
    }
}

impl<const W: usize> BitAndAssign for NodeSet<W> {
    #[inline]
    fn bitand_assign(&mut self, rhs: Self) {
        for (a, b) in self.0.iter_mut().zip(rhs.0) {
            *a &= b;
        }
    }
}

impl<const W: usize> BitOr for NodeSet<W> {
    type Output = Self;
    #[inline]
    fn bitor(mut self, rhs: Self) -> Self {
        self |= rhs;
        self
    }
}

impl<const W: usize> BitOrAssign for NodeSet<W> {
    #[inline]
    fn bitor_assign(&mut self, rhs: Self) {
        for (a, b) in self.0.iter_mut().zip(rhs.0) {
            *a |= b;
        }
    }
}

impl<const W: usize> Not for NodeSet<W> {
    type Output = Self;
    #[inline]
    fn not(mut self) -> Self {
        for a in &mut self.0 {
            *a = !*a;
        }
        self
    }
}

/// Set difference: members of `self` not in `rhs`.
impl<const W: usize> Sub for NodeSet<W> {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        self & !rhs
    }
}

/// One `T` per node of a class of `W` words (`64 · W` values), used as a
/// slice. Stored as `W` rows of 64 so the length follows from `W` without
/// const arithmetic in the type.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(transparent)]
pub struct PerNode<T, const W: usize>(pub [[T; 64]; W]);

impl<T: Copy, const W: usize> PerNode<T, W> {
    /// Every entry `x`.
    pub const fn splat(x: T) -> Self {
        Self([[x; 64]; W])
    }
}

impl<T, const W: usize> Deref for PerNode<T, W> {
    type Target = [T];
    #[inline(always)]
    fn deref(&self) -> &[T] {
        self.0.as_flattened()
    }
}

impl<T, const W: usize> DerefMut for PerNode<T, W> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        self.0.as_flattened_mut()
    }
}

impl<'a, T, const W: usize> IntoIterator for &'a PerNode<T, W> {
    type Item = &'a T;
    type IntoIter = core::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<'a, T, const W: usize> IntoIterator for &'a mut PerNode<T, W> {
    type Item = &'a mut T;
    type IntoIter = core::slice::IterMut<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter_mut()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    impl<const W: usize> NodeSet<W> {
        fn contains_checked(self, id: usize) -> bool {
            id < nodes_of(W) && self.contains(id)
        }
    }

    fn basics<const W: usize>() {
        let top = nodes_of(W) - 1;
        let mut s = NodeSet::<W>::EMPTY;
        s.insert(0);
        s.insert(top);
        s.insert(5);
        assert_eq!(s.iter().collect::<Vec<_>>(), vec![0, 5, top]);
        s.remove(5);
        assert!(!s.contains(5) && s.contains(top));
        assert_eq!(s.len(), 2);
        assert_eq!(NodeSet::<W>::first(nodes_of(W)), NodeSet::FULL);
        assert_eq!(NodeSet::<W>::first(0), NodeSet::EMPTY);
        let f = NodeSet::<W>::first(top);
        assert_eq!(f.len() as usize, top);
        assert!(!f.contains(top) && f.contains(top - 1));
        assert_eq!((f - s).len() as usize, top - 1);
        assert_eq!((f & s).iter().collect::<Vec<_>>(), vec![0]);
        assert_eq!((f | s), NodeSet::FULL);
        assert_eq!(NodeSet::<W>::single(top).block16(nodes_of(W) - 16), 1 << 15);
        // Octets at every offset, across word boundaries and past the end.
        let mut odd = NodeSet::<W>::EMPTY;
        for id in (1..nodes_of(W)).step_by(3) {
            odd.insert(id);
        }
        for from in 0..nodes_of(W) + 8 {
            let want = (0..8)
                .filter(|k| odd.contains_checked(from + k))
                .fold(0u8, |o, k| o | 1 << k);
            assert_eq!(odd.octet_from(from), want, "from {from}");
        }
        let p = PerNode::<u16, W>::splat(3);
        assert_eq!(p.len(), nodes_of(W));
        assert!(p.iter().all(|&x| x == 3));
    }

    #[test]
    fn node_sets_work_in_every_class() {
        basics::<1>();
        basics::<2>();
        basics::<4>();
        basics::<8>();
    }

    #[test]
    fn the_smallest_class_that_fits_is_picked() {
        assert_eq!(Class::for_nodes(2), Ok(Class::N64));
        assert_eq!(Class::for_nodes(64), Ok(Class::N64));
        assert_eq!(Class::for_nodes(65), Ok(Class::N128));
        assert_eq!(Class::for_nodes(129), Ok(Class::N256));
        assert_eq!(Class::for_nodes(401), Ok(Class::N512));
        assert_eq!(Class::for_nodes(512), Ok(Class::N512));
        assert_eq!(Class::for_nodes(513), Err(TooManyNodes(513)));
        let n = with_class!(Class::N256, W => nodes_of(W));
        assert_eq!(n, 256);
    }

    #[test]
    fn ids_keep_seven_bits_up_to_128_nodes() {
        assert_eq!([id_bits(1), id_bits(2), id_bits(4), id_bits(8)], [7, 7, 8, 9]);
    }
}
