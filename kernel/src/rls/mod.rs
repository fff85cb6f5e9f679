//! Mass-property identification: CoM offset and inverse inertia by recursive least squares
//! in information form (seed eqs 3.9-3.10), seeded by a batch over the first two firings,
//! with optional exponential forgetting and an optional innovation change detector that
//! resets the covariance.
//!
//! Three files, one concept each, read in this order:
//! - [`update`]: **the RLS update**, all of it: how one firing's aggregate [`Measurement`]
//!   enters the estimate, stage by stage ([`FiringFold`]), with each stage's step on the
//!   estimator and the change detector;
//! - [`mass_id`]: the estimator's state ([`MassId`]), its solve, status and variances;
//! - [`info_ls`]: one least-squares problem in information form, stored as block floating
//!   point so that the fixed-point kernel holds information that grows without bound
//!   ([`InfoLs`]).
//!
//! The pipeline ([`crate::pipeline`]) builds the measurements from the Kalman filter's
//! angular accelerations and runs one [`FiringFold`] stage per tick.

pub mod info_ls;
pub mod mass_id;
pub mod update;

pub use info_ls::{AddPlan, Factored, InfoLs, MaybeVariances, Solution};
pub use mass_id::{DetectorConfig, EstimateState, MassId, RlsConfig, RlsStatus};
pub use update::{pow_u32, FiringFold, FoldStep, Measurement, Solved, STAGES};
