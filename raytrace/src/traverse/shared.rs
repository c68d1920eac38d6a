//! What the walks of rays sharing an origin (`shared_any.rs`, `shared_closest.rs`) have in
//! common: how many rays walk together, and the bit tricks over their per-ray masks (a byte
//! of bits per node, one per ray).

/// Rays walked together at most: one bit each in a byte of a node's masks.
pub(super) const PACKET: usize = 8;

/// `rows` with byte `r` bit `k` moved to byte `k` bit `r`: the rays that hit child `k`, from
/// the children each ray hits (three delta swaps, Hacker's Delight 7-3).
#[inline(always)]
pub(super) fn transpose8(mut x: u64) -> u64 {
    let t = (x ^ (x >> 7)) & 0x00AA_00AA_00AA_00AA;
    x ^= t ^ (t << 7);
    let t = (x ^ (x >> 14)) & 0x0000_CCCC_0000_CCCC;
    x ^= t ^ (t << 14);
    let t = (x ^ (x >> 28)) & 0x0000_0000_F0F0_F0F0;
    x ^ t ^ (t << 28)
}

/// A bit per non-zero byte of `x`.
#[inline(always)]
pub(super) fn nonzero_bytes(x: u64) -> u32 {
    let mut t = x | (x >> 4);
    t |= t >> 2;
    t |= t >> 1;
    ((t & 0x0101_0101_0101_0101).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u32
}
