//! The drive's components: how many there are and in what order. Their own module because
//! the window's drive ([`super::drive`]) and the sums ([`super::sums`]) both count them.

/// Drive components: accumulated torque (N m s), force (N s), and the rate products
/// `integral omega_i omega_j dt` (rad^2/s, order xx yy zz xy xz yz) that the gyroscopic term
/// `omega x I omega` is linear in; then two sets the model leaves out, the directions of the
/// consistency tests (`super::consistency`):
/// - the torque held over the interval that ends at the sample: a command-to-thrust delay `L`
///   moves the accumulated torque by `-L` times it;
/// - the open thrusters' positive torques about each axis, accumulated (N m s): a thrust error
///   that scales a turn one way and not the other (one weak thruster) is a torque error along
///   it ([`crate::craft::Craft::command`]).
pub const NZ: usize = 18;
/// Components the model uses (the rest only enter the consistency tests).
pub const N_MODEL: usize = 12;
/// First of the accumulated positive torques (after the held torque, `N_MODEL..SPLIT_TORQUE`).
pub const SPLIT_TORQUE: usize = N_MODEL + 3;
/// Rate products of the drive's gyroscopic part (components 6..12), in the order xx yy zz
/// xy xz yz.
pub const PRODUCTS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
