//! colorimetry
