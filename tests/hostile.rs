//! The hostile-input suite (issue 21): invocations a careless or hostile user would try, each
//! checked for the fixed behaviour. No panic (exit 101), no hang, no data loss, no stale or
//! silently truncated result; one clear line on stderr and the documented exit code (0 success,
//! 1 bad input or failed check, 2 usage error).
//!
//! One module per side of the tool: what it writes, what it reads, and the geometry it accepts;
//! then commands at once and signals (`locks`), an input truncated under a running bake
//! (`faults`), every path read against every path written (`paths`), and flags that would do
//! nothing or blame another flag (`settings`).

mod common;

#[path = "hostile/support.rs"]
mod support;

#[path = "hostile/outputs.rs"]
mod outputs;

#[path = "hostile/inputs.rs"]
mod inputs;

#[path = "hostile/geometry.rs"]
mod geometry;

#[path = "hostile/stray.rs"]
mod stray;

#[path = "hostile/bounded.rs"]
mod bounded;

#[path = "hostile/parts.rs"]
mod parts;

#[path = "hostile/locks.rs"]
mod locks;

#[path = "hostile/faults.rs"]
mod faults;

#[path = "hostile/paths.rs"]
mod paths;

#[path = "hostile/settings.rs"]
mod settings;
