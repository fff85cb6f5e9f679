//! A type-checking stand-in for the `kani` crate (the API subset `massid-proofs` uses:
//! `any`, `assume`, `cover!`, `Arbitrary`, `#[kani::proof]`, `#[kani::unwind]`). It proves
//! nothing; it only lets `cargo check` see the harnesses exactly as Kani would compile them.
pub use kani_macros::{proof, unwind};

pub trait Arbitrary: Sized {
    fn any() -> Self;
}
macro_rules! arb {
    ($($t:ty),*) => {$( impl Arbitrary for $t { fn any() -> Self { Default::default() } } )*};
}
arb!(u8, u16, u32, u64, usize, i8, i16, i32, i64, bool, f32, f64);

pub fn any<T: Arbitrary>() -> T {
    T::any()
}
pub fn assume(_cond: bool) {}

#[doc(hidden)]
pub fn cover_fn(_cond: bool, _msg: &'static str) {}

/// As Kani's: an expression of type `()`.
#[macro_export]
macro_rules! cover {
    ($cond:expr, $msg:literal) => {
        $crate::cover_fn($cond, $msg)
    };
}
