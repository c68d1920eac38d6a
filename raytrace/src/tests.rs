//! Unit tests of the whole pipeline (scene → BVH → traversal), kept in one module so the
//! crate builds one test binary.

mod bvh;
mod obj;
mod paths;
mod robustness;
mod sah;
mod shade;
mod wide;
