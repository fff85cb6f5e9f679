//! Identity stand-ins for Kani's `#[kani::proof]` and `#[kani::unwind(n)]` attributes, so
//! that the `cfg(kani)` side of `massid-proofs` can be type-checked where Kani is absent.
extern crate proc_macro;
use proc_macro::TokenStream;

#[proc_macro_attribute]
pub fn proof(_attr: TokenStream, item: TokenStream) -> TokenStream {
    item
}

#[proc_macro_attribute]
pub fn unwind(_attr: TokenStream, item: TokenStream) -> TokenStream {
    item
}
