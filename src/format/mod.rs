//! The `.pvis` writer. Layout constants come from [`crate::runtime`], so writer and reader
//! cannot drift apart. Format: `spec/FORMAT.md`.
