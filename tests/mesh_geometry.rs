//! Meshes of rocks: readers, mass properties, hull, resting contact and the planar body of
//! each direction, verified against closed forms on meshes generated here (boxes, rotated and
//! translated; prisms; wedges with asymmetric pivots; a chamfered base for the contact
//! tolerance; faceted cylinders converging to the cylinder with the polygon's error bound),
//! against an independent quasi-static 3-D computation of the uplift (moments about every
//! edge of the base, in every direction), and round trips through every file format written
//! by independent writers below.

use rockwatch_core::mesh::contact::{parse_azimuths, RockGeometry, UpAxis};
use rockwatch_core::mesh::mass::MassProperties;
use rockwatch_core::mesh::{MeshError, MeshFormat, TriMesh};

type P = [f64; 3];

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol * b.abs().max(1.0),
        "{what}: {a} vs {b} (diff {:e})",
        (a - b).abs()
    );
}

/// A closed, outward mesh of a convex polygon (u, v), given counter-clockwise, extruded along
/// the w axis from −w/2 to w/2; points are placed at (x, y, z) = (u, w, v).
fn extrude(polygon: &[(f64, f64)], width: f64) -> (Vec<P>, Vec<[usize; 3]>) {
    let n = polygon.len();
    let mut vertices = Vec::new();
    for &(u, v) in polygon {
        vertices.push([u, -width / 2.0, v]);
    }
    for &(u, v) in polygon {
        vertices.push([u, width / 2.0, v]);
    }
    let mut faces = Vec::new();
    // A CCW polygon in (u, v) placed at (u, ·, v) has normal −y: the y = −w/2 cap keeps the
    // order, the other reverses it.
    for k in 1..n - 1 {
        faces.push([0, k, k + 1]);
        faces.push([n, n + k + 1, n + k]);
    }
    for i in 0..n {
        let j = (i + 1) % n;
        faces.push([i, n + i, n + j]);
        faces.push([i, n + j, j]);
    }
    (vertices, faces)
}

fn mesh(vertices: Vec<P>, faces: Vec<[usize; 3]>) -> TriMesh {
    let mut m = TriMesh {
        source: "generated".into(),
        face_lines: vec![0; faces.len()],
        vertices,
        faces,
    };
    m.validate().expect("valid mesh");
    m
}

/// Rotation matrix about a unit axis by `angle` (rad), Rodrigues.
fn rotation(axis: P, angle: f64) -> [[f64; 3]; 3] {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    let t = 1.0 - c;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

fn apply(r: &[[f64; 3]; 3], shift: P, p: P) -> P {
    let mut q = shift;
    for i in 0..3 {
        for j in 0..3 {
            q[i] += r[i][j] * p[j];
        }
    }
    q
}

/// Area, centroid and central second moments (Cuu, Cvv per unit area: the covariance) of a
/// simple polygon by the shoelace formulas (independent of the tetrahedra of the library).
fn polygon_moments(poly: &[(f64, f64)]) -> (f64, (f64, f64), (f64, f64)) {
    let n = poly.len();
    let (mut a, mut cu, mut cv, mut iuu, mut ivv) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let (u0, v0) = poly[i];
        let (u1, v1) = poly[(i + 1) % n];
        let cross = u0 * v1 - u1 * v0;
        a += cross / 2.0;
        cu += (u0 + u1) * cross / 6.0;
        cv += (v0 + v1) * cross / 6.0;
        iuu += (u0 * u0 + u0 * u1 + u1 * u1) * cross / 12.0;
        ivv += (v0 * v0 + v0 * v1 + v1 * v1) * cross / 12.0;
    }
    let (gu, gv) = (cu / a, cv / a);
    (a, (gu, gv), (iuu / a - gu * gu, ivv / a - gv * gv))
}

#[test]
fn box_mass_properties_and_every_direction_match_closed_forms() {
    let (a, b, c) = (0.8, 0.5, 1.6); // x, y, z
    let (v, f) = extrude(
        &[(-a / 2.0, 0.0), (a / 2.0, 0.0), (a / 2.0, c), (-a / 2.0, c)],
        b,
    );
    let m = mesh(v, f);
    let mp = MassProperties::of(&m);
    close(mp.volume_m3, a * b * c, 1e-13, "volume");
    for (k, want) in [0.0, 0.0, c / 2.0].iter().enumerate() {
        close(mp.com_m[k], *want, 1e-13, "com");
    }
    let i = mp.inertia_com;
    let vol = a * b * c;
    close(i[0][0], vol * (b * b + c * c) / 12.0, 1e-12, "Ixx");
    close(i[1][1], vol * (a * a + c * c) / 12.0, 1e-12, "Iyy");
    close(i[2][2], vol * (a * a + b * b) / 12.0, 1e-12, "Izz");
    for (p, q) in [(0, 1), (0, 2), (1, 2)] {
        assert!(
            i[p][q].abs() < 1e-14 && i[q][p].abs() < 1e-14,
            "product {p}{q}"
        );
    }
    let rock = RockGeometry::new(&m).unwrap();
    let rest = rock.rest(UpAxis::PlusZ, 0.005).unwrap();
    assert_eq!(rest.facet_vertices, 4);
    close(rest.tilt_deg, 0.0, 1e-9, "tilt");
    for az in [0.0, 30.0, 45.0, 90.0, 135.0, 200.0, 270.0] {
        let d = rest.direction(az);
        let r = f64::to_radians(az);
        // The ray from the centre along d = (sin az, cos az) in (x = east, y = north) leaves
        // the base rectangle through the nearer of its sides: min(a/2 / |sin|, b/2 / |cos|).
        let exit = (a / 2.0 / r.sin().abs()).min(b / 2.0 / r.cos().abs());
        close(d.b_plus_m, exit, 1e-12, "b+");
        close(d.b_minus_m, exit, 1e-12, "b-");
        close(d.h_m, c / 2.0, 1e-12, "h");
        // Axis U × d = (−cos az, sin az, 0): I = cos²·Ixx + sin²·Iyy.
        let rho2 = (r.cos().powi(2) * (b * b + c * c) + r.sin().powi(2) * (a * a + c * c)) / 12.0;
        close(d.rho_m, rho2.sqrt(), 1e-12, "rho");
        close(
            d.alpha_plus_deg,
            (exit / (c / 2.0)).atan().to_degrees(),
            1e-12,
            "alpha",
        );
    }
    // At az = 0 this is the rectangle b × c of docs/general-body.md: ρ² = (B² + H²)/12.
    let d = rest.direction(0.0);
    close(
        d.rho_m * d.rho_m,
        (b * b + c * c) / 12.0,
        1e-12,
        "rectangle rho",
    );
}

#[test]
fn rotated_and_translated_boxes_give_the_same_bodies_in_their_own_frame() {
    let (a, b, c) = (0.6, 0.4, 1.2);
    let (v, f) = extrude(
        &[(-a / 2.0, 0.0), (a / 2.0, 0.0), (a / 2.0, c), (-a / 2.0, c)],
        b,
    );
    let reference = RockGeometry::new(&mesh(v.clone(), f.clone()))
        .unwrap()
        .rest(UpAxis::PlusZ, 0.005)
        .unwrap();
    // (1) Turned by φ about the vertical and moved: mesh azimuth az is body azimuth az + φ
    // (a counter-clockwise turn seen from above lowers clockwise azimuths).
    let phi = 27f64.to_radians();
    let r = rotation([0.0, 0.0, 1.0], phi);
    let shift = [12.5, -3.25, 101.0];
    let moved: Vec<P> = v.iter().map(|p| apply(&r, shift, *p)).collect();
    let rest = RockGeometry::new(&mesh(moved, f.clone()))
        .unwrap()
        .rest(UpAxis::PlusZ, 0.005)
        .unwrap();
    close(rest.mass.com_m[0], shift[0] + 0.0, 1e-12, "com x");
    close(rest.mass.com_m[2], shift[2] + c / 2.0, 1e-12, "com z");
    for az in [0.0, 20.0, 63.0, 90.0, 181.0] {
        let got = rest.direction(az);
        let want = reference.direction(az + 27.0);
        close(got.b_plus_m, want.b_plus_m, 1e-9, "b+");
        close(got.b_minus_m, want.b_minus_m, 1e-9, "b-");
        close(got.h_m, want.h_m, 1e-9, "h");
        close(got.rho_m, want.rho_m, 1e-9, "rho");
    }
    // (2) Tilted by 12° about east and given up = z: it rests on its (tilted) base, and its
    // frame is the body's own (north = R·y), so every direction is unchanged.
    let r = rotation([1.0, 0.0, 0.0], 12f64.to_radians());
    let tilted: Vec<P> = v.iter().map(|p| apply(&r, [0.0; 3], *p)).collect();
    let rest = RockGeometry::new(&mesh(tilted, f.clone()))
        .unwrap()
        .rest(UpAxis::PlusZ, 0.005)
        .unwrap();
    close(rest.tilt_deg, 12.0, 1e-9, "tilt");
    for az in [0.0, 45.0, 90.0, 300.0] {
        let (got, want) = (rest.direction(az), reference.direction(az));
        close(got.b_plus_m, want.b_plus_m, 1e-9, "b+");
        close(got.rho_m, want.rho_m, 1e-9, "rho");
        close(got.h_m, want.h_m, 1e-9, "h");
    }
    // (3) The same box written with y up (x = north, z = east): rotate z → y.
    let to_y_up = |p: &P| [p[1], p[2], p[0]]; // (east x, north y, up z) → (north, up, east)
    let y_up: Vec<P> = v.iter().map(to_y_up).collect();
    let rest = RockGeometry::new(&mesh(y_up, f))
        .unwrap()
        .rest(UpAxis::PlusY, 0.005)
        .unwrap();
    for az in [0.0, 45.0, 90.0] {
        let (got, want) = (rest.direction(az), reference.direction(az));
        close(got.b_plus_m, want.b_plus_m, 1e-12, "b+ (y up)");
        close(got.rho_m, want.rho_m, 1e-12, "rho (y up)");
    }
    // Lying on its side: with up = x the stable facet nearest to +x is the side x = −a/2.
    let rest = reference_geometry(a, b, c)
        .rest(UpAxis::PlusX, 0.005)
        .unwrap();
    close(rest.h_m, a / 2.0, 1e-12, "h on the side");
}

fn reference_geometry(a: f64, b: f64, c: f64) -> RockGeometry {
    let (v, f) = extrude(
        &[(-a / 2.0, 0.0), (a / 2.0, 0.0), (a / 2.0, c), (-a / 2.0, c)],
        b,
    );
    RockGeometry::new(&mesh(v, f)).unwrap()
}

#[test]
fn wedge_has_asymmetric_pivots_from_the_triangle_closed_form() {
    // Triangle base [0, L] on the ground, apex at (p, H), extruded W along north (y).
    let (l, p, hgt, w) = (1.0, 0.15, 1.8, 0.7);
    let poly = [(0.0, 0.0), (l, 0.0), (p, hgt)];
    let (v, f) = extrude(&poly, w);
    let m = mesh(v, f);
    let rest = RockGeometry::new(&m)
        .unwrap()
        .rest(UpAxis::PlusZ, 0.005)
        .unwrap();
    let xbar = (l + p) / 3.0;
    let (area, (gu, gv), (cuu, cvv)) = polygon_moments(&poly);
    close(area, l * hgt / 2.0, 1e-14, "shoelace area");
    close(gu, xbar, 1e-14, "centroid");
    close(gv, hgt / 3.0, 1e-14, "centroid");
    close(rest.mass.volume_m3, area * w, 1e-13, "volume");
    // East (az 90): pivots at x = L (+) and x = 0 (−).
    let east = rest.direction(90.0);
    close(east.b_plus_m, l - xbar, 1e-12, "b+");
    close(east.b_minus_m, xbar, 1e-12, "b-");
    close(east.h_m, hgt / 3.0, 1e-12, "h");
    // Rotation about north (y) through the centroid: in-plane covariance trace.
    close(east.rho_m * east.rho_m, cuu + cvv, 1e-12, "rho² east");
    // Triangle covariance, second independent form: (1/12)·Σ|v_i − g|² per axis.
    let cuu2 = poly.iter().map(|&(u, _)| (u - gu).powi(2)).sum::<f64>() / 12.0;
    close(cuu, cuu2, 1e-12, "triangle covariance");
    let west = rest.direction(270.0);
    close(west.b_plus_m, xbar, 1e-12, "b+ west = b- east");
    close(west.b_minus_m, l - xbar, 1e-12, "b- west");
    close(west.rho_m, east.rho_m, 1e-12, "rho west");
    assert!(east.alpha_plus_deg > east.alpha_minus_deg);
    // North: symmetric pivots W/2, ρ² = W²/12 + Cvv.
    let north = rest.direction(0.0);
    close(north.b_plus_m, w / 2.0, 1e-12, "b+ north");
    close(north.b_minus_m, w / 2.0, 1e-12, "b- north");
    close(
        north.rho_m * north.rho_m,
        w * w / 12.0 + cvv,
        1e-12,
        "rho² north",
    );
}

#[test]
fn upright_triangular_prism_matches_closed_forms() {
    // Right triangle legs 0.9 (east) and 0.6 (north) standing on it, height 1.5 (z).
    let (ex, ny, hgt) = (0.9, 0.6, 1.5);
    // extrude places (u, ·, v): build it lying, then stand it up with x' = u, y' = v, z' = w:
    // a rotation by −90° about x maps (u, w, v) → (u, v, −w); shift up by H/2.
    let poly = [(0.0, 0.0), (ex, 0.0), (0.0, ny)];
    let (v, f) = extrude(&poly, hgt);
    let r = rotation([1.0, 0.0, 0.0], -std::f64::consts::FRAC_PI_2);
    let stood: Vec<P> = v
        .iter()
        .map(|p| apply(&r, [0.0, 0.0, hgt / 2.0], *p))
        .collect();
    let m = mesh(stood, f);
    let rest = RockGeometry::new(&m)
        .unwrap()
        .rest(UpAxis::PlusZ, 0.001)
        .unwrap();
    let (gx, gy) = (ex / 3.0, ny / 3.0);
    close(rest.mass.com_m[0], gx, 1e-12, "com x");
    close(rest.mass.com_m[1], gy, 1e-12, "com y");
    close(rest.h_m, hgt / 2.0, 1e-12, "h");
    let (_, _, (cxx, cyy)) = polygon_moments(&poly);
    // The ray east from the centroid (ex/3, ny/3) leaves through the hypotenuse
    // x/ex + y/ny = 1 at x = 2ex/3 (not at the vertex (ex, 0), which is off the ray); west
    // through the leg x = 0.
    let east = rest.direction(90.0);
    close(east.b_plus_m, ex / 3.0, 1e-12, "b+ east");
    close(east.b_minus_m, gx, 1e-12, "b- east");
    close(
        east.rho_m.powi(2),
        cxx + hgt * hgt / 12.0,
        1e-12,
        "rho east",
    );
    let north = rest.direction(0.0);
    close(north.b_plus_m, ny / 3.0, 1e-12, "b+ north");
    close(north.b_minus_m, gy, 1e-12, "b- north");
    close(
        north.rho_m.powi(2),
        cyy + hgt * hgt / 12.0,
        1e-12,
        "rho north",
    );
}

#[test]
fn contact_tolerance_widens_the_patch_to_a_chamfer_within_it() {
    // A block whose east bottom edge is chamfered: it rises 3 mm over the last 40 mm.
    let (a, c, w, rise, run) = (0.5, 1.0, 0.4, 0.003, 0.04);
    let poly = [
        (-a / 2.0, 0.0),
        (a / 2.0 - run, 0.0),
        (a / 2.0, rise),
        (a / 2.0, c),
        (-a / 2.0, c),
    ];
    let (v, f) = extrude(&poly, w);
    let rock = RockGeometry::new(&mesh(v, f)).unwrap();
    let (_, (gx, gz), _) = polygon_moments(&poly);
    let tight = rock.rest(UpAxis::PlusZ, 0.001).unwrap().direction(90.0);
    let wide = rock.rest(UpAxis::PlusZ, 0.005).unwrap().direction(90.0);
    close(tight.b_plus_m, a / 2.0 - run - gx, 1e-12, "b+ within 1 mm");
    close(wide.b_plus_m, a / 2.0 - gx, 1e-12, "b+ within 5 mm");
    close(tight.b_minus_m, a / 2.0 + gx, 1e-12, "b- tight");
    close(wide.b_minus_m, a / 2.0 + gx, 1e-12, "b- wide");
    close(tight.h_m, gz, 1e-12, "h");
    assert!(wide.alpha_plus_deg > tight.alpha_plus_deg);
    // The patch of another tolerance from the same contact (what ensembles use).
    let rest = rock.rest(UpAxis::PlusZ, 0.001).unwrap();
    assert_eq!(rest.direction_at(90.0, 0.005), wide);
    assert_eq!(rest.direction_at(90.0, 0.001), tight);
    assert_eq!(rest.contact_vertices(), 4);
    assert_eq!(rest.patch(0.005).len(), 6);
    assert!(
        rock.rest(UpAxis::PlusZ, 1.5).is_err(),
        "tolerance above 1 m"
    );
}

/// An upright prism: the convex polygon `base` (east, north; m; counter-clockwise seen from
/// above) from z = 0 to z = `height`, closed and outward ([`TriMesh::prism`], whose volume,
/// centre and inertia the closed-form tests here check).
fn upright_prism(base: &[(f64, f64)], height: f64) -> TriMesh {
    TriMesh::prism(base, height).expect("valid prism")
}

/// The quasi-static uplift of a rigid upright prism of convex base `base` (counter-clockwise,
/// centroid inside) and height `height` under a horizontal pseudo-force a along the unit
/// direction `d` (east, north), by brute force in 3-D, independent of the library's support
/// polygon: the smallest a ≥ 0 at which the moment of gravity plus the inertial force about
/// some base edge, taken about the edge's axis in the sense that lifts the base off, reaches
/// zero. Per unit mass: F = a·d − g·ẑ at the centre of mass C = (centroid, height/2);
/// M_e(a) = ((C − p_k) × F)·ê_k, ê_k along the edge p_k → p_k+1 (the base lies to its left,
/// so a positive moment lifts it about the edge). A scan in steps of g/1000 up to 10 g finds
/// the first bracket, bisection narrows it to 10⁻¹³ g.
fn brute_force_uplift(base: &[(f64, f64)], height: f64, d: (f64, f64)) -> f64 {
    let g = 9.80665;
    let (_, (cx, cy), _) = polygon_moments(base);
    let com = [cx, cy, height / 2.0];
    let moment_max = |a: f64| -> f64 {
        let force = [a * d.0, a * d.1, -g];
        (0..base.len())
            .map(|k| {
                let (p, q) = (base[k], base[(k + 1) % base.len()]);
                let r = [com[0] - p.0, com[1] - p.1, com[2]];
                let m = [
                    r[1] * force[2] - r[2] * force[1],
                    r[2] * force[0] - r[0] * force[2],
                    r[0] * force[1] - r[1] * force[0],
                ];
                let (ex, ey) = (q.0 - p.0, q.1 - p.1);
                (m[0] * ex + m[1] * ey) / ex.hypot(ey)
            })
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert!(moment_max(0.0) < 0.0, "the prism must stand at rest");
    let step = g / 1000.0;
    let mut hi = step;
    while moment_max(hi) < 0.0 {
        hi += step;
        assert!(hi < 10.0 * g, "no uplift below 10 g");
    }
    let mut lo = hi - step;
    while hi - lo > 1e-13 * g {
        let mid = 0.5 * (lo + hi);
        if moment_max(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// A polygon's vertices (east, north; m).
type Polygon = Vec<(f64, f64)>;

/// The base polygons of the reduction tests: a box turned about the vertical, a slender
/// triangle (as on real scans) and an irregular pentagon.
fn reduction_cases() -> Vec<(&'static str, Polygon, f64)> {
    let rect = |w: f64, l: f64, turn_deg: f64, shift: (f64, f64)| -> Polygon {
        let (s, c) = turn_deg.to_radians().sin_cos();
        [
            (-w / 2.0, -l / 2.0),
            (w / 2.0, -l / 2.0),
            (w / 2.0, l / 2.0),
            (-w / 2.0, l / 2.0),
        ]
        .iter()
        .map(|&(x, y)| (c * x - s * y + shift.0, s * x + c * y + shift.1))
        .collect()
    };
    vec![
        ("box", rect(0.6, 0.9, 0.0, (0.0, 0.0)), 1.5),
        ("box turned 17°", rect(0.6, 0.9, 17.0, (2.0, -1.0)), 1.5),
        ("box turned 45°", rect(0.6, 0.9, 45.0, (0.0, 0.0)), 1.5),
        ("box turned 110°", rect(0.3, 1.2, 110.0, (-0.4, 0.7)), 0.8),
        (
            "slender triangle",
            vec![(0.0, 0.0), (1.0, 0.0), (0.15, 0.22)],
            0.5,
        ),
        (
            "pentagon",
            vec![
                (0.0, 0.0),
                (0.7, -0.1),
                (0.95, 0.35),
                (0.5, 0.8),
                (-0.15, 0.5),
            ],
            1.1,
        ),
    ]
}

#[test]
fn lever_arms_equal_the_quasi_static_3d_uplift_in_every_direction() {
    for (name, base, height) in reduction_cases() {
        let rest = RockGeometry::new(&upright_prism(&base, height))
            .unwrap()
            .rest(UpAxis::PlusZ, 0.0)
            .unwrap();
        close(rest.h_m, height / 2.0, 1e-12, "h");
        for k in 0..144 {
            let az = 2.5 * f64::from(k) + 0.3;
            let body = rest.direction(az);
            let (s, c) = az.to_radians().sin_cos();
            let g = 9.80665;
            // Uplift towards +d needs the pseudo-force along +d: b₊ = h·a*/g; b₋ along −d.
            let plus = brute_force_uplift(&base, height, (s, c)) * rest.h_m / g;
            let minus = brute_force_uplift(&base, height, (-s, -c)) * rest.h_m / g;
            close(body.b_plus_m, plus, 1e-9, &format!("{name} az {az}: b+"));
            close(body.b_minus_m, minus, 1e-9, &format!("{name} az {az}: b-"));
        }
    }
}

#[test]
fn box_at_45_degrees_tips_about_the_edge_its_ray_crosses_not_its_corner() {
    // 0.6 m east × 0.9 m north × 1.5 m: at azimuth 45° the ray from the centre leaves through
    // the east side at 0.3/sin 45° = 0.4243 m (α = 29.5°); the corner's projection on the
    // direction, (0.3 + 0.45)/√2 = 0.5303 m (α = 35.3°), overstates the stability.
    let base = [(-0.3, -0.45), (0.3, -0.45), (0.3, 0.45), (-0.3, 0.45)];
    let rest = RockGeometry::new(&upright_prism(&base, 1.5))
        .unwrap()
        .rest(UpAxis::PlusZ, 0.0)
        .unwrap();
    let d = rest.direction(45.0);
    let want = 0.3 / std::f64::consts::FRAC_1_SQRT_2;
    close(d.b_plus_m, want, 1e-12, "b+");
    close(d.b_minus_m, want, 1e-12, "b-");
    assert!(
        (d.alpha_plus_deg - 29.5).abs() < 0.05,
        "{}",
        d.alpha_plus_deg
    );
    assert!(
        (d.alpha_minus_deg - 29.5).abs() < 0.05,
        "{}",
        d.alpha_minus_deg
    );
}

#[test]
fn section_of_a_box_along_its_diagonal_is_the_rectangle_of_its_chord() {
    // 0.6 × 0.9 × 1.5 box, vertical plane at azimuth 45° through its centre: the base chord
    // runs from −r to r with r = 0.3/sin 45° (the exit of the ray through the east and west
    // sides), so the section is a 2r × 1.5 rectangle: perimeter 2(2r + 1.5), every point
    // within |s| ≤ r, 0 ≤ z ≤ 1.5, and the four corners present.
    let base = [(-0.3, -0.45), (0.3, -0.45), (0.3, 0.45), (-0.3, 0.45)];
    let rock = RockGeometry::new(&upright_prism(&base, 1.5)).unwrap();
    let rest = rock.rest(UpAxis::PlusZ, 0.0).unwrap();
    let r = 0.3 / std::f64::consts::FRAC_1_SQRT_2;
    let segments = rock.section(&rest, 45.0);
    let length: f64 = segments
        .iter()
        .map(|[a, b]| (b.0 - a.0).hypot(b.1 - a.1))
        .sum();
    close(length, 2.0 * (2.0 * r + 1.5), 1e-12, "perimeter");
    for &(s, z) in segments.iter().flatten() {
        assert!(s.abs() <= r * (1.0 + 1e-12) && (-1e-12..=1.5 + 1e-12).contains(&z));
    }
    for corner in [(-r, 0.0), (r, 0.0), (-r, 1.5), (r, 1.5)] {
        assert!(
            segments
                .iter()
                .flatten()
                .any(|p| (p.0 - corner.0).abs() < 1e-12 && (p.1 - corner.1).abs() < 1e-12),
            "corner {corner:?}"
        );
    }
}

/// The upright prism of `upright_prism` without the faces whose normals point along `open`
/// (−1: the bottom, +1: the top), as a scanner that saw it from one side leaves it.
fn open_prism(base: &[(f64, f64)], height: f64, open: &[i32]) -> TriMesh {
    let closed = upright_prism(base, height);
    let n = base.len();
    let faces: Vec<[usize; 3]> = closed
        .faces
        .iter()
        .copied()
        .filter(|f| {
            let bottom = f.iter().all(|&v| v < n);
            let top = f.iter().all(|&v| v >= n);
            !(bottom && open.contains(&-1) || top && open.contains(&1))
        })
        .collect();
    TriMesh {
        source: "open".into(),
        face_lines: vec![0; faces.len()],
        vertices: closed.vertices,
        faces,
    }
}

#[test]
fn an_open_scan_is_closed_by_its_lowest_boundary_loop() {
    // A pentagonal prism scanned from above: no base. Capping closes the base loop (planar,
    // level), so the rock is the closed prism: same volume, centre and resting bodies.
    let base = [
        (0.0, 0.0),
        (0.7, -0.1),
        (0.95, 0.35),
        (0.5, 0.8),
        (-0.15, 0.5),
    ];
    let closed = upright_prism(&base, 1.1);
    let mut open = open_prism(&base, 1.1, &[-1]);
    assert!(open.clone().validate().is_err(), "an open scan is refused");
    let cap = open.cap([0.0, 0.0, 1.0]).unwrap().expect("a boundary");
    assert_eq!((cap.loop_vertices, cap.loops), (5, 1));
    close(cap.mean_height_m, 0.0, 1e-15, "loop height");
    close(cap.height_spread_m, 0.0, 1e-15, "planar loop");
    let (area, _, _) = polygon_moments(&base);
    close(cap.area_m2, area, 1e-12, "cap area");
    open.validate().expect("capped mesh is closed");
    let (a, b) = (MassProperties::of(&open), MassProperties::of(&closed));
    close(a.volume_m3, b.volume_m3, 1e-12, "volume");
    for k in 0..3 {
        close(a.com_m[k], b.com_m[k], 1e-12, "com");
    }
    let rest_open = RockGeometry::new(&open)
        .unwrap()
        .rest(UpAxis::PlusZ, 0.0)
        .unwrap();
    let rest_closed = RockGeometry::new(&closed)
        .unwrap()
        .rest(UpAxis::PlusZ, 0.0)
        .unwrap();
    for az in [0.0, 73.0, 200.0] {
        let (p, q) = (rest_open.direction(az), rest_closed.direction(az));
        close(p.b_plus_m, q.b_plus_m, 1e-12, "b+");
        close(p.rho_m, q.rho_m, 1e-12, "rho");
    }
    // Open at both ends: the lower loop is capped, the top stays open and is refused.
    let mut both = open_prism(&base, 1.1, &[-1, 1]);
    let cap = both.cap([0.0, 0.0, 1.0]).unwrap().expect("a boundary");
    assert_eq!(cap.loops, 2);
    close(cap.mean_height_m, 0.0, 1e-15, "the lowest loop");
    assert!(matches!(both.validate(), Err(MeshError::NotClosed { .. })));
    // A closed mesh has nothing to cap.
    assert_eq!(
        upright_prism(&base, 1.1).cap([0.0, 0.0, 1.0]).unwrap(),
        None
    );
}

/// Regular n-gon of circumradius r, CCW.
fn ngon(n: usize, r: f64, phase: f64) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| {
            let t = phase + 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            (r * t.cos(), r * t.sin())
        })
        .collect()
}

#[test]
fn faceted_cylinder_matches_the_polygon_exactly_and_converges_to_the_cylinder() {
    let (radius, hgt) = (0.3, 1.4);
    let pi = std::f64::consts::PI;
    let mut previous_error = f64::INFINITY;
    for n in [8usize, 16, 64, 256, 1024] {
        let poly = ngon(n, radius, 0.0);
        let (v, f) = extrude(&poly, hgt);
        let r = rotation([1.0, 0.0, 0.0], -std::f64::consts::FRAC_PI_2);
        let stood: Vec<P> = v
            .iter()
            .map(|p| apply(&r, [0.0, 0.0, hgt / 2.0], *p))
            .collect();
        let rest = RockGeometry::new(&mesh(stood, f))
            .unwrap()
            .rest(UpAxis::PlusZ, 1e-4)
            .unwrap();
        // The polygon's closed forms: A = (n/2) r² sin(2π/n), J = A r² (2 + cos(2π/n))/6.
        let area = n as f64 / 2.0 * radius * radius * (2.0 * pi / n as f64).sin();
        close(rest.mass.volume_m3, area * hgt, 1e-12, "prism volume");
        let i_in_plane = radius * radius * (2.0 + (2.0 * pi / n as f64).cos()) / 12.0;
        for az in [0.0, 10.0, 77.0, 90.0] {
            let d = rest.direction(az);
            // The ray from the centre of the n-gon (vertex k at angle 2πk/n from +x = east)
            // along az leaves through the edge whose outward normal, at (2k + 1)π/n, is
            // nearest to it: the apothem r cos(π/n) over the cosine of the angle between.
            let dir = (90.0 - az).to_radians(); // angle from east, counter-clockwise
            let nearest = (0..n)
                .map(|k| ((2 * k + 1) as f64 * pi / n as f64 - dir).cos())
                .fold(f64::NEG_INFINITY, f64::max);
            let exit = radius * (pi / n as f64).cos() / nearest;
            close(d.b_plus_m, exit, 1e-12, "b+ polygon");
            close(
                d.rho_m.powi(2),
                i_in_plane + hgt * hgt / 12.0,
                1e-12,
                "rho polygon",
            );
            // Convergence to the cylinder, with the polygon's bounds:
            // r cos(π/n) ≤ b ≤ r; 0 ≤ ρ²_cyl − ρ² = r²(1 − cos(2π/n))/12.
            assert!(d.b_plus_m <= radius * (1.0 + 1e-12));
            assert!(d.b_plus_m >= radius * (pi / n as f64).cos() * (1.0 - 1e-12));
            let rho2_cyl = radius * radius / 4.0 + hgt * hgt / 12.0;
            let gap = rho2_cyl - d.rho_m.powi(2);
            let bound = radius * radius * (1.0 - (2.0 * pi / n as f64).cos()) / 12.0;
            // (equality up to the 1e-12 rounding of the sums checked above)
            assert!(
                gap >= -1e-12 && gap <= bound + 1e-12,
                "n {n}: {gap} {bound}"
            );
        }
        let volume_error = pi * radius * radius * hgt - rest.mass.volume_m3;
        assert!(volume_error > 0.0 && volume_error < previous_error);
        // V_cyl − V_n = r² H (π − (n/2) sin(2π/n)) ≤ r² H · (2π³/3)/n².
        assert!(volume_error <= radius * radius * hgt * 2.0 * pi.powi(3) / 3.0 / (n * n) as f64);
        previous_error = volume_error;
    }
}

// ---- independent writers for the round trips ----

fn write_obj(v: &[P], f: &[[usize; 3]]) -> Vec<u8> {
    let mut s = String::from("# generated\no rock\n");
    for p in v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    s += "vn 0 0 1\n";
    for t in f {
        s += &format!("f {}//1 {}//1 {}//1\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s.into_bytes()
}

fn write_ply(v: &[P], f: &[[usize; 3]], binary: bool) -> Vec<u8> {
    let format = if binary {
        "binary_little_endian"
    } else {
        "ascii"
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment generated\nelement vertex {}\nproperty double x\n\
         property double y\nproperty double z\nproperty uchar red\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        v.len(),
        f.len()
    )
    .into_bytes();
    for p in v {
        if binary {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
            out.push(200);
        } else {
            out.extend_from_slice(format!("{} {} {} 200\n", p[0], p[1], p[2]).as_bytes());
        }
    }
    for t in f {
        if binary {
            out.push(3);
            for i in t {
                out.extend_from_slice(&(*i as i32).to_le_bytes());
            }
        } else {
            out.extend_from_slice(format!("3 {} {} {}\n", t[0], t[1], t[2]).as_bytes());
        }
    }
    out
}

fn write_stl(v: &[P], f: &[[usize; 3]], binary: bool) -> Vec<u8> {
    if binary {
        let mut out = vec![0u8; 80];
        out[..5].copy_from_slice(b"solid"); // binary files may start with "solid" too
        out.extend_from_slice(&(f.len() as u32).to_le_bytes());
        for t in f {
            out.extend_from_slice(&[0u8; 12]);
            for &i in t {
                for c in v[i] {
                    out.extend_from_slice(&(c as f32).to_le_bytes());
                }
            }
            out.extend_from_slice(&[0, 0]);
        }
        out
    } else {
        let mut s = String::from("solid rock\n");
        for t in f {
            s += "  facet normal 0 0 0\n    outer loop\n";
            for &i in t {
                s += &format!("      vertex {} {} {}\n", v[i][0], v[i][1], v[i][2]);
            }
            s += "    endloop\n  endfacet\n";
        }
        s += "endsolid rock\n";
        s.into_bytes()
    }
}

#[test]
fn every_file_format_round_trips_the_wedge() {
    let (l, p, hgt, w) = (1.0, 0.25, 1.5, 0.5);
    let poly = [(0.0, 0.0), (l, 0.0), (p, hgt)];
    let (v, f) = extrude(&poly, w);
    let files: [(&str, Vec<u8>, f64); 5] = [
        ("rock.obj", write_obj(&v, &f), 1e-12),
        ("rock.ply", write_ply(&v, &f, false), 1e-12),
        ("rock.ply", write_ply(&v, &f, true), 1e-14),
        ("rock.stl", write_stl(&v, &f, false), 1e-12),
        ("rock.stl", write_stl(&v, &f, true), 1e-6), // f32 coordinates
    ];
    let dir = tempfile::tempdir().unwrap();
    for (k, (name, bytes, tol)) in files.iter().enumerate() {
        let path = dir.path().join(format!("{k}-{name}"));
        std::fs::write(&path, bytes).unwrap();
        let m = TriMesh::read(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.vertices.len(), 6, "{name}: duplicates merged");
        assert_eq!(m.faces.len(), 8, "{name}");
        let rest = RockGeometry::new(&m)
            .unwrap()
            .rest(UpAxis::PlusZ, 0.005)
            .unwrap();
        close(rest.mass.volume_m3, l * hgt / 2.0 * w, *tol, name);
        let east = rest.direction(90.0);
        close(east.b_plus_m, l - (l + p) / 3.0, *tol, name);
        close(east.h_m, hgt / 3.0, *tol, name);
    }
    // A polygonal OBJ (quads, negative indices) reads as its triangles.
    let quad_box = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 2\nv 1 0 2\nv 1 1 2\nv 0 1 2\n\
                    f -8 -5 -6 -7\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let m = TriMesh::parse(quad_box.as_bytes(), MeshFormat::Obj, "box.obj").unwrap();
    assert_eq!(m.faces.len(), 12);
    close(MassProperties::of(&m).volume_m3, 2.0, 1e-14, "quad box");
}

fn error_of(text: &str, format: MeshFormat, name: &str) -> String {
    match TriMesh::parse(text.as_bytes(), format, name) {
        Ok(_) => panic!("{name} accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_text_mesh_that_is_not_utf8_is_refused_at_the_line_of_the_bad_byte() {
    for (format, name, head) in [
        (MeshFormat::Obj, "latin1.obj", "v 0 0 0\nv 1 0 0\n"),
        (
            MeshFormat::Stl,
            "latin1.stl",
            "solid rock\n  facet normal 0 0 1\n",
        ),
    ] {
        // "# caf\xe9" on line 3: Latin-1, not UTF-8.
        let mut bytes = head.as_bytes().to_vec();
        bytes.extend_from_slice(b"# caf\xe9\nv 0 1 0\n");
        let e = match TriMesh::parse(&bytes, format, name) {
            Ok(_) => panic!("{name} accepted"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains(&format!("{name}:3:")) && e.contains("not UTF-8 text"),
            "{e}"
        );
    }
}

#[test]
fn malformed_open_misoriented_and_degenerate_meshes_are_refused_by_name_and_line() {
    let tetra = |faces: &str| format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n{faces}");
    let good = "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
    assert!(TriMesh::parse(tetra(good).as_bytes(), MeshFormat::Obj, "t.obj").is_ok());
    // A hole.
    let e = error_of(
        &tetra("f 1 3 2\nf 1 2 4\nf 2 3 4\n"),
        MeshFormat::Obj,
        "hole.obj",
    );
    assert!(e.contains("hole.obj:") && e.contains("not a closed"), "{e}");
    // One face flipped: an edge runs twice the same way.
    let e = error_of(
        &tetra("f 1 3 2\nf 1 4 2\nf 2 3 4\nf 3 1 4\n"),
        MeshFormat::Obj,
        "flip.obj",
    );
    assert!(
        e.contains("flip.obj:6:") && e.contains("same direction"),
        "{e}"
    );
    // Collinear face.
    let e = error_of(
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n",
        MeshFormat::Obj,
        "line.obj",
    );
    assert!(e.contains("line.obj:5:") && e.contains("collinear"), "{e}");
    // Two triangles back to back: closed, but no volume.
    let e = error_of(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n",
        MeshFormat::Obj,
        "flat.obj",
    );
    assert!(e.contains("degenerate") && e.contains("volume"), "{e}");
    // Bad index, bad number, unknown statement: file:line.
    let e = error_of(&tetra("f 1 3 9\n"), MeshFormat::Obj, "idx.obj");
    assert!(e.starts_with("idx.obj:5:"), "{e}");
    let e = error_of("v 0 0 zero\n", MeshFormat::Obj, "num.obj");
    assert!(
        e.starts_with("num.obj:1:") && e.contains("not a number"),
        "{e}"
    );
    let e = error_of(&tetra("curv 0 1 2\n"), MeshFormat::Obj, "curv.obj");
    assert!(e.contains("unsupported OBJ statement"), "{e}");
    // PLY: big-endian refused, short line, index out of range.
    let e = error_of(
        "ply\nformat binary_big_endian 1.0\nend_header\n",
        MeshFormat::Ply,
        "be.ply",
    );
    assert!(
        e.contains("be.ply:2:") && e.contains("binary_big_endian"),
        "{e}"
    );
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n";
    let e = error_of(ply, MeshFormat::Ply, "short.ply");
    assert!(
        e.starts_with("short.ply:11:") && e.contains("fewer values"),
        "{e}"
    );
    let ply = ply
        .replacen("\n1 0\n", "\n1 0 0\n", 1)
        .replace("3 0 1 2", "3 0 1 7");
    let e = error_of(&ply, MeshFormat::Ply, "range.ply");
    assert!(
        e.starts_with("range.ply:13:") && e.contains("out of range"),
        "{e}"
    );
    // STL: truncated binary, unterminated ASCII, a facet with 4 vertices.
    let mut bin = vec![0u8; 84];
    bin[80] = 2;
    bin.extend_from_slice(&[0u8; 60]);
    let e = match TriMesh::parse(&bin, MeshFormat::Stl, "cut.stl") {
        Err(e) => e.to_string(),
        Ok(_) => panic!("truncated STL accepted"),
    };
    assert!(e.contains("announces 2 triangles"), "{e}");
    let e = error_of(
        "solid x\nfacet normal 0 0 1\nouter loop\n",
        MeshFormat::Stl,
        "open.stl",
    );
    assert!(e.contains("endsolid"), "{e}");
    let e = error_of(
        "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n\
         vertex 1 1 0\nendloop\nendfacet\nendsolid\n",
        MeshFormat::Stl,
        "four.stl",
    );
    assert!(
        e.starts_with("four.stl:2:") && e.contains("4 vertices"),
        "{e}"
    );
    // Unknown extension.
    assert!(matches!(
        TriMesh::read("rock.xyz"),
        Err(MeshError::UnknownFormat { .. })
    ));
}

#[test]
fn inward_oriented_mesh_is_turned_outward() {
    let (v, f) = extrude(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)], 1.0);
    let flipped: Vec<[usize; 3]> = f.iter().map(|t| [t[0], t[2], t[1]]).collect();
    let m = mesh(v, flipped);
    close(
        MassProperties::of(&m).volume_m3,
        1.0,
        1e-14,
        "volume after turning",
    );
}

#[test]
fn azimuth_lists_and_steps_parse() {
    assert_eq!(
        parse_azimuths("0:360:90").unwrap(),
        vec![0.0, 90.0, 180.0, 270.0]
    );
    assert_eq!(parse_azimuths("0:360:15").unwrap().len(), 24);
    assert_eq!(parse_azimuths("10,55.5").unwrap(), vec![10.0, 55.5]);
    assert!(parse_azimuths("0:360:0").is_err());
    assert!(parse_azimuths("0:720:10").is_err());
    assert!(parse_azimuths("a,b").is_err());
}

/// Volume enclosed by convex facets: Σ area·offset/3 (the divergence theorem on the hull).
fn hull_volume(points: &[P], facets: &[rockwatch_core::mesh::hull::Facet]) -> f64 {
    facets
        .iter()
        .map(|f| {
            let p0 = points[f.polygon[0]];
            let mut twice_area = 0.0;
            for k in 1..f.polygon.len() - 1 {
                let (a, b) = (points[f.polygon[k]], points[f.polygon[k + 1]]);
                let u = [a[0] - p0[0], a[1] - p0[1], a[2] - p0[2]];
                let v = [b[0] - p0[0], b[1] - p0[1], b[2] - p0[2]];
                let c = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                twice_area += c[0] * f.normal[0] + c[1] * f.normal[1] + c[2] * f.normal[2];
            }
            twice_area / 2.0 * f.offset / 3.0
        })
        .sum()
}

#[test]
fn hull_of_a_lattice_is_its_cube_with_six_square_facets() {
    use rockwatch_core::mesh::hull::convex_hull;
    let mut points = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..5 {
                points.push([
                    i as f64 * 0.25 - 0.5,
                    j as f64 * 0.25 - 0.5,
                    k as f64 * 0.25 - 0.5,
                ]);
            }
        }
    }
    let facets = convex_hull(&points).unwrap();
    assert_eq!(facets.len(), 6);
    assert!(
        facets.iter().all(|f| f.polygon.len() == 4),
        "collinear edge points dropped"
    );
    close(hull_volume(&points, &facets), 1.0, 1e-14, "cube volume");
}

#[test]
fn hull_of_a_point_cloud_contains_every_point_and_converges_to_the_sphere() {
    use rockwatch_core::mesh::hull::convex_hull;
    // Fibonacci points on the unit sphere, plus interior points from a fixed LCG.
    let n = 4000;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut points: Vec<P> = (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let t = golden * i as f64;
            [r * t.cos(), r * t.sin(), z]
        })
        .collect();
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 1.1 - 0.55
    };
    for _ in 0..1000 {
        points.push([next(), next(), next()]);
    }
    let facets = convex_hull(&points).unwrap();
    for f in &facets {
        for p in &points {
            let d = f.normal[0] * p[0] + f.normal[1] * p[1] + f.normal[2] * p[2] - f.offset;
            assert!(d <= 1e-9, "a point lies {d} outside a facet");
        }
    }
    // Every sphere point is a hull vertex (they are in convex position).
    let mut on_hull = vec![false; points.len()];
    for f in &facets {
        for &v in &f.polygon {
            on_hull[v] = true;
        }
    }
    assert!(on_hull[..n].iter().all(|&b| b) && !on_hull[n..].iter().any(|&b| b));
    // Volume of an inscribed polytope of 4000 well-spread points: just below 4π/3.
    let v = hull_volume(&points, &facets);
    let sphere = 4.0 / 3.0 * std::f64::consts::PI;
    assert!(v < sphere && v > sphere * (1.0 - 2e-3), "{v} vs {sphere}");
}

/// The display triangles of a resting box (2 × 1 × 3 m, up +z): every vertex within the box
/// centred on the ground point below its centre of mass, the base on the ground (up 0), the
/// top at 3 m, 12 triangles; turned to heading 90° (the mesh's north towards east), its
/// 1 m side lies along north-south no more: east spans the 1 m side.
#[test]
fn a_box_at_rest_is_displayed_centred_on_its_ground_point_and_turned_by_its_heading() {
    let rock = RockGeometry::new(&TriMesh::cuboid(2.0, 1.0, 3.0).unwrap()).unwrap();
    let rest = rock.rest(UpAxis::PlusZ, 0.0).unwrap();
    let extent = |tri: &[[[f64; 3]; 3]], axis: usize| {
        let values = tri.iter().flatten().map(|p| p[axis]);
        let lo = values.clone().fold(f64::INFINITY, f64::min);
        let hi = values.fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    };
    let tri = rock.triangles_at_rest(&rest, 0.0);
    assert_eq!(tri.len(), 12);
    for (axis, half) in [(0, 1.0), (1, 0.5)] {
        let (lo, hi) = extent(&tri, axis);
        close(lo, -half, 1e-12, "low");
        close(hi, half, 1e-12, "high");
    }
    let (lo, hi) = extent(&tri, 2);
    assert!(lo.abs() < 1e-12, "base at {lo}");
    close(hi, 3.0, 1e-12, "top");
    let turned = rock.triangles_at_rest(&rest, 90.0);
    let (lo, hi) = extent(&turned, 0);
    close(lo, -0.5, 1e-12, "east low");
    close(hi, 0.5, 1e-12, "east high");
    let (lo, hi) = extent(&turned, 1);
    close(lo, -1.0, 1e-12, "north low");
    close(hi, 1.0, 1e-12, "north high");
    // Outward: a triangle's normal points away from the centre of mass (0, 0, 1.5).
    for t in &turned {
        let (u, v) = (
            [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]],
            [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]],
        );
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let r = [t[0][0], t[0][1], t[0][2] - 1.5];
        assert!(n[0] * r[0] + n[1] * r[1] + n[2] * r[2] > 0.0, "{t:?}");
    }
}
