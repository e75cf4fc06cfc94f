//! The driver against mocked SPI frames and a mocked DRDY pin (embedded-hal-mock).

use super::*;
use embedded_hal_mock::eh1::digital::{Mock as Pin, State, Transaction as PinT};
use embedded_hal_mock::eh1::spi::{Mock as Spi, Transaction as SpiT};
use std::vec;
use std::vec::Vec;

/// An input frame: command word, optional data word, zeros.
fn input(cmd: u16, data: Option<u16>) -> Vec<u8> {
    let mut f = vec![0u8; FRAME_BYTES];
    f[..2].copy_from_slice(&cmd.to_be_bytes());
    if let Some(d) = data {
        f[3..5].copy_from_slice(&d.to_be_bytes());
    }
    f
}

/// An output frame with a correct CRC.
fn output(response: u16, channels: [i32; 4]) -> Vec<u8> {
    let mut f = vec![0u8; FRAME_BYTES];
    f[..2].copy_from_slice(&response.to_be_bytes());
    for (i, c) in channels.iter().enumerate() {
        let b = c.to_be_bytes();
        f[3 * (1 + i)..3 * (2 + i)].copy_from_slice(&b[1..]);
    }
    let crc = CRC16.checksum(&f[..15]);
    f[15..17].copy_from_slice(&crc.to_be_bytes());
    f
}

fn frame(cmd: u16, data: Option<u16>, out: Vec<u8>) -> [SpiT<u8>; 3] {
    [
        SpiT::transaction_start(),
        SpiT::transfer_in_place(input(cmd, data), out),
        SpiT::transaction_end(),
    ]
}

fn dev(frames: &[[SpiT<u8>; 3]], drdy: &[PinT]) -> Ads131m04<Spi<u8>, Pin> {
    let t: Vec<SpiT<u8>> = frames.iter().flat_map(|f| f.iter().cloned()).collect();
    Ads131m04::new(Spi::new(&t), Pin::new(drdy))
}

fn done(d: Ads131m04<Spi<u8>, Pin>) {
    let (mut spi, mut pin) = d.release();
    spi.done();
    pin.done();
}

#[test]
fn crc_is_ccitt_false() {
    assert_eq!(CRC16.checksum(b"123456789"), 0x29B1);
}

#[test]
fn conversions_are_24_bit_twos_complement_with_status() {
    let ch = [0x7F_FFFF, -0x80_0000, -1, 0x12_3456];
    let status = 0x0500 | 0b1111; // WLENGTH 24 bit, RESET, all DRDY
    let mut d = dev(&[frame(0, None, output(status, ch))], &[PinT::get(State::Low)]);
    assert!(d.data_ready().unwrap());
    let (s, got) = d.read().unwrap();
    assert_eq!(got, ch);
    assert!(s.reset() && !s.locked() && !s.crc_error());
    assert_eq!(s.word_length_code(), 1);
    assert!((0..4).all(|n| s.drdy(n)));
    done(d);
    assert_eq!(sign_extend_24([0x80, 0, 0]), -8_388_608);
    assert_eq!(code_to_uv(0x40_0000, 1), 600_000);
    assert_eq!(code_to_uv(-0x40_0000, 4), -150_000);
}

#[test]
fn a_corrupted_frame_fails_its_crc() {
    let mut bad = output(0x0500, [1, 2, 3, 4]);
    bad[7] ^= 0x10;
    let mut d = dev(&[frame(0, None, bad)], &[PinT::get(State::High)]);
    assert!(!d.data_ready().unwrap());
    assert!(matches!(d.read(), Err(Error::Crc { .. })));
    done(d);
}

#[test]
fn commands_are_answered_in_the_next_frame() {
    let z = [0; 4];
    let mut d = dev(
        &[
            frame(0x0011, None, output(0x0500, z)),
            frame(0x0000, None, output(0xFF24, z)),
            frame(0x0022, None, output(0x0500, z)),
            frame(0x0000, None, output(0x0022, z)),
            frame(0x0033, None, output(0x0022, z)),
            frame(0x0000, None, output(0x0033, z)),
        ],
        &[],
    );
    d.reset().unwrap();
    d.standby().unwrap();
    d.wakeup().unwrap();
    done(d);
}

#[test]
fn a_wrong_acknowledgement_is_an_error() {
    let z = [0; 4];
    let mut d =
        dev(&[frame(0x0011, None, output(0x0500, z)), frame(0x0000, None, output(0x0500, z))], &[]);
    assert_eq!(d.reset(), Err(Error::Response { command: 0x0011, expected: 0xFF24, got: 0x0500 }));
    done(d);
}

#[test]
fn registers_are_read_and_written_with_rreg_and_wreg() {
    let z = [0; 4];
    // RREG ID: 101a aaaa annn nnnn with a = 0, n - 1 = 0.
    assert_eq!(Command::Rreg(reg::ID).word(), 0xA000);
    assert_eq!(Command::Rreg(reg::MODE).word(), 0xA100);
    assert_eq!(Command::Wreg(reg::GAIN1).word(), 0x6200);
    assert_eq!(gain_register([1, 2, 4, 128]), 0x7210);
    let mut d = dev(
        &[
            frame(0xA000, None, output(0x0500, z)),
            frame(0x0000, None, output(0x2410, z)),
            frame(0x6200, Some(0x7210), output(0x0500, z)),
            frame(0x0000, None, output(0x4200, z)),
            frame(0xA180, None, output(0x0500, z)),
            frame(0x0000, None, output(0x0F0E, z)),
        ],
        &[],
    );
    assert_eq!(d.channel_count().unwrap(), 4);
    d.set_gains([1, 2, 4, 128]).unwrap();
    assert_eq!(d.read_register(reg::CLOCK).unwrap(), 0x0F0E);
    done(d);
}
