//! The simulated world around the BioTac: the thesis data-collection protocol
//! (pushes with a wooden plate while an F/T sensor records the reference
//! wrench), and the pieces of the closed-loop world: the arm plant, the
//! skin-object contact and the person's finger.

pub mod arm;
pub mod collect;
pub mod contact;
pub mod finger;

pub use collect::{collect, CollectConfig};
