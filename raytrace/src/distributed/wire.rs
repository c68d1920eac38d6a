//! Hits on the wire: a node's outputs back to rank 0, and rank 0's whole generation to
//! every rank.

use sched::mpi::{Wire, WireError, take};

use crate::HitBatch;

/// Length, then `t` as `f32` bits and `prim`, both little-endian: the bit pattern travels, so
/// every rank shades exactly the hits the tracing rank found.
impl Wire for HitBatch {
    fn encode(&self, out: &mut Vec<u8>) {
        (self.len() as u64).encode(out);
        out.reserve(8 * self.len());
        for &t in &self.t {
            out.extend_from_slice(&t.to_bits().to_le_bytes());
        }
        for &p in &self.prim {
            out.extend_from_slice(&p.to_le_bytes());
        }
    }

    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError> {
        let n = u64::decode(bytes)?;
        let n = usize::try_from(n).unwrap_or(usize::MAX);
        let t = take(bytes, n.saturating_mul(4), "hit distances")?;
        let prim = take(bytes, n.saturating_mul(4), "primitive ids")?;
        let word = |c: &[u8]| u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        Ok(HitBatch {
            t: t.chunks_exact(4).map(|c| f32::from_bits(word(c))).collect(),
            prim: prim.chunks_exact(4).map(word).collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_round_trip_bit_for_bit() {
        let hits = HitBatch {
            t: vec![1.5, f32::INFINITY, -0.0, f32::from_bits(0x7fc0_0001)],
            prim: vec![7, HitBatch::MISS, 0, u32::MAX - 1],
        };
        let mut out = Vec::new();
        hits.encode(&mut out);
        let back = HitBatch::decode(&mut &out[..]).expect("decodes");
        assert_eq!(back.prim, hits.prim);
        let bits = |h: &HitBatch| h.t.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&hits));
        assert!(HitBatch::decode(&mut &out[..out.len() - 1]).is_err());
    }
}
