//! Periodic boundaries and wall surfaces: a periodic system does not
//! know where its faces are, a contact across a face is the contact in the
//! middle of the box, a growing cylinder's surface speed enters the
//! contact like a particle's own approach, and a wall's normal load is
//! what presses on it.

use dem::contact::ContactSpec;
use dem::{step, CylinderSide, Params, Particles, PeriodicAxis, Sink, State, Wall};
use nalgebra::Vector3;

mod common;
use common::sand;

/// Box length of the periodic beds (m).
const L: f64 = 10.0e-3;

/// 4 × 4 × `layers` grains (r = 1 mm) on a jittered lattice, periodic in
/// x and y with period [`L`], on a floor, shifted by `shift` (m) along x
/// and y.
fn periodic_bed(layers: usize, shift: [f64; 2]) -> (Params, State) {
    let spec = ContactSpec::default();
    let mat = sand();
    let mut params = Params::new(&mat, &spec, 1.5e-5).unwrap();
    params.gravity_m_s2 = Vector3::new(0.0, 0.0, -9.81);
    params.periodic = [
        Some(PeriodicAxis::new(0.0, L).unwrap()),
        Some(PeriodicAxis::new(0.0, L).unwrap()),
        None,
    ];
    params
        .walls
        .push(Wall::plane(Vector3::zeros(), Vector3::z(), &mat, &mat, &spec).unwrap());
    let mut p = Particles::new();
    let mut jitter = common::jitter(11, 0.15e-3);
    for k in 0..layers {
        for j in 0..4 {
            for i in 0..4 {
                let x = Vector3::new(
                    (1.25e-3 + 2.5e-3 * i as f64 + jitter() + shift[0]).rem_euclid(L),
                    (1.25e-3 + 2.5e-3 * j as f64 + jitter() + shift[1]).rem_euclid(L),
                    1.2e-3 + 2.3e-3 * k as f64,
                );
                p.push(x, Vector3::zeros(), 1.0e-3, mat.density_kg_m3)
                    .unwrap();
            }
        }
    }
    (params, State::new(p))
}

/// Separation of `b` from `a` along a periodic axis of period [`L`].
fn periodic_gap(a: f64, b: f64) -> f64 {
    let d = b - a;
    d - L * (d / L).round()
}

#[test]
fn a_periodic_bed_does_not_know_where_its_faces_are() {
    // The same bed, once as built and once moved 3.7 mm along x and
    // 6.1 mm along y: grains now meet across other faces. While the bed
    // falls onto the floor and the grains collide (30 ms), every grain is
    // where its twin is, moved by the same amount, to rounding. (Later the
    // collisions amplify the rounding differences, ×3 every 1.5 ms, as
    // in any granular flow: both beds then pack, differently.)
    let shift = [3.7e-3, 6.1e-3];
    let (params, mut a) = periodic_bed(5, [0.0, 0.0]);
    let (_, mut b) = periodic_bed(5, shift);
    let mut touching = 0.0;
    for _ in 0..2_000 {
        step(&params, &mut a, &mut ()).unwrap();
        step(&params, &mut b, &mut ()).unwrap();
        touching = f64::max(touching, b.mean_contacts());
    }
    let mut worst: f64 = 0.0;
    for (xa, xb) in a.particles.position_m.iter().zip(&b.particles.position_m) {
        let dx = periodic_gap(xa.x + shift[0], xb.x);
        let dy = periodic_gap(xa.y + shift[1], xb.y);
        worst = worst.max(dx.abs()).max(dy.abs()).max((xa.z - xb.z).abs());
        // Wrapped into the box at the list builds (half a skin outside at
        // most in between).
        assert!(xb.x > -1e-4 && xb.x < L + 1e-4 && xb.y > -1e-4 && xb.y < L + 1e-4);
    }
    assert!(
        touching > 1.0,
        "the grains collided: {touching} contacts each"
    );
    assert!(worst < 1e-12, "twins apart by {worst} m");
}

#[test]
fn a_periodic_bed_is_the_same_bits_for_any_thread_count() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let (params, mut state) = periodic_bed(6, [0.0, 0.0]);
            for _ in 0..1_500 {
                step(&params, &mut state, &mut ()).unwrap();
            }
            (
                state.particles.position_m.clone(),
                state.particles.angular_velocity_rad_s.clone(),
            )
        })
    };
    let one = run(1);
    assert!(one == run(2), "2 threads differ from 1");
    assert!(one == run(3), "3 threads differ from 1");
}

#[test]
fn motion_kept_in_the_rows_is_the_same_bits_across_periodic_faces() {
    // The grains move along x through the face at x = L: each list build
    // wraps them back into the box, which the rows must follow.
    let (params, mut state) = periodic_bed(4, [0.0, 0.0]);
    for v in &mut state.particles.velocity_m_s {
        v.x = 0.6;
    }
    let start: Vec<f64> = state.particles.position_m.iter().map(|x| x.x).collect();
    let end = common::rows_only_matches_plain(&params, &state);
    let wrapped = (end.particles.position_m.iter().zip(&start)).filter(|(x, &x0)| x.x < x0);
    assert!(wrapped.count() > 8, "too few grains crossed the face");
}

#[test]
fn a_periodic_bed_is_the_same_bits_in_either_instruction_set() {
    // The pair pass's AVX2 copy (where the CPU has it) against the
    // baseline one, pairs meeting across both periodic faces. The
    // instruction set is process-wide, so the runs go one after the other.
    let run = |simd: dem::Simd| {
        dem::use_simd(simd);
        let (params, mut state) = periodic_bed(6, [0.0, 0.0]);
        // Step by step, then through `advance` (the first sweep from the
        // packed rows, an AVX2 copy of its own).
        for _ in 0..750 {
            step(&params, &mut state, &mut ()).unwrap();
        }
        for _ in 0..3 {
            dem::advance(&params, &mut state, &mut (), 250).unwrap();
        }
        (
            state.particles.position_m.clone(),
            state.particles.angular_velocity_rad_s.clone(),
        )
    };
    let best = dem::best_simd();
    let base = run(dem::Simd::Baseline);
    let fast = run(best);
    dem::use_simd(best);
    assert!(base == fast, "{best:?} differs from the baseline");
}

/// Two grains in a 10 mm box periodic along y meet obliquely (friction,
/// so the tangential spring's history matters) around `y_meet` (m);
/// returns grain 0's path relative to `y_meet` and grain 1's spin.
fn oblique_meeting(y_meet: f64, periodic: bool) -> Vec<[f64; 4]> {
    let spec = ContactSpec::default();
    let mat = sand();
    let mut params = Params::new(&mat, &spec, 1.0e-6).unwrap();
    if periodic {
        params.periodic = [None, Some(PeriodicAxis::new(0.0, L).unwrap()), None];
    }
    let mut p = Particles::new();
    let (v, r) = (0.05, 1.0e-3);
    // Grain 0 below the meeting point, grain 1 above, offset in x.
    for (dy, vy, dx) in [(-1.2e-3, v, -0.6e-3), (1.2e-3, -v, 0.6e-3)] {
        let y = if periodic {
            (y_meet + dy).rem_euclid(L)
        } else {
            y_meet + dy
        };
        p.push(
            Vector3::new(dx, y, 0.0),
            Vector3::new(0.0, vy, 0.0),
            r,
            2920.0,
        )
        .unwrap();
    }
    let mut state = State::new(p);
    let mut path = Vec::new();
    for k in 0..60_000 {
        step(&params, &mut state, &mut ()).unwrap();
        if k % 1000 == 999 {
            let x = state.particles.position_m[0];
            path.push([
                x.x,
                if periodic {
                    periodic_gap(y_meet, x.y)
                } else {
                    x.y - y_meet
                },
                state.particles.velocity_m_s[0].x,
                state.particles.angular_velocity_rad_s[1].z,
            ]);
        }
    }
    path
}

#[test]
fn grains_meet_across_a_periodic_face_as_in_the_middle_of_the_box() {
    // The meeting at the face y = 0 (each grain on its own side, wrapped
    // while in contact) against the same meeting in open space.
    let across = oblique_meeting(0.0, true);
    let open = oblique_meeting(5.0e-3, false);
    let spun = open.iter().map(|s| s[3].abs()).fold(0.0, f64::max);
    assert!(spun > 1.0, "the contact spins the grains: {spun} rad/s");
    for (a, b) in across.iter().zip(&open) {
        for (u, w) in a.iter().zip(b) {
            assert!((u - w).abs() <= 1e-9 * (1.0 + w.abs()), "{a:?} vs {b:?}");
        }
    }
}

/// A rod of the actuator's radius (9.35 mm) along y through the origin,
/// the grains outside it, of the sand's material.
fn rod(spec: &ContactSpec) -> Wall {
    let mat = sand();
    Wall::cylinder(
        Vector3::zeros(),
        Vector3::y(),
        9.35e-3,
        CylinderSide::Outside,
        &mat,
        &mat,
        spec,
    )
    .unwrap()
}

/// The force on grain 0 at a step's first evaluation.
struct FirstForce(Option<Vector3<f64>>);

impl Sink for FirstForce {
    fn add_external_forces(&mut self, _: f64, p: &mut Particles) {
        self.0.get_or_insert(p.force_n[0]);
    }
}

#[test]
fn a_growing_cylinder_pushes_like_a_grain_moving_onto_it() {
    // A grain touching a rod whose radius grows at u, and the same grain
    // moving onto a fixed rod at u: the same contact force (damping and
    // all) at the first evaluation.
    let spec = ContactSpec::default();
    let mat = sand();
    let u = 0.02;
    let force = |growth: f64, grain_v: f64| {
        let mut params = Params::new(&mat, &spec, 1.0e-6).unwrap();
        let mut rod = rod(&spec);
        rod.normal_velocity_m_s = growth;
        params.walls.push(rod);
        let mut p = Particles::new();
        p.push(
            Vector3::new(9.35e-3 + 0.99e-3, 0.0, 0.0),
            Vector3::new(-grain_v, 0.0, 0.0),
            1.0e-3,
            2920.0,
        )
        .unwrap();
        let mut state = State::new(p);
        let mut first = FirstForce(None);
        step(&params, &mut state, &mut first).unwrap();
        first.0.unwrap()
    };
    let (grown, moving, still) = (force(u, 0.0), force(0.0, u), force(0.0, 0.0));
    assert!(
        (grown - moving).norm() < 1e-9 * moving.norm(),
        "{grown} vs {moving}"
    );
    // The damping adds to the elastic force: the surface's speed counted.
    assert!(grown.x.abs() > 1.05 * still.x.abs(), "{grown} vs {still}");
}

#[test]
fn a_grain_resting_on_a_rod_loads_it_with_its_weight_along_the_normal() {
    // A grain settled on top of a horizontal rod and one against a side
    // wall: the normal load on the rod is its weight; the side wall, which
    // it does not touch, carries none.
    let spec = ContactSpec::default();
    let mat = sand();
    let mut params = Params::new(&mat, &spec, 2.0e-6).unwrap();
    params.gravity_m_s2 = Vector3::new(0.0, 0.0, -9.81);
    params.walls = vec![
        rod(&spec),
        Wall::plane(
            Vector3::new(0.02, 0.0, 0.0),
            -Vector3::x(),
            &mat,
            &mat,
            &spec,
        )
        .unwrap(),
    ];
    let mut p = Particles::new();
    p.push(
        Vector3::new(0.0, 0.0, 10.36e-3),
        Vector3::zeros(),
        1.0e-3,
        2920.0,
    )
    .unwrap();
    let weight = p.mass_kg[0] * 9.81;
    let mut state = State::new(p);
    for _ in 0..60_000 {
        step(&params, &mut state, &mut ()).unwrap();
    }
    let loads = state.wall_normal_loads_n();
    assert!(
        (loads[0] / weight - 1.0).abs() < 1e-3,
        "{} vs {weight}",
        loads[0]
    );
    assert_eq!(loads[1], 0.0);
    // The force on the rod points down: the load is its size.
    assert!((state.wall_forces_n()[0].z + loads[0]).abs() < 1e-6 * weight);
}
