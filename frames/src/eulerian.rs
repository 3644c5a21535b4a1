//! Eulerian frame (being written).
