//! The functions of `f64` that `core` lacks, for a build without `std`.
//!
//! With `std` (the default) `f64`'s own methods are used, and this trait is never called: a
//! type's inherent methods come before a trait's. Without it, the runtime and the code bgc
//! generates call these, computed by `libm` (a port of musl's), so that a firmware with no
//! operating system evaluates the same residuals; `powi` is the square-and-multiply loop
//! that `f64::powi` compiles to, so both give the same bits.

/// The functions of `f64` that residual code calls and `core` does not provide.
pub trait Real: Sized {
    /// `e^x`.
    fn exp(self) -> Self;
    /// The natural logarithm.
    fn ln(self) -> Self;
    /// The base-2 logarithm.
    fn log2(self) -> Self;
    /// The square root.
    fn sqrt(self) -> Self;
    /// The sine (radians).
    fn sin(self) -> Self;
    /// The cosine (radians).
    fn cos(self) -> Self;
    /// The tangent (radians).
    fn tan(self) -> Self;
    /// The hyperbolic tangent.
    fn tanh(self) -> Self;
    /// The arc tangent.
    fn atan(self) -> Self;
    /// The inverse hyperbolic tangent.
    fn atanh(self) -> Self;
    /// `self^n`, by squaring.
    fn powi(self, n: i32) -> Self;
    /// `self^e`.
    fn powf(self, e: Self) -> Self;
    /// The smallest integer not below `self`.
    fn ceil(self) -> Self;
    /// `|self|`.
    fn abs(self) -> Self;
}

#[cfg(not(feature = "std"))]
impl Real for f64 {
    fn exp(self) -> f64 {
        libm::exp(self)
    }
    fn ln(self) -> f64 {
        libm::log(self)
    }
    fn log2(self) -> f64 {
        libm::log2(self)
    }
    fn sqrt(self) -> f64 {
        libm::sqrt(self)
    }
    fn sin(self) -> f64 {
        libm::sin(self)
    }
    fn cos(self) -> f64 {
        libm::cos(self)
    }
    fn tan(self) -> f64 {
        libm::tan(self)
    }
    fn tanh(self) -> f64 {
        libm::tanh(self)
    }
    fn atan(self) -> f64 {
        libm::atan(self)
    }
    fn atanh(self) -> f64 {
        libm::atanh(self)
    }
    fn powi(self, n: i32) -> f64 {
        powi(self, n)
    }
    fn powf(self, e: f64) -> f64 {
        libm::pow(self, e)
    }
    fn ceil(self) -> f64 {
        libm::ceil(self)
    }
    fn abs(self) -> f64 {
        libm::fabs(self)
    }
}

#[cfg(feature = "std")]
impl Real for f64 {
    fn exp(self) -> f64 {
        f64::exp(self)
    }
    fn ln(self) -> f64 {
        f64::ln(self)
    }
    fn log2(self) -> f64 {
        f64::log2(self)
    }
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    fn sin(self) -> f64 {
        f64::sin(self)
    }
    fn cos(self) -> f64 {
        f64::cos(self)
    }
    fn tan(self) -> f64 {
        f64::tan(self)
    }
    fn tanh(self) -> f64 {
        f64::tanh(self)
    }
    fn atan(self) -> f64 {
        f64::atan(self)
    }
    fn atanh(self) -> f64 {
        f64::atanh(self)
    }
    fn powi(self, n: i32) -> f64 {
        f64::powi(self, n)
    }
    fn powf(self, e: f64) -> f64 {
        f64::powf(self, e)
    }
    fn ceil(self) -> f64 {
        f64::ceil(self)
    }
    fn abs(self) -> f64 {
        f64::abs(self)
    }
}

/// `x^n` as compiler-rt's `__powidf2` computes it: square and multiply from the lowest bit,
/// then the reciprocal for a negative `n`.
#[cfg_attr(feature = "std", allow(dead_code))]
pub(crate) fn powi(mut x: f64, n: i32) -> f64 {
    let reciprocal = n < 0;
    let mut b = n;
    let mut r = 1.0;
    loop {
        if b & 1 != 0 {
            r *= x;
        }
        b /= 2;
        if b == 0 {
            break;
        }
        x *= x;
    }
    if reciprocal {
        1.0 / r
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a build without `std` computes with `libm` is what `std` computes, to a couple
    /// of units in the last place, over the ranges residual code meets (signals in the
    /// model's units, angles, ratios). `atanh` is the exception near ±1, where a change of
    /// its argument in the last place moves it by hundreds (1/(1 − x²) at 0.999), and
    /// `f64::atanh` is computed by a formula of its own (`0.5 ln_1p(2x/(1 − x))`): the two
    /// differ there by what their arguments' rounding makes of it.
    #[test]
    fn libm_agrees_with_the_standard_library() {
        type Pair = (&'static str, fn(f64) -> f64, fn(f64) -> f64, f64, f64, f64);
        let pairs: [Pair; 8] = [
            ("exp", libm::exp, f64::exp, -30.0, 30.0, 2.0),
            ("log", libm::log, f64::ln, 1e-6, 1e6, 2.0),
            ("sqrt", libm::sqrt, f64::sqrt, 0.0, 1e6, 2.0),
            ("sin", libm::sin, f64::sin, -50.0, 50.0, 2.0),
            ("cos", libm::cos, f64::cos, -50.0, 50.0, 2.0),
            ("tanh", libm::tanh, f64::tanh, -20.0, 20.0, 2.0),
            ("atan", libm::atan, f64::atan, -1e3, 1e3, 2.0),
            ("atanh", libm::atanh, f64::atanh, -0.999, 0.999, 500.0),
        ];
        for (name, ours, theirs, from, to, most) in pairs {
            for k in 0..=2000 {
                let x = from + (to - from) * f64::from(k) / 2000.0;
                let (a, b) = (ours(x), theirs(x));
                let ulps = (a - b).abs() / (f64::EPSILON * b.abs().max(f64::MIN_POSITIVE));
                assert!(ulps <= most, "{name}({x}): libm {a}, std {b}, {ulps} ulps");
            }
        }
    }

    /// The loop a build without `std` uses gives the bits `f64::powi` gives, on the powers
    /// generated code raises signals to.
    #[test]
    fn powi_by_squaring_is_bit_identical_to_the_standard_one() {
        for &x in &[0.3, -1.7, 2.0, 1e-3, 123.456, -0.999] {
            for n in -9..=12 {
                let x = core::hint::black_box(x);
                assert_eq!(powi(x, n).to_bits(), f64::powi(x, n).to_bits(), "{x}^{n}");
            }
        }
    }
}
