//! Closest point of a triangle to a point, with its barycentric weights
//! (the shape-function values that spread a contact force on the nodes).

use nalgebra::Vector3;

/// The point of triangle (a, b, c) closest to `p` and its barycentric
/// weights (w_a, w_b, w_c), by the Voronoi regions of the vertices, edges
/// and face (Ericson, *Real-Time Collision Detection*, §5.1.5).
pub fn closest_point_on_triangle(
    p: &Vector3<f64>,
    [a, b, c]: [Vector3<f64>; 3],
) -> (Vector3<f64>, [f64; 3]) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (a + ab * v + ac * w, [1.0 - v - w, v, w])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_and_weights() {
        let t = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
        ];
        let cases = [
            (Vector3::new(0.2, 0.3, 0.7), [0.5, 0.2, 0.3]),
            (Vector3::new(-1.0, -1.0, 0.0), [1.0, 0.0, 0.0]),
            (Vector3::new(2.0, -0.5, 1.0), [0.0, 1.0, 0.0]),
            (Vector3::new(0.5, -2.0, 0.0), [0.5, 0.5, 0.0]),
            (Vector3::new(1.0, 1.0, 3.0), [0.0, 0.5, 0.5]),
            (Vector3::new(-1.0, 0.25, 0.0), [0.75, 0.0, 0.25]),
        ];
        for (p, want) in cases {
            let (q, w) = closest_point_on_triangle(&p, t);
            for k in 0..3 {
                assert!((w[k] - want[k]).abs() < 1e-12, "{p:?}: {w:?}");
            }
            let back = t[0] * w[0] + t[1] * w[1] + t[2] * w[2];
            assert!((back - q).norm() < 1e-12);
        }
    }
}
