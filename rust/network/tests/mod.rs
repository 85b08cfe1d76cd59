//! End-to-end checks of the event-driven engine against a plain dense, layer-by-layer
//! implementation of docs/model.md written here for clarity (test-only), on random small
//! networks and windows, with one engine state reused across windows (sparse resets).
//!
//! `reference` holds the dense model and `strategies` the random inputs; the tests are grouped
//! by what they check: `agreement` (the engine against the dense reference), `exact` (exact
//! potentials and ties), `api` (the push and window API, and bad input), `kernels` (scalar
//! against AVX2).

#![allow(clippy::float_cmp, clippy::needless_range_loop)] // exact equality; dense loops by index

use proptest::prelude::*;

use super::*;
use crate::error::Error;

mod agreement;
mod api;
mod exact;
mod kernels;
mod reference;
mod strategies;
