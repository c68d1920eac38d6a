//! cobalt's integration tests: one binary, one module per concern.

// Seeded randomness shared by the modules below.
mod testkit;

// Makespan guarantees of the policies against the exact optimum, and exactly-once delivery
// in the simulator, on random small instances.
mod policies;

// The threaded runtime: exactly-once outputs under injected errors and panics, and agreement
// with the simulator on static plans.
mod runtime;

// Costs and sizes at the extremes: 1e-12..1e12, a million equal tasks, 1024 devices.
mod extremes;

// The `cobalt schedule` command line: its output contract and its errors.
mod cli;

// `cobalt trace`: hits against an independent f64 reference, the file formats, bad rays.
mod trace;

// `cobalt render`: the PNGs and report it writes, and its argument errors.
mod render;

// `cobalt tradeoff`: the preset and AO-sample tables and their JSON.
mod tradeoff;

// Scenes in any units: the same image at every power-of-two scale, CPU and GPU.
mod scale;

// `cobalt estimate`: the JSON contract, exact estimates at full sampling, ray files, bad input.
mod estimate;

// `cobalt bench`: the run records, simulated records and charts it writes; bad values.
mod bench;

// `cobalt knn` and `cobalt collide`: the bench record shape, full sampling exact, bad input.
mod spatial;

// Scene formats: OBJ, PLY, glTF and GLB render the same image from the same triangles; a glTF's
// node transforms and materials as the baked OBJ's; malformed files of each are refused.
mod formats;

// Hostile input: special files, links and inputs given as outputs, failures at each step of
// writing, absurd sizes, odd encodings, degenerate scenes, overflowing costs, bad GPU settings;
// random and mutated argument lists, ray files and cost files.
mod hostile;

// `mpirun -np 3 cobalt render`: the image of one process, byte for byte; a scene missing on
// some ranks ends every rank with an error (feature `mpi`, needs Open MPI's `mpirun`).
#[cfg(feature = "mpi")]
mod mpi;

// Calibration files: what one render learns plans the next one's first frame, and a damaged
// file is named.
mod calibration;

// The modules of each crate import each other in one direction (no file depends on itself
// through others), and ARCHITECTURE.md names only paths that exist.
mod architecture;
mod imports;
