//! Building large state where it lives (the C ABI's caller-owned blocks): a value returned
//! by a constructor is built on the stack and then copied, tens of kB for the
//! identification's sums, so their initial values are written field by field through
//! [`core::mem::MaybeUninit`] instead (`flight_id::FlightId::init_in_place`).
//!
//! Three `unsafe` operations live here and nowhere else: viewing an uninitialised array as
//! its uninitialised elements ([`elements`]), projecting a field of an uninitialised struct
//! ([`field!`], which checks at compile time that the field is the struct's own), and taking a
//! struct whose fields were all written as initialised ([`assume_all_written!`], which checks
//! at compile time that its list names every field; its uses are `unsafe`).
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

/// Calls nothing: ties the pattern check in [`assume_all_written!`] to the type in `slot`, so
/// that the struct named there is the one in the slot.
pub(crate) fn check_fields<T>(_slot: &MaybeUninit<T>, _pattern: impl FnOnce(&T)) {}

/// `field!(slot, Type, name)`: field `name` of the `Type` struct in `slot` (a
/// `&mut MaybeUninit<Type>`) as `&mut MaybeUninit` of the field's type, to write in place.
/// The field must be `Type`'s own: `offset_of!` accepts nothing else, so a field reached
/// through `Deref` (a reference or a box in the slot) does not compile.
macro_rules! field {
    ($slot:expr, $ty:ty, $name:ident) => {{
        let slot: &mut ::core::mem::MaybeUninit<$ty> = $slot;
        let _own_field = ::core::mem::offset_of!($ty, $name);
        // SAFETY: the closure returns the place of field `name` of the `Type` behind its
        // argument, a field of its own (`offset_of!` above), through `addr_of_mut!` (no
        // reference to the uninitialised struct); the pointer is `slot`'s, valid and aligned.
        unsafe {
            $crate::in_place::project(slot, |p: *mut $ty| ::core::ptr::addr_of_mut!((*p).$name))
        }
    }};
}
pub(crate) use field;

/// `unsafe { assume_all_written!(slot, Type { a, b, c }) }`: `slot` (a
/// `&mut MaybeUninit<Type>`) as its value. The list must name every field of `Type`: it is
/// matched as an exhaustive pattern, so a field added to the struct fails to compile until its
/// constructor names it here. That every field named was written is the caller's to show:
/// the expansion is unsafe, so each use needs its own `unsafe` block and SAFETY comment.
macro_rules! assume_all_written {
    ($slot:expr, $ty:path { $($f:ident),* $(,)? }) => {{
        let slot: &mut ::core::mem::MaybeUninit<_> = $slot;
        $crate::in_place::check_fields(slot, |v| {
            let $ty { $($f: _),* } = v;
        });
        slot.assume_init_mut()
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
        fill(field!(&mut s, Two, a), 5);
        field!(&mut s, Two, b).write(1);
        // SAFETY: both fields written just above.
        let s = unsafe { assume_all_written!(&mut s, Two { a, b }) };
        assert_eq!((s.a, s.b), ([5; 4], 1));
    }
}
