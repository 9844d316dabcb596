//! shafts: see the crate tour in lib.rs. (Under construction.)
