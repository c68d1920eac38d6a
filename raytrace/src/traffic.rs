//! What crosses between the host and a device: bytes each way and the times the host waited.

use std::ops::AddAssign;

/// Bytes moved and host waits, counted where they happen (a buffer written or read back, a
/// wait for the device). A CPU device shares the host's memory and counts nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Traffic {
    /// Bytes written from the host to the device: task lists, parameters, tables.
    pub host_to_device_bytes: u64,
    /// Bytes read back from the device, the paths' values excepted (they are film bytes).
    pub device_to_host_bytes: u64,
    /// Times the host blocked until the device had finished its work.
    pub host_waits: u64,
}

impl AddAssign for Traffic {
    fn add_assign(&mut self, o: Self) {
        self.host_to_device_bytes += o.host_to_device_bytes;
        self.device_to_host_bytes += o.device_to_host_bytes;
        self.host_waits += o.host_waits;
    }
}

impl Traffic {
    /// Bytes both ways.
    pub fn bytes(&self) -> u64 {
        self.host_to_device_bytes + self.device_to_host_bytes
    }
}
