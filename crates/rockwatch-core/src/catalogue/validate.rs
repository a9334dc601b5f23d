//! One entry as written ([`RawPbr`], shared by the TOML and CSV readers) → a validated
//! [`Pbr`]: every rule of the catalogue format (module doc of [`crate::catalogue`]), every
//! failure of the entry as (field, message) for the reader to place (file, line, entry, id).
//!
//! Units as written: degrees for `lat`, `lon`, `azimuth_deg`, `alpha_deg`, `heading_deg`;
//! metres for sizes and `contact_tolerance_m`; μs, μk, e dimensionless. A field's sub-fields
//! are named with the reader's separator: `width_m.min` (TOML), `width_m_min` (CSV).

use std::fmt;
use std::path::Path;

use serde::de::{self, Deserializer, Visitor};
use serde::Deserialize;

use super::distribution::{Distribution, Domain, MU_K_DOMAIN, MU_S_DOMAIN, RESTITUTION_DOMAIN};
use super::ensemble::default_seed;
use super::geometry::{domain_of, Geometry, MeshRock, RockModel, GEOMETRY_FORMS};
use super::pbr::Pbr;
use super::StationId;
use crate::azimuth::Azimuth;
use crate::mesh::contact::{
    azimuth_steps, parse_azimuths, RockGeometry, UpAxis, DEFAULT_CONTACT_TOLERANCE_M,
};
use crate::pbr_id::PbrId;
use crate::rocking3d::body::NOMINAL_DENSITY_KG_M3;
use crate::rocking3d::RockBody;

/// Largest ensemble size K accepted in a catalogue.
pub const MAX_ENSEMBLE: usize = 10_000;

/// The directions of a mesh entry without `azimuths`: every 15° (true azimuths).
pub(super) const DEFAULT_MESH_DIRECTIONS: AzimuthSteps = AzimuthSteps {
    from: 0.0,
    to: 360.0,
    step: 15.0,
};

/// One entry as written, before validation (shared by the TOML and CSV readers). Every field
/// is optional here, so that validation can report every missing required field at once.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPbr {
    #[serde(default)]
    pub(super) id: Option<String>,
    #[serde(default)]
    pub(super) name: Option<String>,
    #[serde(default)]
    pub(super) lat: Option<f64>,
    #[serde(default)]
    pub(super) lon: Option<f64>,
    #[serde(default)]
    pub(super) station: Option<String>,
    #[serde(default)]
    pub(super) azimuth_deg: Option<f64>,
    #[serde(default)]
    pub(super) mesh: Option<String>,
    #[serde(default)]
    pub(super) up: Option<String>,
    #[serde(default)]
    pub(super) azimuths: Option<RawAzimuths>,
    #[serde(default)]
    pub(super) cap: Option<bool>,
    #[serde(default)]
    pub(super) model: Option<String>,
    #[serde(default)]
    pub(super) heading_deg: Option<Distribution>,
    #[serde(default)]
    pub(super) contact_tolerance_m: Option<Distribution>,
    #[serde(default)]
    pub(super) width_m: Option<Distribution>,
    #[serde(default)]
    pub(super) height_m: Option<Distribution>,
    #[serde(default)]
    pub(super) half_diagonal_m: Option<Distribution>,
    #[serde(default)]
    pub(super) alpha_deg: Option<Distribution>,
    #[serde(default)]
    pub(super) b_plus_m: Option<Distribution>,
    #[serde(default)]
    pub(super) b_minus_m: Option<Distribution>,
    #[serde(default)]
    pub(super) h_m: Option<Distribution>,
    #[serde(default)]
    pub(super) rho_m: Option<Distribution>,
    #[serde(default)]
    pub(super) mu_s: Option<Distribution>,
    #[serde(default)]
    pub(super) mu_k: Option<Distribution>,
    #[serde(default)]
    pub(super) restitution: Option<Distribution>,
    #[serde(default)]
    pub(super) source: Option<String>,
    #[serde(default)]
    pub(super) ensemble: Option<Integer>,
    #[serde(default)]
    pub(super) seed: Option<Integer>,
}

/// The directions of a meshed rock as written: a list of degrees, a step form
/// `{ from, to, step }` (TO excluded), or (CSV) the text `FROM:TO:STEP` or `A,B,C`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub(super) enum RawAzimuths {
    List(Vec<f64>),
    Steps(AzimuthSteps),
    Text(String),
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AzimuthSteps {
    from: f64,
    to: f64,
    step: f64,
}

/// Most directions of one catalogued rock.
pub const MAX_DIRECTIONS: usize = 360;

/// An integer of either sign up to the `u64` range (TOML integers are `i64`, CSV seeds `u64`);
/// range checks happen in validation, with the field's own message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Integer(pub(super) i128);

impl<'de> Deserialize<'de> for Integer {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct IntegerVisitor;
        impl Visitor<'_> for IntegerVisitor {
            type Value = Integer;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an integer")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Integer, E> {
                Ok(Integer(i128::from(v)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Integer, E> {
                Ok(Integer(i128::from(v)))
            }
        }
        deserializer.deserialize_any(IntegerVisitor)
    }
}

/// One problem of an entry: (field, message).
pub(super) type Problem = (String, String);

/// The value of `result`, or `None` with its problem added to `problems`.
fn check<T>(problems: &mut Vec<Problem>, result: Result<T, Problem>) -> Option<T> {
    result.map_err(|problem| problems.push(problem)).ok()
}

/// Validates one entry: every problem found, in field order (a check that depends on another
/// field's value is skipped when that field is itself wrong; the mesh is read and the nominal
/// block built only once everything else is right).
pub(super) fn validate(
    raw: RawPbr,
    sep: char,
    base_dir: Option<&Path>,
) -> Result<Pbr, Vec<Problem>> {
    let mut problems: Vec<Problem> = Vec::new();
    let missing = |field: &str| -> Problem {
        let why = if field == "source" {
            " (required: where the numbers come from, e.g. a survey, a paper, or \
             \"illustrative\" for made-up values)"
        } else {
            ""
        };
        (field.to_owned(), format!("missing field `{field}`{why}"))
    };
    for (field, given) in [
        ("id", raw.id.is_some()),
        ("name", raw.name.is_some()),
        ("lat", raw.lat.is_some()),
        ("lon", raw.lon.is_some()),
        ("station", raw.station.is_some()),
        ("mu_s", raw.mu_s.is_some()),
        ("mu_k", raw.mu_k.is_some()),
        ("source", raw.source.is_some()),
    ] {
        if !given {
            problems.push(missing(field));
        }
    }
    // The id's one check (a missing id is said above).
    let pbr_id = raw.id.as_deref().and_then(|text| {
        check(
            &mut problems,
            PbrId::parse(text).map_err(|e| ("id".to_owned(), e.to_string())),
        )
    });
    for (field, text) in [("name", &raw.name), ("source", &raw.source)] {
        if text.as_deref().is_some_and(|t| t.trim().is_empty()) {
            let why = if field == "source" {
                " (say where the numbers come from)"
            } else {
                ""
            };
            problems.push((field.to_owned(), format!("{field} must not be blank{why}")));
        }
    }
    if let Some(lat) = raw.lat {
        if !(lat.is_finite() && (-90.0..=90.0).contains(&lat)) {
            problems.push((
                "lat".to_owned(),
                format!("lat = {lat} must be in [-90, 90] degrees"),
            ));
        }
    }
    if let Some(lon) = raw.lon {
        if !(lon.is_finite() && (-180.0..=180.0).contains(&lon)) {
            problems.push((
                "lon".to_owned(),
                format!("lon = {lon} must be in [-180, 180] degrees"),
            ));
        }
    }
    let station = match &raw.station {
        Some(text) => check(
            &mut problems,
            StationId::parse(text).map_err(|why| ("station".to_owned(), format!("station {why}"))),
        ),
        None => None,
    };
    let geometry = check(&mut problems, raw_geometry(&raw));
    let model = check(&mut problems, rock_model(&raw));
    let azimuths = check(&mut problems, entry_directions(&raw));
    if let Some(geometry) = &geometry {
        for (field, d) in geometry.fields() {
            check(
                &mut problems,
                check_distribution(field, &d, domain_of(field), sep),
            );
        }
    }
    // μk is compared with μs only when both are valid.
    let mut friction_valid = true;
    for (field, d, domain) in [
        ("mu_s", &raw.mu_s, MU_S_DOMAIN),
        ("mu_k", &raw.mu_k, MU_K_DOMAIN),
        ("restitution", &raw.restitution, RESTITUTION_DOMAIN),
    ] {
        if let Some(d) = d {
            let valid = check(&mut problems, check_distribution(field, d, domain, sep)).is_some();
            friction_valid &= valid || field == "restitution";
        }
    }
    if let (Some(mu_s_d), Some(mu_k_d), true) = (raw.mu_s, raw.mu_k, friction_valid) {
        let (mu_s, mu_k) = (mu_s_d.nominal(), mu_k_d.nominal());
        // A midpoint such as (0.4 + 0.8)/2 = 0.6000000000000001 must not count as exceeding
        // 0.6: an excess of a few ulps is rounding, and the nominal μk is then taken equal to
        // μs.
        if mu_k > mu_s * (1.0 + 4.0 * f64::EPSILON) {
            let nominal = if mu_s_d.is_fixed() && mu_k_d.is_fixed() {
                ""
            } else {
                "nominal "
            };
            problems.push((
                "mu_k".to_owned(),
                format!("{nominal}mu_k = {mu_k} exceeds {nominal}mu_s = {mu_s}"),
            ));
        }
    }
    let ensemble = match raw.ensemble.map(|k| k.0) {
        None => Some(1),
        Some(k) if (1..=MAX_ENSEMBLE as i128).contains(&k) => Some(k as usize),
        Some(k) => {
            problems.push((
                "ensemble".to_owned(),
                format!("ensemble = {k} must be an integer from 1 to {MAX_ENSEMBLE}"),
            ));
            None
        }
    };
    if let (Some(geometry), Some(ensemble)) = (&geometry, ensemble) {
        let n_uncertain = geometry
            .fields()
            .iter()
            .map(|(_, d)| Some(*d))
            .chain([raw.mu_s, raw.mu_k, raw.restitution])
            .flatten()
            .filter(|d| !d.is_fixed())
            .count();
        if ensemble > 1 && n_uncertain == 0 {
            problems.push((
                "ensemble".to_owned(),
                format!(
                    "ensemble = {ensemble} but no parameter is uncertain: give a range or a \
                     normal for at least one of {}, mu_s, mu_k, restitution, or drop ensemble",
                    geometry
                        .fields()
                        .iter()
                        .map(|(name, _)| *name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
    }
    let seed = match raw.seed.map(|s| s.0) {
        None => Some(default_seed(raw.id.as_deref().unwrap_or_default())),
        Some(s) => check(
            &mut problems,
            u64::try_from(s).map_err(|_| {
                (
                    "seed".to_owned(),
                    format!("seed = {s} must be an integer from 0 to {}", u64::MAX),
                )
            }),
        ),
    };
    if raw.cap.is_some() && raw.mesh.is_none() {
        problems.push((
            "cap".to_owned(),
            "cap needs mesh (it closes an open scan)".to_owned(),
        ));
    }
    let (
        Some(id),
        Some(name),
        Some(lat),
        Some(lon),
        Some(station),
        Some(geometry),
        Some(model),
        Some(azimuths),
        Some(mu_s_d),
        Some(mu_k_d),
        Some(source),
        Some(ensemble),
        Some(seed),
        true,
    ) = (
        pbr_id,
        raw.name.clone(),
        raw.lat,
        raw.lon,
        station,
        geometry,
        model,
        azimuths,
        raw.mu_s,
        raw.mu_k,
        raw.source.clone(),
        ensemble,
        seed,
        problems.is_empty(),
    )
    else {
        return Err(problems);
    };
    let azimuth = azimuths[0];
    let (mu_s, mu_k) = (mu_s_d.nominal(), mu_k_d.nominal());
    let fields = geometry.fields();
    let nominal_geometry: Vec<f64> = fields.iter().map(|(_, d)| d.nominal()).collect();
    let one = |problem: Problem| vec![problem];
    let mesh = match &raw.mesh {
        Some(file) => Some(
            load_mesh(
                file,
                raw.up.as_deref(),
                raw.cap.unwrap_or(false),
                azimuths,
                nominal_geometry[1],
                model,
                base_dir,
            )
            .map_err(one)?,
        ),
        None => None,
    };
    let nominal = match &mesh {
        // Every direction's nominal block must be valid; the first is the entry's nominal.
        Some(m) => m
            .blocks(
                nominal_geometry[0],
                nominal_geometry[1],
                mu_s,
                mu_k.min(mu_s),
                raw.restitution.map(|d| d.nominal()),
            )
            .map(|blocks| blocks[0]),
        None => geometry.block(
            &nominal_geometry,
            mu_s,
            mu_k.min(mu_s),
            raw.restitution.map(|d| d.nominal()),
        ),
    }
    .map_err(|e| {
        one((
            fields[0].0.to_owned(),
            format!("nominal block rejected: {e}"),
        ))
    })?;
    Ok(Pbr {
        id,
        name,
        lat_deg: lat,
        lon_deg: lon,
        station,
        azimuth,
        geometry,
        mu_s: mu_s_d,
        mu_k: mu_k_d,
        restitution: raw.restitution,
        source,
        ensemble,
        seed,
        nominal,
        mesh,
    })
}

/// The entry's toppling directions: a planar block's `azimuth_deg`, or a mesh rock's
/// `azimuths` (default every 15°).
fn entry_directions(raw: &RawPbr) -> Result<Vec<Azimuth>, Problem> {
    let fail = |field: &str, message: &str| Err((field.to_owned(), message.to_owned()));
    match (&raw.mesh, raw.azimuth_deg, &raw.azimuths) {
        (Some(_), Some(_), _) => fail(
            "azimuth_deg",
            "azimuth_deg cannot be combined with mesh: give the directions as azimuths = \
             [...] or azimuths = { from, to, step }",
        ),
        // A mesh rock may fall in any direction: every 15° unless the entry says otherwise.
        (Some(_), None, None) => directions(&RawAzimuths::Steps(DEFAULT_MESH_DIRECTIONS)),
        (Some(_), None, Some(written)) => directions(written),
        (None, _, Some(_)) => fail(
            "azimuths",
            "azimuths needs mesh (a planar block has azimuth_deg)",
        ),
        (None, None, None) => fail("azimuth_deg", "azimuth_deg is missing"),
        (None, Some(degrees), None) => match Azimuth::from_degrees(degrees) {
            Ok(azimuth) if (0.0..360.0).contains(&degrees) => Ok(vec![azimuth]),
            _ => Err((
                "azimuth_deg".to_owned(),
                format!("azimuth_deg = {degrees} must be in [0, 360) degrees clockwise from north"),
            )),
        },
    }
}

/// The directions of a mesh entry: each a finite azimuth, taken modulo 360, distinct, at most
/// [`MAX_DIRECTIONS`].
fn directions(written: &RawAzimuths) -> Result<Vec<Azimuth>, (String, String)> {
    let fail = |message: String| Err(("azimuths".to_owned(), format!("azimuths: {message}")));
    let degrees = match written {
        RawAzimuths::List(list) => list.clone(),
        RawAzimuths::Steps(AzimuthSteps { from, to, step }) => {
            match azimuth_steps(*from, *to, *step) {
                Ok(list) => list,
                Err(e) => return fail(e.to_string()),
            }
        }
        RawAzimuths::Text(text) => match parse_azimuths(text) {
            Ok(list) => list,
            Err(e) => return fail(e.to_string()),
        },
    };
    if degrees.is_empty() || degrees.len() > MAX_DIRECTIONS {
        return fail(format!(
            "give 1 to {MAX_DIRECTIONS} directions, got {}",
            degrees.len()
        ));
    }
    let mut azimuths: Vec<Azimuth> = Vec::with_capacity(degrees.len());
    for d in degrees {
        let normalised = d.rem_euclid(360.0);
        let Ok(azimuth) = Azimuth::from_degrees(normalised) else {
            return fail(format!("{d} is not a finite number of degrees"));
        };
        if azimuths.iter().any(|a| a.degrees() == normalised) {
            return fail(format!("the direction {normalised}° is given twice"));
        }
        azimuths.push(azimuth);
    }
    Ok(azimuths)
}

/// The entry's `model` (default planar), with what the 3-D model cannot take refused.
fn rock_model(raw: &RawPbr) -> Result<RockModel, (String, String)> {
    let model = match &raw.model {
        None => return Ok(RockModel::Planar),
        Some(text) => RockModel::parse(text).map_err(|e| ("model".to_owned(), e.to_string()))?,
    };
    if model == RockModel::Rigid3d {
        let refused = [
            (raw.mesh.is_none(), "model", "model = \"3d\" needs mesh: the 3-D model integrates a rock from its closed mesh"),
            (raw.restitution.is_some(), "restitution", "restitution is not a parameter of model = \"3d\": impacts are plastic and what each one dissipates follows from the rock's geometry (docs/rocking-3d.md)"),
            (raw.contact_tolerance_m.is_some(), "contact_tolerance_m", "contact_tolerance_m belongs to the planar reduction (model = \"2d\"): the 3-D model's contact is the hull itself"),
            (raw.azimuths.is_some(), "azimuths", "azimuths belongs to the planar reduction (model = \"2d\"): the 3-D rock falls in whatever direction the ground motion takes it"),
        ];
        if let Some((_, field, message)) = refused.iter().find(|(given, _, _)| *given) {
            return Err(((*field).to_owned(), (*message).to_owned()));
        }
    }
    Ok(model)
}

/// Reads and analyses the mesh of an entry (relative paths from `base_dir`); for
/// `model = "3d"` also its rigid body.
#[allow(clippy::too_many_arguments)]
fn load_mesh(
    file: &str,
    up: Option<&str>,
    cap: bool,
    azimuths: Vec<Azimuth>,
    tolerance_m: f64,
    model: RockModel,
    base_dir: Option<&Path>,
) -> Result<MeshRock, (String, String)> {
    let up = match up {
        Some(text) => UpAxis::parse(text).map_err(|e| ("up".to_owned(), format!("up: {e}")))?,
        None => UpAxis::PlusZ,
    };
    let written = Path::new(file);
    let path = match base_dir {
        Some(dir) if written.is_relative() => dir.join(written),
        _ => written.to_owned(),
    };
    let mesh_error = |e: crate::mesh::MeshError| ("mesh".to_owned(), format!("mesh: {e}"));
    let (rock, cap) = RockGeometry::read_with(&path, cap.then_some(up)).map_err(mesh_error)?;
    let rest = rock.rest(up, tolerance_m).map_err(mesh_error)?;
    let body = match model {
        RockModel::Planar => None,
        RockModel::Rigid3d => Some(
            RockBody::from_mesh(&rock, &rest, NOMINAL_DENSITY_KG_M3).map_err(|e| {
                (
                    "model".to_owned(),
                    format!("model = \"3d\": the mesh gives no rigid body: {e}"),
                )
            })?,
        ),
    };
    Ok(MeshRock {
        path,
        up,
        azimuths,
        rock,
        rest,
        cap,
        body,
    })
}

/// The entry's geometry: exactly one complete form of [`GEOMETRY_FORMS`]; the error names the
/// first field that conflicts or is missing.
fn raw_geometry(raw: &RawPbr) -> Result<Geometry, (String, String)> {
    let planar = [
        ("width_m", raw.width_m),
        ("height_m", raw.height_m),
        ("half_diagonal_m", raw.half_diagonal_m),
        ("alpha_deg", raw.alpha_deg),
        ("b_plus_m", raw.b_plus_m),
        ("b_minus_m", raw.b_minus_m),
        ("h_m", raw.h_m),
        ("rho_m", raw.rho_m),
    ];
    if raw.mesh.is_some() {
        if let Some((field, _)) = planar.iter().find(|(_, d)| d.is_some()) {
            return Err((
                (*field).to_owned(),
                format!("{field} cannot be combined with mesh: the mesh gives the geometry"),
            ));
        }
        return Ok(Geometry::Mesh {
            heading_deg: raw.heading_deg.unwrap_or(Distribution::Fixed(0.0)),
            contact_tolerance_m: raw
                .contact_tolerance_m
                .unwrap_or(Distribution::Fixed(DEFAULT_CONTACT_TOLERANCE_M)),
        });
    }
    for (field, given) in [
        ("heading_deg", raw.heading_deg.is_some()),
        ("contact_tolerance_m", raw.contact_tolerance_m.is_some()),
        ("up", raw.up.is_some()),
    ] {
        if given {
            return Err((field.to_owned(), format!("{field} needs mesh")));
        }
    }
    let value = |field: &str| match field {
        "width_m" => raw.width_m,
        "height_m" => raw.height_m,
        "half_diagonal_m" => raw.half_diagonal_m,
        "alpha_deg" => raw.alpha_deg,
        "b_plus_m" => raw.b_plus_m,
        "b_minus_m" => raw.b_minus_m,
        "h_m" => raw.h_m,
        _ => raw.rho_m,
    };
    let forms_text = "width_m + height_m, half_diagonal_m + alpha_deg, b_plus_m + b_minus_m \
                      + h_m + rho_m, or mesh";
    let used: Vec<usize> = (0..GEOMETRY_FORMS.len())
        .filter(|&i| GEOMETRY_FORMS[i].iter().any(|f| value(f).is_some()))
        .collect();
    match used[..] {
        [] => Err((
            "width_m".to_owned(),
            format!("the geometry is missing: give {forms_text}"),
        )),
        [form] => {
            let fields = GEOMETRY_FORMS[form];
            let mut distributions = Vec::with_capacity(fields.len());
            for field in fields {
                match value(field) {
                    Some(d) => distributions.push(d),
                    None => {
                        return Err((
                            (*field).to_owned(),
                            format!(
                                "{field} is missing: this geometry needs {}",
                                fields.join(" + ")
                            ),
                        ))
                    }
                }
            }
            Ok(Geometry::from_form(form, &distributions))
        }
        [first, second, ..] => {
            let given = |i: usize| {
                GEOMETRY_FORMS[i]
                    .iter()
                    .copied()
                    .find(|f| value(f).is_some())
                    .unwrap_or(GEOMETRY_FORMS[i][0])
            };
            let (a, b) = (given(first), given(second));
            Err((
                b.to_owned(),
                format!("{b} cannot be combined with {a}: give one geometry, {forms_text}"),
            ))
        }
    }
}

/// Checks one distribution against its parameter's domain; errors name `field` or
/// `field{sep}min` etc.
fn check_distribution(
    field: &str,
    distribution: &Distribution,
    domain: Domain,
    sep: char,
) -> Result<(), (String, String)> {
    let need = |name: String, value: f64| -> Result<(), (String, String)> {
        if domain.contains(value) {
            Ok(())
        } else {
            let message = format!("{name} = {value} must be {}", domain.requirement);
            Err((name, message))
        }
    };
    match *distribution {
        Distribution::Fixed(v) => need(field.to_owned(), v),
        Distribution::Uniform { min, max } => {
            need(format!("{field}{sep}min"), min)?;
            need(format!("{field}{sep}max"), max)?;
            if min < max {
                Ok(())
            } else {
                let name = format!("{field}{sep}min");
                let message = format!(
                    "{name} = {min} must be less than {field}{sep}max = {max} (use a plain number \
                     for a known value)"
                );
                Err((name, message))
            }
        }
        Distribution::Normal { mean, sd } => {
            need(format!("{field}{sep}mean"), mean)?;
            if sd.is_finite() && sd > 0.0 {
                Ok(())
            } else {
                let name = format!("{field}{sep}sd");
                let message = format!(
                    "{name} = {sd} must be a finite number > 0 (use a plain number for a known \
                     value)"
                );
                Err((name, message))
            }
        }
    }
}
