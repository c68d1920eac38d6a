//! Seeded randomness for the tests that are not proptest's: SplitMix64, with the seed taken
//! from `COBALT_SEED` when set, so a failure can be replayed.

pub(crate) struct Rng(u64);

impl Rng {
    /// A generator seeded from `COBALT_SEED`, or from `default`; prints the seed so a failing
    /// run can be repeated.
    pub(crate) fn from_env(default: u64) -> Self {
        let seed = std::env::var("COBALT_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(default);
        eprintln!("seed {seed} (set COBALT_SEED to replay)");
        Rng(seed)
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub(crate) fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// A directory of this test process's own, named by `tag`, created if missing. It lies under
/// the build's own temporary folder, so runs leave nothing in the system's `/tmp`.
pub(crate) fn temp_dir(tag: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("cobalt-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// The built `cobalt` binary, to be given arguments. Its cache directory is one of its own,
/// empty: a render neither reads the user's calibration (so every test starts from equal
/// speeds, whatever ran before) nor writes into it.
pub(crate) fn command() -> std::process::Command {
    static SPAWNED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = SPAWNED.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_cobalt"));
    cmd.env("XDG_CACHE_HOME", temp_dir("cache").join(n.to_string()));
    cmd
}

/// Runs the built `cobalt` binary with `args` (see [`command`]).
pub(crate) fn cobalt(args: &[&str]) -> std::process::Output {
    command()
        .args(args)
        .output()
        .expect("the cobalt binary runs")
}
