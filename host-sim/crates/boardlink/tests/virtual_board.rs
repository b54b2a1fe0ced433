//! The host tool's library against the virtual board over a real
//! pseudo-terminal: the firmware's own tasks on one side, the host's link
//! on the other, the serial stack between them.

use std::time::{Duration, Instant};

use boardlink::{expect_ack, Link};
use urechis::controller::{Fault, Params, State};
use urechis::protocol::{HostCommand, NackReason, StoredTable, TableSource, PROTOCOL_VERSION};
use vboard::{Options, VirtualBoard};

fn board() -> (VirtualBoard, Link) {
    let vb = VirtualBoard::start(&Options::default()).expect("virtual board");
    let link = Link::open(vb.port()).expect("open the pty");
    (vb, link)
}

#[test]
fn info_reports_the_compiled_in_table_and_no_zero() {
    let (_vb, mut link) = board();
    let info = link.connect().unwrap();
    assert_eq!(info.protocol_version, PROTOCOL_VERSION);
    assert_eq!(info.table_source, TableSource::CompiledIn);
    assert_eq!(info.stored_table, StoredTable::Absent);
    assert_eq!(
        info.table_checksum,
        urechis::table::generated::TABLE.checksum
    );
    assert!(info.pressure_zero_kpa.is_nan());
    assert_eq!(info.state, State::Idle);
}

#[test]
fn tare_then_link_loss_stops_the_cycle_safely() {
    let (vb, mut link) = board();
    link.connect().unwrap();
    // No zero yet: Start is refused.
    match link.command(HostCommand::Start, 1000).unwrap() {
        Err(NackReason::Command(urechis::controller::CommandError::NoPressureZero)) => {}
        other => panic!("{other:?}"),
    }
    expect_ack(&mut link, HostCommand::Tare, 3000).unwrap();
    let info = link.connect().unwrap();
    assert!(
        (info.pressure_zero_kpa - 101.325).abs() < 0.5,
        "{}",
        info.pressure_zero_kpa
    );
    if let Err(e) = expect_ack(&mut link, HostCommand::Start, 1000) {
        let info = link.connect().unwrap();
        panic!("{e:#}: {info:?}");
    }
    // Silence: the board must stop within its link timeout + a period.
    let silent = Instant::now();
    let bound = Duration::from_millis(u64::from(Params::DEFAULT.link_timeout_ms) + 500);
    let fault = loop {
        let t = link
            .next_sample(Duration::from_millis(500))
            .unwrap()
            .expect("telemetry keeps coming");
        if t.state == State::Fault {
            break t.fault;
        }
        assert!(
            silent.elapsed() < bound,
            "no link-loss stop within {bound:?}"
        );
    };
    assert_eq!(fault, Some(Fault::LinkLoss));
    std::thread::sleep(Duration::from_millis(50));
    assert!(vb.outputs_safe(), "valve open and pump driver off");
    let info = link.connect().unwrap();
    assert_eq!(info.last_fault, Some(Fault::LinkLoss));
}
