//! Closed-form solutions used as test oracles, each with its source.

/// Lamé's thick cylinder under internal pressure, plane strain
/// (Timoshenko & Goodier, Theory of Elasticity, 3rd ed., 1970, sec. 28):
/// radial displacement at radius `r` of a cylinder with inner radius `a`,
/// outer radius `b` (free), internal pressure `p`, Young's modulus `e`,
/// Poisson's ratio `nu`:
///
///   u_r = (1 + nu) p a^2 / (E (b^2 - a^2)) ((1 - 2 nu) r + b^2 / r).
pub fn lame_radial_displacement(a: f64, b: f64, p: f64, e: f64, nu: f64, r: f64) -> f64 {
    (1.0 + nu) * p * a * a / (e * (b * b - a * a)) * ((1.0 - 2.0 * nu) * r + b * b / r)
}

/// Plane-strain Hertz contact of a cylinder of radius `r` on a rigid flat
/// under load `p_per_mm` per unit length (Johnson, Contact Mechanics, 1985,
/// sec. 4.3, with the rigid flat): E* = E / (1 - nu^2),
/// half-width a = sqrt(4 P' R / (pi E*)), peak pressure p0 = 2 P' / (pi a).
/// Returns (a, p0).
pub fn hertz_line_contact(radius: f64, p_per_mm: f64, e: f64, nu: f64) -> (f64, f64) {
    let e_star = e / (1.0 - nu * nu);
    let a = (4.0 * p_per_mm * radius / (std::f64::consts::PI * e_star)).sqrt();
    (a, 2.0 * p_per_mm / (std::f64::consts::PI * a))
}

/// Hertz pressure at position `x` for half-width `a` and peak `p0`:
/// p(x) = p0 sqrt(1 - x^2/a^2) inside the contact, 0 outside.
pub fn hertz_pressure(a: f64, p0: f64, x: f64) -> f64 {
    if x.abs() < a { p0 * (1.0 - (x / a).powi(2)).sqrt() } else { 0.0 }
}

/// Cattaneo-Mindlin partial slip in 2D (Johnson 1985, sec. 7.2): the stick
/// zone half-width c for a tangential load Q below mu P: c/a = sqrt(1 - Q/(mu P)).
pub fn cattaneo_stick_ratio(q: f64, mu: f64, p: f64) -> f64 {
    (1.0 - q / (mu * p)).sqrt()
}
