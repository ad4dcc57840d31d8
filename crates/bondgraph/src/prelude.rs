//! What the modules use from `alloc`, and without `std` the functions of `f64` that `core`
//! lacks: the same names with and without `std`.

pub(crate) use alloc::vec;
pub(crate) use alloc::vec::Vec;

// A test build links `std` whatever the features, and `f64`'s own methods come first.
#[cfg(not(any(feature = "std", test)))]
pub(crate) use crate::math::Real;
