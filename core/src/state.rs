//! Checkpoint state: what a frame or the simulation carries from one step to the next,
//! as a `#[derive(Serialize, Deserialize)]` struct encoded with
//! [postcard](https://docs.rs/postcard) (integers as varints, `f64` as its 8 bytes
//! little-endian, so every real, NaN included, comes back bit for bit).
//!
//! The state structs borrow what they save (`Cow::Borrowed`) and own what they load, so
//! one struct serves both ways:
//!
//! ```
//! use multifield_core::state::{copy_into, decode, encode};
//! use serde::{Deserialize, Serialize};
//! use std::borrow::Cow;
//!
//! #[derive(Serialize, Deserialize)]
//! struct State<'a> {
//!     steps: u64,
//!     theta: Cow<'a, [f64]>,
//! }
//!
//! let (steps, theta) = (3, vec![0.25, 1.0 / 3.0]);
//! let bytes = encode(&State { steps, theta: Cow::Borrowed(&theta) }).unwrap();
//! let back: State = decode(&bytes, "state").unwrap();
//! let mut restored = vec![0.0; 2];
//! copy_into(&mut restored, &back.theta, "volume fraction").unwrap();
//! assert_eq!(back.steps, 3);
//! assert_eq!(restored[1].to_bits(), (1.0_f64 / 3.0).to_bits());
//! // a NaN comes back bit for bit, but no run writes one: restoring it is refused
//! let nan = vec![0.25, f64::NAN];
//! let back: State = decode(&encode(&State { steps, theta: Cow::Borrowed(&nan) }).unwrap(), "state").unwrap();
//! let e = copy_into(&mut restored, &back.theta, "volume fraction").unwrap_err();
//! assert_eq!(e, "volume fraction[1] is NaN, not a finite number");
//! ```
//!
//! Restored state is checked before it is used ([`copy_into`], [`finite`], [`length`]): a
//! checkpoint whose checksum was recomputed over impossible state (a damaged or forged
//! file) is refused with the array, the index and the value, rather than failing inside a
//! kernel.

use crate::finite::first_non_finite;
use crate::math::Real;
use serde::{Deserialize, Serialize};

/// The bytes of `state`.
pub fn encode<T: Serialize + ?Sized>(state: &T) -> Result<Vec<u8>, String> {
    postcard::to_stdvec(state).map_err(|e| format!("the state cannot be encoded: {e}"))
}

/// Decodes what [`encode`] wrote; every byte must be used. An error names `what`.
pub fn decode<'a, T: Deserialize<'a>>(bytes: &'a [u8], what: &str) -> Result<T, String> {
    let (state, rest) = postcard::take_from_bytes(bytes).map_err(|e| format!("{what}: {e}"))?;
    if !rest.is_empty() {
        return Err(format!("{what}: {} bytes left over (a checkpoint of another version?)", rest.len()));
    }
    Ok(state)
}

/// Copies a restored array into `out`, whose length it must have (the grid's or the
/// frame's, from the case), and whose values must be finite ([`length`], [`finite`]).
pub fn copy_into(out: &mut [Real], restored: &[Real], what: &str) -> Result<(), String> {
    length(restored.len(), out.len(), what)?;
    finite(restored, what)?;
    out.copy_from_slice(restored);
    Ok(())
}

/// Refuses a restored array of `n` values where the case makes `want`; the error names
/// `what` and both counts.
pub fn length(n: usize, want: usize, what: &str) -> Result<(), String> {
    if n != want {
        return Err(format!("{what}: {n} values in the checkpoint, {want} here"));
    }
    Ok(())
}

/// Refuses restored state with a real that is not finite (NaN, ±∞), which no run writes
/// (a run that produces one stops before its next checkpoint). The error names `what`,
/// the entry (the index in an array, `what[12]`, then the component, `what[12].0`; a
/// struct's field by its name) and the value.
pub fn finite<T: Serialize + ?Sized>(value: &T, what: &str) -> Result<(), String> {
    let Some((path, x)) = first_non_finite(value) else {
        return Ok(());
    };
    let at = match path.split_once('.') {
        _ if path.is_empty() => what.to_string(),
        Some((k, rest)) if k.bytes().all(|b| b.is_ascii_digit()) => format!("{what}[{k}].{rest}"),
        None if path.bytes().all(|b| b.is_ascii_digit()) => format!("{what}[{path}]"),
        _ => format!("{what}: {path}"),
    };
    Err(format!("{at} is {x}, not a finite number"))
}

/// Refuses a restored value outside `[lo, hi]` (NaN included); the error names `what`,
/// the index and the value, and says why with `why`.
pub fn within(values: &[Real], lo: Real, hi: Real, what: &str, why: &str) -> Result<(), String> {
    match values.iter().position(|x| !(*x >= lo && *x <= hi)) {
        Some(k) => Err(format!("{what}[{k}] is {}, outside [{lo}, {hi}] ({why})", values[k])),
        None => Ok(()),
    }
}
