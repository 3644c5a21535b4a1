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
//! let (steps, theta) = (3, vec![0.25, f64::NAN]);
//! let bytes = encode(&State { steps, theta: Cow::Borrowed(&theta) }).unwrap();
//! let back: State = decode(&bytes, "state").unwrap();
//! let mut restored = vec![0.0; 2];
//! copy_into(&mut restored, &back.theta, "volume fraction").unwrap();
//! assert_eq!(back.steps, 3);
//! assert_eq!(restored[1].to_bits(), f64::NAN.to_bits());
//! ```

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
/// frame's, from the case).
pub fn copy_into(out: &mut [Real], restored: &[Real], what: &str) -> Result<(), String> {
    if restored.len() != out.len() {
        return Err(format!("{what}: {} values in the checkpoint, {} here", restored.len(), out.len()));
    }
    out.copy_from_slice(restored);
    Ok(())
}
