//! The board's peripherals, simulated: the MS5837 answering its real
//! command bytes on an I²C bus, the pump's STEP/DIR/ENABLE pins and
//! end-stops wired to the emulated plant's syringe pump, the relief valve
//! and advance drive, and the UART as a pseudo-terminal.

use std::cell::Cell;
use std::convert::Infallible;
use std::io::Write;
use std::sync::{Arc, Mutex, MutexGuard};

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_time::Timer;
use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource, Operation};
use embedded_hal_async::i2c::{ErrorType as I2cErrorType, I2c};
use emulator::sensor::SensorFault;
use emulator::Plant;
use urechis::drivers::i2c_bus_clear::{clear_bus, BusClearError};
use urechis::drivers::ms5837::{
    compensate_raw, crc4, Calibration, ADDRESS, CMD_ADC_READ, CMD_CONVERT_D1, CMD_CONVERT_D2,
    CMD_PROM_READ, CMD_RESET,
};
use urechis::drivers::pump::{Direction, SimStepTimer, StepPulses};
use urechis::safety::{advance_level, safe_outputs, valve_level, SafePins};
use urechis::tasks::sensor::{BusRecovery, MODEL};
use urechis::tasks::ControlIo;

/// Everything the board's pins and bus touch, shared with the plant's
/// clock thread.
pub struct Rig {
    /// The emulated plant.
    pub plant: Plant,
    /// The sensor's atmosphere (absolute kPa): what reads as zero gauge in
    /// free water.
    pub atmosphere_kpa: f64,
    /// The sensor's RMS noise (kPa).
    pub noise_kpa: f64,
    /// The step timer on STEP (TIM1 CH3 on the board), on the board's
    /// clock: [`Rig::sync_steps`] delivers its edges to the plant.
    pub step_timer: SimStepTimer,
    /// DIR is high.
    pub dir_high: bool,
    /// ENABLE is low (the driver is on).
    pub enabled: bool,
    /// DIR level that injects.
    pub inject_dir_high: bool,
    /// Relief valve open (not energised).
    pub valve_open: bool,
    /// Advance drive on.
    pub advance_on: bool,
    /// Microsteps the plant took from STEP pulses.
    pub pulses: u64,
    /// Times the watchdog was fed since boot.
    pub watchdog_feeds: u64,
    /// Bus recoveries (bus clear and peripheral reset) the sensor task made.
    pub bus_recoveries: u64,
}

impl Rig {
    /// Runs the step timer up to the board's clock now: each rising edge
    /// with the driver on moves the plant's pump one microstep in DIR's
    /// direction (refused at a closed end-stop).
    pub fn sync_steps(&mut self) {
        let now_us = embassy_time::Instant::now().as_micros();
        let Rig {
            plant,
            step_timer,
            dir_high,
            enabled,
            inject_dir_high,
            pulses,
            ..
        } = self;
        step_timer.advance(now_us, |_| {
            if *enabled {
                let direction = if *dir_high == *inject_dir_high {
                    Direction::Inject
                } else {
                    Direction::Withdraw
                };
                if plant.pulse(direction) {
                    *pulses += 1;
                }
            }
        });
    }
}

/// The rig behind a lock (the board thread and the plant thread share it).
pub type SharedRig = Arc<Mutex<Rig>>;

/// Locks the rig; a poisoned lock (a panicked thread) still holds a whole
/// rig, so it is used as it is.
pub fn lock(rig: &SharedRig) -> MutexGuard<'_, Rig> {
    rig.lock().unwrap_or_else(|e| e.into_inner())
}

/// Which output pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PinRole {
    /// STEP, as the safe state drives it: low stops its timer.
    Step,
    /// DIR.
    Dir,
    /// ENABLE, active low.
    Enable,
    /// The relief valve's gate: high = energised = closed.
    Valve,
    /// The advance drive: high = on.
    Advance,
}

/// One of the board's output pins (the pump driver's inputs, the valve,
/// the advance drive).
pub struct PumpPin {
    rig: SharedRig,
    role: PinRole,
}

impl PumpPin {
    /// The pin `role` on `rig`.
    pub fn new(rig: SharedRig, role: PinRole) -> Self {
        Self { rig, role }
    }

    fn set(&mut self, high: bool) {
        let mut r = lock(&self.rig);
        match self.role {
            // Only the safe state drives STEP as a pin: it stops the timer
            // (the board's `drive_outputs_safe` does the same), after the
            // edges it already made.
            PinRole::Step => {
                if !high {
                    r.sync_steps();
                    r.step_timer.stop();
                }
            }
            PinRole::Dir => r.dir_high = high,
            PinRole::Enable => r.enabled = !high,
            PinRole::Valve => r.valve_open = !high,
            PinRole::Advance => r.advance_on = high,
        }
    }
}

impl PinErrorType for PumpPin {
    type Error = Infallible;
}

impl OutputPin for PumpPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.set(false);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.set(true);
        Ok(())
    }
}

/// STEP's timer, as the pump task drives it: the rig's [`SimStepTimer`]
/// on the board's clock, its edges delivered to the plant.
pub struct StepTimerPin {
    rig: SharedRig,
}

impl StepTimerPin {
    /// The step timer of `rig`.
    pub fn new(rig: SharedRig) -> Self {
        Self { rig }
    }

    /// The rig with the timer brought up to now.
    fn synced(&self) -> MutexGuard<'_, Rig> {
        let mut r = lock(&self.rig);
        r.sync_steps();
        r
    }
}

impl StepPulses for StepTimerPin {
    fn start(&mut self, first_us: u32, second_us: u32) {
        self.synced().step_timer.start(first_us, second_us);
    }

    fn queue_period(&mut self, period_us: u32) {
        self.synced().step_timer.queue_period(period_us);
    }

    fn finish(&mut self) {
        self.synced().step_timer.finish();
    }

    fn stop(&mut self) {
        self.synced().step_timer.stop();
    }

    fn pulses(&self) -> u32 {
        self.synced().step_timer.pulses()
    }

    fn running(&self) -> bool {
        self.synced().step_timer.running()
    }

    async fn wait_pulse(&mut self, seen: u32) {
        loop {
            let at_us = {
                let r = self.synced();
                match r.step_timer.next_completion_us() {
                    Some(at) if r.step_timer.pulses() == seen => at,
                    _ => return,
                }
            };
            Timer::at(embassy_time::Instant::from_micros(at_us)).await;
        }
    }
}

/// A normally-closed end-stop switch to GND with a pull-up, as the board
/// wires it: at the end the switch opens and the pin reads high.
pub struct EndStopPin {
    rig: SharedRig,
    empty: bool,
}

impl EndStopPin {
    /// The EMPTY (`empty`) or FULL switch of `rig`.
    pub fn new(rig: SharedRig, empty: bool) -> Self {
        Self { rig, empty }
    }

    fn triggered(&self) -> bool {
        let stops = lock(&self.rig).plant.end_stops();
        if self.empty {
            stops.empty
        } else {
            stops.full
        }
    }
}

impl PinErrorType for EndStopPin {
    type Error = Infallible;
}

impl InputPin for EndStopPin {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.triggered())
    }

    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.triggered())
    }
}

/// The relief valve, the advance drive and the watchdog.
pub struct Outputs {
    rig: SharedRig,
}

impl Outputs {
    /// The outputs of `rig`.
    pub fn new(rig: SharedRig) -> Self {
        Self { rig }
    }
}

impl Outputs {
    fn pin(&self, role: PinRole) -> PumpPin {
        PumpPin::new(Arc::clone(&self.rig), role)
    }
}

impl ControlIo for Outputs {
    fn set_relief_valve_open(&mut self, open: bool) {
        let _ = self.pin(PinRole::Valve).set_state(valve_level(open));
    }

    fn set_advance_drive(&mut self, on: bool) {
        let _ = self.pin(PinRole::Advance).set_state(advance_level(on));
    }

    fn drive_safe(&mut self) {
        // The board's routine, on the simulated pins (infallible).
        let _ = safe_outputs(SafePins {
            driver_enable: &mut self.pin(PinRole::Enable),
            step: &mut self.pin(PinRole::Step),
            relief_valve: &mut self.pin(PinRole::Valve),
            advance_drive: &mut self.pin(PinRole::Advance),
        });
    }

    fn start_watchdog(&mut self) {}

    fn feed_watchdog(&mut self) {
        lock(&self.rig).watchdog_feeds += 1;
    }
}

/// The calibration words of the simulated part: the datasheet's example
/// coefficients C1..C6 of the MS5837-02BA, factory bits 0x0340, and the
/// CRC-4 the firmware checks.
pub fn prom() -> [u16; 7] {
    let mut p = [0x0340, 46372, 43981, 29059, 27842, 31553, 28165];
    p[0] |= u16::from(crc4(&p)) << 12;
    p
}

/// Why the simulated bus refused a transaction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BusFault;

impl embedded_hal::i2c::Error for BusFault {
    fn kind(&self) -> ErrorKind {
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
    }
}

/// An MS5837-02BA on an I²C bus: reset, PROM read, D1/D2 conversions and
/// ADC read with the datasheet's command bytes. The temperature is held
/// at 20.00 °C (D2 = C5·2⁸), the pressure is the plant's line pressure at
/// the sensor plus the atmosphere and noise, turned into the D1 that the
/// firmware's own compensation maps back to it (to the part's 1 Pa).
pub struct Ms5837Sim {
    rig: SharedRig,
    prom: [u16; 7],
    calibration: Calibration,
    pointer: u8,
    adc: u32,
    last_d1: u32,
    noise_state: u32,
}

impl Ms5837Sim {
    /// The part on `rig`'s bus.
    pub fn new(rig: SharedRig) -> Self {
        let prom = prom();
        // The PROM above carries its own CRC: it always parses.
        let calibration = Calibration::from_prom(&prom).unwrap_or(Calibration {
            factory: prom[0],
            sens_t1: prom[1],
            off_t1: prom[2],
            tcs: prom[3],
            tco: prom[4],
            t_ref: prom[5],
            tempsens: prom[6],
        });
        Self {
            rig,
            prom,
            calibration,
            pointer: CMD_RESET,
            adc: 0,
            last_d1: 0,
            noise_state: 0x2545_F491,
        }
    }

    fn d2(&self) -> u32 {
        u32::from(self.calibration.t_ref) << 8
    }

    /// Uniform noise of RMS `rms` (kPa).
    fn noise_kpa(&mut self, rms: f64) -> f64 {
        let mut x = self.noise_state;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.noise_state = x;
        let u = f64::from(x) / f64::from(u32::MAX) * 2.0 - 1.0;
        u * rms * 3f64.sqrt()
    }

    /// The D1 whose compensated pressure is `pa` (binary search on the
    /// firmware's own compensation, increasing in D1).
    fn d1_for(&self, pa: i64) -> u32 {
        let d2 = self.d2();
        // The ADC's 24 bits.
        let (mut lo, mut hi) = (1u32, 0x00FF_FFFF);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            let p = i64::from(compensate_raw(MODEL, &self.calibration, mid, d2).pressure_pa);
            if p < pa {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        lo
    }

    fn convert_d1(&mut self, fault: Option<SensorFault>) -> u32 {
        if fault == Some(SensorFault::Frozen) && self.last_d1 != 0 {
            return self.last_d1;
        }
        let (sensed, atmosphere, rms) = {
            let r = lock(&self.rig);
            (r.plant.truth().sensed_kpa, r.atmosphere_kpa, r.noise_kpa)
        };
        let kpa = atmosphere + sensed + self.noise_kpa(rms);
        let d1 = self.d1_for((kpa * 1000.0).round() as i64);
        self.last_d1 = d1;
        d1
    }
}

impl I2cErrorType for Ms5837Sim {
    type Error = BusFault;
}

impl I2c for Ms5837Sim {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), BusFault> {
        let fault = {
            let mut r = lock(&self.rig);
            let fault = r.plant.sensor_fault();
            if r.plant.sensor_mut().injected_attempt_fails() {
                return Err(BusFault);
            }
            fault
        };
        if fault == Some(SensorFault::Hang) {
            core::future::pending::<()>().await;
        }
        if address != ADDRESS {
            return Err(BusFault);
        }
        for op in operations.iter_mut() {
            match op {
                Operation::Write(bytes) => {
                    let Some(&cmd) = bytes.first() else { continue };
                    self.pointer = cmd;
                    if cmd == CMD_RESET {
                        self.adc = 0;
                    } else if (CMD_CONVERT_D1..CMD_CONVERT_D1 + 10).contains(&cmd) {
                        self.adc = self.convert_d1(fault);
                    } else if (CMD_CONVERT_D2..CMD_CONVERT_D2 + 10).contains(&cmd) {
                        self.adc = self.d2();
                    }
                }
                Operation::Read(buf) => {
                    if self.pointer == CMD_ADC_READ {
                        let v = self.adc.to_be_bytes();
                        for (b, v) in buf.iter_mut().zip(&v[1..]) {
                            *b = *v;
                        }
                        // A second read without a conversion reads 0.
                        self.adc = 0;
                    } else if (CMD_PROM_READ..CMD_PROM_READ + 14).contains(&self.pointer) {
                        let i = usize::from((self.pointer - CMD_PROM_READ) / 2);
                        let w = self.prom.get(i).copied().unwrap_or(0).to_be_bytes();
                        for (b, v) in buf.iter_mut().zip(&w) {
                            *b = *v;
                        }
                    } else {
                        buf.fill(0);
                    }
                }
            }
        }
        Ok(())
    }
}

/// The two lines of the simulated bus during a bus clear: a device that
/// holds SDA low lets go after a few SCL pulses.
struct Lines {
    /// SCL pulses the device still needs before it releases SDA.
    held_for: Cell<u8>,
    scl_high: Cell<bool>,
    sda_driven_low: Cell<bool>,
}

/// SCL, driven by the bus clear.
struct Scl<'a>(&'a Lines);
/// SDA, driven and read by the bus clear.
struct Sda<'a>(&'a Lines);

impl PinErrorType for Scl<'_> {
    type Error = Infallible;
}

impl OutputPin for Scl<'_> {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.scl_high.set(false);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        if !self.0.scl_high.get() {
            // A rising edge clocks the stuck device one bit on.
            self.0.held_for.set(self.0.held_for.get().saturating_sub(1));
        }
        self.0.scl_high.set(true);
        Ok(())
    }
}

impl PinErrorType for Sda<'_> {
    type Error = Infallible;
}

impl OutputPin for Sda<'_> {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.0.sda_driven_low.set(true);
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Infallible> {
        self.0.sda_driven_low.set(false);
        Ok(())
    }
}

impl InputPin for Sda<'_> {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(!self.is_low()?)
    }

    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(self.0.sda_driven_low.get() || self.0.held_for.get() > 0)
    }
}

/// Timing is not simulated on the bus lines.
struct NoDelay;

impl embedded_hal::delay::DelayNs for NoDelay {
    fn delay_ns(&mut self, _ns: u32) {}
}

/// SCL pulses a device holding SDA needs before it lets go (it was
/// caught after three bits of a byte).
pub const STUCK_SDA_CLOCKS: u8 = 6;

impl BusRecovery for Ms5837Sim {
    fn recover_bus(&mut self) -> Result<(), BusClearError> {
        let stuck = lock(&self.rig).plant.sensor_fault() == Some(SensorFault::StuckSda);
        let lines = Lines {
            held_for: Cell::new(if stuck { STUCK_SDA_CLOCKS } else { 0 }),
            scl_high: Cell::new(true),
            sda_driven_low: Cell::new(false),
        };
        // The firmware's own bus clear, on the simulated lines.
        let result = clear_bus(&mut Scl(&lines), &mut Sda(&lines), &mut NoDelay);
        let mut r = lock(&self.rig);
        if result.is_ok() {
            r.plant.sensor_mut().bus_cleared();
        }
        r.bus_recoveries += 1;
        result.map(|_| ())
    }
}

/// Bytes the host sent, on their way to the link's receive task.
pub type RxPipe = Pipe<CriticalSectionRawMutex, 1024>;

/// The UART's transmit side: frames go to the pseudo-terminal at the
/// board's line rate (115200 baud, 10 bits a byte); bytes the host does
/// not take within a few milliseconds are dropped, as a virtual COM port
/// with nobody listening drops them.
pub struct PtyTx {
    port: Box<dyn serialport::SerialPort>,
}

impl PtyTx {
    /// Transmits on `port` (the pseudo-terminal's master side).
    pub fn new(port: Box<dyn serialport::SerialPort>) -> Self {
        Self { port }
    }
}

/// Microseconds one byte takes at 115200 baud, 8N1.
pub const BYTE_US: u64 = 87;

impl embedded_io_async::ErrorType for PtyTx {
    type Error = Infallible;
}

impl embedded_io_async::Write for PtyTx {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        // A full pseudo-terminal (nobody reading) times out: dropped.
        let _ = self.port.write_all(buf);
        Timer::after_micros(BYTE_US * buf.len() as u64).await;
        Ok(buf.len())
    }

    async fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use emulator::PlantConfig;

    #[test]
    fn the_safe_state_stops_the_step_timer() {
        let plant = Plant::new(&PlantConfig::paper(), 40.0, 1).expect("paper plant");
        let rig = Arc::new(Mutex::new(Rig {
            plant,
            atmosphere_kpa: 101.325,
            noise_kpa: 0.0,
            step_timer: SimStepTimer::new(),
            dir_high: true,
            enabled: true,
            inject_dir_high: true,
            valve_open: false,
            advance_on: true,
            pulses: 0,
            watchdog_feeds: 0,
            bus_recoveries: 0,
        }));
        let mut step = StepTimerPin::new(Arc::clone(&rig));
        // A long first period: the timer is still running at the check.
        step.start(60_000, 1_000);
        assert!(step.running());
        Outputs::new(Arc::clone(&rig)).drive_safe();
        assert!(!step.running());
        let r = lock(&rig);
        assert!(!r.step_timer.step_high());
        assert!(!r.enabled && r.valve_open && !r.advance_on);
        assert_eq!(r.pulses, 0);
    }
}
