//! retina
