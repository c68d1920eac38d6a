//! Ray tracing on the CPU and GPU, scheduled by `sched`. (Work in progress: see issue 3.)
