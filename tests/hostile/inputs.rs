//! Hostile inputs: see tests/hostile.rs.
