//! `rhier interact`: moves applied one at a time to a solved scene, against a
//! fresh solve of each configuration and against the brute force (every link
//! evaluated again), and the command line around it.

mod cli;
mod door;
mod kept;
mod moves;
mod prime;
mod restore;
mod shafts;
