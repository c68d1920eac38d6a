//! Collision queries on parry3d, scheduled by `sched`. (Work in progress: see issue 6.)
