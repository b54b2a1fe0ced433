//! `host-sim board` against `host-sim virtual-board` over a real
//! pseudo-terminal, as a user runs them: two processes, the serial stack
//! between them, the firmware's own tasks on the far side.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Mutex, MutexGuard};

const HOST_SIM: &str = env!("CARGO_BIN_EXE_host-sim");

/// One virtual board at a time: each runs its tasks against deadlines of
/// a few ms, which two boards (and their host tools) on a 2-core machine
/// can miss together.
static ONE_BOARD: Mutex<()> = Mutex::new(());

/// A `host-sim virtual-board` process, killed (by its id) when dropped.
struct VirtualBoard {
    child: Child,
    port: String,
    _alone: MutexGuard<'static, ()>,
}

impl VirtualBoard {
    fn start(args: &[&str]) -> VirtualBoard {
        // A test that failed while holding the lock poisons it; the next
        // board may still run alone.
        let alone = ONE_BOARD.lock().unwrap_or_else(|e| e.into_inner());
        let mut child = Command::new(HOST_SIM)
            .arg("virtual-board")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let mut line = String::new();
        BufReader::new(stdout).read_line(&mut line).unwrap();
        let port = line
            .strip_prefix("port: ")
            .unwrap_or_else(|| panic!("first line `{line}`"))
            .trim()
            .to_owned();
        VirtualBoard {
            child,
            port,
            _alone: alone,
        }
    }

    fn board(&self, args: &[&str]) -> Output {
        Command::new(HOST_SIM)
            .args(["board", "--port", &self.port])
            .args(args)
            .output()
            .unwrap()
    }
}

impl Drop for VirtualBoard {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn failed(out: &Output) -> String {
    assert!(
        !out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn write_rig(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("my-rig.toml");
    std::fs::write(&path, rig::Rig::paper_default().to_toml().unwrap()).unwrap();
    path
}

#[test]
fn board_cli_against_the_virtual_board() {
    let dir = tempfile::tempdir().unwrap();
    let vb = VirtualBoard::start(&[]);

    let info = ok(&vb.board(&["info"]));
    assert!(
        info.contains(&format!(
            "protocol: {}",
            urechis::protocol::PROTOCOL_VERSION
        )),
        "{info}"
    );
    assert!(info.contains(&format!(
        "CRC {:#010x}, compiled in",
        urechis::table::generated::TABLE.checksum
    )));
    assert!(info.contains("pressure zero: none"), "{info}");

    // params: get to a file, one field out of range refused by name.
    let params = dir.path().join("params.toml");
    ok(&vb.board(&["params", "get", "--out", params.to_str().unwrap()]));
    let text = std::fs::read_to_string(&params).unwrap();
    std::fs::write(
        &params,
        text.replace("max_volume_ml = 10.0", "max_volume_ml = 99.0"),
    )
    .unwrap();
    let err = failed(&vb.board(&["params", "set", params.to_str().unwrap()]));
    assert!(
        err.contains("field `max_volume_ml` = 99 is refused") && err.contains(&vb.port),
        "{err}"
    );
    std::fs::write(&params, text.replace("hold_ms = 500", "hold_ms = 400")).unwrap();
    ok(&vb.board(&["params", "set", params.to_str().unwrap()]));
    assert!(ok(&vb.board(&["info"])).contains("hold_ms = 400"));

    // No zero: a run is refused and says why; tare, then three cycles.
    let rig = write_rig(dir.path());
    let exp = dir.path().join("exp");
    let run = |out: &Path| {
        vb.board(&[
            "run",
            "--cycles",
            "3",
            "--depth-mm",
            "40",
            "--rig",
            rig.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let err = failed(&run(&exp));
    assert!(err.contains("tare"), "{err}");
    assert!(ok(&vb.board(&["tare"])).contains("pressure zero 101."));
    let done = ok(&run(&exp));
    assert!(
        done.contains("3 cycle(s), 0 frame(s) failed their CRC"),
        "{done}"
    );
    let diagnosis = Command::new(HOST_SIM)
        .args(["diagnose", exp.to_str().unwrap()])
        .output()
        .unwrap();
    ok(&diagnosis);

    // A damaged table image is refused before anything is sent.
    let image = dir.path().join("table.bin");
    std::fs::write(&image, b"URTB not a table").unwrap();
    let err = failed(&vb.board(&["push-table", image.to_str().unwrap()]));
    assert!(err.contains("not a valid table image"), "{err}");

    // Nobody on the other end of a port: a clear error naming it.
    let err = String::from_utf8_lossy(
        &Command::new(HOST_SIM)
            .args(["board", "--port", "/dev/null", "info"])
            .output()
            .unwrap()
            .stderr,
    )
    .into_owned();
    assert!(err.contains("/dev/null"), "{err}");
}

#[test]
fn a_fault_on_the_virtual_board_is_reported_with_its_cause() {
    let dir = tempfile::tempdir().unwrap();
    let vb = VirtualBoard::start(&["--scenario", "stalled_pump"]);
    ok(&vb.board(&["tare"]));
    let rig = write_rig(dir.path());
    let out = dir.path().join("stall");
    let err = failed(&vb.board(&[
        "run",
        "--cycles",
        "1",
        "--depth-mm",
        "40",
        "--rig",
        rig.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    assert!(err.contains("fault PumpStall"), "{err}");
    assert!(rig::Experiment::read(&out).is_ok());
    let info = ok(&vb.board(&["info"]));
    assert!(info.contains("fault: PumpStall"), "{info}");
    // A stall leaves no cause behind: Reset returns to Idle, and the
    // cause stays on record.
    assert!(ok(&vb.board(&["reset"])).contains("Idle"));
    let info = ok(&vb.board(&["info"]));
    assert!(
        info.contains("state: Idle") && info.contains("last fault: PumpStall"),
        "{info}"
    );
}

#[test]
fn the_virtual_board_runs_faster_on_request() {
    // The board's own uptime against the wall clock over three seconds,
    // read twice through `board info`; whether a run keeps its deadlines
    // at that speed is the ignored test below.
    let vb = VirtualBoard::start(&["--speed", "2"]);
    let uptime_s = |vb: &VirtualBoard| -> f64 {
        let info = ok(&vb.board(&["info"]));
        let line = info.lines().find(|l| l.trim_start().starts_with("uptime:"));
        let value = line.and_then(|l| l.split_whitespace().nth(1));
        value
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no uptime in `{info}`"))
    };
    let board_0 = uptime_s(&vb);
    let wall_0 = std::time::Instant::now();
    std::thread::sleep(std::time::Duration::from_secs(3));
    let board_1 = uptime_s(&vb);
    let rate = (board_1 - board_0) / wall_0.elapsed().as_secs_f64();
    assert!(
        (1.7..2.3).contains(&rate),
        "{rate:.2} board seconds per wall second"
    );
}

#[test]
#[ignore = "on the VM's AMD host a run at 1.5× or 2× faults with ControlOverrun (a control step more than 30 ms of board time after the last) in most runs, at 1× never: cargo test -p host-sim --test board_cli -- --ignored"]
fn a_run_at_twice_the_speed_keeps_its_deadlines() {
    let dir = tempfile::tempdir().unwrap();
    let vb = VirtualBoard::start(&["--speed", "2"]);
    ok(&vb.board(&["tare"]));
    let rig = write_rig(dir.path());
    let out = dir.path().join("fast");
    let started = std::time::Instant::now();
    ok(&vb.board(&[
        "run",
        "--cycles",
        "2",
        "--depth-mm",
        "40",
        "--rig",
        rig.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]));
    let wall_s = started.elapsed().as_secs_f64();
    let exp = rig::Experiment::read(&out).unwrap();
    let board_s = exp.runs[0].samples.last().unwrap().t_s;
    // Two cycles of about 4 s of board time each, at twice the wall clock
    // (the host tool's own start-up and the tare are in the wall time).
    assert!(board_s > 6.0, "{board_s} s of board time");
    assert!(
        wall_s < board_s / 1.5,
        "{wall_s:.1} s of wall time for {board_s:.1} s of board time"
    );
}
