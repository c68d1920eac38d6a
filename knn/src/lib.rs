//! k-nearest-neighbour queries on kiddo, scheduled by `sched`. (Work in progress: see issue 6.)
