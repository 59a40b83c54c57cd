//! Hostile geometry: see tests/hostile.rs.
