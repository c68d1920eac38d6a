//! Rendering on the ranks of an MPI job (feature `mpi`): on rank 0, every other rank is one
//! more path device ([`RankPaths`]) beside rank 0's own, planned by the same engine
//! ([`render_over_ranks`]); the other ranks serve the tasks they are sent
//! ([`serve_paths`]). Only task ranges go out and the paths' values come back.

mod paths;

pub use paths::{PathOutput, RankPaths, render_over_ranks, serve_paths};
