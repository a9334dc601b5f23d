//! The harness of rockwatch's integration tests (`tests/` at the repository root), one concern
//! per module:
//!
//! - [`process`]: running the rockwatch binary (one invocation with its options, a node, a
//!   child whose stderr is read as it comes); the binary's path comes from the test crate
//!   ([`rockwatch_bin!`]).
//! - [`fixtures`]: the shared data: repository paths, the Rinaldi record in its forms, the
//!   engine tests' blocks, a node configuration.
//! - [`physics_reference`]: independent numerical references for the physics tests
//!   (quadrature, root finding, an absolute-frame Newton–Euler solve).
//! - [`netns`]: network namespaces for the tests that open DDS or servers.
//! - [`node_output`]: reading what the node prints and serves (summary counts, JSON lines,
//!   Prometheus metrics).
//! - [`peers`]: the optional independent peers (ObsPy, Cyclone DDS, the colcon build of
//!   `msg/`).
//! - `seedlink_server` (feature `seedlink-server`): the SeedLink servers of the acquisition
//!   tests.
//!
//! It depends on the core and never on the shell: the core's tests use it too (see
//! Cargo.toml). The few helpers that need the shell's API are in `tests/shell_harness`.

pub mod fixtures;
pub mod netns;
pub mod node_output;
pub mod peers;
pub mod physics_reference;
pub mod process;
#[cfg(feature = "seedlink-server")]
pub mod seedlink_server;
