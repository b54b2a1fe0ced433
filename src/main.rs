//! The board binary. On the STM32 target it wires the NUCLEO-F446RE
//! (interrupts, clocks, drivers from pins, one task per role; the tasks and
//! the wiring table are in [`urechis::board`]); on any other target it only
//! explains itself, so host builds of the whole workspace (tests, host-sim)
//! stay green.
#![cfg_attr(all(target_os = "none", feature = "board"), no_std)]
#![cfg_attr(all(target_os = "none", feature = "board"), no_main)]

#[cfg(not(all(target_os = "none", feature = "board")))]
fn main() {
    eprintln!(
        "urechis firmware: build for the board with `cargo run --release` \
         (target thumbv7em-none-eabihf); on the host use host-sim (`cargo demo`)."
    );
}

#[cfg(all(target_os = "none", feature = "board"))]
mod firmware {
    use defmt_rtt as _;
    use embassy_executor::Spawner;
    use embassy_stm32::flash::Flash;
    use embassy_stm32::gpio::{Input, Level, Output, Pull, Speed};
    use embassy_stm32::wdg::IndependentWatchdog;
    use embassy_stm32::{bind_interrupts, dma, peripherals, usart, Config};
    use embassy_sync::mutex::Mutex;
    use static_cell::StaticCell;
    use urechis::board::safe::{drive_outputs_safe, take_reset_record};
    use urechis::board::{
        control_task, pump_task, rx_task, sensor_task, tx_task, BoardFlash, BoardStore,
        ControlOutputs, Pump, Sensor, SensorBus, StepTimer, RX_RING_BYTES, SHARED,
        WATCHDOG_TIMEOUT_US,
    };
    use urechis::controller::{Controller, Fault};
    use urechis::drivers::pump::{PumpConfig, PumpPins};
    use urechis::protocol::{Hello, TableSource};
    use urechis::store::{Store, BOARD_LAYOUT};
    use urechis::table::generated::TABLE;
    use urechis::table::image::TableBuf;
    use urechis::tasks::control::BootInfo;
    use urechis::tasks::link::BAUD_RATE;
    use urechis::tasks::sensor::{MODEL, OSR};
    use urechis::tasks::stored_table;

    // DMA streams per RM0390 table 28: USART2 RX stream 5 / TX stream 6
    // (DMA1, channel chosen by the HAL); the sensor bus binds its own
    // (`urechis::board::I2cIrqs`).
    bind_interrupts!(struct Irqs {
        TIM1_UP_TIM10 => urechis::board::step_timer::UpdateInterrupt;
        USART2 => usart::InterruptHandler<peripherals::USART2>;
        DMA1_STREAM5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
        DMA1_STREAM6 => dma::InterruptHandler<peripherals::DMA1_CH6>;
    });

    #[embassy_executor::main]
    async fn main(spawner: Spawner) {
        // Before anything else: every output at its safe level (the same
        // routine as the Fault state and the panic handler), and why the
        // last run ended.
        let _ = drive_outputs_safe();
        let panicked = take_reset_record();
        let mut config = Config::default();
        {
            // HSI 16 MHz / 8 = 2 MHz into the PLL (the input ST recommends,
            // for the least jitter), × 168 = 336 MHz VCO (100–432 MHz), / 4 =
            // 84 MHz; no overdrive needed, flash wait states set by the HAL.
            // APB1 ≤ 45 MHz on the F446.
            use embassy_stm32::rcc::*;
            config.rcc.hsi = true;
            config.rcc.pll_src = PllSource::HSI;
            config.rcc.pll = Some(Pll {
                prediv: PllPreDiv::DIV8,
                mul: PllMul::MUL168,
                divp: Some(PllPDiv::DIV4),
                divq: None,
                divr: None,
            });
            config.rcc.sys = Sysclk::PLL1_P;
            config.rcc.ahb_pre = AHBPrescaler::DIV1;
            config.rcc.apb1_pre = APBPrescaler::DIV2;
            config.rcc.apb2_pre = APBPrescaler::DIV1;
        }
        // Read before init: the watchdog's reset flag says whether the last
        // run ended in a stalled control loop.
        let csr = embassy_stm32::pac::RCC.csr().read();
        let p = embassy_stm32::init(config);
        embassy_stm32::pac::RCC.csr().modify(|w| w.set_rmvf(true));
        defmt::info!(
            "urechis {} (reset: watchdog {}, pin {}, power-on {}, software {})",
            env!("CARGO_PKG_VERSION"),
            csr.wdgrstf(),
            csr.padrstf(),
            csr.porrstf(),
            csr.sftrstf()
        );
        if let Some((kind, pc)) = panicked {
            defmt::error!("the last run ended in a {} (pc {=u32:#010x})", kind, pc);
        }

        // Table: an uploaded one from flash if it verifies, else the
        // compiled-in one (a bad one is logged; the controller refuses
        // `Start`). The zero: the last tare's, from flash.
        let mut store = Store::new(BoardFlash(Flash::new_blocking(p.FLASH)), BOARD_LAYOUT);
        let (uploaded, stored) = stored_table(&mut store);
        static TABLE_BUF: StaticCell<TableBuf> = StaticCell::new();
        let (table, table_source) = match uploaded {
            Some(buf) => (TABLE_BUF.init(buf).table(), TableSource::Uploaded),
            None => (TABLE, TableSource::CompiledIn),
        };
        match table.verify() {
            Ok(()) => defmt::info!(
                "table: {} depths x {} diameters, CRC {=u32:#010x}, placeholder {}",
                table.depths_mm.len(),
                table.diameters_mm.len(),
                table.checksum,
                table.placeholder
            ),
            Err(e) => defmt::error!("table: verification failed ({}): the cycle cannot start", e),
        }
        match store.load_zero() {
            Ok(Some(zero)) => {
                defmt::info!("sensor: zero {} kPa absolute, from the last tare", zero);
                SHARED.set_zero_kpa(Some(zero));
            }
            Ok(None) => defmt::warn!("sensor: no zero stored: tare before the first start"),
            Err(e) => defmt::error!("sensor: zero unreadable ({}): tare again", e),
        }
        static STORE: StaticCell<BoardStore> = StaticCell::new();
        let store: &'static BoardStore = STORE.init(Mutex::new(store));

        // Safe levels first: valve de-energised (open, vented), advance off,
        // stepper driver disabled (ENABLE is active low), STEP low with its
        // timer stopped.
        let relief_valve = Output::new(p.PA8, Level::Low, Speed::Low);
        let advance_drive = Output::new(p.PA9, Level::Low, Speed::Low);
        let enable = Output::new(p.PB5, Level::High, Speed::Low);
        let step = StepTimer::new(p.TIM1, p.PA10, Irqs);
        let dir = Output::new(p.PB3, Level::Low, Speed::Low);
        let end_empty = Input::new(p.PB4, Pull::Up);
        let end_full = Input::new(p.PB10, Pull::Up);

        let pins = PumpPins {
            step,
            dir,
            enable,
            end_empty,
            end_full,
        };
        let pump: Pump = match Pump::new(pins, PumpConfig::default()) {
            Ok(pump) => pump,
            Err(rejected) => defmt::panic!("pump: config rejected: {}", rejected.error),
        };

        let i2c = SensorBus::new(p.I2C1, p.PB8, p.PB9, p.DMA1_CH7, p.DMA1_CH0);
        let sensor = Sensor::new(i2c, MODEL, OSR);

        let mut uart_config = usart::Config::default();
        uart_config.baudrate = BAUD_RATE;
        let uart = match usart::Uart::new(
            p.USART2,
            p.PA3,
            p.PA2,
            p.DMA1_CH6,
            p.DMA1_CH5,
            Irqs,
            uart_config,
        ) {
            Ok(uart) => uart,
            Err(e) => defmt::panic!("usart2: {}", e),
        };
        let (tx, rx) = uart.split();
        static RX_RING: StaticCell<[u8; RX_RING_BYTES]> = StaticCell::new();
        let rx = rx.into_ring_buffered(RX_RING.init([0; RX_RING_BYTES]));

        let mut controller = Controller::with_default_params(table);
        if panicked.is_some() {
            // The handler drove the outputs safe and reset: come back up
            // latched, reporting the panic as a panic.
            controller.latch_fault(Fault::Panic);
        } else if csr.wdgrstf() {
            // The last run's control loop starved the watchdog: come back up
            // latched in the safe state, not in Idle.
            controller.latch_fault(Fault::ControlOverrun);
        }
        let outputs = ControlOutputs {
            relief_valve,
            advance_drive,
            watchdog: IndependentWatchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US),
        };

        // Each task fits its pool of one: spawning can only fail on a second
        // spawn of the same task, which this function never does.
        let boot = BootInfo {
            table_source,
            stored_table: stored,
        };
        spawner.spawn(defmt::unwrap!(pump_task(pump)));
        spawner.spawn(defmt::unwrap!(sensor_task(sensor, store)));
        spawner.spawn(defmt::unwrap!(tx_task(tx, Hello::new(&table))));
        spawner.spawn(defmt::unwrap!(rx_task(rx, store)));
        spawner.spawn(defmt::unwrap!(control_task(controller, outputs, boot)));
    }
}
