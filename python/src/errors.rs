//! The package's one error type, `waggle.WaggleError`, and the argument checks that raise it.
//!
//! Every bad argument a caller can pass is reported as a `WaggleError` naming the argument, so
//! nothing a Python caller hands over can panic the extension. It subclasses `ValueError`:
//! code that catches `ValueError` keeps working without knowing about Waggle.

use pyo3::prelude::*;

pyo3::create_exception!(
    waggle,
    WaggleError,
    pyo3::exceptions::PyValueError,
    "An argument Waggle cannot use; the message names the argument (a ValueError)."
);

/// `WaggleError` whose message starts with the argument's name.
pub fn bad_arg(name: &str, reason: impl std::fmt::Display) -> PyErr {
    WaggleError::new_err(format!("{name}: {reason}"))
}

/// An integer argument that must fit `T` (stamps, sequence numbers, sizes). Arguments arrive
/// as `i128` so that a negative or huge Python int is a `WaggleError` naming the argument
/// rather than PyO3's anonymous `OverflowError`.
pub fn int_arg<T: TryFrom<i128>>(name: &str, value: i128) -> PyResult<T> {
    T::try_from(value).map_err(|_| {
        bad_arg(
            name,
            format!("{value} is out of range ({})", std::any::type_name::<T>()),
        )
    })
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("WaggleError", m.py().get_type::<WaggleError>())
}
