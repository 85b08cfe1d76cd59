//! Elementwise functions whose results are the same bits on every CPU, for the scene renderer
//! (`uavsnn.scenes.portable`): the `libm` crate's software implementations, where NumPy's
//! `exp`, `sin`, ... run code chosen for the processor (Intel's SVML on AVX-512, NumPy's own
//! SIMD loops elsewhere), each rounding its last bits in its own way.

use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

use super::errors::detach;
use crate::error::Error;

type Unary = fn(f64) -> f64;
type Binary = fn(f64, f64) -> f64;

/// The functions of one argument `portable_unary` knows, by NumPy's names.
const UNARY: [(&str, Unary); 4] = [
    ("exp", libm::exp),
    ("sin", libm::sin),
    ("cos", libm::cos),
    ("arctan", libm::atan),
];

/// The functions of two arguments `portable_binary` knows, by NumPy's names.
const BINARY: [(&str, Binary); 2] = [("arctan2", libm::atan2), ("power", libm::pow)];

fn lookup<F: Copy>(table: &[(&'static str, F)], op: &str) -> crate::Result<F> {
    table
        .iter()
        .find(|(name, _)| *name == op)
        .map(|(_, f)| *f)
        .ok_or_else(|| {
            let names: Vec<&str> = table.iter().map(|(name, _)| *name).collect();
            Error::param("op", format!("must be one of {names:?}, got {op:?}"))
        })
}

/// `op(x)` for each element of `x`.
#[pyfunction]
fn portable_unary<'py>(
    py: Python<'py>,
    op: &str,
    x: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let x = x.as_slice()?;
    let out = detach(py, || {
        let f = lookup(&UNARY, op)?;
        Ok(x.iter().map(|&v| f(v)).collect::<Vec<f64>>())
    })?;
    Ok(out.into_pyarray(py))
}

/// `op(x, y)` for each pair of elements of `x` and `y`, which have one length.
#[pyfunction]
fn portable_binary<'py>(
    py: Python<'py>,
    op: &str,
    x: PyReadonlyArray1<'py, f64>,
    y: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (x, y) = (x.as_slice()?, y.as_slice()?);
    let out = detach(py, || {
        let f = lookup(&BINARY, op)?;
        if x.len() != y.len() {
            return Err(Error::param(
                "y",
                format!("must have x's length {}, got {}", x.len(), y.len()),
            ));
        }
        Ok(x.iter()
            .zip(y)
            .map(|(&a, &b)| f(a, b))
            .collect::<Vec<f64>>())
    })?;
    Ok(out.into_pyarray(py))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(portable_unary, m)?)?;
    m.add_function(wrap_pyfunction!(portable_binary, m)?)?;
    Ok(())
}
