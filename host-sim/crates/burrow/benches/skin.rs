//! One explicit step of the paper's zone skin, the solver's inner loop
//! besides the grains: the mid-surface membrane (the scenario's 24 × 6)
//! and the solid wall (`ScenarioSpec::with_solid(2)`: 24 × 13 graded rows,
//! two hexahedra thick), both inflated to D ≈ 22 mm so the law is in its
//! stiffening range. `cargo bench --target host-tuple -p burrow --bench skin`.

use burrow::ScenarioSpec;
use criterion::{criterion_group, criterion_main, Criterion};
use fem::Ends;

fn inflated(layers: usize) -> fem::Skin<skin::SkinLaw> {
    let spec = ScenarioSpec::paper(0.04, 1.5e-3);
    // The scenario's skin is the solid: the membrane has to be asked for.
    let spec = if let Some(layers) = std::num::NonZeroUsize::new(layers) {
        spec.with_solid(layers)
    } else {
        spec.with_membrane()
    };
    let mut skin = spec.skin(Ends::Clamped).expect("the paper's skin");
    skin.pressure_pa = 2_000.0;
    skin.relax(1e-4, 200_000).expect("relaxes");
    skin
}

fn step(c: &mut Criterion) {
    for (name, layers) in [("membrane 24x6", 0), ("solid 24x13x2", 2)] {
        let mut skin = inflated(layers);
        let dt = skin.stable_time_step_s().expect("a stable step");
        c.bench_function(&format!("skin step, {name}"), |b| {
            b.iter(|| skin.step(dt).expect("steps"))
        });
    }
}

criterion_group!(benches, step);
criterion_main!(benches);
