//! (being written) Learning rules.
