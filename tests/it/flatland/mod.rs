//! Flatland, the 2D space-time radiosity of the paper: form factors, the visibility
//! complex and views against brute force, visibility events and incremental updates
//! of moving segments against from-scratch solves, scene validation and the CLI.

mod cli;
mod complex;
mod dynamic;
mod events;
mod form_factors;
mod scene;
mod views;
