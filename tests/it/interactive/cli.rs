//! The `rhier interact` command line.
