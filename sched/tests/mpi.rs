//! `sched::mpi` in a cluster of one: the process run without `mpirun` is rank 0 of 1.
//! MPI can be initialised once per process, so this is one test in a binary of its own;
//! several ranks are tested through `cobalt render` under `mpirun` (tests/mpi.rs at the root).
#![cfg(feature = "mpi")]

use sched::mpi::{Cluster, ClusterError};

#[test]
fn a_cluster_of_one() {
    let cluster = Cluster::init().expect("MPI starts as a singleton");
    assert_eq!((cluster.rank(), cluster.size()), (0, 1));
    assert!(cluster.is_root());
    // MPI is initialised once per process: a second cluster is an error, not a crash.
    assert_eq!(Cluster::init().err(), Some(ClusterError::Init));

    assert_eq!(cluster.agree("loading", Ok::<_, String>(7)), Ok(7));
    let err = cluster
        .agree("loading the scene", Err::<(), _>("no such file: a.obj"))
        .unwrap_err();
    assert_eq!(
        err,
        ClusterError::Failed {
            step: "loading the scene".into(),
            reasons: vec![(0, "no such file: a.obj".into())],
        }
    );
    assert_eq!(
        err.to_string(),
        "loading the scene failed on rank 0: no such file: a.obj"
    );
    // A failure without a message still counts as one.
    let silent = cluster.agree("building", Err::<(), _>("")).unwrap_err();
    assert_eq!(
        silent.to_string(),
        "building failed on rank 0: (no message)"
    );

    assert_eq!(cluster.all_gather_f64(&[1.0, 2.5]), vec![1.0, 2.5]);
    let mut bytes = vec![1, 2, 3];
    cluster.broadcast(&mut bytes);
    assert_eq!(bytes, vec![1, 2, 3]);
    assert_eq!(cluster.latency(3), vec![0.0]);
    // Nobody to tell: finishing a round of one rank sends nothing.
    cluster.finish();
    assert!(cluster.comm_seconds() > 0.0);
}
