//! (being written) Public gradient checks.
