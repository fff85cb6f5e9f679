//! The obligations, one file per family of primitives, and the lists that are run.

pub mod div;
pub mod float;
pub mod mul;
pub mod shift;
pub mod split;

use crate::discharge::Discharge;

/// The kernel's fixed-point format (Q8.24).
pub const FRAC: u32 = 24;
/// Fractional bits of the integer float's mantissa quotient.
pub use massid_kernel::int_float::QUOTIENT_FRAC;

/// Every obligation proved in `cargo test`.
pub fn all() -> Vec<Box<dyn Discharge>> {
    use div::*;
    use mul::*;
    let mut v: Vec<Box<dyn Discharge>> = vec![
        Box::new(WideningProduct(Widening::Direct)),
        Box::new(RoundedProduct {
            frac: FRAC,
            widening: Widening::Direct,
        }),
        Box::new(UnsignedByHalves),
        // the fixed kernel's exact sums (`massid_kernel::flight_id::exact`): their
        // multiply-accumulate and the prediction's rounding
        Box::new(MulAcc),
        Box::new(RoundedSum {
            frac: massid_kernel::flight_id::exact::PREDICTION_FRAC,
        }),
        Box::new(shift::ShiftSaturating),
        Box::new(shift::ShiftNearest),
        Box::new(split::SplitWord { frac: FRAC }),
        Box::new(split::TopBits),
        Box::new(IntegerPart { frac: FRAC }),
        Box::new(SignedQuotient),
        Box::new(Normalise),
        Box::new(ByI64 { frac: FRAC }),
        // the integer float (`massid_kernel::IntFloat`): its rounding and aligned sum, and
        // its mantissa quotient, the fixed-point quotient at 30 fractional bits
        Box::new(float::RoundToMantissa),
        Box::new(float::AlignedSum),
        Box::new(IntegerPart {
            frac: QUOTIENT_FRAC,
        }),
        Box::new(ByI64 {
            frac: QUOTIENT_FRAC,
        }),
    ];
    for bit in 0..FRAC.max(QUOTIENT_FRAC) {
        v.push(Box::new(RestoringStep { bit }));
    }
    // The fixed kernel's sample rounded from its exact drive (`flight_id::exact`,
    // `ExactMoments::item_of_drive`): every shift a drive's configuration can take.
    let prediction = massid_kernel::flight_id::exact::PREDICTION_FRAC;
    for frac in response_fracs().filter(|f| *f != prediction) {
        v.push(Box::new(RoundedSum { frac }));
    }
    v
}

/// The shifts `round_product` takes from a drive's response: [`massid_kernel::flight_id::
/// exact::response_frac`] of every window length the kernel takes (`MAX_WINDOW_SAMPLES`; it
/// grows with the length's bits) and every response (0 to `RESPONSE_BITS` bits).
pub fn response_fracs() -> std::ops::RangeInclusive<u32> {
    use massid_kernel::flight_id::exact::{response_frac, MAX_WINDOW_SAMPLES, RESPONSE_BITS};
    response_frac(1, 0)..=response_frac(MAX_WINDOW_SAMPLES, RESPONSE_BITS)
}

/// Obligations Z3 has not discharged in the time tried (see `proofs/README.md`): each
/// relates a signed or digit-wise multiplier or divider to the exact operation, which
/// neither the bit-vector nor the integer theory does in reasonable time here.
pub fn open() -> Vec<Box<dyn Discharge>> {
    use mul::*;
    vec![
        Box::new(WideningProduct(Widening::ByHalves)),
        Box::new(RoundedProduct {
            frac: FRAC,
            widening: Widening::ByHalves,
        }),
        Box::new(div::Digit),
    ]
}
