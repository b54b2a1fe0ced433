//! The control task: every [`CONTROL_PERIOD_MS`] it gathers the latest
//! inputs, calls [`Controller::step`] and hands the outputs on. It never
//! waits on anything but its ticker, so a slow link or sensor cannot stall
//! it; the independent watchdog is fed only when the step says so.

use core::sync::atomic::Ordering;

use embassy_stm32::gpio::{Level, Output};
use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_time::{with_timeout, Duration, Ticker};

use super::channels::{
    PumpStatus, PUMP_COMMAND, PUMP_STATUS, REQUESTS, SAMPLE, TELEMETRY, TELEMETRY_DROPPED,
};
use super::link::reply;
use super::now_ms;
use crate::controller::{Controller, EndStops, Inputs, PressureSample, CONTROL_PERIOD_MS};
use crate::protocol::{DeviceMessage, HostCommand, HostMessage};

/// Independent-watchdog timeout (µs): ten control periods. The LSI clock
/// behind it may run up to 47 kHz instead of 32 kHz, which shortens this to
/// about 68 ms, still far above one period.
pub const WATCHDOG_TIMEOUT_US: u32 = 100_000;

/// Longest wait at boot for the sensor's first sample (ms): init and tare
/// take about 0.2 s. Past it the loop starts anyway and the controller
/// reports the missing sensor.
pub const FIRST_SAMPLE_TIMEOUT_MS: u64 = 1_000;

/// Pins and peripherals the control task drives directly.
pub struct ControlOutputs {
    /// Relief valve driver (normally open valve): high = energised = closed.
    pub relief_valve: Output<'static>,
    /// External advance drive: high = on.
    pub advance_drive: Output<'static>,
    /// The independent watchdog, not yet started.
    pub watchdog: IndependentWatchdog<'static, IWDG>,
}

/// Runs the controller at [`CONTROL_PERIOD_MS`].
///
/// Each step reads the latest [`SAMPLE`] and [`PUMP_STATUS`] and at most one
/// pending request from [`REQUESTS`]; then signals the pump command, sets
/// the valve and advance outputs, queues the command's reply and one
/// telemetry sample (counted in [`TELEMETRY_DROPPED`] when the queue is
/// full), and pets the watchdog only if `feed_watchdog`. `GetParams` is
/// answered from the controller without a step input.
#[embassy_executor::task]
pub async fn control_task(mut controller: Controller<'static>, mut io: ControlOutputs) -> ! {
    if let Some(mut first) = SAMPLE.receiver() {
        if with_timeout(Duration::from_millis(FIRST_SAMPLE_TIMEOUT_MS), first.get())
            .await
            .is_err()
        {
            defmt::warn!(
                "control: no sensor sample after {} ms, starting anyway",
                FIRST_SAMPLE_TIMEOUT_MS
            );
        }
    }
    io.watchdog.unleash();
    defmt::info!(
        "control: running every {} ms, watchdog {} us",
        CONTROL_PERIOD_MS,
        WATCHDOG_TIMEOUT_US
    );

    let mut ticker = Ticker::every(Duration::from_millis(u64::from(CONTROL_PERIOD_MS)));
    let mut dropped_reported = 0;
    let mut last_state = controller.state();
    loop {
        ticker.next().await;
        let pump = PUMP_STATUS.try_get().unwrap_or(PumpStatus {
            // No report yet: the pump task has not run; refuse motion.
            volume_ml: f32::NAN,
            end_stops: EndStops {
                empty: true,
                full: true,
            },
        });
        let request = REQUESTS.try_receive().ok();
        let command = request.and_then(|msg| {
            if msg.body == HostCommand::GetParams {
                reply(DeviceMessage::Params {
                    seq: msg.seq,
                    params: *controller.params(),
                });
            }
            msg.body.to_controller()
        });
        let inputs = Inputs {
            now_ms: now_ms(),
            pressure: SAMPLE.try_get().unwrap_or(PressureSample::Missing),
            pump_volume_ml: pump.volume_ml,
            end_stops: pump.end_stops,
            command,
        };
        let out = controller.step(&inputs);

        if out.state != last_state {
            defmt::info!(
                "control: {} -> {} (fault {})",
                last_state,
                out.state,
                out.telemetry.fault
            );
            last_state = out.state;
        }
        PUMP_COMMAND.signal(out.pump);
        io.relief_valve.set_level(if out.relief_valve_open {
            Level::Low
        } else {
            Level::High
        });
        io.advance_drive.set_level(if out.advance_drive {
            Level::High
        } else {
            Level::Low
        });
        if let (Some(HostMessage { seq, .. }), Some(result)) = (request, out.command_result) {
            reply(DeviceMessage::command_reply(seq, result));
        }
        if TELEMETRY.try_send(out.telemetry).is_err() {
            TELEMETRY_DROPPED.fetch_add(1, Ordering::Relaxed);
        }
        if out.feed_watchdog {
            io.watchdog.pet();
        }

        let dropped = TELEMETRY_DROPPED.load(Ordering::Relaxed);
        if dropped != dropped_reported && out.telemetry.t_ms % 1_000 < CONTROL_PERIOD_MS {
            defmt::warn!("control: {} telemetry samples dropped so far", dropped);
            dropped_reported = dropped;
        }
    }
}
