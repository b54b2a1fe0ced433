//! The FEM skin against the closed-form tube inflation (the membrane, and
//! the shell with its bending), the closed-form edge bending of a clamped
//! tube, and the consistency of its internal forces with its energy (the
//! solid wall's too).

use fem::{Ends, Skin, SkinKind, SkinSpec, VolumeControl};
use nalgebra::{Rotation3, Vector3};
use skin::membrane::{self, Tube, TubeGeometry};
use skin::{default_skin, StrainEnergy, Yeoh};

/// Wall of the thin reference tube (m): T/R ≈ 1e-5, so its thick-wall
/// correction is ~1e-5 relative.
const THIN_WALL_MM: f64 = 1e-4;

/// Pressure (Pa) of the thin-wall (membrane) inflation of the zone's
/// mid-surface at mid-surface diameter `mid_diameter_m`, in plane strain:
/// the closed-form tube of the same mid-surface radius and a vanishing
/// wall, its pressure scaled by T/t (a membrane's pressure is linear in
/// its thickness).
fn thin_wall_reference_pa(law: Yeoh, spec: &SkinSpec, mid_diameter_m: f64) -> f64 {
    let mid_mm = 2.0 * spec.mid_radius_m * 1e3;
    let g = TubeGeometry {
        outer_diameter_mm: mid_mm + THIN_WALL_MM,
        wall_thickness_mm: THIN_WALL_MM,
        length_mm: spec.length_m * 1e3,
    };
    let tube = Tube::new(g, law, membrane::Ends::PlaneStrain).unwrap();
    // Outer diameter of the thin tube whose mid-surface is at the target:
    // the wall thins by λ3 = 1/λθ in plane strain.
    let lambda = mid_diameter_m * 1e3 / mid_mm;
    let d = mid_diameter_m * 1e3 + THIN_WALL_MM / lambda;
    tube.pressure_kpa(d).unwrap() * 1e3 * (spec.thickness_m * 1e3) / THIN_WALL_MM
}

/// The paper's zone as a membrane (no bending, the default): what the
/// closed-form membrane tube describes exactly.
fn membrane_spec(around: usize, along: usize) -> SkinSpec {
    let spec = SkinSpec::paper(around, along);
    assert_eq!(spec.kind, SkinKind::Membrane);
    spec
}

/// The paper's zone as a shell (bending).
fn shell_spec(around: usize, along: usize) -> SkinSpec {
    SkinSpec {
        kind: SkinKind::Shell,
        ..SkinSpec::paper(around, along)
    }
}

/// The paper's zone as a solid wall `layers` hexahedra thick
/// (`tests/solid.rs` checks it against the thick tube).
fn solid_spec(around: usize, along: usize, layers: usize) -> SkinSpec {
    SkinSpec {
        kind: SkinKind::solid(layers).expect("at least one layer"),
        ..SkinSpec::paper(around, along)
    }
}

#[test]
fn plane_strain_inflation_matches_the_closed_form_tube_within_2_percent() {
    let law = default_skin();
    let spec = membrane_spec(32, 6);
    let mut skin = Skin::new(law, &spec, Ends::PlaneStrain).unwrap();
    // Pressures giving outer diameters from ~20 to 25 mm (thin-wall law).
    let mut last_d = 18.7e-3;
    for target_outer_mm in [20.0, 22.5, 25.0] {
        // Mid-surface diameter whose outer diameter is the target:
        // d + T/λ = D with λ = d/d0.
        let (d0, t) = (2.0 * spec.mid_radius_m, spec.thickness_m);
        let dd = target_outer_mm * 1e-3;
        let mid = 0.5 * (dd + (dd * dd - 4.0 * t * d0).sqrt());
        skin.pressure_pa = thin_wall_reference_pa(law, &spec, mid);
        let tol = 1e-9 * skin.pressure_pa * spec.length_m * spec.mid_radius_m;
        let r = skin.relax(tol, 400_000).unwrap();
        let j = skin.mesh.middle_ring();
        let got_mid = 2.0 * skin.ring_radius_m(j);
        let want = thin_wall_reference_pa(law, &spec, got_mid);
        let err = (skin.pressure_pa - want) / want;
        let outer = skin.outer_diameter_at_mid_length_m();
        println!(
            "D = {:.3} mm: p = {:.2} Pa, closed form at that diameter {:.2} Pa, error {:+.3} % ({} steps)",
            outer * 1e3,
            skin.pressure_pa,
            want,
            100.0 * err,
            r.steps
        );
        assert!(err.abs() < 0.02, "pressure error {err} at D = {outer}");
        assert!(outer > last_d);
        // Uniform: every ring at the same radius (plane strain holds).
        for j in 0..=skin.mesh.along {
            assert!((2.0 * skin.ring_radius_m(j) - got_mid).abs() < 1e-6 * got_mid);
        }
        last_d = outer;
    }
    assert!((last_d - 25e-3).abs() < 0.5e-3, "final D {last_d}");
}

/// Relative pressure error against the closed form at D ≈ 22.5 mm with
/// `around` nodes round the circumference.
fn pressure_error(around: usize) -> f64 {
    let law = default_skin();
    let spec = membrane_spec(around, 4);
    let mut skin = Skin::new(law, &spec, Ends::PlaneStrain).unwrap();
    skin.pressure_pa = 550.0;
    skin.relax(1e-9 * 550.0 * spec.length_m * spec.mid_radius_m, 400_000)
        .unwrap();
    let mid = 2.0 * skin.ring_radius_m(skin.mesh.middle_ring());
    let want = thin_wall_reference_pa(law, &spec, mid);
    (skin.pressure_pa - want) / want
}

#[test]
fn the_discretisation_error_falls_with_the_mesh() {
    let errors = [16, 32, 64].map(pressure_error);
    println!("pressure error at 16/32/64 nodes round: {errors:?}");
    // The polygon's error is second order in the element angle.
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!((3.0..5.0).contains(&ratio), "{errors:?}");
    }
}

#[test]
fn injected_volume_gives_the_closed_form_pressure() {
    let law = default_skin();
    let spec = SkinSpec::paper(32, 4);
    let mut skin = Skin::new(law, &spec, Ends::PlaneStrain).unwrap();
    // The polygon's volume when every node is at mid-surface radius r:
    // N/2·r²·sin(2π/N)·L; r chosen for an outer diameter near 25 mm.
    let n = spec.around as f64;
    let r = 11.75e-3;
    let target = 0.5 * n * r * r * (std::f64::consts::TAU / n).sin() * spec.length_m;
    let bulk = 1e6;
    skin.volume_control = Some(VolumeControl {
        target_volume_m3: target,
        bulk_modulus_pa: bulk,
    });
    let relaxed = skin
        .relax(1e-12 * bulk * spec.length_m * spec.mid_radius_m, 400_000)
        .unwrap();
    let v = skin.enclosed_volume_m3();
    let mid = 2.0 * skin.ring_radius_m(skin.mesh.middle_ring());
    let want = thin_wall_reference_pa(law, &spec, mid);
    let err = (skin.pressure_pa - want) / want;
    println!(
        "volume control: V/V_target − 1 = {:.2e}, D = {:.3} mm, p = {:.2} Pa vs closed form {want:.2} Pa ({:+.3} %), {} steps",
        v / target - 1.0,
        skin.outer_diameter_at_mid_length_m() * 1e3,
        skin.pressure_pa,
        100.0 * err,
        relaxed.steps
    );
    // The penalty leaves V short of the target by exactly p/K.
    assert!(((target - v) / target - skin.pressure_pa / bulk).abs() < 1e-12);
    assert!((v - target).abs() < 1e-3 * target);
    assert!(err.abs() < 0.02, "{err}");
}

fn perturbed_skin(spec: &SkinSpec, ends: Ends) -> Skin<Yeoh> {
    let mut skin = Skin::new(default_skin(), spec, ends).unwrap();
    // A deterministic, non-symmetric finite deformation (stretch ~1.3 plus
    // ±0.3 mm wobble), so every term of the stress is active.
    for (a, x) in skin.position_m.iter_mut().enumerate() {
        let s = a as f64;
        *x = Vector3::new(1.3 * x.x, 1.25 * x.y, 1.1 * x.z)
            + Vector3::new((1.7 * s).sin(), (2.3 * s).cos(), (0.9 * s).sin()) * 3e-4;
    }
    skin
}

#[test]
fn internal_forces_are_the_gradient_of_the_strain_energy() {
    // The shell with clamped ends (mirror ghosts) and with free ends, and
    // the membrane.
    for (spec, ends) in [
        (shell_spec(12, 3), Ends::Clamped),
        (shell_spec(12, 4), Ends::PlaneStrain),
        (membrane_spec(12, 3), Ends::Clamped),
        (solid_spec(8, 2, 2), Ends::PlaneStrain),
    ] {
        forces_match_the_energy_gradient(perturbed_skin(&spec, ends));
    }
}

fn forces_match_the_energy_gradient(mut skin: Skin<Yeoh>) {
    let mut f = vec![Vector3::zeros(); skin.node_count()];
    skin.internal_forces_n(&mut f).unwrap();
    let worst = worst_gradient_error(&mut skin, &f, |s| s.strain_energy_j().unwrap());
    println!("largest |f − dE/dx| / max|f| = {worst:.2e}");
    assert!(worst < 1e-6, "{worst}");
}

/// Largest difference between the forces `f` and the central finite
/// differences of `energy` over every node coordinate of `skin`, over the
/// largest force.
fn worst_gradient_error(
    skin: &mut Skin<Yeoh>,
    f: &[Vector3<f64>],
    energy: impl Fn(&Skin<Yeoh>) -> f64,
) -> f64 {
    let scale = f.iter().map(|v| v.norm()).fold(0.0, f64::max);
    assert!(scale > 0.0);
    let h = 1e-8;
    let mut worst = 0.0f64;
    for (a, fa) in f.iter().enumerate() {
        for k in 0..3 {
            let x0 = skin.position_m[a][k];
            skin.position_m[a][k] = x0 + h;
            let ep = energy(skin);
            skin.position_m[a][k] = x0 - h;
            let em = energy(skin);
            skin.position_m[a][k] = x0;
            worst = worst.max(((ep - em) / (2.0 * h) - fa[k]).abs() / scale);
        }
    }
    worst
}

#[test]
fn rigid_motions_leave_no_energy_or_force() {
    // Free ends: clamped ones are tied to the body's frame. The shell and
    // the membrane.
    for spec in [shell_spec(12, 3), membrane_spec(12, 3), solid_spec(8, 2, 2)] {
        rigid_motion_leaves_no_energy_or_force(perturbed_skin(&spec, Ends::PlaneStrain));
    }
    // At rest: no energy, no force, no stress.
    let rest = Skin::new(default_skin(), &shell_spec(12, 3), Ends::Clamped).unwrap();
    assert!(rest.strain_energy_j().unwrap().abs() < 1e-15);
    let mut f = vec![Vector3::zeros(); rest.node_count()];
    rest.internal_forces_n(&mut f).unwrap();
    assert!(f.iter().all(|f| f.norm() < 1e-15));
    assert!(rest.von_mises_pa().unwrap().iter().all(|s| s.abs() < 1e-9));
}

fn rigid_motion_leaves_no_energy_or_force(mut skin: Skin<Yeoh>) {
    let e0 = skin.strain_energy_j().unwrap();
    let mut f0 = vec![Vector3::zeros(); skin.node_count()];
    skin.internal_forces_n(&mut f0).unwrap();
    let rot = Rotation3::from_euler_angles(0.4, -1.1, 2.0);
    let shift = Vector3::new(0.01, -0.02, 0.005);
    for x in skin.position_m.iter_mut() {
        *x = rot * *x + shift;
    }
    let e1 = skin.strain_energy_j().unwrap();
    assert!((e1 - e0).abs() < 1e-12 * e0, "{e0} vs {e1}");
    let mut f1 = vec![Vector3::zeros(); skin.node_count()];
    skin.internal_forces_n(&mut f1).unwrap();
    for (a, b) in f0.iter().zip(&f1) {
        // Forces rotate with the body and sum to zero.
        assert!((rot * a - b).norm() < 1e-9 * a.norm().max(1e-9));
    }
    let total: Vector3<f64> = f1.iter().sum();
    assert!(total.norm() < 1e-9 * f1.iter().map(|v| v.norm()).sum::<f64>());
}

#[test]
fn the_vtk_file_holds_the_mesh_and_the_element_stresses() {
    let mut skin = Skin::new(default_skin(), &SkinSpec::paper(12, 3), Ends::Clamped).unwrap();
    skin.pressure_pa = 300.0;
    skin.relax(1e-7, 200_000).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("skin.vtk");
    std::fs::write(&path, fem::vtk::to_vtk(&skin).unwrap()).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let (n, m) = (skin.node_count(), skin.elements.len());
    assert_eq!(lines[4], format!("POINTS {n} double"));
    assert_eq!(lines[5 + n], format!("POLYGONS {m} {}", 4 * m));
    let at = lines
        .iter()
        .position(|l| l.starts_with("SCALARS von_mises_pa"))
        .unwrap();
    let vm: Vec<f64> = lines[at + 2..at + 2 + m]
        .iter()
        .map(|l| l.parse().unwrap())
        .collect();
    for (a, b) in vm.iter().zip(skin.von_mises_pa().unwrap()) {
        assert!((a - b).abs() <= 1e-12 * b.abs());
    }
    assert!(vm.iter().all(|v| *v > 0.0));
    assert!(text.contains(&format!("POINT_DATA {n}\nVECTORS displacement_m double")));
}

#[test]
fn closed_end_inflation_matches_the_closed_form_tube_within_2_percent() {
    let law = default_skin();
    let spec = membrane_spec(32, 6);
    let mut skin = Skin::new(law, &spec, Ends::Closed).unwrap();
    let mid_mm = 2.0 * spec.mid_radius_m * 1e3;
    let thin = Tube::new(
        TubeGeometry {
            outer_diameter_mm: mid_mm + THIN_WALL_MM,
            wall_thickness_mm: THIN_WALL_MM,
            length_mm: spec.length_m * 1e3,
        },
        law,
        membrane::Ends::Closed,
    )
    .unwrap();
    let scale = spec.thickness_m * 1e3 / THIN_WALL_MM;
    for p in [300.0, 500.0, 640.0, 690.0] {
        skin.pressure_pa = p;
        skin.relax(1e-9 * p * spec.length_m * spec.mid_radius_m, 400_000)
            .unwrap();
        let mid = 2.0 * skin.ring_radius_m(skin.mesh.middle_ring()) * 1e3;
        let d = mid + THIN_WALL_MM * mid_mm / mid;
        let want = thin.pressure_kpa(d).unwrap() * 1e3 * scale;
        let lz_want = thin.axial_stretch(d).unwrap();
        let far = skin.mesh.ring(skin.mesh.along).start;
        let lz = skin.position_m[far].z / spec.length_m;
        let err = (p - want) / want;
        println!(
            "closed ends: D = {:.3} mm, p = {p} Pa vs closed form {want:.2} Pa ({:+.3} %), λz = {lz:.5} vs {lz_want:.5}",
            skin.outer_diameter_at_mid_length_m() * 1e3,
            100.0 * err
        );
        assert!(err.abs() < 0.02, "{err}");
        assert!((lz - lz_want).abs() < 0.01 * (lz_want - 1.0).abs().max(0.01));
    }
}

/// Sum of the internal z forces on the front ring (N): what the skin pulls
/// on whatever holds that ring.
fn front_ring_internal_z_n(skin: &Skin<Yeoh>) -> f64 {
    let mut f = vec![Vector3::zeros(); skin.node_count()];
    skin.internal_forces_n(&mut f).unwrap();
    skin.mesh.ring(skin.mesh.along).map(|a| f[a].z).sum()
}

#[test]
fn a_free_head_settles_where_the_clamped_skin_carries_its_load() {
    // Push the free head back with a constant force until it comes to
    // rest; then clamp a fresh skin's front ring at that displacement: the
    // skin must carry the same force (the head's rigid-body coupling and
    // the FEM statics agree).
    let spec = SkinSpec::paper(16, 4);
    let load_n = -2e-3;
    let mut skin = Skin::new(default_skin(), &spec, Ends::Head).unwrap();
    skin.damping_per_s = 400.0;
    let head = skin.head.as_mut().unwrap();
    head.external_force_n = load_n;
    let dt = 0.5 * skin.stable_time_step_s().unwrap();
    for _ in 0..200_000 {
        skin.step(dt).unwrap();
    }
    let head = skin.head.unwrap();
    assert!(head.velocity_m_s.abs() < 1e-7, "{}", head.velocity_m_s);
    let u = head.displacement_m;
    assert!(u < -1e-5, "pushed back: {u}");
    assert!((head.receding_m() + u).abs() < 1e-15);
    // Every front-ring node moved with the head, none radially.
    for a in skin.mesh.ring(spec.along) {
        let (now, rest) = (skin.position_m[a], skin.mesh.rest_m[a]);
        assert!((now.z - rest.z - u).abs() < 1e-15);
        assert!((now.xy() - rest.xy()).norm() < 1e-15);
    }
    let mut clamped = Skin::new(default_skin(), &spec, Ends::Clamped).unwrap();
    for a in clamped.mesh.ring(spec.along) {
        clamped.position_m[a].z += u;
    }
    clamped.relax(1e-10, 400_000).unwrap();
    let carried = front_ring_internal_z_n(&clamped);
    assert!(
        (carried - load_n).abs() < 0.01 * load_n.abs(),
        "{carried} vs {load_n}"
    );
}

#[test]
fn the_bending_forces_are_the_gradient_of_the_bending_energy() {
    // The bending term alone, so its forces are not lost beside the
    // membrane's: clamped (mirror ghosts) and free ends.
    // Graded rows too: the second differences on unequal rows.
    let graded = SkinSpec {
        end_row_m: Some(1e-3),
        ..shell_spec(12, 4)
    };
    for (spec, ends) in [
        (shell_spec(12, 4), Ends::Clamped),
        (shell_spec(12, 4), Ends::PlaneStrain),
        (graded, Ends::Clamped),
        (graded, Ends::PlaneStrain),
    ] {
        let mut skin = perturbed_skin(&spec, ends);
        println!("{} rows", skin.mesh.along);
        let bending = skin.bending.clone().unwrap();
        let mut f = vec![Vector3::zeros(); skin.node_count()];
        bending.add_internal_forces_n(&skin.position_m, &mut f);
        let worst = worst_gradient_error(&mut skin, &f, |s| bending.energy_j(&s.position_m));
        println!("{ends:?}: largest |f − dW_b/dx| / max|f| = {worst:.2e}");
        assert!(worst < 1e-6, "{ends:?}: {worst}");
    }
}

#[test]
fn a_clamped_tube_bends_at_its_ends_as_the_linear_shell_theory_says() {
    // A tube long against the bending length 1/β (≈ 3.1 mm here), clamped
    // at both ends, under a pressure small enough for linear theory
    // (w/R ≈ 1e-3). At a clamped end w = w′ = 0 and
    // w(z) = w∞·[1 − e^(−βz)(cos βz + sin βz)], β⁴ = 3(1 − ν²)/(R²T²)
    // (Timoshenko & Woinowsky-Krieger, §15.2): the profile peaks at βz = π
    // at w∞·(1 + e^(−π)), and the curvature at the end is w″(0) = 2β²·w∞,
    // so the bending stress there is √(3(1 − ν²))·pR/T, 1.5× the hoop
    // stress. Far from the ends, w∞ = R²(p − νN_z/R)/(ET); with the length
    // held, N_z = ν·mean(N_θ) = νpR·(1 − 2/(βL)) (each end zone lacks
    // w∞/β of hoop strain).
    let law = default_skin();
    let (along, length_m) = (96, 48e-3);
    let spec = SkinSpec {
        length_m,
        ..shell_spec(32, along)
    };
    let mut skin = Skin::new(law, &spec, Ends::Clamped).unwrap();
    let (r, t, nu) = (spec.mid_radius_m, spec.thickness_m, 0.5);
    let e = 3.0 * law.shear_modulus_kpa() * 1e3;
    let p = 1e-3 * e * t / (r * (1.0 - nu * nu));
    let beta = (3.0 * (1.0 - nu * nu) / (r * r * t * t)).powf(0.25);
    let w_inf = p * r * r * (1.0 - nu * nu * (1.0 - 2.0 / (beta * length_m))) / (e * t);
    skin.pressure_pa = p;
    let h = length_m / along as f64;
    let relaxed = skin.relax(1e-8 * p * r * h, 2_000_000).unwrap();
    // The polygon's nodes sit on the circle: radial displacement of ring j.
    let w = |j: usize| skin.ring_radius_m(j) - r;
    let mid = w(skin.mesh.middle_ring());
    let j_peak = (std::f64::consts::PI / beta / h).round() as usize;
    let x = beta * h * j_peak as f64;
    let peak_shape = 1.0 - (-x).exp() * (x.cos() + x.sin());
    let bending = skin.bending.as_ref().unwrap();
    let nodes = bending.node_bending(&skin.position_m);
    let ring0 = skin.mesh.ring(0);
    let n0 = ring0.len() as f64;
    let curvature_at_end = ring0.map(|a| nodes[a].along_per_m).sum::<f64>() / n0;
    // The bending stress at the end, E/(1 − ν²)·T/2·Δb_z (Δb_θ = 0 there),
    // against 6M/T², M = D·2β²w, for the far field w the tube reached.
    let stress = bending.plate_modulus_pa * 0.5 * t * curvature_at_end;
    let want_stress = e / (1.0 - nu * nu) * t * beta * beta * mid;
    println!(
        "clamped tube ({} steps): w mid / w∞ = {:.4}, w(βz = {x:.2}) / (w mid·{peak_shape:.4}) = {:.4}, end curvature / 2β²w_mid = {:.4}, bending stress {stress:.3} / {want_stress:.3} Pa",
        relaxed.steps,
        mid / w_inf,
        w(j_peak) / (mid * peak_shape),
        curvature_at_end / (2.0 * beta * beta * mid),
    );
    assert!(
        (mid / w_inf - 1.0).abs() < 0.02,
        "far field {}",
        mid / w_inf
    );
    assert!((w(j_peak) / (mid * peak_shape) - 1.0).abs() < 0.01);
    assert!((curvature_at_end / (2.0 * beta * beta * mid) - 1.0).abs() < 0.02);
    assert!((stress / want_stress - 1.0).abs() < 0.02);
    // The membrane has no such boundary layer: it leaves the clamp at an
    // angle (a kink), most of the far field within the first row.
    let mut membrane = Skin::new(
        law,
        &SkinSpec {
            kind: SkinKind::Membrane,
            ..spec
        },
        Ends::Clamped,
    )
    .unwrap();
    membrane.pressure_pa = p;
    membrane.relax(1e-8 * p * r * h, 2_000_000).unwrap();
    let first_row = (membrane.ring_radius_m(1) - r) / (membrane.ring_radius_m(along / 2) - r);
    println!(
        "first row / far field: membrane {first_row:.3}, shell {:.3}",
        w(1) / mid
    );
    assert!(first_row > 0.5, "{first_row}");
    assert!(w(1) / mid < 0.1, "{}", w(1) / mid);
}

#[test]
fn with_its_bending_the_shell_still_inflates_as_the_closed_form_tube_within_2_percent() {
    // Free (plane-strain) ends: the bending adds only the wall's
    // through-thickness effect, ≈ T²/12R² relative, and the free ends' curl.
    let law = default_skin();
    let spec = shell_spec(32, 6);
    let mut skin = Skin::new(law, &spec, Ends::PlaneStrain).unwrap();
    for p in [300.0, 550.0] {
        skin.pressure_pa = p;
        skin.relax(1e-9 * p * spec.length_m * spec.mid_radius_m, 400_000)
            .unwrap();
        let mid = 2.0 * skin.ring_radius_m(skin.mesh.middle_ring());
        let want = thin_wall_reference_pa(law, &spec, mid);
        let err = (p - want) / want;
        println!(
            "shell, plane strain: p = {p} Pa vs closed form {want:.2} Pa ({:+.3} %)",
            100.0 * err
        );
        assert!(err.abs() < 0.02, "{err}");
    }
}

#[test]
fn graded_rows_are_fine_at_the_ends_and_symmetric() {
    use fem::mesh::TubeMesh;
    let m = TubeMesh::graded(8.475e-3, 20e-3, 24, 0.35e-3, 20e-3 / 13.0).unwrap();
    let rows: Vec<f64> = (0..m.along).map(|j| m.row_m(j)).collect();
    println!(
        "{} rows: {:?}",
        m.along,
        rows.iter()
            .map(|h| (h * 1e6).round() / 1e3)
            .collect::<Vec<_>>()
    );
    assert_eq!(m.along % 2, 0);
    assert!((m.ring_z_m[m.middle_ring()] - 10e-3).abs() < 1e-12);
    assert_eq!(m.ring_z_m[m.along], 20e-3);
    for j in 0..m.along {
        assert!((rows[j] - rows[m.along - 1 - j]).abs() < 1e-12, "symmetric");
    }
    // The fit scales the nominal rows by at most the last row's share.
    assert!((rows[0] / 0.35e-3 - 1.0).abs() < 0.15, "{}", rows[0]);
    for w in rows[..m.along / 2].windows(2) {
        let growth = w[1] / w[0];
        assert!(
            growth > 0.999 && growth < TubeMesh::GRADING_RATIO + 1e-9,
            "{growth}"
        );
    }
    assert!(rows.iter().all(|&h| h <= 20e-3 / 13.0 * 1.15));
    // The nodes sit on their rings.
    for j in 0..=m.along {
        for a in m.ring(j) {
            assert_eq!(m.rest_m[a].z, m.ring_z_m[j]);
        }
    }
    assert!(TubeMesh::graded(8.475e-3, 20e-3, 24, 0.0, 1e-3).is_err());
    assert!(TubeMesh::graded(8.475e-3, 20e-3, 24, 2e-3, 1e-3).is_err());
}

#[test]
fn the_calipers_at_mid_length_tell_a_round_zone_from_a_lobed_one() {
    let spec = SkinSpec::paper(24, 6);
    let mut skin = Skin::new(default_skin(), &spec, Ends::Clamped).unwrap();
    skin.pressure_pa = 600.0;
    skin.relax(1e-9, 400_000).unwrap();
    let (lo, hi) = skin.calipers_at_mid_length_m();
    println!(
        "D {:.3} mm, calipers {:.4}–{:.4} mm",
        skin.outer_diameter_at_mid_length_m() * 1e3,
        lo * 1e3,
        hi * 1e3
    );
    let d = skin.outer_diameter_at_mid_length_m();
    // Round up to the mesh's own anisotropy (alternating diagonals): 0.9 %.
    assert!(hi - lo < 0.01 * d, "round: {lo} {hi}");
    assert!(lo <= d && d <= hi);
    // Push the middle ring's top node 3 mm out: one caliper grows by 3 mm.
    let j = skin.mesh.middle_ring();
    let top = skin.mesh.ring(j).start + 6; // θ = 90°
    let r = skin.position_m[top].xy().norm();
    skin.position_m[top].y *= (r + 3e-3) / r;
    skin.position_m[top].x *= (r + 3e-3) / r;
    // The caliper through the pushed node, before the push: its own
    // radius was r, its opposite's is unchanged.
    let ring = skin.mesh.ring(j);
    let opposite = ring.start + (6 + ring.len() / 2) % ring.len();
    let before = r + skin.position_m[opposite].xy().norm();
    let (_, hi2) = skin.calipers_at_mid_length_m();
    let t = skin.ring_thickness_m(j).unwrap();
    assert!(
        (hi2 - (before + 3e-3 + t)).abs() < 1e-12,
        "{hi2} vs {}",
        before + 3e-3 + t
    );
    assert!(hi2 > hi + 2.5e-3);
}

#[test]
fn round_rings_stay_round_under_a_one_sided_load() {
    // The pressurised zone pushed sideways at one node of its middle ring:
    // free, the ring dents; with `round_rings` every inner ring stays a
    // circle (calipers equal), its radius set by the loads as a whole.
    let spec = SkinSpec::paper(24, 6);
    let mut spread = Vec::new();
    for round in [false, true] {
        let mut skin = Skin::new(default_skin(), &spec, Ends::Clamped).unwrap();
        skin.round_rings = round;
        skin.pressure_pa = 400.0;
        skin.damping_per_s = 200.0;
        let j = skin.mesh.middle_ring();
        let pushed = skin.mesh.ring(j).start + 6;
        let dt = 0.5 * skin.stable_time_step_s().unwrap();
        for _ in 0..20_000 {
            skin.external_force_n[pushed] = Vector3::new(0.0, -5e-3, 0.0);
            skin.step(dt).unwrap();
        }
        let (lo, hi) = skin.calipers_at_mid_length_m();
        println!("round {round}: calipers {:.4}–{:.4} mm", lo * 1e3, hi * 1e3);
        if round {
            for j in 1..skin.mesh.along {
                let r: Vec<f64> = skin
                    .mesh
                    .ring(j)
                    .map(|a| skin.position_m[a].xy().norm())
                    .collect();
                let (a, b) = r
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
                assert!(b - a < 1e-12, "ring {j}: {a} to {b}");
            }
        }
        spread.push(hi - lo);
    }
    assert!(spread[0] > 0.1e-3, "{spread:?}");
    assert!(spread[1] < 1e-12, "{spread:?}");
}

/// A principal-stretch law drives the FEM skin through the same interface:
/// the membrane elements take its W1, W2 from the invariant form (the
/// contour integrals of `skin::ogden`), the closed-form tube its principal
/// stresses directly; the two meet within the mesh's 2 %.
#[test]
fn an_ogden_skin_inflates_as_its_closed_form_tube() {
    // Two stiffening terms of the default skin's small-strain modulus
    // (μ = ½Σμpαp ≈ 4.6 kPa): neither α is ±2, so no term is Mooney–Rivlin.
    let law = skin::Ogden::new(&[
        skin::OgdenTerm {
            mu_kpa: 3.2,
            alpha: 2.7,
        },
        skin::OgdenTerm {
            mu_kpa: 0.05,
            alpha: 9.0,
        },
    ])
    .unwrap();
    assert!((law.shear_modulus_kpa() - 4.545).abs() < 1e-9);
    let spec = membrane_spec(32, 6);
    let mut skin = Skin::new(law.clone(), &spec, Ends::Closed).unwrap();
    let mid_mm = 2.0 * spec.mid_radius_m * 1e3;
    let thin = Tube::new(
        TubeGeometry {
            outer_diameter_mm: mid_mm + THIN_WALL_MM,
            wall_thickness_mm: THIN_WALL_MM,
            length_mm: spec.length_m * 1e3,
        },
        law,
        membrane::Ends::Closed,
    )
    .unwrap();
    let scale = spec.thickness_m * 1e3 / THIN_WALL_MM;
    for p in [300.0, 600.0] {
        skin.pressure_pa = p;
        skin.relax(1e-9 * p * spec.length_m * spec.mid_radius_m, 400_000)
            .unwrap();
        let mid = 2.0 * skin.ring_radius_m(skin.mesh.middle_ring()) * 1e3;
        let d = mid + THIN_WALL_MM * mid_mm / mid;
        let want = thin.pressure_kpa(d).unwrap() * 1e3 * scale;
        let err = (p - want) / want;
        println!(
            "Ogden, closed ends: D = {:.3} mm, p = {p} Pa vs closed form {want:.2} Pa ({:+.3} %)",
            skin.outer_diameter_at_mid_length_m() * 1e3,
            100.0 * err
        );
        assert!(err.abs() < 0.02, "{err}");
        assert!(mid > mid_mm + 0.5, "inflated: {mid} mm");
    }
}
