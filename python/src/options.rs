//! Keyword options (`Embodier(setup, **options)`, `Cell(embodier, arms, **options)`, ...),
//! read by one helper: a keyword the callable does not know is a `TypeError` naming it (and
//! listing the known ones), a value of the wrong type a `TypeError` naming the keyword and
//! the type expected. Values are checked by the library (an `InputError` naming the field).

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The keywords given to `callable`, each taken once by its type.
pub struct Options<'py> {
    callable: &'static str,
    given: Option<Bound<'py, PyDict>>,
}

impl<'py> Options<'py> {
    /// The keywords of `kwargs`, each one of `known`.
    pub fn new(
        callable: &'static str,
        kwargs: Option<&Bound<'py, PyDict>>,
        known: &[&str],
    ) -> PyResult<Options<'py>> {
        if let Some(kwargs) = kwargs {
            for key in kwargs.keys() {
                let name: String = key.extract()?;
                if !known.contains(&name.as_str()) {
                    return Err(PyTypeError::new_err(format!(
                        "{callable}() got an unexpected keyword argument {name:?} (it takes {})",
                        known.join(", ")
                    )));
                }
            }
        }
        Ok(Options {
            callable,
            given: kwargs.cloned(),
        })
    }

    /// The value of keyword `key` as a `T` (`what` names the type for the error), `None` when
    /// it is not given.
    pub fn get<T>(&self, key: &str, what: &str) -> PyResult<Option<T>>
    where
        T: for<'a> FromPyObject<'a, 'py>,
    {
        let Some(value) = (self.given.as_ref()).map(|d| d.get_item(key)).transpose()? else {
            return Ok(None);
        };
        let Some(value) = value else {
            return Ok(None);
        };
        value.extract::<T>().map(Some).map_err(|_| {
            let got = (value.get_type().name())
                .map(|n| n.to_string())
                .unwrap_or_default();
            PyTypeError::new_err(format!(
                "{}(): {key}: expected {what}, got {got}",
                self.callable
            ))
        })
    }

    /// [`Options::get`], or `default`.
    pub fn or<T>(&self, key: &str, what: &str, default: T) -> PyResult<T>
    where
        T: for<'a> FromPyObject<'a, 'py>,
    {
        Ok(self.get(key, what)?.unwrap_or(default))
    }
}
