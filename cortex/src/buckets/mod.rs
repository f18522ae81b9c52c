//! The neural buckets of the cortex (paper S-03): W (lateral-inhibition weights), C (cone
//! types), D (demosaicker), P (cell positions). M (motion) lives in [`crate::motion`].

pub mod c;
pub mod d;
pub mod p;
pub mod p_plain;
pub mod shift;
pub mod w;
