//! The virtual board: the firmware's own board tasks
//! ([`urechis::tasks`]: sensor, pump, control, link RX and TX, with their
//! channels and timing) run on the host against the emulated plant, and
//! speak the host link over a pseudo-terminal, so that `host-sim board`
//! (or any tool) drives it exactly as it drives the NUCLEO.
//!
//! What stands in for the hardware ([`peripherals`]):
//!
//! - the **MS5837** answers the driver's real command bytes (reset, PROM
//!   with its CRC-4, D1/D2 conversions, ADC read) on a simulated I²C bus,
//!   its pressure the plant's line pressure plus the atmosphere and noise;
//! - **STEP** comes from the firmware's model of its step timer
//!   ([`urechis::drivers::pump::SimStepTimer`], edges at the queued
//!   periods on the board's clock), each rising edge with the driver on
//!   (ENABLE) moving the plant's syringe pump one microstep in DIR's
//!   direction; the **end-stops** read its plunger position; the **relief
//!   valve** and **advance drive** go to the plant;
//! - the **flash** is a RAM sector with NOR semantics
//!   ([`urechis::store::RamFlash`]) that survives a [`VirtualBoard::reboot`];
//! - the **UART** is a pseudo-terminal, paced at 115200 baud.
//!
//! The clock ([`clock`]) runs in step with wall time by default, so a host
//! tool sees the board's real timing, and up to [`clock::MAX_SPEED`] times
//! faster on request ([`Options::speed`]; one speed per process). Each
//! task runs on a thread of its own under a small executor that sleeps
//! until a waker fires (the board runs them as five embassy tasks on one
//! core; here, as there, a task is polled only when it was woken).
//! The plant advances in 1 ms sub-steps on a thread of its own, following
//! the same clock.

pub mod clock;
pub mod peripherals;

use std::future::Future;
use std::pin::pin;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll, Wake, Waker};
use std::thread::{self, JoinHandle, Thread};
use std::time::Duration;

use anyhow::{anyhow, Context as _, Result};
use embassy_futures::select::select;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex as AsyncMutex;
use embassy_sync::signal::Signal;
use emulator::scenario::StateEntries;
use emulator::{Injection, Plant, PlantConfig};
use serialport::{SerialPort, TTYPort};
use urechis::controller::{Controller, State};
use urechis::drivers::ms5837::Ms5837;
use urechis::drivers::pump::{PumpConfig, PumpPins, SimStepTimer, SyringePump};
use urechis::protocol::{Hello, TableSource};
use urechis::store::{Layout, RamFlash, Store};
use urechis::table::generated::TABLE;
use urechis::tasks::control::BootInfo;
use urechis::tasks::sensor::{MODEL, OSR};
use urechis::tasks::{self, stored_table, Shared};

use peripherals::{
    lock, EndStopPin, Ms5837Sim, Outputs, PinRole, PtyTx, PumpPin, Rig, RxPipe, SharedRig,
    StepTimerPin,
};

/// The virtual flash: a 16 KiB table area and a 16 KiB zero area.
pub type VirtualFlash = RamFlash<0x8000, 0x4000>;

/// Where the store's areas are in [`VirtualFlash`].
pub const VIRTUAL_LAYOUT: Layout = Layout {
    table_offset: 0,
    table_len: 0x4000,
    zero_offset: 0x4000,
    zero_len: 0x4000,
};

/// How the virtual board is set up.
#[derive(Clone, Debug)]
pub struct Options {
    /// The plant and the faults put into it (an emulator scenario); `None`:
    /// the paper's actuator, healthy.
    pub scenario: Option<emulator::Scenario>,
    /// Sand cover above the actuator axis (mm) when no scenario gives one.
    pub depth_mm: f64,
    /// Seed of the plant's random draws.
    pub seed: u64,
    /// Board seconds per wall second (1 = real time; see [`clock`]).
    pub speed: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            scenario: None,
            depth_mm: 40.0,
            seed: 1,
            speed: 1.0,
        }
    }
}

/// What the board thread is told.
struct Control {
    /// Ends the current boot (reboot or shutdown).
    wake: Signal<CriticalSectionRawMutex, ()>,
    /// Stop for good.
    stop: AtomicBool,
    /// Boots so far (the tasks are running once it is non-zero).
    boots: AtomicU32,
    /// The controller's state, copied from the tasks for the plant's
    /// triggers (index in `State::ALL`).
    state: AtomicU8,
    /// Bytes from the host.
    rx: RxPipe,
}

/// A running virtual board.
pub struct VirtualBoard {
    port: String,
    control: Arc<Control>,
    rig: SharedRig,
    threads: Vec<JoinHandle<()>>,
    /// The pseudo-terminal's slave side, held open so the master never
    /// sees a hang-up between host sessions.
    _slave: TTYPort,
}

impl VirtualBoard {
    /// Creates the pseudo-terminal, the plant and the flash, and boots the
    /// board on threads of its own.
    pub fn start(options: &Options) -> Result<VirtualBoard> {
        clock::set_speed(options.speed)?;
        let (config, depth_mm, injections) = match &options.scenario {
            Some(s) => (s.plant.clone(), s.depth_mm, s.injections.clone()),
            None => (PlantConfig::paper(), options.depth_mm, Vec::new()),
        };
        let mut plant = Plant::new(&config, depth_mm, options.seed)?;
        // The firmware's sensor task reads the part; the plant's model of
        // one must not race it.
        plant.sensor_mut().attach_driver();
        let rig = Arc::new(Mutex::new(Rig {
            plant,
            atmosphere_kpa: config.sensor.atmosphere_kpa,
            noise_kpa: config.sensor.noise_kpa,
            step_timer: SimStepTimer::new(),
            dir_high: false,
            enabled: false,
            inject_dir_high: PumpConfig::default().inject_dir_high,
            valve_open: true,
            advance_on: false,
            pulses: 0,
            watchdog_feeds: 0,
            bus_recoveries: 0,
        }));
        // The slave side is held open without a lock: a host opens it
        // (exclusively) by its name.
        let (master, slave) = TTYPort::pair().context("creating a pseudo-terminal")?;
        let port = slave
            .name()
            .ok_or_else(|| anyhow!("the pseudo-terminal has no name"))?;
        let control = Arc::new(Control {
            wake: Signal::new(),
            stop: AtomicBool::new(false),
            boots: AtomicU32::new(0),
            state: AtomicU8::new(0),
            rx: RxPipe::new(),
        });
        let mut reader = master.try_clone().context("cloning the pseudo-terminal")?;
        let mut writer = master.try_clone().context("cloning the pseudo-terminal")?;
        reader.set_timeout(Duration::from_millis(20))?;
        writer.set_timeout(Duration::from_millis(5))?;
        let mut threads = Vec::new();
        {
            let control = Arc::clone(&control);
            threads.push(
                thread::Builder::new()
                    .name("vboard-uart-rx".into())
                    .spawn(move || uart_rx(reader, &control))?,
            );
        }
        {
            let control = Arc::clone(&control);
            let rig = Arc::clone(&rig);
            threads.push(
                thread::Builder::new()
                    .name("vboard-plant".into())
                    .spawn(move || plant_clock(&rig, &control, injections))?,
            );
        }
        {
            let control = Arc::clone(&control);
            let rig = Arc::clone(&rig);
            threads.push(
                thread::Builder::new()
                    .name("vboard-mcu".into())
                    .spawn(move || mcu(writer, &rig, &control))?,
            );
        }
        drop(master);
        // Returns once the MCU runs its tasks: a host may talk at once.
        let since = std::time::Instant::now();
        while control.boots.load(Ordering::Relaxed) == 0 {
            anyhow::ensure!(
                since.elapsed() < Duration::from_secs(10),
                "the virtual board did not boot within 10 s"
            );
            thread::sleep(Duration::from_millis(1));
        }
        Ok(VirtualBoard {
            port,
            control,
            rig,
            threads,
            _slave: slave,
        })
    }

    /// The pseudo-terminal a host opens (`/dev/pts/N`).
    pub fn port(&self) -> &str {
        &self.port
    }

    /// Resets the MCU: the tasks stop where they are and the board boots
    /// again (reading the table and the zero from its flash), as after a
    /// reset button press. The plant keeps its state. Returns once the
    /// board runs again.
    pub fn reboot(&self) -> Result<()> {
        let before = self.control.boots.load(Ordering::Relaxed);
        self.control.wake.signal(());
        let since = std::time::Instant::now();
        while self.control.boots.load(Ordering::Relaxed) == before {
            anyhow::ensure!(
                since.elapsed() < Duration::from_secs(10),
                "the virtual board did not boot again within 10 s"
            );
            thread::sleep(Duration::from_millis(1));
        }
        Ok(())
    }

    /// Microsteps the plant's pump took from STEP pulses so far.
    pub fn pulses(&self) -> u64 {
        lock(&self.rig).pulses
    }

    /// Bus recoveries the sensor task made so far (all boots).
    pub fn bus_recoveries(&self) -> u64 {
        lock(&self.rig).bus_recoveries
    }

    /// The plant's true state now.
    pub fn truth(&self) -> emulator::Truth {
        lock(&self.rig).plant.truth()
    }

    /// True while the relief valve is open and the pump driver is off: the
    /// safe state as the pins show it.
    pub fn outputs_safe(&self) -> bool {
        let r = lock(&self.rig);
        r.valve_open && !r.enabled
    }

    /// Stops the board and its threads.
    pub fn shutdown(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        self.control.stop.store(true, Ordering::Relaxed);
        self.control.wake.signal(());
        for t in self.threads.drain(..) {
            // A thread that panicked has nothing left to stop.
            let _ = t.join();
        }
    }
}

impl Drop for VirtualBoard {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Host bytes into the receive pipe.
fn uart_rx(mut port: Box<dyn SerialPort>, control: &Control) {
    let mut buf = [0u8; 256];
    while !control.stop.load(Ordering::Relaxed) {
        match std::io::Read::read(&mut port, &mut buf) {
            Ok(n) => {
                let mut rest = buf.get(..n).unwrap_or(&[]);
                while !rest.is_empty() && !control.stop.load(Ordering::Relaxed) {
                    match control.rx.try_write(rest) {
                        Ok(k) => rest = rest.get(k..).unwrap_or(&[]),
                        Err(_) => thread::sleep(Duration::from_millis(1)),
                    }
                }
            }
            Err(_) => thread::sleep(Duration::from_millis(1)),
        }
    }
}

/// The plant follows the board's clock in 1 ms sub-steps; the scenario's
/// injections fire on the controller's states.
fn plant_clock(rig: &SharedRig, control: &Control, mut pending: Vec<Injection>) {
    let mut entries = StateEntries::default();
    while !control.stop.load(Ordering::Relaxed) {
        let now_ms = tasks::now_ms();
        let state = State::ALL
            .get(usize::from(control.state.load(Ordering::Relaxed)))
            .copied()
            .unwrap_or(State::Idle);
        entries.note(state, now_ms);
        {
            let mut r = lock(rig);
            r.sync_steps();
            let (valve, advance) = (r.valve_open, r.advance_on);
            r.plant.set_outputs(valve, advance);
            r.plant.advance_to(now_ms, 100);
            // Scenario times count from its start command, which the
            // emulator gives at START_MS.
            let scenario_ms = entries
                .first_ms()
                .map(|s| now_ms.saturating_sub(s) + emulator::scenario::START_MS);
            pending.retain(|inj| {
                let due = entries.due(&inj.at, scenario_ms, now_ms);
                if due {
                    r.plant.inject(inj.fault);
                }
                !due
            });
        }
        thread::sleep(Duration::from_millis(1));
    }
}

/// The MCU: boots, runs the five tasks until a reset, boots again.
fn mcu(writer: Box<dyn SerialPort>, rig: &SharedRig, control: &Control) {
    let mut flash = VirtualFlash::new();
    let mut tx = PtyTx::new(writer);
    while !control.stop.load(Ordering::Relaxed) {
        let (f, t) = boot(flash, tx, rig, control);
        flash = f;
        tx = t;
        // What the host sent while the MCU was in reset is lost.
        control.rx.clear();
        // Pins go to their reset levels: timer stopped, driver off, valve
        // vented.
        let mut r = lock(rig);
        r.sync_steps();
        r.step_timer.stop();
        r.enabled = false;
        r.valve_open = true;
        r.advance_on = false;
    }
}

/// One boot of the board, as `src/main.rs` wires it, until a reset; gives
/// back what survives it (the flash and the UART).
fn boot(
    flash: VirtualFlash,
    mut tx: PtyTx,
    rig: &SharedRig,
    control: &Control,
) -> (VirtualFlash, PtyTx) {
    let mut store = Store::new(flash, VIRTUAL_LAYOUT);
    let (uploaded, stored) = stored_table(&mut store);
    let (table, table_source) = match &uploaded {
        Some(buf) => (buf.table(), TableSource::Uploaded),
        None => (TABLE, TableSource::CompiledIn),
    };
    let shared = Shared::new();
    if let Ok(zero) = store.load_zero() {
        shared.set_zero_kpa(zero);
    }
    let store = AsyncMutex::new(store);
    let controller = Controller::with_default_params(table);
    let boot = BootInfo {
        table_source,
        stored_table: stored,
    };
    let pins = PumpPins {
        step: StepTimerPin::new(Arc::clone(rig)),
        dir: PumpPin::new(Arc::clone(rig), PinRole::Dir),
        enable: PumpPin::new(Arc::clone(rig), PinRole::Enable),
        end_empty: EndStopPin::new(Arc::clone(rig), true),
        end_full: EndStopPin::new(Arc::clone(rig), false),
    };
    let mut outputs = Outputs::new(Arc::clone(rig));
    let sensor = Ms5837::new(Ms5837Sim::new(Arc::clone(rig)), MODEL, OSR);
    let hello = Hello::new(&table);
    match SyringePump::new(pins, PumpConfig::default()) {
        Ok(pump) => {
            // One thread per task, as the board's executor polls only the
            // task that was woken: the pump's microsteps do not hold up
            // the sensor's deadlines. They share only `Shared` and the
            // store, as on the board.
            let running = AtomicBool::new(true);
            let (shared, store, running) = (&shared, &store, &running);
            let outputs = &mut outputs;
            let tx = &mut tx;
            thread::scope(|s| {
                s.spawn(move || {
                    block_on(select(
                        async {
                            tasks::sensor::run(sensor, shared, store).await;
                        },
                        until_reset(running),
                    ))
                });
                s.spawn(move || {
                    block_on(select(
                        async {
                            tasks::pump::run(pump, shared).await;
                        },
                        until_reset(running),
                    ))
                });
                s.spawn(move || {
                    block_on(select(
                        async {
                            tasks::control::run(controller, outputs, shared, boot).await;
                        },
                        until_reset(running),
                    ))
                });
                s.spawn(move || {
                    block_on(select(
                        async {
                            tasks::link::rx(&control.rx, shared, store).await;
                        },
                        until_reset(running),
                    ))
                });
                s.spawn(move || {
                    block_on(select(
                        async {
                            tasks::link::tx(tx, shared, hello).await;
                        },
                        until_reset(running),
                    ))
                });
                let watch = async {
                    loop {
                        let i = State::ALL
                            .iter()
                            .position(|st| *st == shared.state())
                            .unwrap_or(0);
                        control.state.store(i as u8, Ordering::Relaxed);
                        embassy_time::Timer::after_millis(5).await;
                    }
                };
                control.boots.fetch_add(1, Ordering::Relaxed);
                block_on(select(watch, control.wake.wait()));
                running.store(false, Ordering::Relaxed);
            });
        }
        // The default configuration is valid; were it not, the board
        // would sit without tasks until the next reset.
        Err(_) => {
            control.boots.fetch_add(1, Ordering::Relaxed);
            block_on(control.wake.wait())
        }
    }
    (store.into_inner().into_flash(), tx)
}

/// Ends when `running` goes false (a reset), looking every 5 ms of board
/// time.
async fn until_reset(running: &AtomicBool) {
    while running.load(Ordering::Relaxed) {
        embassy_time::Timer::after_millis(5).await;
    }
}

/// Unparks the thread that polls.
struct Unpark(Thread);

impl Wake for Unpark {
    fn wake(self: Arc<Self>) {
        self.0.unpark();
    }
}

/// Polls `future` on this thread, sleeping until a waker fires.
fn block_on<F: Future>(future: F) -> F::Output {
    let mut future = pin!(future);
    let waker = Waker::from(Arc::new(Unpark(thread::current())));
    let mut cx = Context::from_waker(&waker);
    loop {
        if let Poll::Ready(out) = future.as_mut().poll(&mut cx) {
            return out;
        }
        thread::park();
    }
}
