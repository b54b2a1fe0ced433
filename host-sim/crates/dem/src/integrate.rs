//! Velocity Verlet for translation and rotation (spheres: isotropic
//! inertia, so ω advances like v): half kick, drift, forces, half kick.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::forces::{far, simd, Simd};
use super::particles::{pack_one, Motion, Packed, Particles, Sphere};
use super::team::Team;
use super::wall_contacts::{SweepWalls, WallContacts, WALL_CHUNK};
use super::Params;

/// Particles per parallel task: whole wall chunks, whose contacts a task
/// evaluates after its drift.
const CHUNK: usize = 1024;
const _: () = assert!(CHUNK.is_multiple_of(WALL_CHUNK));

/// The wall contacts for [`kick_drift`], and whether it evaluates them
/// (it adds pending ones in any case).
pub(crate) type Walls<'a> = (&'a Params, &'a mut WallContacts, bool);

/// First half: v += dt/2 F/m, ω += dt/2 τ/I, x += dt v, writing the new
/// state into `packed` (resized to fit) for the force pass that follows.
/// With `close_previous`, the previous step's closing half kick (the same
/// forces, since nothing changed them) is applied first, in the same
/// operations as [`kick`]: one sweep instead of two, the same bits.
/// Once read, each force and torque is set to the body force
/// `body_accel_m_s2` × m and zero, where the pair pass would start its
/// sums (on a bed beyond the caches, a sweep of its own that came from
/// memory). With `from_rows`, the motion is read from `packed` (which must
/// hold the current positions, velocities and spins) and written there
/// alone, `p`'s own positions, velocities and spins left behind for
/// [`Packed::unpack_into`]; else it is read from `p` and written to both.
/// Pending wall contributions are added to the sums before they are read;
/// with `walls`' flag, each task then evaluates its particles' wall
/// contacts from the rows it has just written, to be added in the next
/// sweep ([`WallContacts::sweep_pieces`]).
/// Returns the largest squared displacement from `reference_m` (m²), for
/// the Verlet-list check: NaN if any position is NaN.
pub(crate) fn kick_drift(
    p: &mut Particles,
    (dt_s, body_accel_m_s2): (f64, Vector3<f64>),
    reference_m: &[Vector3<f64>],
    packed: &mut Packed,
    (params, contacts, evaluate): Walls,
    (close_previous, from_rows): (bool, bool),
    team: &Team,
) -> f64 {
    // Rows that are read first are not streamed past the caches.
    let stream = !from_rows && far(p.len());
    let walls = contacts.sweep_pieces(params, CHUNK, evaluate);
    let args = (p, dt_s, body_accel_m_s2, reference_m, packed, walls, team);
    match (close_previous, stream, from_rows) {
        (true, true, _) => kick_drift_in::<true, true, false>(args),
        (false, true, _) => kick_drift_in::<false, true, false>(args),
        (true, false, true) => kick_drift_in::<true, false, true>(args),
        (false, false, true) => kick_drift_in::<false, false, true>(args),
        (true, false, false) => kick_drift_in::<true, false, false>(args),
        (false, false, false) => kick_drift_in::<false, false, false>(args),
    }
}

/// The arguments of [`kick_drift`] but the flags.
type KickDriftArgs<'a, 't, 's> = (
    &'a mut Particles,
    f64,
    Vector3<f64>,
    &'a [Vector3<f64>],
    &'a mut Packed,
    Vec<SweepWalls<'a>>,
    &'a Team<'t, 's>,
);

/// [`kick_drift`], compiled with and without the closing half kick
/// (`CLOSE`), streaming stores of the packed rows (`STREAM`, on beds
/// beyond the caches: see [`store_rows`]) and the motion taken from the
/// rows (`FROM_ROWS`), so that none pays a branch per particle.
fn kick_drift_in<const CLOSE: bool, const STREAM: bool, const FROM_ROWS: bool>(
    (p, dt_s, body, reference_m, packed, walls, team): KickDriftArgs,
) -> f64 {
    let simd = simd();
    packed.resize(p.len());
    let (r, m) = (&p.radius_m[..], &p.mass_kg[..]);
    let mut chunks = Vec::with_capacity(p.len().div_ceil(CHUNK));
    let mut x0 = reference_m.chunks(CHUNK);
    let mut im = p.inv_mass_per_kg.chunks(CHUNK);
    let mut ii = p.inv_inertia_per_kg_m2.chunks(CHUNK);
    let mut sphere = packed.sphere.chunks_mut(CHUNK);
    let mut motion = packed.motion.chunks_mut(CHUNK);
    let mut v = p.velocity_m_s.chunks_mut(CHUNK);
    let mut w = p.angular_velocity_rad_s.chunks_mut(CHUNK);
    let mut f = p.force_n.chunks_mut(CHUNK);
    let mut t = p.torque_n_m.chunks_mut(CHUNK);
    let mut walls = walls.into_iter();
    for (c, x) in p.position_m.chunks_mut(CHUNK).enumerate() {
        let pieces = (v.next(), w.next(), f.next(), t.next(), im.next(), ii.next());
        let rows = (x0.next(), sphere.next(), motion.next());
        let (Some(v), Some(w), Some(f), Some(t), Some(im), Some(ii)) = pieces else {
            break;
        };
        let (Some(x0), Some(sphere), Some(motion)) = rows else {
            break;
        };
        let walls = walls.next();
        chunks.push((
            Chunk {
                first: c * CHUNK,
                x,
                v,
                w,
                f,
                t,
                im,
                ii,
                x0,
                sphere,
                motion,
            },
            walls,
        ));
    }
    let max2 = team.map(chunks, |_, (mut chunk, walls)| {
        if let Some(walls) = &walls {
            walls.add_pending(chunk.f, chunk.t);
        }
        let args = (chunk.reborrow(), r, m, dt_s, body);
        let max2 = match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `Simd::Avx2` is chosen only where the CPU has AVX2.
            Simd::Avx2 => unsafe { sweep_avx2::<CLOSE, STREAM, FROM_ROWS>(args) },
            _ => sweep::<CLOSE, STREAM, FROM_ROWS>(args),
        };
        if let Some(mut walls) = walls {
            walls.evaluate(chunk.sphere, chunk.motion);
        }
        max2
    });
    f64::from_bits(max2.into_iter().fold(0, u64::max))
}

/// One task's share of the first sweep: particles `first..` of the
/// slices, each cut to the task's chunk.
struct Chunk<'a> {
    first: usize,
    x: &'a mut [Vector3<f64>],
    v: &'a mut [Vector3<f64>],
    w: &'a mut [Vector3<f64>],
    f: &'a mut [Vector3<f64>],
    t: &'a mut [Vector3<f64>],
    im: &'a [f64],
    ii: &'a [f64],
    x0: &'a [Vector3<f64>],
    sphere: &'a mut [Sphere],
    motion: &'a mut [Motion],
}

impl Chunk<'_> {
    /// The same chunk, borrowed again.
    fn reborrow(&mut self) -> Chunk<'_> {
        Chunk {
            first: self.first,
            x: self.x,
            v: self.v,
            w: self.w,
            f: self.f,
            t: self.t,
            im: self.im,
            ii: self.ii,
            x0: self.x0,
            sphere: self.sphere,
            motion: self.motion,
        }
    }
}

/// The arguments of [`sweep`]: a chunk, every particle's radius and mass,
/// the step (s) and the body acceleration (m/s²).
type SweepArgs<'a, 'b> = (Chunk<'a>, &'b [f64], &'b [f64], f64, Vector3<f64>);

/// [`kick_drift_in`] over one chunk, returning its largest squared
/// displacement as bits.
#[inline(always)]
fn sweep<const CLOSE: bool, const STREAM: bool, const FROM_ROWS: bool>(
    (c, r, m, dt_s, body): SweepArgs,
) -> u64 {
    let h = 0.5 * dt_s;
    let Chunk {
        first,
        x,
        v,
        w,
        f,
        t,
        im,
        ii,
        x0,
        sphere,
        motion,
    } = c;
    // The largest squared displacement as bits: for the values here (≥ 0,
    // or NaN) the integers order as the numbers do, NaN above all, so one
    // NaN makes the result NaN (`f64::max` would drop it and a bed gone
    // non-finite would step on unseen).
    let mut max2 = 0u64;
    for k in 0..x.len() {
        let i = first + k;
        let (mut xk, mut vk, mut wk, rk, mk) = if FROM_ROWS {
            let (s, q) = (&sphere[k], &motion[k]);
            (
                s.position_m(),
                q.velocity_m_s(),
                q.spin_rad_s(),
                s.radius_m(),
                q.mass_kg(),
            )
        } else {
            (x[k], v[k], w[k], r[i], m[i])
        };
        let (dv, dw) = half_kick(&f[k], &t[k], im[k], ii[k], h);
        f[k] = body * mk;
        t[k] = Vector3::zeros();
        if CLOSE {
            vk += dv;
            wk += dw;
        }
        vk += dv;
        wk += dw;
        xk += vk * dt_s;
        max2 = max2.max((xk - x0[k]).norm_squared().to_bits());
        if !FROM_ROWS {
            (x[k], v[k], w[k]) = (xk, vk, wk);
        }
        let rows = pack_one(&xk, &vk, &wk, rk, mk);
        store_rows::<STREAM>(&mut sphere[k], &mut motion[k], rows);
    }
    if STREAM {
        fence_streams();
    }
    max2
}

/// [`sweep`] for AVX2: with the motion in the rows, each row is one
/// 256-bit register and a particle's kick and drift a few vector
/// operations (the compiler leaves the three-component form scalar); the
/// same operations lane by lane, so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn sweep_avx2<const CLOSE: bool, const STREAM: bool, const FROM_ROWS: bool>(
    args: SweepArgs,
) -> u64 {
    use std::arch::x86_64::*;
    if STREAM || !FROM_ROWS {
        return sweep::<CLOSE, STREAM, FROM_ROWS>(args);
    }
    let (c, _, _, dt_s, body) = args;
    let h = 0.5 * dt_s;
    // [x, y, z, 0] from a three-component vector, and back.
    let load3 = |v: &Vector3<f64>| {
        let p = v.as_ptr();
        // SAFETY: a `Vector3<f64>` is three contiguous f64.
        unsafe {
            _mm256_insertf128_pd::<1>(
                _mm256_castpd128_pd256(_mm_loadu_pd(p)),
                _mm_load_sd(p.add(2)),
            )
        }
    };
    let store3 = |v: &mut Vector3<f64>, q: __m256d| {
        let p = v.as_mut_ptr();
        // SAFETY: as for `load3`.
        unsafe {
            _mm_storeu_pd(p, _mm256_castpd256_pd128(q));
            _mm_store_sd(p.add(2), _mm256_extractf128_pd::<1>(q));
        }
    };
    let body = load3(&body);
    let zero = _mm256_setzero_pd();
    let dt = _mm256_set1_pd(dt_s);
    let mut max2 = 0u64;
    let n = c.x.len();
    let (sphere, f, t, im, ii, x0, motion) = (
        &mut c.sphere[..n],
        &mut c.f[..n],
        &mut c.t[..n],
        &c.im[..n],
        &c.ii[..n],
        &c.x0[..n],
        &mut c.motion[..n],
    );
    for k in 0..n {
        let (s, q) = (sphere[k].0.as_mut_ptr(), &mut motion[k].0);
        // SAFETY: a sphere row is 32-byte aligned, a motion row's halves
        // too (`Sphere`, `Motion`).
        let (xr, v, w) = unsafe {
            (
                _mm256_load_pd(s),
                _mm256_load_pd(q[0].as_ptr()),
                _mm256_load_pd(q[1].as_ptr()),
            )
        };
        // The half kick's changes, with nothing in the fourth lane (the
        // mass beside v, the padding beside ω).
        let dv = _mm256_mul_pd(load3(&f[k]), _mm256_set1_pd(h * im[k]));
        let dw = _mm256_mul_pd(load3(&t[k]), _mm256_set1_pd(h * ii[k]));
        let (dv, dw) = (
            _mm256_blend_pd::<0b1000>(dv, zero),
            _mm256_blend_pd::<0b1000>(dw, zero),
        );
        let mass = _mm256_permute4x64_pd::<0b1111_1111>(v);
        store3(&mut f[k], _mm256_mul_pd(body, mass));
        store3(&mut t[k], zero);
        let (mut v, mut w) = (v, w);
        if CLOSE {
            v = _mm256_add_pd(v, dv);
            w = _mm256_add_pd(w, dw);
        }
        v = _mm256_add_pd(v, dv);
        w = _mm256_blend_pd::<0b1000>(_mm256_add_pd(w, dw), zero);
        // x += v dt, the radius kept.
        let x = _mm256_blend_pd::<0b1000>(_mm256_add_pd(xr, _mm256_mul_pd(v, dt)), xr);
        let mut d = [0.0; 4];
        // SAFETY: `d` holds four f64.
        unsafe { _mm256_storeu_pd(d.as_mut_ptr(), _mm256_sub_pd(x, load3(&x0[k]))) };
        let d = Vector3::new(d[0], d[1], d[2]);
        max2 = max2.max(d.norm_squared().to_bits());
        // SAFETY: as for the loads.
        unsafe {
            _mm256_store_pd(s, x);
            _mm256_store_pd(q[0].as_mut_ptr(), v);
            _mm256_store_pd(q[1].as_mut_ptr(), w);
        }
    }
    max2
}

/// The changes of velocity (m/s) and spin (rad/s) a half kick of `h` (s)
/// gives a particle under force `f` (N) and torque `t` (N·m): the one
/// formula of the first sweep and of [`kick`], so that fusing the closing
/// kick into the sweep keeps the bits.
#[inline(always)]
fn half_kick(
    f: &Vector3<f64>,
    t: &Vector3<f64>,
    inv_mass_per_kg: f64,
    inv_inertia_per_kg_m2: f64,
    h: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    (f * (h * inv_mass_per_kg), t * (h * inv_inertia_per_kg_m2))
}

/// Stores a particle's packed rows; with `STREAM`, past the caches
/// (non-temporal stores). The rows are only written here, so a plain store
/// first reads each line from memory to own it; on a bed larger than the
/// caches the pass that reads them comes long after, from memory anyway.
#[inline(always)]
fn store_rows<const STREAM: bool>(
    sphere: &mut Sphere,
    motion: &mut Motion,
    rows: (Sphere, Motion),
) {
    #[cfg(target_arch = "x86_64")]
    if STREAM {
        use std::arch::x86_64::{_mm_loadu_pd, _mm_stream_pd};
        let (s, m) = rows;
        let halves = |q: &[f64; 4]| [[q[0], q[1]], [q[2], q[3]]];
        let put = |to: *mut f64, q: &[f64; 4]| {
            for (h, half) in halves(q).iter().enumerate() {
                // SAFETY: SSE2 is part of x86-64; `to` points into a row
                // aligned to 32 bytes (a sphere) or 64 (a motion row), so
                // each half is 16-byte aligned, as the store needs.
                unsafe { _mm_stream_pd(to.add(2 * h), _mm_loadu_pd(half.as_ptr())) }
            }
        };
        put(sphere.0.as_mut_ptr(), &s.0);
        put(motion.0[0].as_mut_ptr(), &m.0[0]);
        put(motion.0[1].as_mut_ptr(), &m.0[1]);
        return;
    }
    (*sphere, *motion) = rows;
}

/// Orders a task's streaming stores before what follows it (they are not
/// ordered by the task's join otherwise).
#[inline(always)]
fn fence_streams() {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of x86-64.
    unsafe {
        std::arch::x86_64::_mm_sfence()
    }
}

/// Second half: v += dt/2 F/m, ω += dt/2 τ/I.
pub fn kick(p: &mut Particles, dt_s: f64) {
    let h = 0.5 * dt_s;
    (
        p.velocity_m_s.par_chunks_mut(CHUNK),
        p.angular_velocity_rad_s.par_chunks_mut(CHUNK),
        p.force_n.par_chunks(CHUNK),
        p.torque_n_m.par_chunks(CHUNK),
        p.inv_mass_per_kg.par_chunks(CHUNK),
        p.inv_inertia_per_kg_m2.par_chunks(CHUNK),
    )
        .into_par_iter()
        .for_each(|(v, w, f, t, im, ii)| {
            for k in 0..v.len() {
                let (dv, dw) = half_kick(&f[k], &t[k], im[k], ii[k], h);
                v[k] += dv;
                w[k] += dw;
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Particles in motion with forces on them, more than one task's chunk.
    fn moving(n: usize) -> Particles {
        let mut p = Particles::new();
        for i in 0..n {
            let s = i as f64;
            let x = Vector3::new(1e-3 * s, 2e-3 * (s * 0.7).sin(), -1e-3 * s.sqrt());
            let v = Vector3::new((s * 0.3).cos(), 0.1 * s.sin(), -0.01 * s);
            p.push(x, v, 1e-3 * (1.0 + 0.001 * s), 2920.0).unwrap();
            p.angular_velocity_rad_s[i] = Vector3::new(0.5 * s.sin(), -s.cos(), 2.0);
            p.force_n[i] = Vector3::new(1e-4 * s.cos(), -2e-4, 3e-4 * s.sin());
            p.torque_n_m[i] = Vector3::new(1e-7, -1e-7 * s.sin(), 1e-8 * s);
        }
        p
    }

    #[test]
    fn streamed_rows_are_the_stored_ones() {
        // The far-bed sweep writes the packed rows past the caches; it
        // must leave every row and every particle as the plain sweep does.
        let n = 2 * CHUNK + 37;
        let reference: Vec<_> = moving(n).position_m;
        let g = Vector3::new(0.0, 0.0, -9.81);
        for close in [false, true] {
            let (mut a, mut b) = (moving(n), moving(n));
            let (mut pa, mut pb) = (Packed::default(), Packed::default());
            let team = Team::alone();
            let args = |p, packed| (p, 1.5e-5, g, &reference[..], packed, Vec::new(), &team);
            let (ma, mb) = if close {
                (
                    kick_drift_in::<true, false, false>(args(&mut a, &mut pa)),
                    kick_drift_in::<true, true, false>(args(&mut b, &mut pb)),
                )
            } else {
                (
                    kick_drift_in::<false, false, false>(args(&mut a, &mut pa)),
                    kick_drift_in::<false, true, false>(args(&mut b, &mut pb)),
                )
            };
            assert!(ma > 0.0);
            assert_eq!(ma.to_bits(), mb.to_bits());
            for i in 0..n {
                assert_eq!(pa.sphere[i].0, pb.sphere[i].0, "sphere row {i}");
                assert_eq!(pa.motion[i].0, pb.motion[i].0, "motion row {i}");
                assert_eq!(a.position_m[i], b.position_m[i]);
                assert_eq!(a.velocity_m_s[i], b.velocity_m_s[i]);
                assert_eq!(a.force_n[i], b.force_n[i]);
            }
            // And the rows are the state's, not stale.
            let (x, r) = (&a.position_m[n - 1], a.radius_m[n - 1]);
            assert_eq!(pb.sphere[n - 1].0, [x.x, x.y, x.z, r]);
        }
    }
}
