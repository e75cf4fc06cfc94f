//! The host link's serial port: bytes only; framing and buffering are the firmware's.

pub trait HostSerial {
    /// The received byte, if one waits (also clears receive errors).
    fn read_byte(&mut self) -> Option<u8>;
    /// Writes `byte` if the transmitter takes it; false (nothing written) otherwise.
    fn write_byte(&mut self, byte: u8) -> bool;
    /// Receive interrupt on.
    fn listen_rx(&mut self);
    /// Transmit-empty interrupt on or off.
    fn listen_tx(&mut self, on: bool);
    /// Bytes lost to receive overruns so far.
    fn overruns(&self) -> u32;
}
