//! (being written) Optimisers.
