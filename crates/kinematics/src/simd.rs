//! Four `f64` lanes in one 256-bit AVX register ([`F64x4`]) and eight in
//! one 512-bit AVX-512 register ([`F64x8`]), with the same operations, for
//! the kernels that run the same arithmetic on several contacts at once
//! ([`crate::forward_batch`]). What follows says it of [`F64x4`] and AVX2;
//! [`F64x8`] is the same with AVX-512F ([`avx512_available`]).
//!
//! The operations are the AVX instructions themselves (`core::arch`
//! intrinsics, each inlined into its caller), which are only sound on a
//! machine with AVX. A value is its own proof of that: the only
//! constructors, [`F64x4::splat`] and [`F64x4::new`], are compiled for
//! AVX2 (`#[target_feature]`), so that code can call them only from a
//! function compiled for AVX2 or in an `unsafe` block whose caller checked
//! [`avx2_available`]; every other value (and every [`Mask4`]) comes from
//! operations on such values. The kernels themselves are compiled for
//! AVX2 too, which is what inlines the operations into single instructions.
//! Each lane is computed with the IEEE operations of the scalar code, in
//! the same order: no fused multiply-add (Rust never contracts
//! `a * b + c`), so that the lanes give the scalar code's bits wherever
//! they follow the same formula.

#![allow(
    unsafe_code,
    reason = "SIMD intrinsics on values that exist only on a machine with their instructions (module docs)"
)]

use std::arch::x86_64::{
    __m256d, __m512d, __mmask8, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ,
    _CMP_UNORD_Q, _mm256_add_pd, _mm256_and_pd, _mm256_andnot_pd, _mm256_blendv_pd, _mm256_cmp_pd,
    _mm256_div_pd, _mm256_loadu_pd, _mm256_max_pd, _mm256_min_pd, _mm256_movemask_pd,
    _mm256_mul_pd, _mm256_or_pd, _mm256_set1_pd, _mm256_sqrt_pd, _mm256_sub_pd, _mm256_xor_pd,
    _mm512_abs_pd, _mm512_add_pd, _mm512_castpd_si512, _mm512_castsi512_pd, _mm512_cmp_pd_mask,
    _mm512_div_pd, _mm512_loadu_pd, _mm512_mask_blend_pd, _mm512_max_pd, _mm512_min_pd,
    _mm512_mul_pd, _mm512_set1_epi64, _mm512_set1_pd, _mm512_sqrt_pd, _mm512_sub_pd,
    _mm512_xor_si512,
};
use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Mul, Neg, Sub, SubAssign};

/// Four `f64` lanes.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct F64x4(__m256d);

/// A lane-wise comparison's outcome: every bit set in a true lane, none in
/// a false one.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Mask4(__m256d);

impl F64x4 {
    /// `value` in every lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn splat(value: f64) -> Self {
        Self(_mm256_set1_pd(value))
    }

    /// Lane `l` is `values[l]`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn new(values: [f64; 4]) -> Self {
        // SAFETY: `values` is four readable `f64`.
        Self(unsafe { _mm256_loadu_pd(values.as_ptr()) })
    }

    /// The lanes in memory order.
    #[inline(always)]
    pub(crate) fn as_array(&self) -> &[f64; 4] {
        // SAFETY: `F64x4` is an `__m256d`, four `f64` in lane order.
        unsafe { &*std::ptr::from_ref(self).cast::<[f64; 4]>() }
    }

    #[inline(always)]
    pub(crate) fn sqrt(self) -> Self {
        // SAFETY: AVX code on an existing value (module documentation).
        Self(unsafe { _mm256_sqrt_pd(self.0) })
    }

    /// `|x|` (the sign bit cleared).
    #[inline(always)]
    pub(crate) fn abs(self) -> Self {
        // SAFETY: AVX code on an existing value (module documentation).
        Self(unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), self.0) })
    }

    /// The larger of each pair; `other` where either is NaN (`maxpd`).
    #[inline(always)]
    pub(crate) fn max(self, other: Self) -> Self {
        // SAFETY: AVX code on an existing value (module documentation).
        Self(unsafe { _mm256_max_pd(self.0, other.0) })
    }

    /// The smaller of each pair; `other` where either is NaN (`minpd`).
    #[inline(always)]
    pub(crate) fn min(self, other: Self) -> Self {
        // SAFETY: AVX code on an existing value (module documentation).
        Self(unsafe { _mm256_min_pd(self.0, other.0) })
    }

    #[inline(always)]
    pub(crate) fn is_nan(self) -> Mask4 {
        // SAFETY: AVX code on an existing value (module documentation).
        Mask4(unsafe { _mm256_cmp_pd::<_CMP_UNORD_Q>(self.0, self.0) })
    }

    /// Neither infinite nor NaN.
    #[inline(always)]
    pub(crate) fn is_finite(self) -> Mask4 {
        // SAFETY: AVX code on an existing value (module documentation).
        Mask4(unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(self.abs().0, _mm256_set1_pd(f64::INFINITY)) })
    }
}

/// Lane-wise comparisons, false where either side is NaN (ordered,
/// quiet: the predicates of `cmppd`).
macro_rules! comparisons {
    ($type:ident, $mask:ident, $intrinsic:ident) => {
        comparisons!($type, $mask, $intrinsic,
            lt: _CMP_LT_OQ, le: _CMP_LE_OQ, ge: _CMP_GE_OQ, gt: _CMP_GT_OQ, eq: _CMP_EQ_OQ);
    };
    ($type:ident, $mask:ident, $intrinsic:ident, $($name:ident: $predicate:ident),*) => {
        impl $type {
            $(
                #[inline(always)]
                pub(crate) fn $name(self, other: Self) -> $mask {
                    // SAFETY: SIMD code on existing values (module documentation).
                    $mask(unsafe { $intrinsic::<$predicate>(self.0, other.0) })
                }
            )*
        }
    };
}

comparisons!(F64x4, Mask4, _mm256_cmp_pd);

impl Mask4 {
    /// `a` in the lanes where the mask is set, `b` elsewhere.
    #[inline(always)]
    pub(crate) fn select(self, a: F64x4, b: F64x4) -> F64x4 {
        // SAFETY: AVX code on an existing value (module documentation).
        F64x4(unsafe { _mm256_blendv_pd(b.0, a.0, self.0) })
    }

    /// Bit `l` set where lane `l` is.
    #[inline(always)]
    pub(crate) fn bits(self) -> u32 {
        // SAFETY: AVX code on an existing value (module documentation).
        let bits = unsafe { _mm256_movemask_pd(self.0) };
        bits.cast_unsigned()
    }
}

macro_rules! binary {
    ($type:ident, $trait:ident, $method:ident, $intrinsic:ident) => {
        impl $trait for $type {
            type Output = Self;
            #[inline(always)]
            fn $method(self, other: Self) -> Self {
                // SAFETY: AVX code on existing values (module documentation).
                Self(unsafe { $intrinsic(self.0, other.0) })
            }
        }
    };
}

binary!(F64x4, Add, add, _mm256_add_pd);
binary!(F64x4, Sub, sub, _mm256_sub_pd);
binary!(F64x4, Mul, mul, _mm256_mul_pd);
binary!(F64x4, Div, div, _mm256_div_pd);
binary!(Mask4, BitAnd, bitand, _mm256_and_pd);
binary!(Mask4, BitOr, bitor, _mm256_or_pd);

impl Neg for F64x4 {
    type Output = Self;
    /// The sign bit flipped.
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: AVX code on an existing value (module documentation).
        Self(unsafe { _mm256_xor_pd(_mm256_set1_pd(-0.0), self.0) })
    }
}

impl AddAssign for F64x4 {
    #[inline(always)]
    fn add_assign(&mut self, other: Self) {
        *self = *self + other;
    }
}

impl SubAssign for F64x4 {
    #[inline(always)]
    fn sub_assign(&mut self, other: Self) {
        *self = *self - other;
    }
}

/// Whether this machine runs AVX2 code (checked once, then cached by the
/// standard library).
#[inline]
pub(crate) fn avx2_available() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// Eight `f64` lanes in one 512-bit AVX-512 register: [`F64x4`]'s
/// operations, twice as wide, for a machine with AVX-512F. Its
/// constructors are compiled for AVX-512F as [`F64x4`]'s are for AVX2, so
/// that a value is again its own proof that the machine runs its
/// instructions.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct F64x8(__m512d);

/// [`F64x8`]'s comparisons: bit `l` set where lane `l` is true.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Mask8(__mmask8);

impl F64x8 {
    /// `value` in every lane.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(crate) fn splat(value: f64) -> Self {
        Self(_mm512_set1_pd(value))
    }

    /// Lane `l` is `values[l]`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(crate) fn new(values: [f64; 8]) -> Self {
        // SAFETY: `values` is eight readable `f64`.
        Self(unsafe { _mm512_loadu_pd(values.as_ptr()) })
    }

    /// The lanes in memory order.
    #[inline(always)]
    pub(crate) fn as_array(&self) -> &[f64; 8] {
        // SAFETY: `F64x8` is an `__m512d`, eight `f64` in lane order.
        unsafe { &*std::ptr::from_ref(self).cast::<[f64; 8]>() }
    }

    #[inline(always)]
    pub(crate) fn sqrt(self) -> Self {
        // SAFETY: AVX-512 code on an existing value (module documentation).
        Self(unsafe { _mm512_sqrt_pd(self.0) })
    }

    /// `|x|` (the sign bit cleared).
    #[inline(always)]
    pub(crate) fn abs(self) -> Self {
        // SAFETY: AVX-512 code on an existing value (module documentation).
        Self(unsafe { _mm512_abs_pd(self.0) })
    }

    /// The larger of each pair; `other` where either is NaN (`vmaxpd`).
    #[inline(always)]
    pub(crate) fn max(self, other: Self) -> Self {
        // SAFETY: AVX-512 code on an existing value (module documentation).
        Self(unsafe { _mm512_max_pd(self.0, other.0) })
    }

    /// The smaller of each pair; `other` where either is NaN (`vminpd`).
    #[inline(always)]
    pub(crate) fn min(self, other: Self) -> Self {
        // SAFETY: AVX-512 code on an existing value (module documentation).
        Self(unsafe { _mm512_min_pd(self.0, other.0) })
    }

    #[inline(always)]
    pub(crate) fn is_nan(self) -> Mask8 {
        // SAFETY: AVX-512 code on an existing value (module documentation).
        Mask8(unsafe { _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(self.0, self.0) })
    }

    /// Neither infinite nor NaN.
    #[inline(always)]
    pub(crate) fn is_finite(self) -> Mask8 {
        let infinity = F64x8(
            // SAFETY: AVX-512 code beside an existing value (module documentation).
            unsafe { _mm512_set1_pd(f64::INFINITY) },
        );
        self.abs().lt(infinity)
    }
}

comparisons!(F64x8, Mask8, _mm512_cmp_pd_mask);

impl Mask8 {
    /// `a` in the lanes where the mask is set, `b` elsewhere.
    #[inline(always)]
    pub(crate) fn select(self, a: F64x8, b: F64x8) -> F64x8 {
        // SAFETY: AVX-512 code on existing values (module documentation).
        F64x8(unsafe { _mm512_mask_blend_pd(self.0, b.0, a.0) })
    }

    /// Bit `l` set where lane `l` is.
    #[inline(always)]
    pub(crate) fn bits(self) -> u32 {
        u32::from(self.0)
    }
}

impl BitAnd for Mask8 {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, other: Self) -> Self {
        Self(self.0 & other.0)
    }
}

impl BitOr for Mask8 {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }
}

binary!(F64x8, Add, add, _mm512_add_pd);
binary!(F64x8, Sub, sub, _mm512_sub_pd);
binary!(F64x8, Mul, mul, _mm512_mul_pd);
binary!(F64x8, Div, div, _mm512_div_pd);

impl Neg for F64x8 {
    type Output = Self;
    /// The sign bit flipped.
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: AVX-512 code on an existing value (module documentation).
        Self(unsafe {
            let sign = _mm512_set1_epi64(i64::MIN);
            _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(self.0), sign))
        })
    }
}

impl AddAssign for F64x8 {
    #[inline(always)]
    fn add_assign(&mut self, other: Self) {
        *self = *self + other;
    }
}

impl SubAssign for F64x8 {
    #[inline(always)]
    fn sub_assign(&mut self, other: Self) {
        *self = *self - other;
    }
}

/// Whether this machine runs AVX-512F code (checked once, then cached by
/// the standard library).
#[inline]
pub(crate) fn avx512_available() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
}
