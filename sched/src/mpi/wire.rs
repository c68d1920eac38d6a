use std::ops::Range;

use thiserror::Error;

/// A value sent between ranks as bytes: tasks from rank 0 to the nodes, outputs back.
///
/// Both ends run the same build, so the format is plain little-endian without versioning.
/// There are two required methods.
pub trait Wire: Sized {
    /// Appends the value's bytes to `out`.
    fn encode(&self, out: &mut Vec<u8>);

    /// Reads one value from the front of `bytes` and advances it past the value.
    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError>;
}

/// Bytes that do not hold the value expected.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("expected {wanted}, found {left} byte(s)")]
pub struct WireError {
    /// What was being read.
    pub wanted: &'static str,
    /// Bytes left at that point.
    pub left: usize,
}

/// Takes `n` bytes from the front of `bytes`, or says what was missing.
pub fn take<'b>(
    bytes: &mut &'b [u8],
    n: usize,
    wanted: &'static str,
) -> Result<&'b [u8], WireError> {
    if bytes.len() < n {
        return Err(WireError {
            wanted,
            left: bytes.len(),
        });
    }
    let (head, tail) = bytes.split_at(n);
    *bytes = tail;
    Ok(head)
}

impl Wire for u64 {
    fn encode(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }

    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError> {
        let b = take(bytes, 8, "a u64")?;
        let mut a = [0; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
}

impl Wire for f64 {
    fn encode(&self, out: &mut Vec<u8>) {
        self.to_bits().encode(out);
    }

    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError> {
        u64::decode(bytes).map(f64::from_bits)
    }
}

/// A range of a buffer that every rank holds: the task is its own id.
impl Wire for Range<usize> {
    fn encode(&self, out: &mut Vec<u8>) {
        (self.start as u64).encode(out);
        (self.end as u64).encode(out);
    }

    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError> {
        let start = u64::decode(bytes)?;
        let end = u64::decode(bytes)?;
        let index = |v: u64| {
            usize::try_from(v).map_err(|_| WireError {
                wanted: "a range index that fits usize",
                left: bytes.len(),
            })
        };
        Ok(index(start)?..index(end)?)
    }
}

/// A list: its length, then its items.
impl<W: Wire> Wire for Vec<W> {
    fn encode(&self, out: &mut Vec<u8>) {
        (self.len() as u64).encode(out);
        for w in self {
            w.encode(out);
        }
    }

    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError> {
        let n = u64::decode(bytes)?;
        // Every item takes at least one byte, so a corrupt length cannot reserve gigabytes;
        // it runs out of bytes instead.
        let mut v = Vec::with_capacity(usize::try_from(n).unwrap_or(usize::MAX).min(bytes.len()));
        for _ in 0..n {
            v.push(W::decode(bytes)?);
        }
        Ok(v)
    }
}

impl Wire for String {
    fn encode(&self, out: &mut Vec<u8>) {
        (self.len() as u64).encode(out);
        out.extend_from_slice(self.as_bytes());
    }

    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError> {
        let n = u64::decode(bytes)?;
        let n = usize::try_from(n).unwrap_or(usize::MAX);
        let b = take(bytes, n, "a string")?;
        Ok(String::from_utf8_lossy(b).into_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        let tasks = vec![0..4usize, 4..9, 9..9];
        let mut out = Vec::new();
        tasks.encode(&mut out);
        1.5f64.encode(&mut out);
        String::from("rank 2: no such file").encode(&mut out);
        let mut b = &out[..];
        assert_eq!(Vec::<Range<usize>>::decode(&mut b), Ok(tasks));
        assert_eq!(f64::decode(&mut b), Ok(1.5));
        assert_eq!(
            String::decode(&mut b).as_deref(),
            Ok("rank 2: no such file")
        );
        assert!(b.is_empty());
    }

    #[test]
    fn truncated_bytes_are_an_error_not_a_panic() {
        let mut out = Vec::new();
        vec![1.0f64, 2.0].encode(&mut out);
        out.truncate(out.len() - 3);
        let err = Vec::<f64>::decode(&mut &out[..]).unwrap_err();
        assert_eq!(err.wanted, "a u64");
        assert_eq!(err.left, 5);
        // A length larger than what follows is an error, not a shorter list.
        let mut long = Vec::new();
        3u64.encode(&mut long);
        1.0f64.encode(&mut long);
        assert!(Vec::<f64>::decode(&mut &long[..]).is_err());
    }
}
