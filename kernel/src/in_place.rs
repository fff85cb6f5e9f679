//! Building large state where it lives (the C ABI's caller-owned blocks): a value returned
//! by a constructor is built on the stack and then copied, tens of kB for the
//! identification's sums, so their initial values are written field by field through
//! [`core::mem::MaybeUninit`] instead (`flight_id::FlightId::init_in_place`).
//!
//! Three `unsafe` operations live here and nowhere else: viewing an uninitialised array as
//! its uninitialised elements ([`elements`]), projecting a field of an uninitialised struct
//! ([`field!`]), and taking a struct whose fields were all written as initialised
//! ([`assume_all_written!`], which checks at compile time that its list names every field).
//! Everything else writes through [`MaybeUninit::write`], which is safe.

use core::mem::MaybeUninit;

/// The elements of an uninitialised array, each uninitialised.
pub(crate) fn elements<E, const N: usize>(a: &mut MaybeUninit<[E; N]>) -> &mut [MaybeUninit<E>; N] {
    // SAFETY: `MaybeUninit<[E; N]>` and `[MaybeUninit<E>; N]` have the same size, alignment
    // and layout (`MaybeUninit<T>` is `repr(transparent)`-like over `T`'s layout, and an array
    // is its elements at stride `size_of::<E>()`); neither requires anything of the bytes, and
    // the borrow of `a` is carried over, so the view is unique for its lifetime.
    unsafe { &mut *a.as_mut_ptr().cast::<[MaybeUninit<E>; N]>() }
}

/// Writes `v` to every element of `a`.
pub(crate) fn fill<T: Copy, const N: usize>(a: &mut MaybeUninit<[T; N]>, v: T) -> &mut [T; N] {
    for e in elements(a).iter_mut() {
        e.write(v);
    }
    // SAFETY: every element was written just above.
    unsafe { a.assume_init_mut() }
}

/// Writes `v` to every entry of the matrix `a`.
pub(crate) fn fill2<T: Copy, const N: usize, const M: usize>(
    a: &mut MaybeUninit<[[T; N]; M]>,
    v: T,
) -> &mut [[T; N]; M] {
    for row in elements(a).iter_mut() {
        fill(row, v);
    }
    // SAFETY: every row was filled just above.
    unsafe { a.assume_init_mut() }
}

/// Writes `v` to every entry of the matrices `a`.
pub(crate) fn fill3<T: Copy, const N: usize, const M: usize, const L: usize>(
    a: &mut MaybeUninit<[[[T; N]; M]; L]>,
    v: T,
) -> &mut [[[T; N]; M]; L] {
    for m in elements(a).iter_mut() {
        fill2(m, v);
    }
    // SAFETY: every matrix was filled just above.
    unsafe { a.assume_init_mut() }
}

/// The field of `slot` that `place` picks, as an uninitialised value of the field's type.
///
/// # Safety
/// `place` returns the place of a field of the struct behind its argument, made with
/// [`core::ptr::addr_of_mut!`] (no reference to the struct, which may be uninitialised, and
/// no `Deref`). [`field!`] is the safe way to call this.
pub(crate) unsafe fn project<S, F>(
    slot: &mut MaybeUninit<S>,
    place: impl FnOnce(*mut S) -> *mut F,
) -> &mut MaybeUninit<F> {
    let f = place(slot.as_mut_ptr());
    // SAFETY: `f` is a field's place inside `*slot` (the caller's contract): valid, aligned
    // and writable for the borrow of `slot`, which the result carries, so it is unique;
    // `MaybeUninit<F>` has `F`'s layout and asks nothing of the bytes.
    unsafe { &mut *f.cast::<MaybeUninit<F>>() }
}

/// `field!(slot, name)`: field `name` of the struct in `slot` (a `&mut MaybeUninit` of a
/// plain struct, no `Deref`) as `&mut MaybeUninit` of the field's type, to write in place.
macro_rules! field {
    ($slot:expr, $name:ident) => {{
        let slot: &mut ::core::mem::MaybeUninit<_> = $slot;
        // SAFETY: the closure returns the place of field `name` of the struct behind its
        // argument, through `addr_of_mut!` (no reference to the uninitialised struct); the
        // pointer is `slot`'s, valid and aligned.
        unsafe { $crate::in_place::project(slot, |p| ::core::ptr::addr_of_mut!((*p).$name)) }
    }};
}
pub(crate) use field;

/// `assume_all_written!(slot, Type { a, b, c })`: `slot` (a `&mut MaybeUninit<Type>`) as its
/// value, once the caller has written each field named, through [`field!`]. The list must
/// name every field of `Type`: it is matched as an exhaustive pattern, so a field added to the
/// struct fails to compile until its constructor writes it and names it here.
macro_rules! assume_all_written {
    ($slot:expr, $ty:ident { $($f:ident),* $(,)? }) => {{
        let _every_field = |v: &$ty| {
            let $ty { $($f: _),* } = v;
        };
        let slot: &mut ::core::mem::MaybeUninit<$ty> = $slot;
        // SAFETY: the caller wrote every field listed (this macro's contract), and the list is
        // every field of the struct (the exhaustive pattern above).
        unsafe { slot.assume_init_mut() }
    }};
}
pub(crate) use assume_all_written;

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing)]
    use super::*;

    #[test]
    fn fills_write_every_entry() {
        let mut a = MaybeUninit::<[[[i64; 5]; 4]; 3]>::uninit();
        let v = fill3(&mut a, 7);
        assert!(v.iter().flatten().flatten().all(|x| *x == 7));
        v[2][3][4] = 1;
        let mut b = MaybeUninit::<[u8; 9]>::uninit();
        assert_eq!(*fill(&mut b, 3), [3; 9]);
    }

    #[test]
    fn fields_are_written_in_place() {
        struct Two {
            a: [u32; 4],
            b: u8,
        }
        let mut s = MaybeUninit::<Two>::uninit();
        fill(field!(&mut s, a), 5);
        field!(&mut s, b).write(1);
        let s = assume_all_written!(&mut s, Two { a, b });
        assert_eq!((s.a, s.b), ([5; 4], 1));
    }
}
