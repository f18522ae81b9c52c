//! The neural buckets of the cortex (paper S-03): W (lateral-inhibition weights), C (cone
//! types), D (demosaicker), P (cell positions), M (eye motion).

pub mod c;
pub mod d;
pub mod m;
pub mod p;
pub mod p_plain;
pub mod shift;
pub mod w;
