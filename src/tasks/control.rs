//! The control task: every [`CONTROL_PERIOD_MS`] it gathers the latest
//! inputs, calls [`Controller::step`] and hands the outputs on. It never
//! waits on anything but its ticker, so a slow link or sensor cannot stall
//! it; the independent watchdog is fed only when the step says so.

use core::sync::atomic::Ordering;

use embassy_time::{with_timeout, Duration, Ticker};

use super::log::{log_info, log_warn};
use super::{now_ms, PumpStatus, Shared, TareRequest};
use crate::controller::{
    Command, Controller, EndStops, Inputs, PressureSample, State, CONTROL_PERIOD_MS,
};
use crate::protocol::{
    DeviceMessage, FirmwareVersion, HostCommand, Info, NackReason, StoredTable, TableSource,
    TareError, PROTOCOL_VERSION,
};

/// Longest wait at boot for the sensor's first sample (ms): the part's
/// init takes about 20 ms. Past it the loop starts anyway and the
/// controller reports the missing sensor.
pub const FIRST_SAMPLE_TIMEOUT_MS: u64 = 1_000;

/// The outputs the control task drives itself, and the watchdog.
pub trait ControlIo {
    /// Relief valve (normally open part): `true` = open, line vented.
    fn set_relief_valve_open(&mut self, open: bool);
    /// External advance drive on or off.
    fn set_advance_drive(&mut self, on: bool);
    /// Starts the independent watchdog (once, before the first step).
    fn start_watchdog(&mut self);
    /// Feeds the watchdog.
    fn feed_watchdog(&mut self);
    /// Drives every output to its safe level with
    /// [`crate::safety::safe_outputs`] (driver off, STEP low, valve vented,
    /// advance off), whoever owns the pin otherwise: called before the
    /// first step and on every step in the Fault state.
    fn drive_safe(&mut self);
}

/// What the board found at boot, for [`Info`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BootInfo {
    /// Where the table the controller runs on came from.
    pub table_source: TableSource,
    /// What the flash's table area held.
    pub stored_table: StoredTable,
}

/// Runs the controller at [`CONTROL_PERIOD_MS`].
///
/// Each step reads the latest [`Shared::sample`] and
/// [`Shared::pump_status`] and at most one pending request from
/// [`Shared::requests`]; every request, and any other host frame the link
/// saw ([`Shared::host_seen`]), feeds the link watch
/// ([`HostCommand::link_feed`]). It hands the zero in force to the
/// controller, then signals the pump command, sets the valve and advance
/// outputs, queues the command's reply and one telemetry sample (counted
/// in [`Shared::telemetry_dropped`] when the queue is full), and feeds the
/// watchdog only if `feed_watchdog`. In the Fault state (and once before
/// the first step) the outputs are set by [`ControlIo::drive_safe`]. `GetParams` and `GetInfo` are
/// answered from the controller; `Tare` is passed to the sensor task in
/// Idle and refused otherwise.
pub async fn run<IO: ControlIo>(
    mut controller: Controller<'_>,
    io: &mut IO,
    shared: &Shared,
    boot: BootInfo,
) -> ! {
    if let Some(mut first) = shared.sample.receiver() {
        if with_timeout(Duration::from_millis(FIRST_SAMPLE_TIMEOUT_MS), first.get())
            .await
            .is_err()
        {
            log_warn!(
                "control: no sensor sample after {} ms, starting anyway",
                FIRST_SAMPLE_TIMEOUT_MS
            );
        }
    }
    io.drive_safe();
    io.start_watchdog();
    log_info!("control: running every {} ms", CONTROL_PERIOD_MS);

    let mut ticker = Ticker::every(Duration::from_millis(u64::from(CONTROL_PERIOD_MS)));
    let mut dropped_reported = 0;
    let mut last_state = controller.state();
    loop {
        ticker.next().await;
        let zero = shared.zero_kpa();
        if zero.map(f32::to_bits) != controller.pressure_zero_kpa().map(f32::to_bits) {
            controller.set_pressure_zero(zero);
        }
        let pump = shared.pump_status.try_get().unwrap_or(PumpStatus {
            // No report yet: the pump task has not run; refuse motion.
            volume_ml: f32::NAN,
            end_stops: EndStops {
                empty: true,
                full: true,
            },
        });
        let request = shared.requests.try_receive().ok();
        let seen = shared.host_seen.swap(false, Ordering::Relaxed);
        let now = now_ms();
        let command = match &request {
            Some(msg) => {
                answer(&controller, shared, &boot, msg.seq, &msg.body, now);
                Some(msg.body.link_feed())
            }
            None => seen.then_some(Command::Heartbeat),
        };
        let inputs = Inputs {
            now_ms: now,
            pressure: shared.sample.try_get().unwrap_or(PressureSample::Missing),
            pump_volume_ml: pump.volume_ml,
            end_stops: pump.end_stops,
            command,
        };
        let out = controller.step(&inputs);

        if out.state != last_state {
            log_info!(
                "control: {} -> {} (fault {})",
                last_state,
                out.state,
                out.telemetry.fault
            );
            last_state = out.state;
        }
        shared.set_state(out.state);
        shared.pump_command.signal(out.pump);
        if out.state == State::Fault {
            // The same routine as boot and the panic handler: the pump
            // task's Disable follows, but the pins do not wait for it.
            io.drive_safe();
        } else {
            io.set_relief_valve_open(out.relief_valve_open);
            io.set_advance_drive(out.advance_drive);
        }
        if let (Some(msg), Some(result)) = (&request, out.command_result) {
            // Requests answered above (GetParams, GetInfo, Tare) only fed
            // the link watch; their Heartbeat's result is no reply.
            if msg.body.to_controller().is_some() {
                shared.reply(DeviceMessage::command_reply(msg.seq, result));
            }
        }
        if shared.telemetry.try_send(out.telemetry).is_err() {
            shared.telemetry_dropped.fetch_add(1, Ordering::Relaxed);
        }
        if out.feed_watchdog {
            io.feed_watchdog();
        }

        let dropped = shared.telemetry_dropped.load(Ordering::Relaxed);
        if dropped != dropped_reported && out.telemetry.t_ms % 1_000 < CONTROL_PERIOD_MS {
            log_warn!("control: {} telemetry samples dropped so far", dropped);
            dropped_reported = dropped;
        }
    }
}

/// Answers the requests the controller's step does not: `GetParams`,
/// `GetInfo`, and `Tare` (handed to the sensor task in Idle).
fn answer(
    controller: &Controller<'_>,
    shared: &Shared,
    boot: &BootInfo,
    seq: u8,
    body: &HostCommand,
    now: u32,
) {
    match body {
        HostCommand::GetParams => shared.reply(DeviceMessage::Params {
            seq,
            params: *controller.params(),
        }),
        HostCommand::GetInfo => shared.reply(DeviceMessage::Info {
            seq,
            info: info(controller, shared, boot, now),
        }),
        HostCommand::Tare => {
            if controller.state() != State::Idle {
                shared.reply(DeviceMessage::nack(
                    seq,
                    NackReason::Tare(TareError::NotIdle),
                ));
            } else if shared.tare.signaled() {
                shared.reply(DeviceMessage::nack(seq, NackReason::Tare(TareError::Busy)));
            } else {
                shared.tare.signal(TareRequest {
                    seq,
                    params: *controller.params(),
                });
            }
        }
        _ => {}
    }
}

/// What the device runs and how it is, now.
pub fn info(controller: &Controller<'_>, shared: &Shared, boot: &BootInfo, now: u32) -> Info {
    let table = controller.table();
    let (last_fault, last_fault_ms) = match controller.last_fault() {
        Some((f, t)) => (Some(f), t),
        None => (None, 0),
    };
    Info {
        protocol_version: PROTOCOL_VERSION,
        firmware_version: FirmwareVersion::CURRENT,
        table_format_version: table.format_version,
        table_checksum: table.checksum,
        table_placeholder: table.placeholder,
        table_source: boot.table_source,
        stored_table: boot.stored_table,
        pressure_zero_kpa: controller.pressure_zero_kpa().unwrap_or(f32::NAN),
        state: controller.state(),
        fault: controller.fault(),
        alarm: controller.alarm(),
        last_fault,
        last_fault_ms,
        uptime_ms: now,
        frame_errors: shared.frame_errors.load(Ordering::Relaxed),
        telemetry_dropped: shared.telemetry_dropped.load(Ordering::Relaxed),
    }
}
