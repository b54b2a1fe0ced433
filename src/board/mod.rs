//! The embassy glue for the NUCLEO-F446RE: the concrete STM32 types behind
//! the generic tasks of [`crate::tasks`] (embassy tasks cannot be generic,
//! so each is a one-line wrapper here), the outputs the control task
//! drives, and the flash the store uses. The task table is in
//! [`crate::tasks`].
//!
//! # Wiring (NUCLEO-F446RE, Arduino header names in brackets)
//!
//! | signal | pin | notes |
//! |---|---|---|
//! | I²C1 SCL | PB8 (D15) | MS5837 SCL; 100 kHz, external 4.7 kΩ pull-ups to 3.3 V |
//! | I²C1 SDA | PB9 (D14) | MS5837 SDA |
//! | STEP | PA10 (D2) | stepper driver STEP (A4988/DRV8825) from TIM1_CH3 (AF1), idles low; fit a 10 kΩ pull-down so no edge steps the motor while the MCU is in reset |
//! | DIR | PB3 (D3) | stepper driver DIR (PB3 is SWO: leave SWO trace off) |
//! | ENABLE | PB5 (D4) | stepper driver EN, active low; boots high (off). Fit a 10 kΩ pull-up to 3.3 V so the driver also stays off while the MCU is in reset |
//! | end-stop EMPTY | PB4 (D5) | normally-closed microswitch to GND, internal pull-up: low in travel, high when the plunger is fully in (the switch opens) or the wire is broken; debounced 2 ms |
//! | end-stop FULL | PB10 (D6) | normally-closed microswitch to GND, internal pull-up: high when the plunger is fully out or the wire is broken; debounced 2 ms |
//! | relief valve | PA8 (D7) | logic-level N-MOSFET gate to a normally-open valve: high = energised = closed; fit 100 Ω in series and a 100 kΩ gate-source pull-down so the valve vents while the MCU is in reset |
//! | advance drive | PA9 (D8) | high = external advance drive on; fit a 10 kΩ pull-down so the drive stays off while the MCU is in reset |
//! | USART2 TX | PA2 | ST-LINK virtual COM port, 115200 8N1 |
//! | USART2 RX | PA3 | ST-LINK virtual COM port |
//!
//! Every output's resistor holds the level [`crate::safety::safe_outputs`]
//! drives, so the rig is as safe with the MCU in reset (pins floating) as
//! after a fault or a panic. DIR needs none: it does nothing with the
//! driver off.
//!
//! Sensor and pump grounds go to the NUCLEO's GND; the stepper driver's motor
//! supply is separate. Clocks: HSI 16 MHz → /8 = 2 MHz PLL input (ST's
//! recommended value) → 336 MHz VCO → /4 = 84 MHz SYSCLK (APB1 42 MHz,
//! APB2 84 MHz), so no solder-bridge change is needed for an external clock.
//!
//! # Flash
//!
//! Sectors 6 and 7 (`0x0804_0000`–`0x0807_FFFF`) hold the store
//! ([`crate::store::BOARD_LAYOUT`]); `src/board/memory.x` gives the linker only the
//! first 256 KiB. An erase stalls the CPU for up to a few seconds (128 KiB
//! sector, RM0390 §3.5): [`BoardFlash`] widens the independent watchdog to
//! its longest period around each erase and restores it afterwards. Erases
//! happen only in Idle (a table upload, every 8,192nd tare).

pub mod safe;
pub mod step_timer;

use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::gpio::{Input, Level, Output, OutputOpenDrain, Speed};
use embassy_stm32::i2c::{self, I2c, Master};
use embassy_stm32::mode::Async;
use embassy_stm32::peripherals::IWDG;
use embassy_stm32::time::Hertz;
use embassy_stm32::usart::{RingBufferedUartRx, UartTx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{dma, peripherals, Peri};
use embedded_hal::digital::OutputPin;
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};

use crate::controller::Controller;
use crate::drivers::i2c_bus_clear::{clear_bus, BusClearError};
use crate::drivers::ms5837::Ms5837;
use crate::drivers::pump::SyringePump;
use crate::protocol::Hello;
use crate::safety::{advance_level, valve_level};
use crate::tasks::control::BootInfo;
use crate::tasks::sensor::BusRecovery;
use crate::tasks::{self, ControlIo, Shared, StoreMutex};
pub use step_timer::StepTimer;

/// Independent-watchdog timeout (µs): ten control periods. The LSI clock
/// behind it may run up to 47 kHz instead of 32 kHz, which shortens this to
/// about 68 ms, still far above one period.
pub const WATCHDOG_TIMEOUT_US: u32 = 100_000;

/// Size of the RX DMA ring (bytes): 22 ms of line time at 115200 baud, read
/// out on every idle line or half-full ring.
pub const RX_RING_BYTES: usize = 256;

/// The tasks' channels and signals.
pub static SHARED: Shared = Shared::new();

/// The pump as the board builds it: STEP from TIM1 CH3 ([`StepTimer`]),
/// DIR and ENABLE outputs and the EMPTY, FULL end-stop inputs.
pub type Pump =
    SyringePump<StepTimer, Output<'static>, Output<'static>, Input<'static>, Input<'static>>;

/// I²C bus speed: 100 kHz tolerates the capacitance of a cable to a
/// buried sensor.
pub const I2C_HZ: u32 = 100_000;

// DMA streams per RM0390 table 28: I2C1 RX stream 0 / TX stream 7 (DMA1,
// channel chosen by the HAL).
embassy_stm32::bind_interrupts!(
    /// The interrupts of the sensor's I²C bus and its DMA streams.
    pub struct I2cIrqs {
        I2C1_EV => i2c::EventInterruptHandler<peripherals::I2C1>;
        I2C1_ER => i2c::ErrorInterruptHandler<peripherals::I2C1>;
        DMA1_STREAM0 => dma::InterruptHandler<peripherals::DMA1_CH0>;
        DMA1_STREAM7 => dma::InterruptHandler<peripherals::DMA1_CH7>;
    }
);

/// The sensor's I²C bus as the board builds it: I2C1 on PB8 (SCL) / PB9
/// (SDA) with DMA, which [`BusRecovery`] takes down, clears and builds
/// again.
pub struct SensorBus {
    /// `None` only inside a recovery.
    i2c: Option<I2c<'static, Async, Master>>,
}

impl SensorBus {
    /// The bus over the board's I2C1, PB8, PB9 and DMA1 streams 7 (TX)
    /// and 0 (RX), which it owns from now on.
    pub fn new(
        i2c1: Peri<'static, peripherals::I2C1>,
        scl: Peri<'static, peripherals::PB8>,
        sda: Peri<'static, peripherals::PB9>,
        tx_dma: Peri<'static, peripherals::DMA1_CH7>,
        rx_dma: Peri<'static, peripherals::DMA1_CH0>,
    ) -> Self {
        let mut config = i2c::Config::default();
        config.frequency = Hertz(I2C_HZ);
        Self {
            i2c: Some(I2c::new(i2c1, scl, sda, tx_dma, rx_dma, I2cIrqs, config)),
        }
    }
}

impl embedded_hal_async::i2c::ErrorType for SensorBus {
    type Error = i2c::Error;
}

impl embedded_hal_async::i2c::I2c for SensorBus {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [embedded_hal_async::i2c::Operation<'_>],
    ) -> Result<(), i2c::Error> {
        match &mut self.i2c {
            Some(i2c) => i2c.transaction(address, operations).await,
            None => Err(i2c::Error::Bus),
        }
    }
}

impl BusRecovery for SensorBus {
    fn recover_bus(&mut self) -> Result<(), BusClearError> {
        // Dropping the driver turns the peripheral's clock off and
        // disconnects its pins.
        self.i2c = None;
        // SAFETY: the driver that owned these singletons was just dropped;
        // this bus is their only user, and builds the driver again below.
        let (scl, sda) = unsafe { (peripherals::PB8::steal(), peripherals::PB9::steal()) };
        let cleared = {
            let mut scl = OutputOpenDrain::new(scl, Level::High, Speed::Low);
            let mut sda = OutputOpenDrain::new(sda, Level::High, Speed::Low);
            clear_bus(&mut scl, &mut sda, &mut embassy_time::Delay)
        };
        // Peripheral reset (RM0390 §6.3.13): a controller stuck in a
        // transfer state starts clean.
        let rcc = embassy_stm32::pac::RCC;
        rcc.apb1rstr().modify(|w| w.set_i2c1rst(true));
        rcc.apb1rstr().modify(|w| w.set_i2c1rst(false));
        // SAFETY: as above.
        let fresh = unsafe {
            SensorBus::new(
                peripherals::I2C1::steal(),
                peripherals::PB8::steal(),
                peripherals::PB9::steal(),
                peripherals::DMA1_CH7::steal(),
                peripherals::DMA1_CH0::steal(),
            )
        };
        *self = fresh;
        cleared.map(|_| ())
    }
}

/// The sensor as the board builds it.
pub type Sensor = Ms5837<SensorBus>;

/// The store as the board builds it.
pub type BoardStore = StoreMutex<BoardFlash>;

/// Pins and peripherals the control task drives directly.
pub struct ControlOutputs {
    /// Relief valve driver (normally open valve): high = energised = closed.
    pub relief_valve: Output<'static>,
    /// External advance drive: high = on.
    pub advance_drive: Output<'static>,
    /// The independent watchdog, not yet started.
    pub watchdog: IndependentWatchdog<'static, IWDG>,
}

impl ControlIo for ControlOutputs {
    fn set_relief_valve_open(&mut self, open: bool) {
        // Infallible on the STM32.
        let _ = self.relief_valve.set_state(valve_level(open));
    }

    fn set_advance_drive(&mut self, on: bool) {
        let _ = self.advance_drive.set_state(advance_level(on));
    }

    fn drive_safe(&mut self) {
        // Register writes: infallible.
        let _ = safe::drive_outputs_safe();
    }

    fn start_watchdog(&mut self) {
        self.watchdog.unleash();
    }

    fn feed_watchdog(&mut self) {
        self.watchdog.pet();
    }
}

/// The internal flash, with the watchdog widened around erases.
pub struct BoardFlash(pub Flash<'static, Blocking>);

impl ErrorType for BoardFlash {
    type Error = embassy_stm32::flash::Error;
}

impl ReadNorFlash for BoardFlash {
    const READ_SIZE: usize = <Flash<'static, Blocking> as ReadNorFlash>::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.0.read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl NorFlash for BoardFlash {
    const WRITE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::WRITE_SIZE;
    const ERASE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        use embassy_stm32::pac::iwdg::vals::{Key, Pr};
        let wdg = embassy_stm32::pac::IWDG;
        let (pr, rl) = (wdg.pr().read().pr(), wdg.rlr().read().rl());
        let set = |pr: Pr, rl: u16| {
            while wdg.sr().read().pvu() || wdg.sr().read().rvu() {}
            wdg.kr().write(|w| w.set_key(Key::ENABLE));
            wdg.pr().write(|w| w.set_pr(pr));
            wdg.rlr().write(|w| w.set_rl(rl));
            wdg.kr().write(|w| w.set_key(Key::RESET));
        };
        // /256 and the full reload: about 32 s at 32 kHz, 22 s at 47 kHz.
        set(Pr::from_bits(6), 0x0FFF);
        let result = self.0.erase(from, to);
        set(pr, rl);
        result
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.0.write(offset, bytes)
    }
}

/// The sensor task ([`tasks::sensor::run`]).
#[embassy_executor::task]
pub async fn sensor_task(sensor: Sensor, store: &'static BoardStore) -> ! {
    tasks::sensor::run(sensor, &SHARED, store).await
}

/// The pump task ([`tasks::pump::run`]).
#[embassy_executor::task]
pub async fn pump_task(pump: Pump) -> ! {
    tasks::pump::run(pump, &SHARED).await
}

/// The control task ([`tasks::control::run`]).
#[embassy_executor::task]
pub async fn control_task(
    controller: Controller<'static>,
    mut io: ControlOutputs,
    boot: BootInfo,
) -> ! {
    tasks::control::run(controller, &mut io, &SHARED, boot).await
}

/// The link's receiver ([`tasks::link::rx`]).
#[embassy_executor::task]
pub async fn rx_task(rx: RingBufferedUartRx<'static>, store: &'static BoardStore) -> ! {
    tasks::link::rx(rx, &SHARED, store).await
}

/// The link's transmitter ([`tasks::link::tx`]).
#[embassy_executor::task]
pub async fn tx_task(tx: UartTx<'static, Async>, hello: Hello) -> ! {
    tasks::link::tx(tx, &SHARED, hello).await
}
