//! The burrowing cycle: a pure, `no_std` state machine with no HAL and no
//! async inside. The board, the host emulator and the QEMU tests all call the
//! same [`Controller::step`], every [`CONTROL_PERIOD_MS`] (100 Hz). Only f32
//! basic operations and `libm` are used, so identical inputs give
//! bit-identical outputs on the host and on the Cortex-M4.
//!
//! # The cycle
//!
//! ```text
//!        Start                 target / plateau          hold_ms
//! Idle ─────────▶ Expand ───────────────────────▶ Hold ──────────▶ Shrink
//!  ▲               ▲                                                 │
//!  │               │ advance_ms (more cycles)                        │ volume back at rest
//!  │               └──────────────────────────── Advance ◀───────────┤
//!  └──── after `cycles` cycles, or after a Stop ─────────────────────┘
//! ```
//!
//! - **Idle**: pump held, valve closed. `Start` captures the pump volume as
//!   the rest volume and enters Expand. It is refused with `BadTable` when
//!   the table failed verification, and with `CauseActive` while
//!   [`Controller::alarm`] reports a condition (unhealthy sensor, closed
//!   end-stop, volume out of limits) or before the first valid reading,
//!   and with `NoPressureZero` unless a gauge zero inside
//!   [`PRESSURE_ZERO_RANGE_KPA`] was set ([`Controller::set_pressure_zero`]:
//!   the board takes it on the host's `Tare` command and keeps it in flash;
//!   it is never re-captured by itself).
//! - **Expand**: `Run { +expand_rate }`. The outer diameter is estimated two
//!   ways: from the pumped volume, `D = sqrt(D0² + 4·ΔV/(π·L))`
//!   ([`ExpansionZone`], D0 and L from the table), and from the table at the
//!   measured pressure, `table.diameter_mm(p, depth)`; telemetry carries
//!   both. Expansion ends (→ Hold) when the volume estimate would pass
//!   `target_diameter_mm` within the next period, when the table estimate
//!   has reached it (never over-expand: either estimate suffices), or
//!   earlier on the sand's plateau: with `p_e = p − table.membrane_kpa(D)`,
//!   once the least-squares slope dp_e/dV over a sliding window falls below
//!   `plateau_slope_fraction` × the largest slope of this expansion
//!   ([`PlateauDetector`], where the exact arming rules are).
//! - **Hold**: `Hold` for `hold_ms` (the sand collapses around the head).
//! - **Shrink**: `Run { −shrink_rate }` until the pump volume is within
//!   `rest_tolerance_ml` of the rest volume (it may end up to one period's
//!   withdrawal below it).
//! - **Advance**: pump `Hold`, `advance_drive = true` for `advance_ms`; one
//!   cycle is complete ([`Controller::cycle`]); then the next Expand, or
//!   Idle after `cycles` cycles (0 = until `Stop`).
//! - `Stop` from any active state: straight to Shrink, then Idle. In Idle it
//!   is a no-op. `SetParams` is accepted only in Idle (else `Busy`) and an
//!   invalid set is rejected whole (`InvalidParams`). `Reset` is a no-op in
//!   Idle and `Busy` in the other non-fault states.
//!
//! # Safety monitors
//!
//! A fault latches [`State::Fault`]: every step outputs
//! `PumpCommand::Disable`, `relief_valve_open = true`,
//! `advance_drive = false`, whatever the inputs; `Start`, `Stop` and
//! `SetParams` are refused with `Faulted`. `Reset` is refused with
//! `CauseActive` while any instantaneous cause is present (over-pressure
//! reading, sensor bus/range/stale condition, closed end-stop, volume out of
//! limits); otherwise it returns to Idle. A volume fault thus needs the pump
//! re-homed (power cycle): the driver stays disabled.
//!
//! Over-pressure and the volume limit are watched in every state (at rest
//! too: venting is the remedy). The sensor, end-stop, stall, leak,
//! mismatch and overrun monitors latch only while a cycle is active
//! (Expand, Hold, Shrink, Advance); in Idle they are reported by
//! [`Controller::alarm`] and block `Start`. Only the diameter mismatch
//! depends on the table (and the plateau stop, which is no fault); every
//! other monitor compares raw readings with parameters. When several
//! conditions hold in one step the first row below is reported.
//!
//! Bound: longest time from the last step with healthy inputs to the first
//! step whose outputs are safe (see [`detection_bound_ms`]; defaults in
//! brackets, as the `*_DETECT_MS` constants). End to end: from the physical
//! event to the line vented, adding the sensor's period and read time, the
//! oldest reading accepted (`sensor_stale_ms`), the end-stops' debounce and
//! the valve's response ([`end_to_end_bound_ms`] with [`BOARD_TIMING`]). A
//! panic or HardFault drives the outputs safe in its handler: the valve's
//! response alone [50 ms].
//!
//! | fault | detection rule | bound | end to end | where |
//! |---|---|---|---|---|
//! | `OverPressure` | reading > `max_pressure_kpa` (+∞ included, even above the sensor range) | 1 period [10 ms] | max(sensor period + read + bound, stale bound) + valve [110 ms] | all states |
//! | `SensorBus` | `sensor_bus_error_steps` consecutive `BusError`/`Missing` (the sensor task publishes `BusError` after two failed periods, [`crate::sensing`]) | 2 + that many periods from the first failed read [50 ms] | bound + valve [100 ms] | active |
//! | `SensorOutOfRange` | reading NaN, −∞ or below `sensor_min_kpa` | 1 period [10 ms] | as `OverPressure` [110 ms] | active |
//! | `SensorFrozen` | bit-identical reading for ≥ `sensor_frozen_ms` while the pump runs | `sensor_frozen_ms` + 1 period [310 ms] | bound + valve [360 ms] | active |
//! | `SensorStale` | `now − taken_ms` > `sensor_stale_ms` (wrapping; a future stamp is stale) | `sensor_stale_ms` + 1 period [60 ms] | bound + valve [110 ms] | active |
//! | `EndStop` | `empty` or `full` triggered (debounced) (injecting drives towards `empty`) | 1 period [10 ms] | debounce + poll + bound + valve [64 ms] | active |
//! | `VolumeLimit` | pump volume NaN, > `max_volume_ml` or < `min_volume_ml` | 1 period [10 ms] | bound + valve [60 ms] | all states |
//! | `PumpStall` | a block of `stall_volume_ml` pumped (counted steps) with a pressure change < `stall_min_rise_kpa`: a rise in Expand, a fall in Shrink (unless already within that of the pressure at `Start`) | 2 blocks at the slower pumping rate + 2 periods + the pump's ramp [1030 ms] | sensor period + read + bound + valve [1097 ms] | Expand, Shrink |
//! | `Leak` | in Hold, pressure > max(`leak_max_drop_kpa`, `leak_max_drop_fraction` × peak) below the hold's peak | 1 period [10 ms] | as `OverPressure` [110 ms] | Hold |
//! | `DiameterMismatch` | in Expand, \|D_table − D_volume\| > `diameter_mismatch_mm` for ≥ `diameter_mismatch_ms` | `diameter_mismatch_ms` + 1 period [510 ms] | sensor period + read + bound + valve [577 ms] | Expand |
//! | `ControlOverrun` | step more than [`CONTROL_OVERRUN_LIMIT_MS`] (30 ms) after the previous one, or time going backwards | the late step itself [0 ms] | valve [50 ms]; a loop that stops for good: the watchdog's reset, then the pull resistors | active |
//! | `LinkLoss` | no command (a `Heartbeat` counts) for more than `link_timeout_ms` (0 = watch off, only allowed with a cycle limit) | `link_timeout_ms` + 1 period [2010 ms] | bound + valve [2060 ms] | active |
//!
//! Safe action for every row: pump disabled, relief valve open, advance
//! drive off, latched until an accepted `Reset`.
//!
//! # Watchdog
//!
//! `feed_watchdog` is true exactly when the step came on time (no overrun),
//! in every state, Fault included: the independent watchdog guards the
//! control loop, the Fault state guards the plant. A late step is never
//! fed, so a loop that stalls for good resets the MCU.

pub mod bounds;
pub mod geometry;
pub mod machine;
pub mod monitors;
pub mod params;
pub mod plateau;
pub mod types;

pub use bounds::*;
pub use geometry::ExpansionZone;
pub use machine::{Controller, ExpandEnd};
pub use params::{FieldRange, ParamError, ParamField, Params, LINK_TIMEOUT_MIN_MS, RANGES};
pub use plateau::{PlateauDetector, PLATEAU_CONFIRM_SAMPLES, PLATEAU_WINDOW_SAMPLES};
pub use types::*;
