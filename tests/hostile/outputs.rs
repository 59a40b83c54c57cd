//! Hostile outputs: see tests/hostile.rs.
