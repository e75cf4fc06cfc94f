//! The driver against mocked SPI frames and pins (embedded-hal-mock).

use super::*;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::digital::{Mock as Pin, State, Transaction as PinT};
use embedded_hal_mock::eh1::spi::{Mock as Spi, Transaction as SpiT};
use std::vec;
use std::vec::Vec;

type Dev = Ad2s1210<Spi<u8>, Pin, Pin, Pin, NoopDelay>;

fn frame(t: SpiT<u8>) -> Vec<SpiT<u8>> {
    vec![SpiT::transaction_start(), t, SpiT::transaction_end()]
}

fn sample_pulse() -> Vec<PinT> {
    vec![PinT::set(State::Low), PinT::set(State::High)]
}

struct Rig {
    spi: Vec<SpiT<u8>>,
    a0: Vec<PinT>,
    a1: Vec<PinT>,
    sample: Vec<PinT>,
}

impl Rig {
    fn new() -> Self {
        Rig { spi: vec![], a0: vec![], a1: vec![], sample: vec![] }
    }

    fn mode(&mut self, a0: State, a1: State) -> &mut Self {
        self.a0.push(PinT::set(a0));
        self.a1.push(PinT::set(a1));
        self
    }

    fn sample(&mut self) -> &mut Self {
        self.sample.extend(sample_pulse());
        self
    }

    fn spi(&mut self, t: SpiT<u8>) -> &mut Self {
        self.spi.extend(frame(t));
        self
    }

    fn build(&self) -> Dev {
        Ad2s1210::new(
            Spi::new(&self.spi),
            Pin::new(&self.a0),
            Pin::new(&self.a1),
            Pin::new(&self.sample),
            NoopDelay::new(),
        )
    }
}

fn done(dev: Dev) {
    let (mut spi, mut a0, mut a1, mut sample, _) = dev.release();
    spi.done();
    a0.done();
    a1.done();
    sample.done();
}

#[test]
fn position_is_sampled_and_read_in_one_24_bit_frame_with_the_faults() {
    let mut rig = Rig::new();
    rig.mode(State::Low, State::Low)
        .sample()
        .spi(SpiT::read_vec(vec![0xAB, 0xCD, 0x00]))
        .sample()
        .spi(SpiT::read_vec(vec![0x12, 0x34, Faults::LOSS_OF_SIGNAL]));
    let mut dev = rig.build();
    // Power-up resolution is 14 bits: the two low bits of the left-aligned word are dropped.
    let r = dev.read_position().unwrap();
    assert_eq!(r, Reading { value: 0xABCC, faults: Faults(0) });
    // The mode pins are not written again for a second position read.
    let r = dev.read_position().unwrap();
    assert_eq!(r.value, 0x1234);
    assert!(r.faults.has(Faults::LOSS_OF_SIGNAL) && r.faults.position_invalid());
    done(dev);
}

#[test]
fn velocity_is_signed_and_scales_with_resolution_and_clock() {
    let mut rig = Rig::new();
    rig.mode(State::Low, State::High).sample().spi(SpiT::read_vec(vec![0xC0, 0x03, 0x00]));
    let mut dev = rig.build();
    let r = dev.read_velocity().unwrap();
    assert_eq!(r.value, -0x4000, "0xC003 masked to 14 bits is -16384");
    done(dev);
    // Half of full scale at 14 bits and the nominal 8.192 MHz: 250 rps.
    assert_eq!(velocity_mrps(-0x4000, Resolution::Bits14, NOMINAL_CLKIN_HZ), -250_000);
    assert_eq!(velocity_mrps(0x7FFF, Resolution::Bits16, NOMINAL_CLKIN_HZ), 124_996);
    // A 10.24 MHz clock tracks 25 % faster.
    assert_eq!(velocity_mrps(0x4000, Resolution::Bits10, 10_240_000), 1_562_500);
}

#[test]
fn configure_writes_address_then_data_and_verifies_by_reading_back() {
    let control = Control {
        phase_lock_44: false,
        hysteresis: true,
        encoder_resolution: Resolution::Bits12,
        resolution: Resolution::Bits16,
    };
    assert_eq!(control.to_bits(), 0b0101_0111);
    assert_eq!(Control::from_bits(control.to_bits()), control);
    assert_eq!(Control::POWER_UP.to_bits(), 0x7E);
    let mut rig = Rig::new();
    rig.mode(State::High, State::High)
        .spi(SpiT::write_vec(vec![reg::CONTROL]))
        .spi(SpiT::write_vec(vec![0x57]))
        .spi(SpiT::write_vec(vec![reg::CONTROL]))
        .spi(SpiT::transfer(vec![reg::FAULT], vec![0x57]))
        // Back to position mode at 16 bits: nothing masked.
        .mode(State::Low, State::Low)
        .sample()
        .spi(SpiT::read_vec(vec![0xFF, 0xFF, 0]));
    let mut dev = rig.build();
    dev.configure(control).unwrap();
    assert_eq!(dev.resolution(), Resolution::Bits16);
    assert_eq!(dev.read_position().unwrap().value, 0xFFFF);
    done(dev);
}

#[test]
fn a_control_register_that_reads_back_wrong_is_an_error() {
    let mut rig = Rig::new();
    rig.mode(State::High, State::High)
        .spi(SpiT::write_vec(vec![reg::CONTROL]))
        .spi(SpiT::write_vec(vec![0x7E]))
        .spi(SpiT::write_vec(vec![reg::CONTROL]))
        .spi(SpiT::transfer(vec![reg::FAULT], vec![0x7A]));
    let mut dev = rig.build();
    assert_eq!(dev.configure(Control::POWER_UP), Err(Error::Verify { wrote: 0x7E, read: 0x7A }));
    // The resolution did not change.
    assert_eq!(dev.resolution(), Resolution::Bits14);
    done(dev);
}

#[test]
fn faults_are_cleared_by_sample_read_sample() {
    let mut rig = Rig::new();
    rig.sample()
        .mode(State::High, State::High)
        .spi(SpiT::write_vec(vec![reg::FAULT]))
        .spi(SpiT::transfer(vec![reg::FAULT], vec![Faults::CLIPPING | Faults::PARITY]))
        .sample();
    let mut dev = rig.build();
    let f = dev.clear_faults().unwrap();
    assert!(f.has(Faults::CLIPPING) && f.has(Faults::PARITY) && !f.has(Faults::LOSS_OF_SIGNAL));
    assert!(!Faults(Faults::PARITY).position_invalid());
    done(dev);
}

#[test]
fn excitation_thresholds_and_reset_are_register_writes() {
    // 10 kHz from 8.192 MHz: 10000 * 32768 / 8192000 = 40 = 0x28.
    assert_eq!(excitation_code(10_000, NOMINAL_CLKIN_HZ), Some(0x28));
    assert_eq!(excitation_code(2_000, NOMINAL_CLKIN_HZ), Some(8));
    assert_eq!(excitation_code(20_000, NOMINAL_CLKIN_HZ), Some(80));
    assert_eq!(excitation_code(1_999, NOMINAL_CLKIN_HZ), None);
    assert_eq!(excitation_code(20_001, NOMINAL_CLKIN_HZ), None);
    // A slow clock would need a code above 7 bits.
    assert_eq!(excitation_code(20_000, 4_000_000), None);
    let mut rig = Rig::new();
    rig.mode(State::High, State::High)
        .spi(SpiT::write_vec(vec![reg::EXCITATION_FREQUENCY]))
        .spi(SpiT::write_vec(vec![0x28]))
        .spi(SpiT::write_vec(vec![reg::LOS_THRESHOLD]))
        .spi(SpiT::write_vec(vec![0x2D]))
        .spi(SpiT::write_vec(vec![reg::SOFTWARE_RESET]));
    let mut dev = rig.build();
    assert_eq!(dev.set_excitation(10_000, NOMINAL_CLKIN_HZ), Ok(0x28));
    assert_eq!(dev.set_excitation(30_000, NOMINAL_CLKIN_HZ), Err(Error::OutOfRange));
    dev.set_threshold(Threshold::Los, 0x2D).unwrap();
    assert_eq!(dev.write_register(reg::LOT_LOW_THRESHOLD, 0x80), Err(Error::OutOfRange));
    dev.software_reset().unwrap();
    done(dev);
}
