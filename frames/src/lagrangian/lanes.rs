//! Four f64 lanes for the collocated grid's transfers (one material point or one node per
//! lane): the few operations its kernel needs, written once in `collocated.rs` over the
//! [`Lanes`] trait and compiled twice, for [`Portable`] (plain Rust on `[f64; 4]`, any CPU)
//! and, on x86-64, for [`AvxFma`] (one AVX register, with FMA), whose impl is the only place
//! with intrinsics. Both give the same bits: each operation is the same IEEE operation per
//! lane (`mul_add` is fused in both, `max`/`min`/`select` have the same rule for NaN).
//!
//! A lane value can only be made through its token (`Lanes::splat`, `load`, `pairs`), and
//! the AVX token only exists where the CPU has AVX and FMA (`AvxFma::detect`): that is
//! what makes the AVX impl's operators safe.
use multifield_core::math::Real;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};

/// What the quadratic B-spline needs of a number: arithmetic and truncation toward zero
/// of a small value (|x| < 2³¹). `f64` and the lanes of [`Lanes`] have it.
pub trait Arith: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self> {
    /// `x` truncated toward zero (|x| < 2³¹), as a float.
    fn trunc_small(self) -> Self;
    /// The constant `c` as a number of this kind (in every lane).
    fn splat_as(self, c: Real) -> Self;
}

impl Arith for Real {
    #[inline(always)]
    fn trunc_small(self) -> Real {
        self as i64 as Real
    }
    #[inline(always)]
    fn splat_as(self, c: Real) -> Real {
        c
    }
}

/// Four f64 lanes.
pub trait Lane: Arith + Div<Output = Self> {
    /// Per-lane truth values of a comparison.
    type Mask: Copy + BitAnd<Output = Self::Mask> + BitOr<Output = Self::Mask>;
    /// `self · b + c`, fused (one rounding).
    fn mul_add(self, b: Self, c: Self) -> Self;
    /// `self > o ? self : o` per lane (`o` where either is NaN).
    fn max(self, o: Self) -> Self;
    /// `self < o ? self : o` per lane (`o` where either is NaN).
    fn min(self, o: Self) -> Self;
    /// `self < o` per lane (false for NaN).
    fn lt(self, o: Self) -> Self::Mask;
    /// `self > o` per lane (false for NaN).
    fn gt(self, o: Self) -> Self::Mask;
    /// `m` and not `self`, per lane.
    fn and_not(m: Self::Mask, not: Self::Mask) -> Self::Mask;
    /// `yes` where `m`, else `no`, per lane.
    fn select(m: Self::Mask, yes: Self, no: Self) -> Self;
    /// The lanes as an array.
    fn to_array(self) -> [Real; 4];
    /// The lanes into `to`.
    fn store(self, to: &mut [Real; 4]);
    /// The inverse of [`Lanes::pairs`]: lane l of `a` and of `b` into `to[l]`.
    fn unpairs(a: Self, b: Self, to: [&mut [Real; 2]; 4]);
    /// The 4 × 4 transpose: lane l of `r[k]` to lane k of the result's `l`.
    fn transpose4(r: [Self; 4]) -> [Self; 4];
}

/// A kind of lanes (a token: the AVX one exists only where the CPU has it).
pub trait Lanes: Copy {
    /// Its four lanes.
    type V: Lane;
    /// `x` in every lane.
    fn splat(self, x: Real) -> Self::V;
    /// Four numbers into the lanes.
    fn load(self, a: &[Real; 4]) -> Self::V;
    /// Four numbers anywhere into the lanes.
    fn gather(self, p: [&Real; 4]) -> Self::V;
    /// Four pairs as the lanes of their first and of their second entries.
    fn pairs(self, p: [&[Real; 2]; 4]) -> (Self::V, Self::V);
}

/// Plain Rust lanes: any CPU.
#[derive(Clone, Copy, Debug)]
pub struct Portable;

/// Four f64 of the portable lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct P4(pub [Real; 4]);

impl P4 {
    #[inline(always)]
    fn map(self, o: P4, f: impl Fn(Real, Real) -> Real) -> P4 {
        P4([f(self.0[0], o.0[0]), f(self.0[1], o.0[1]), f(self.0[2], o.0[2]), f(self.0[3], o.0[3])])
    }
}

macro_rules! p4_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for P4 {
            type Output = P4;
            #[inline(always)]
            fn $f(self, o: P4) -> P4 {
                self.map(o, |a, b| a $op b)
            }
        }
    };
}
p4_op!(Add, add, +);
p4_op!(Sub, sub, -);
p4_op!(Mul, mul, *);
p4_op!(Div, div, /);

impl Neg for P4 {
    type Output = P4;
    #[inline(always)]
    fn neg(self) -> P4 {
        P4(self.0.map(|a| -a))
    }
}

impl Arith for P4 {
    #[inline(always)]
    fn trunc_small(self) -> P4 {
        P4(self.0.map(Real::trunc_small))
    }
    #[inline(always)]
    fn splat_as(self, c: Real) -> P4 {
        P4([c; 4])
    }
}

/// Four truth values.
#[derive(Clone, Copy, Debug)]
pub struct B4([bool; 4]);

impl BitAnd for B4 {
    type Output = B4;
    #[inline(always)]
    fn bitand(self, o: B4) -> B4 {
        B4([self.0[0] & o.0[0], self.0[1] & o.0[1], self.0[2] & o.0[2], self.0[3] & o.0[3]])
    }
}

impl BitOr for B4 {
    type Output = B4;
    #[inline(always)]
    fn bitor(self, o: B4) -> B4 {
        B4([self.0[0] | o.0[0], self.0[1] | o.0[1], self.0[2] | o.0[2], self.0[3] | o.0[3]])
    }
}

impl Lane for P4 {
    type Mask = B4;
    #[inline(always)]
    fn mul_add(self, b: P4, c: P4) -> P4 {
        P4([0, 1, 2, 3].map(|l| self.0[l].mul_add(b.0[l], c.0[l])))
    }
    #[inline(always)]
    fn max(self, o: P4) -> P4 {
        self.map(o, |a, b| if a > b { a } else { b })
    }
    #[inline(always)]
    fn min(self, o: P4) -> P4 {
        self.map(o, |a, b| if a < b { a } else { b })
    }
    #[inline(always)]
    fn lt(self, o: P4) -> B4 {
        B4([0, 1, 2, 3].map(|l| self.0[l] < o.0[l]))
    }
    #[inline(always)]
    fn gt(self, o: P4) -> B4 {
        B4([0, 1, 2, 3].map(|l| self.0[l] > o.0[l]))
    }
    #[inline(always)]
    fn and_not(m: B4, not: B4) -> B4 {
        B4([0, 1, 2, 3].map(|l| m.0[l] && !not.0[l]))
    }
    #[inline(always)]
    fn select(m: B4, yes: P4, no: P4) -> P4 {
        P4([0, 1, 2, 3].map(|l| if m.0[l] { yes.0[l] } else { no.0[l] }))
    }
    #[inline(always)]
    fn to_array(self) -> [Real; 4] {
        self.0
    }
    #[inline(always)]
    fn store(self, to: &mut [Real; 4]) {
        *to = self.0;
    }
    #[inline(always)]
    fn unpairs(a: P4, b: P4, to: [&mut [Real; 2]; 4]) {
        for (l, t) in to.into_iter().enumerate() {
            *t = [a.0[l], b.0[l]];
        }
    }
    #[inline(always)]
    fn transpose4(r: [P4; 4]) -> [P4; 4] {
        [0, 1, 2, 3].map(|l| P4([r[0].0[l], r[1].0[l], r[2].0[l], r[3].0[l]]))
    }
}

impl Lanes for Portable {
    type V = P4;
    #[inline(always)]
    fn splat(self, x: Real) -> P4 {
        P4([x; 4])
    }
    #[inline(always)]
    fn load(self, a: &[Real; 4]) -> P4 {
        P4(*a)
    }
    #[inline(always)]
    fn gather(self, p: [&Real; 4]) -> P4 {
        P4([*p[0], *p[1], *p[2], *p[3]])
    }
    #[inline(always)]
    fn pairs(self, p: [&[Real; 2]; 4]) -> (P4, P4) {
        (P4([p[0][0], p[1][0], p[2][0], p[3][0]]), P4([p[0][1], p[1][1], p[2][1], p[3][1]]))
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx::{AvxFma, A4};

#[cfg(target_arch = "x86_64")]
mod avx {
    //! The AVX lanes. Every `unsafe` here calls AVX or FMA intrinsics, which is sound
    //! because an `A4` only exists where an `AvxFma` was made, and `AvxFma::detect` makes
    //! one only on a CPU with AVX and FMA. The functions are inlined into the kernel's
    //! `#[target_feature(enable = "avx,fma")]` instances, where they become instructions.
    use super::{Arith, Lane, Lanes};
    use multifield_core::math::Real;
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};

    /// The token of the AVX lanes (with FMA).
    #[derive(Clone, Copy, Debug)]
    pub struct AvxFma(());

    impl AvxFma {
        /// The token, where the CPU has AVX and FMA.
        pub fn detect() -> Option<AvxFma> {
            (is_x86_feature_detected!("avx") && is_x86_feature_detected!("fma")).then_some(AvxFma(()))
        }
    }

    /// Four f64 in an AVX register.
    #[derive(Clone, Copy, Debug)]
    pub struct A4(__m256d);

    macro_rules! a4_op {
        ($tr:ident, $f:ident, $intr:ident) => {
            impl $tr for A4 {
                type Output = A4;
                #[inline(always)]
                fn $f(self, o: A4) -> A4 {
                    A4(unsafe { $intr(self.0, o.0) })
                }
            }
        };
    }
    a4_op!(Add, add, _mm256_add_pd);
    a4_op!(Sub, sub, _mm256_sub_pd);
    a4_op!(Mul, mul, _mm256_mul_pd);
    a4_op!(Div, div, _mm256_div_pd);

    impl Neg for A4 {
        type Output = A4;
        #[inline(always)]
        fn neg(self) -> A4 {
            A4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
        }
    }

    impl Arith for A4 {
        #[inline(always)]
        fn trunc_small(self) -> A4 {
            A4(unsafe { _mm256_cvtepi32_pd(_mm256_cvttpd_epi32(self.0)) })
        }
        #[inline(always)]
        fn splat_as(self, c: Real) -> A4 {
            A4(unsafe { _mm256_set1_pd(c) })
        }
    }

    /// Four comparison results (all ones or all zeros per lane).
    #[derive(Clone, Copy, Debug)]
    pub struct M4(__m256d);

    impl BitAnd for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitand(self, o: M4) -> M4 {
            M4(unsafe { _mm256_and_pd(self.0, o.0) })
        }
    }

    impl BitOr for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitor(self, o: M4) -> M4 {
            M4(unsafe { _mm256_or_pd(self.0, o.0) })
        }
    }

    impl Lane for A4 {
        type Mask = M4;
        #[inline(always)]
        fn mul_add(self, b: A4, c: A4) -> A4 {
            A4(unsafe { _mm256_fmadd_pd(self.0, b.0, c.0) })
        }
        #[inline(always)]
        fn max(self, o: A4) -> A4 {
            A4(unsafe { _mm256_max_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn min(self, o: A4) -> A4 {
            A4(unsafe { _mm256_min_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: A4) -> M4 {
            M4(unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn gt(self, o: A4) -> M4 {
            M4(unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn and_not(m: M4, not: M4) -> M4 {
            M4(unsafe { _mm256_andnot_pd(not.0, m.0) })
        }
        #[inline(always)]
        fn select(m: M4, yes: A4, no: A4) -> A4 {
            A4(unsafe { _mm256_blendv_pd(no.0, yes.0, m.0) })
        }
        #[inline(always)]
        fn to_array(self) -> [Real; 4] {
            let mut out = [0.0; 4];
            self.store(&mut out);
            out
        }
        #[inline(always)]
        fn store(self, to: &mut [Real; 4]) {
            unsafe { _mm256_storeu_pd(to.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn unpairs(a: A4, b: A4, to: [&mut [Real; 2]; 4]) {
            unsafe {
                let (lo, hi) = (_mm256_unpacklo_pd(a.0, b.0), _mm256_unpackhi_pd(a.0, b.0));
                let [t0, t1, t2, t3] = to;
                _mm_storeu_pd(t0.as_mut_ptr(), _mm256_castpd256_pd128(lo));
                _mm_storeu_pd(t1.as_mut_ptr(), _mm256_castpd256_pd128(hi));
                _mm_storeu_pd(t2.as_mut_ptr(), _mm256_extractf128_pd::<1>(lo));
                _mm_storeu_pd(t3.as_mut_ptr(), _mm256_extractf128_pd::<1>(hi));
            }
        }
        #[inline(always)]
        fn transpose4(r: [A4; 4]) -> [A4; 4] {
            unsafe {
                let (t0, t1) = (_mm256_unpacklo_pd(r[0].0, r[1].0), _mm256_unpackhi_pd(r[0].0, r[1].0));
                let (t2, t3) = (_mm256_unpacklo_pd(r[2].0, r[3].0), _mm256_unpackhi_pd(r[2].0, r[3].0));
                [
                    A4(_mm256_permute2f128_pd::<0x20>(t0, t2)),
                    A4(_mm256_permute2f128_pd::<0x20>(t1, t3)),
                    A4(_mm256_permute2f128_pd::<0x31>(t0, t2)),
                    A4(_mm256_permute2f128_pd::<0x31>(t1, t3)),
                ]
            }
        }
    }

    impl Lanes for AvxFma {
        type V = A4;
        #[inline(always)]
        fn splat(self, x: Real) -> A4 {
            A4(unsafe { _mm256_set1_pd(x) })
        }
        #[inline(always)]
        fn load(self, a: &[Real; 4]) -> A4 {
            A4(unsafe { _mm256_loadu_pd(a.as_ptr()) })
        }
        #[inline(always)]
        fn gather(self, p: [&Real; 4]) -> A4 {
            A4(unsafe { _mm256_set_pd(*p[3], *p[2], *p[1], *p[0]) })
        }
        #[inline(always)]
        fn pairs(self, p: [&[Real; 2]; 4]) -> (A4, A4) {
            unsafe {
                let v02 = _mm256_set_m128d(_mm_loadu_pd(p[2].as_ptr()), _mm_loadu_pd(p[0].as_ptr()));
                let v13 = _mm256_set_m128d(_mm_loadu_pd(p[3].as_ptr()), _mm_loadu_pd(p[1].as_ptr()));
                (A4(_mm256_unpacklo_pd(v02, v13)), A4(_mm256_unpackhi_pd(v02, v13)))
            }
        }
    }
}
