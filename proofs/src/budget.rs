//! Error budgets: how far each kernel output may be from `reference_f64`, in one table.
