//! Block-floating-point normalisation (`split_pow2` of a fixed-point word, `Scaled::from_i64`
//! of a 64-bit sum).

use crate::discharge::Obligation;
use crate::prover::{Prover, ProverExt};
use massid_kernel::int::split::{split_word, top_bits};
use massid_kernel::int::MachineExt;

/// `split_word(b, frac)`: zero gives (0, 0); otherwise `2^frac <= |m| < 2^(frac+1)` and
/// `b = m 2^k` exactly for `k <= 0`, `m = floor(b / 2^k)` for `k > 0`. Every word.
pub struct SplitWord {
    /// Fractional bits of the format.
    pub frac: u32,
}

impl Obligation for SplitWord {
    fn name(&self) -> String {
        format!("split_pow2_q{}_{}", 32 - self.frac, self.frac)
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["b"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let b = &x[0];
        let (mant, k) = p.under_test(|m| split_word(m, b, self.frac));
        let (bi, mi, ki) = (p.sw(b), p.sw(&mant), p.sw(&k));
        let zero = p.int(0);
        let is_zero = p.i_eq(&bi, &zero);
        let normal = p.i_within(
            &p.i_abs(&mi),
            1i128 << self.frac,
            (1i128 << (self.frac + 1)) - 1,
        );
        let up = p.is_negative(&k);
        let kneg = p.neg(&k);
        let exact_up = p.i_eq(&p.i_shl(&bi, &kneg), &mi);
        let low = p.i_shl(&mi, &k);
        let floor_down = p.all(
            &p.i_le(&low, &bi),
            &p.i_lt(&bi, &p.i_add(&low, &p.i_shl(&p.int(1), &k))),
        );
        let k_range = p.i_within(&ki, -i128::from(self.frac), 31 - i128::from(self.frac));
        let nonzero = p.all(
            &p.all(&normal, &k_range),
            &p.select_bool(&up, &exact_up, &floor_down),
        );
        let property = p.select_bool(
            &is_zero,
            &p.all(&p.i_eq(&mi, &zero), &p.i_eq(&ki, &zero)),
            &nonzero,
        );
        (p.b(true), property)
    }
}

/// `top_bits(v, 30)` (what `Scaled::from_i64` runs): `len` is the bit length of `|v|`,
/// `sh = max(len - 30, 0)`, `m = floor(v / 2^sh)` with `|m| <= 2^30`. Every 64-bit `v`.
/// (`|m| < 2^30` was the comment's claim; Z3 refuted it at `v = 1 - 2^31`, where the floor
/// of a negative value reaches `-2^30`.)
pub struct TopBits;

impl Obligation for TopBits {
    fn name(&self) -> String {
        "top_bits_i64_30".into()
    }
    fn inputs(&self) -> &'static [&'static str] {
        &["v_hi", "v_lo"]
    }
    fn check<P: Prover>(&self, p: &P, x: &[P::W]) -> (P::Bool, P::Bool) {
        let v = p.d_of(&x[0], &x[1]);
        let (mant, sh, len) = p.under_test(|m| top_bits(m, &v, 30));
        let (vi, mi) = (p.int_d(&v, true), p.sw(&mant));
        let av = p.i_abs(&vi);
        let zero = p.int(0);
        let len_ok = p.select_bool(
            &p.i_eq(&vi, &zero),
            &p.eq(&len, &p.w(0)),
            &p.all(
                &p.i_le(&p.i_shl(&p.int(1), &p.sub(&len, &p.w(1))), &av),
                &p.i_lt(&av, &p.i_shl(&p.int(1), &len)),
            ),
        );
        let len_i = p.uw(&len);
        let sh_ok = p.select_bool(
            &p.i_lt(&p.int(30), &len_i),
            &p.i_eq(&p.uw(&sh), &p.i_sub(&len_i, &p.int(30))),
            &p.eq(&sh, &p.w(0)),
        );
        let low = p.i_shl(&mi, &sh);
        let floor = p.all(
            &p.i_le(&low, &vi),
            &p.i_lt(&vi, &p.i_add(&low, &p.i_shl(&p.int(1), &sh))),
        );
        let small = p.i_le(&p.i_abs(&mi), &p.int(1 << 30));
        let property = p.all(&p.all(&len_ok, &sh_ok), &p.all(&floor, &small));
        (p.b(true), property)
    }
}
