//! The PBR catalogue: file formats, validation messages, nominal blocks, Latin-hypercube
//! ensembles, the horizontal projection, and the example catalogue `config/catalogue.toml`.

use rockwatch_test_harness::fixtures::rinaldi;
use std::path::{Path, PathBuf};

use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::catalogue::{
    default_seed, Catalogue, CatalogueError, Distribution, Pbr, MAX_REPORTED_PROBLEMS,
};
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::lhs::{latin_hypercube_seeded, standard_normal_quantile};
use rockwatch_core::record::Record;
use rockwatch_core::simulate::{simulate, SimulationOptions, Status};

fn repo(path: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join(path)
}

// ---------------------------------------------------------------------------------------------
// Helpers: a valid entry in TOML, modified field by field.

/// The fields of a valid entry, as TOML right-hand sides.
const BASE: &[(&str, &str)] = &[
    ("id", "\"pinnacle-2\""),
    ("name", "\"Pinnacle\""),
    ("lat", "34.28"),
    ("lon", "-118.48"),
    ("station", "\"CI.RRS.00\""),
    ("azimuth_deg", "228.0"),
    ("width_m", "0.5"),
    ("height_m", "1.5"),
    ("mu_s", "0.6"),
    ("mu_k", "0.5"),
    ("source", "\"illustrative\""),
];

/// Field changes: `(field, Some(new TOML value))` sets or adds, `(field, None)` removes.
type Changes<'a> = &'a [(&'a str, Option<&'a str>)];

/// One `[[pbr]]` table: BASE with `changes` applied (`Some(v)` sets or adds, `None` removes).
fn entry(changes: &[(&str, Option<&str>)]) -> String {
    let mut fields: Vec<(String, String)> = BASE
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    for (key, value) in changes {
        fields.retain(|(k, _)| k != key);
        if let Some(v) = value {
            fields.push((key.to_string(), v.to_string()));
        }
    }
    let mut text = String::from("[[pbr]]\n");
    for (k, v) in fields {
        text.push_str(&format!("{k} = {v}\n"));
    }
    text
}

/// A two-entry catalogue: a valid "ok-1", then BASE ("pinnacle-2") with `changes`.
fn two_entries(changes: &[(&str, Option<&str>)]) -> String {
    format!("{}\n{}", entry(&[("id", Some("\"ok-1\""))]), entry(changes))
}

/// 1-based line of the `n`-th (0-based) `[[pbr]]` header in `text`.
fn header_line(text: &str, n: usize) -> usize {
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim() == "[[pbr]]")
        .nth(n)
        .map(|(i, _)| i + 1)
        .unwrap()
}

fn toml_error(text: &str) -> String {
    Catalogue::from_toml_str(text, "test.toml")
        .expect_err("the catalogue should be rejected")
        .to_string()
}

fn load_toml(text: &str) -> Catalogue {
    Catalogue::from_toml_str(text, "test.toml").unwrap()
}

fn only(text: &str) -> Pbr {
    load_toml(text).pbrs()[0].clone()
}

// ---------------------------------------------------------------------------------------------
// Validation messages, field by field.

#[test]
fn every_invalid_field_is_reported_with_entry_index_id_and_problem() {
    let cases: &[(Changes, &str)] = &[
        (&[("name", Some("\"  \""))], "name must not be blank"),
        (
            &[("source", Some("\"\""))],
            "source must not be blank (say where the numbers come from)",
        ),
        (&[("lat", Some("91"))], "lat = 91 must be in [-90, 90] degrees"),
        (&[("lat", Some("nan"))], "lat = NaN must be in [-90, 90] degrees"),
        (
            &[("lon", Some("-180.5"))],
            "lon = -180.5 must be in [-180, 180] degrees",
        ),
        (
            &[("station", Some("\"CI.RRS\""))],
            "station \"CI.RRS\" is not NET.STA.LOC (network, station and location codes \
             separated by two dots, e.g. \"CI.RRS.00\"; an empty location is written \"CI.RRS.\")",
        ),
        (
            &[("station", Some("\"CIX.RRS.00\""))],
            "station \"CIX.RRS.00\": network code \"CIX\" must be 1–2 upper-case letters or digits",
        ),
        (
            &[("station", Some("\"CI.RRSABC.00\""))],
            "station \"CI.RRSABC.00\": station code \"RRSABC\" must be 1–5 upper-case letters or \
             digits",
        ),
        (
            &[("station", Some("\"CI.RRS.000\""))],
            "station \"CI.RRS.000\": location code \"000\" must be 0–2 upper-case letters or digits",
        ),
        (
            &[("station", Some("\"ci.RRS.00\""))],
            "station \"ci.RRS.00\": network code \"ci\" must be 1–2 upper-case letters or digits",
        ),
        (
            &[("azimuth_deg", Some("360"))],
            "azimuth_deg = 360 must be in [0, 360) degrees clockwise from north",
        ),
        (
            &[("azimuth_deg", Some("-1.5"))],
            "azimuth_deg = -1.5 must be in [0, 360) degrees clockwise from north",
        ),
        (
            &[("width_m", Some("0"))],
            "width_m = 0 must be a finite length > 0 (metres)",
        ),
        (
            &[("height_m", Some("-1.5"))],
            "height_m = -1.5 must be a finite length > 0 (metres)",
        ),
        (
            &[("height_m", Some("inf"))],
            "height_m = inf must be a finite length > 0 (metres)",
        ),
        (
            &[("width_m", Some("{ min = 0.5, max = 0.4 }"))],
            "width_m.min = 0.5 must be less than width_m.max = 0.4 (use a plain number for a \
             known value)",
        ),
        (
            &[("width_m", Some("{ min = -0.1, max = 0.4 }"))],
            "width_m.min = -0.1 must be a finite length > 0 (metres)",
        ),
        (
            &[("height_m", Some("{ mean = 1.5, sd = 0 }"))],
            "height_m.sd = 0 must be a finite number > 0 (use a plain number for a known value)",
        ),
        (
            &[("height_m", Some("{ mean = -1.5, sd = 0.1 }"))],
            "height_m.mean = -1.5 must be a finite length > 0 (metres)",
        ),
        (
            &[("width_m", Some("{ min = 0.5 }"))],
            "width_m: a distribution is { min, max } (uniform) or { mean, sd } (normal), got \
             { min }",
        ),
        (
            &[("width_m", Some("{ min = 0.4, max = 0.6, mean = 0.5 }"))],
            "width_m: a distribution is { min, max } (uniform) or { mean, sd } (normal), got \
             { min, max, mean }",
        ),
        (
            &[("width_m", Some("{ min = 0.4, max = 0.6, mode = 0.5 }"))],
            "width_m: unknown key `mode`: a distribution is { min, max } (uniform) or \
             { mean, sd } (normal)",
        ),
        (
            &[("width_m", Some("\"wide\""))],
            "width_m: invalid type: string \"wide\", expected a number, a range \
             { min = .., max = .. } or a normal { mean = .., sd = .. }",
        ),
        (&[("mu_s", Some("0"))], "mu_s = 0 must be a finite number > 0"),
        (
            &[("mu_k", Some("-0.1"))],
            "mu_k = -0.1 must be in [0, 4/3) (mu_k ≥ 4/3 makes slide-rocking ill-posed: \
             Painlevé paradox)",
        ),
        (
            &[("mu_s", Some("1.5")), ("mu_k", Some("1.4"))],
            "mu_k = 1.4 must be in [0, 4/3) (mu_k ≥ 4/3 makes slide-rocking ill-posed: \
             Painlevé paradox)",
        ),
        (&[("mu_k", Some("0.9"))], "mu_k = 0.9 exceeds mu_s = 0.6"),
        (
            &[("mu_k", Some("{ mean = 0.7, sd = 0.05 }"))],
            "nominal mu_k = 0.7 exceeds nominal mu_s = 0.6",
        ),
        (
            &[("restitution", Some("1.2"))],
            "restitution = 1.2 must be in [0, 1]",
        ),
        (
            &[("restitution", Some("{ min = 0.5, max = 1.1 }"))],
            "restitution.max = 1.1 must be in [0, 1]",
        ),
        (
            &[("ensemble", Some("0")), ("width_m", Some("{ min = 0.4, max = 0.6 }"))],
            "ensemble = 0 must be an integer from 1 to 10000",
        ),
        (
            &[
                ("ensemble", Some("10001")),
                ("width_m", Some("{ min = 0.4, max = 0.6 }")),
            ],
            "ensemble = 10001 must be an integer from 1 to 10000",
        ),
        (
            &[("ensemble", Some("5"))],
            "ensemble = 5 but no parameter is uncertain: give a range or a normal for at least \
             one of width_m, height_m, mu_s, mu_k, restitution, or drop ensemble",
        ),
        (
            &[("seed", Some("-1"))],
            "seed = -1 must be an integer from 0 to 18446744073709551615",
        ),
        (&[("lat", None)], "missing field `lat`"),
        (
            &[("source", None)],
            "missing field `source` (required: where the numbers come from, e.g. a survey, a \
             paper, or \"illustrative\" for made-up values)",
        ),
        (
            &[("lat", Some("\"north\""))],
            "lat: invalid type: string \"north\", expected f64",
        ),
        (
            &[("ensemble", Some("2.5"))],
            "ensemble: invalid type: floating point `2.5`, expected an integer",
        ),
    ];
    for (changes, problem) in cases {
        let text = two_entries(changes);
        let line = header_line(&text, 1);
        let expected = format!("test.toml:{line}: pbr[1] (id \"pinnacle-2\"): {problem}");
        assert_eq!(toml_error(&text), expected, "changes {changes:?}");
    }
}

#[test]
fn invalid_ids_are_reported() {
    let text = two_entries(&[("id", Some("\"\""))]);
    let line = header_line(&text, 1);
    assert_eq!(
        toml_error(&text),
        format!("test.toml:{line}: pbr[1]: id must not be empty")
    );

    let text = two_entries(&[("id", Some("\"two words\""))]);
    assert_eq!(
        toml_error(&text),
        format!(
            "test.toml:{line}: pbr[1] (id \"two words\"): id \"two words\" must not contain \
             whitespace or control characters"
        )
    );

    let text = two_entries(&[("id", Some("\"ok-1\""))]);
    assert_eq!(
        toml_error(&text),
        format!("test.toml:{line}: pbr[1] (id \"ok-1\"): id \"ok-1\" is already used by pbr[0] (line 1)")
    );

    let text = two_entries(&[("id", None)]);
    assert_eq!(
        toml_error(&text),
        format!("test.toml:{line}: pbr[1]: missing field `id`")
    );
}

#[test]
fn unknown_fields_are_rejected_by_name() {
    let text = two_entries(&[("colour", Some("\"red\""))]);
    let line = header_line(&text, 1);
    let message = toml_error(&text);
    let prefix =
        format!("test.toml:{line}: pbr[1] (id \"pinnacle-2\"): unknown field `colour`, expected one of `id`, ");
    assert!(message.starts_with(&prefix), "{message}");

    // The field is also available programmatically for the typed errors.
    let err =
        Catalogue::from_toml_str(&two_entries(&[("mu_k", Some("0.9"))]), "t.toml").unwrap_err();
    match err {
        CatalogueError::Entry {
            index, id, field, ..
        } => {
            assert_eq!(index, 1);
            assert_eq!(id.as_deref(), Some("pinnacle-2"));
            assert_eq!(field.as_deref(), Some("mu_k"));
        }
        other => panic!("unexpected error {other:?}"),
    }
}

#[test]
fn document_level_problems_name_the_source() {
    let message = toml_error("[[pbrs]]\nid = \"x\"\n");
    assert!(message.starts_with("test.toml: "), "{message}");
    assert!(message.contains("unknown field `pbrs`"), "{message}");

    let message = toml_error("[[pbr]\nid = 3");
    assert!(message.starts_with("test.toml: "), "{message}");

    assert_eq!(
        toml_error("# nothing here\n"),
        "test.toml: the catalogue has no PBR entries"
    );
}

#[test]
fn load_chooses_the_reader_by_extension_and_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("catalogue.json");
    std::fs::write(&json, "{}").unwrap();
    let message = Catalogue::load(&json).unwrap_err().to_string();
    assert_eq!(
        message,
        format!(
            "{}: unknown catalogue format: the file name must end in .toml or .csv",
            json.display()
        )
    );

    let missing = dir.path().join("missing.toml");
    let message = Catalogue::load(&missing).unwrap_err().to_string();
    assert!(
        message.starts_with(&format!(
            "{}: cannot read the catalogue: ",
            missing.display()
        )),
        "{message}"
    );

    // Upper-case extensions are accepted; the path is the source name in later errors.
    let upper = dir.path().join("BAD.TOML");
    std::fs::write(&upper, two_entries(&[("mu_k", Some("0.9"))])).unwrap();
    let message = Catalogue::load(&upper).unwrap_err().to_string();
    assert!(
        message.starts_with(&format!("{}:", upper.display()))
            && message.ends_with("mu_k = 0.9 exceeds mu_s = 0.6"),
        "{message}"
    );
}

// ---------------------------------------------------------------------------------------------
// CSV.

const CSV_HEADER: &str = "id,name,lat,lon,station,azimuth_deg,width_m,height_m,mu_s,mu_k,source";
const CSV_ROW: &str =
    "pinnacle-2,Pinnacle,34.28,-118.48,CI.RRS.00,228.0,0.5,1.5,0.6,0.5,illustrative";

fn csv_error(text: &str) -> String {
    Catalogue::from_csv_str(text, "test.csv")
        .expect_err("the catalogue should be rejected")
        .to_string()
}

#[test]
fn csv_and_toml_of_the_same_entry_load_equal() {
    let toml = load_toml(&entry(&[]));
    let csv = Catalogue::from_csv_str(&format!("{CSV_HEADER}\n{CSV_ROW}\n"), "x.csv").unwrap();
    assert_eq!(toml.pbrs(), csv.pbrs());
}

#[test]
fn csv_problems_are_reported_with_line_and_column_names() {
    // Validation shares the TOML rules, with CSV column names and the row's line.
    let text = format!(
        "# comment\n{CSV_HEADER}\n{}\n",
        CSV_ROW.replace(",0.5,illustrative", ",0.9,illustrative")
    );
    assert_eq!(
        csv_error(&text),
        "test.csv:3: pbr[0] (id \"pinnacle-2\"): mu_k = 0.9 exceeds mu_s = 0.6"
    );

    let header = "id,name,lat,lon,station,azimuth_deg,width_m,width_m_min,width_m_max,height_m,mu_s,mu_k,source";
    let both = "p,P,34,-118,CI.RRS.00,0,0.5,0.4,0.6,1.5,0.6,0.5,illustrative";
    assert_eq!(
        csv_error(&format!("{header}\n{both}\n")),
        "test.csv:2: pbr[0] (id \"p\"): width_m: fill exactly one of width_m, width_m_min + \
         width_m_max, or width_m_mean + width_m_sd (got width_m, width_m_min, width_m_max)"
    );
    let reversed = "p,P,34,-118,CI.RRS.00,0,,0.6,0.4,1.5,0.6,0.5,illustrative";
    assert_eq!(
        csv_error(&format!("{header}\n{reversed}\n")),
        "test.csv:2: pbr[0] (id \"p\"): width_m_min = 0.6 must be less than width_m_max = 0.4 \
         (use a plain number for a known value)"
    );
    let none = "p,P,34,-118,CI.RRS.00,0,,,,1.5,0.6,0.5,illustrative";
    assert_eq!(
        csv_error(&format!("{header}\n{none}\n")),
        "test.csv:2: pbr[0] (id \"p\"): width_m is missing: this geometry needs width_m + \
         height_m"
    );

    let not_a_number = CSV_ROW.replace("34.28", "north");
    assert_eq!(
        csv_error(&format!("{CSV_HEADER}\n{not_a_number}\n")),
        "test.csv:2: pbr[0] (id \"pinnacle-2\"): lat = \"north\" is not a number"
    );
    let empty_lat = CSV_ROW.replace("34.28", "");
    assert_eq!(
        csv_error(&format!("{CSV_HEADER}\n{empty_lat}\n")),
        "test.csv:2: pbr[0] (id \"pinnacle-2\"): lat is missing (empty cell)"
    );
    let header_k = format!("{CSV_HEADER},ensemble");
    assert_eq!(
        csv_error(&format!("{header_k}\n{CSV_ROW},2.5\n")),
        "test.csv:2: pbr[0] (id \"pinnacle-2\"): ensemble = \"2.5\" is not an integer"
    );
    let second = CSV_ROW.replace("pinnacle-2", "pinnacle-3");
    assert_eq!(
        csv_error(&format!("{CSV_HEADER}\n{CSV_ROW}\n{second}\n{CSV_ROW}\n")),
        "test.csv:4: pbr[2] (id \"pinnacle-2\"): id \"pinnacle-2\" is already used by pbr[0] (line 2)"
    );
}

#[test]
fn csv_header_problems_are_reported() {
    assert_eq!(
        csv_error(&format!("{CSV_HEADER},colour\n{CSV_ROW},red\n")),
        "test.csv:1: unknown column \"colour\" in the CSV header (known: id, name, lat, lon, \
         station, source, azimuth_deg, ensemble, seed, mesh, up, azimuths, cap, model, and for P in width_m, \
         height_m, half_diagonal_m, alpha_deg, b_plus_m, b_minus_m, h_m, rho_m, heading_deg, \
         contact_tolerance_m, mu_s, mu_k, restitution: P, P_min + P_max, or P_mean + P_sd)"
    );
    assert_eq!(
        csv_error(&format!("{CSV_HEADER},lat\n{CSV_ROW},1\n")),
        "test.csv:1: column \"lat\" appears twice in the CSV header"
    );
    let no_lat = CSV_HEADER.replace("lat,", "");
    assert_eq!(
        csv_error(&format!("{no_lat}\n")),
        "test.csv:1: the CSV header has no \"lat\" column"
    );
    let no_mu_k = CSV_HEADER.replace("mu_k,", "");
    assert_eq!(
        csv_error(&format!("{no_mu_k}\n")),
        "test.csv:1: the CSV header has no column for mu_k (mu_k, mu_k_min + mu_k_max, or \
         mu_k_mean + mu_k_sd)"
    );
    let message = csv_error(&format!("{CSV_HEADER}\n{CSV_ROW},extra\n"));
    assert!(
        message.starts_with("test.csv:2: invalid CSV row:"),
        "{message}"
    );
    assert_eq!(
        csv_error(&format!("{CSV_HEADER}\n")),
        "test.csv: the catalogue has no PBR entries"
    );
}

#[test]
fn csv_accepts_the_whole_u64_seed_range_and_an_omitted_seed_is_fnv1a_of_the_id() {
    // TOML integers stop at 2^63 - 1; the FNV-1a hash of this id is above that, so only the
    // CSV form can spell it. Omitting the seed must be the same as giving that hash.
    let id = "pinnacle-2";
    let fnv = default_seed(id);
    assert!(
        fnv > i64::MAX as u64,
        "pick an id whose hash needs the top bit"
    );
    let header =
        format!("{CSV_HEADER},seed,ensemble").replace("width_m,", "width_m_min,width_m_max,");
    let row = |seed: &str| format!("{},{seed},8", CSV_ROW.replace(",0.5,1.5,", ",0.4,0.6,1.5,"));
    let explicit =
        Catalogue::from_csv_str(&format!("{header}\n{}\n", row(&fnv.to_string())), "a.csv")
            .unwrap();
    let implicit = Catalogue::from_csv_str(&format!("{header}\n{}\n", row("")), "b.csv").unwrap();
    assert_eq!(explicit.pbrs()[0].seed(), fnv);
    assert_eq!(explicit.pbrs(), implicit.pbrs());
    assert_eq!(
        explicit.pbrs()[0].members().unwrap(),
        implicit.pbrs()[0].members().unwrap()
    );
    let max = Catalogue::from_csv_str(
        &format!("{header}\n{}\n", row(&u64::MAX.to_string())),
        "c.csv",
    )
    .unwrap();
    assert_eq!(max.pbrs()[0].seed(), u64::MAX);
}

// ---------------------------------------------------------------------------------------------
// The example catalogue.

#[test]
fn example_catalogue_loads_and_its_csv_twin_is_equal() {
    let toml = Catalogue::load(repo("config/catalogue.toml")).unwrap();
    let csv = Catalogue::load(repo("tests/data/catalogue/example.csv")).unwrap();
    assert_eq!(toml.pbrs(), csv.pbrs());
    assert!((6..=8).contains(&toml.len()), "about six entries");

    let stations: Vec<&str> = toml.stations().iter().map(|s| s.as_str()).collect();
    assert_eq!(stations, ["CI.RRS.00", "CI.SYL.00"]);
    let rrs: Vec<&str> = toml
        .pbrs_for_station("CI.RRS.00")
        .map(|p| p.id().as_str())
        .collect();
    let syl: Vec<&str> = toml
        .pbrs_for_station("CI.SYL.00")
        .map(|p| p.id().as_str())
        .collect();
    assert_eq!(rrs.len() + syl.len(), toml.len());
    assert!(rrs.contains(&"rrs-slender-pillar") && syl.contains(&"syl-stocky-block"));
    assert_eq!(toml.pbrs_for_station("CI.XXX.00").count(), 0);
    assert_eq!(toml.pbrs_for_station("ci.rrs.00").count(), 0);
    for pbr in toml.pbrs() {
        assert!(pbr.source().contains("illustrative"), "{}", pbr.id());
        assert!(pbr.members().is_ok());
    }
    let station = toml.get("syl-stocky-block").unwrap().station();
    assert_eq!(
        (station.network(), station.station(), station.location()),
        ("CI", "SYL", "00")
    );
}

#[test]
fn example_catalogue_roles_hold_by_their_parameters() {
    let cat = Catalogue::load(repo("config/catalogue.toml")).unwrap();
    let nominal = |id: &str| cat.get(id).unwrap().nominal();
    for id in ["rrs-slender-pillar", "syl-slender-tombstone"] {
        let p = nominal(id);
        assert!(
            p.plus.tan_alpha <= 0.25 && p.mu_s > p.plus.tan_alpha,
            "{id}: slender, rocking-prone"
        );
    }
    for id in ["rrs-stocky-boulder", "syl-stocky-block"] {
        let p = nominal(id);
        assert!(
            p.plus.tan_alpha >= 1.25 && p.mu_s < p.plus.tan_alpha,
            "{id}: stocky"
        );
    }
    let slab = nominal("rrs-sliding-slab");
    assert!(slab.mu_s < slab.plus.tan_alpha && slab.mu_k < slab.plus.tan_alpha);
    let column = nominal("syl-slide-rock-column");
    assert!(column.mu_k > column.plus.tan_alpha && column.mu_s > column.plus.tan_alpha);
    let ensemble = cat.get("rrs-pinnacle-ensemble").unwrap();
    assert!(ensemble.ensemble_size() > 1);
}

fn sylmar() -> Record {
    Record::read(&repo("tests/data/records/RSN1084_NORTHR_SCS142.AT2")).unwrap()
}

#[test]
fn example_catalogue_behaves_as_its_comments_say() {
    // The claims in config/catalogue.toml, checked with the block engine on the bundled
    // records: slender blocks overturn, stocky blocks never rock and slide less than 0.1 m,
    // the slab slides more than 0.1 m without rocking, the column slide-rocks, and the
    // ensemble straddles the overturning threshold (some but not all members fall).
    let cat = Catalogue::load(repo("config/catalogue.toml")).unwrap();
    let (rrs, syl) = (rinaldi(), sylmar());
    let options = SimulationOptions::default();
    let run = |id: &str| {
        let pbr = cat.get(id).unwrap();
        let record = if pbr.station().as_str() == "CI.RRS.00" {
            &rrs
        } else {
            &syl
        };
        simulate(pbr.nominal(), record, &options).unwrap().summary
    };
    for id in ["rrs-slender-pillar", "syl-slender-tombstone"] {
        assert_eq!(run(id).status, Status::Overturned, "{id}");
    }
    for id in ["rrs-stocky-boulder", "syl-stocky-block"] {
        let s = run(id);
        assert!(
            s.status == Status::Ok && s.max_abs_theta == 0.0,
            "{id}: {s:?}"
        );
        assert!(s.max_abs_slide < 0.1, "{id}: slide {}", s.max_abs_slide);
    }
    let slab = run("rrs-sliding-slab");
    assert!(
        slab.max_abs_theta == 0.0 && slab.max_abs_slide > 0.1,
        "{slab:?}"
    );
    let column = run("syl-slide-rock-column");
    assert!(column.status == Status::Ok, "{column:?}");
    assert!(
        column.modes.iter().any(|(_, m)| m.as_str() == "slide-rock"),
        "{column:?}"
    );

    let members = cat.get("rrs-pinnacle-ensemble").unwrap().members().unwrap();
    let fallen = members
        .iter()
        .filter(|p| simulate(**p, &rrs, &options).unwrap().summary.overturned)
        .count();
    assert!(
        0 < fallen && fallen < members.len(),
        "{fallen} of {}",
        members.len()
    );
}

// ---------------------------------------------------------------------------------------------
// Nominal block and ensembles.

/// Standard normal CDF by composite Simpson integration of the density from 0 (independent of
/// the library's erfc): Φ(z) = ½ + sgn z ∫₀^|z| φ. With h ≤ 1e-3 the Simpson error bound
/// h⁴·max|φ⁗|·|z|/180 is below 1e-13 for |z| ≤ 10.
fn phi_by_quadrature(z: f64) -> f64 {
    let pdf = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let a = z.abs().min(10.0);
    let n = (((a / 1e-3).ceil() as usize).max(2) + 1) & !1;
    let h = a / n as f64;
    let mut sum = pdf(0.0) + pdf(a);
    for k in 1..n {
        sum += if k % 2 == 1 { 4.0 } else { 2.0 } * pdf(k as f64 * h);
    }
    0.5 + z.signum() * sum * h / 3.0
}

/// Asserts that the `k`-th values `cdf(x)` put exactly one member in each of the K strata.
fn assert_stratified(name: &str, values: &[f64], cdf: impl Fn(f64) -> f64) {
    let n = values.len();
    let mut seen = vec![0usize; n];
    for &x in values {
        let u = cdf(x);
        assert!((0.0..1.0).contains(&u), "{name}: F({x}) = {u}");
        seen[(u * n as f64).floor() as usize] += 1;
    }
    assert!(
        seen.iter().all(|&c| c == 1),
        "{name}: strata counts {seen:?}"
    );
}

const UNCERTAIN: &[(&str, Option<&str>)] = &[
    ("width_m", Some("{ min = 0.5, max = 0.9 }")),
    ("height_m", Some("{ mean = 2.0, sd = 0.1 }")),
    ("mu_s", Some("{ min = 0.7, max = 0.8 }")),
    ("mu_k", Some("{ mean = 0.4, sd = 0.02 }")),
    ("restitution", Some("{ min = 0.8, max = 0.95 }")),
];

fn uncertain_with(extra: &[(&str, Option<&str>)]) -> Pbr {
    let mut changes = UNCERTAIN.to_vec();
    changes.extend_from_slice(extra);
    only(&entry(&changes))
}

#[test]
fn nominal_block_is_midpoint_of_ranges_and_mean_of_normals() {
    let pbr = uncertain_with(&[]);
    let expected = BlockParams::from_width_height(0.7, 2.0, 0.75, 0.4, Some(0.875)).unwrap();
    let nominal = pbr.nominal();
    // Midpoints (a+b)/2 of these decimal endpoints round to within one ulp of the literals.
    for (got, want) in [
        (nominal.base_width_m(), expected.base_width_m()),
        (2.0 * nominal.com_height_m, 2.0 * expected.com_height_m),
        (nominal.mu_s, expected.mu_s),
        (nominal.mu_k, expected.mu_k),
        (nominal.restitution.unwrap(), expected.restitution.unwrap()),
    ] {
        assert!((got - want).abs() < 1e-15, "{got} vs {want}");
    }
    assert_eq!(
        pbr.width_m(),
        Some(Distribution::Uniform { min: 0.5, max: 0.9 })
    );
    assert_eq!(pbr.ensemble_size(), 1);
}

#[test]
fn ensemble_of_one_is_exactly_the_nominal_block() {
    for k in [None, Some("1")] {
        let pbr = uncertain_with(&[("ensemble", k)]);
        assert_eq!(pbr.members().unwrap(), vec![pbr.nominal()]);
    }
    let fixed = only(&entry(&[]));
    assert_eq!(
        fixed.nominal(),
        BlockParams::from_width_height(0.5, 1.5, 0.6, 0.5, None).unwrap()
    );
    assert_eq!(fixed.members().unwrap(), vec![fixed.nominal()]);
}

#[test]
fn members_follow_the_documented_lhs_columns_and_quantile_maps() {
    // Independent re-implementation of the documented construction: columns in the order
    // width_m, height_m, mu_s, mu_k, restitution (fixed ones skipped), ranges min + u(max-min),
    // normals mean + sd Φ⁻¹(u) (the truncation at 0 is 20 sd away for height and mu_k, so
    // Φ(a) ≈ 1e-89 does not change u in double precision).
    let k = 64;
    let pbr = uncertain_with(&[("ensemble", Some("64")), ("mu_s", Some("0.75"))]);
    let lhs = latin_hypercube_seeded(k, 4, default_seed("pinnacle-2"));
    let members = pbr.members().unwrap();
    assert_eq!(members.len(), k);
    for (m, u) in members.iter().zip(lhs.samples()) {
        let width = 0.5 + u[0] * 0.4;
        let height = 2.0 + 0.1 * standard_normal_quantile(u[1]);
        let mu_k = 0.4 + 0.02 * standard_normal_quantile(u[2]);
        let e = 0.8 + u[3] * 0.15;
        // 1e-12: the quantile maps are a few flops; the only difference allowed is rounding.
        assert!((m.base_width_m() - width).abs() < 1e-12);
        assert!((2.0 * m.com_height_m - height).abs() < 1e-12);
        assert_eq!(m.mu_s, 0.75);
        assert!((m.mu_k - mu_k).abs() < 1e-12);
        assert!((m.restitution.unwrap() - e).abs() < 1e-12);
    }
}

#[test]
fn every_uncertain_margin_is_stratified_one_member_per_stratum() {
    let k = 200;
    let pbr = uncertain_with(&[("ensemble", Some("200"))]);
    let members = pbr.members().unwrap();
    assert_eq!(members.len(), k);
    let column = |f: fn(&BlockParams) -> f64| members.iter().map(f).collect::<Vec<_>>();
    assert_stratified("width_m", &column(|p| p.base_width_m()), |x| {
        (x - 0.5) / 0.4
    });
    assert_stratified("height_m", &column(|p| 2.0 * p.com_height_m), |x| {
        phi_by_quadrature((x - 2.0) / 0.1)
    });
    assert_stratified("mu_s", &column(|p| p.mu_s), |x| (x - 0.7) / 0.1);
    assert_stratified("mu_k", &column(|p| p.mu_k), |x| {
        phi_by_quadrature((x - 0.4) / 0.02)
    });
    assert_stratified("restitution", &column(|p| p.restitution.unwrap()), |x| {
        (x - 0.8) / 0.15
    });
}

#[test]
fn truncated_normal_members_stay_valid_and_are_stratified_in_the_truncated_cdf() {
    // mu_k ~ N(0.05, 0.1²) truncated to [0, 4/3): 31 % of the untruncated mass is below 0.
    // The truncated CDF is (Φ(z) − Φ(a)) / (1 − Φ(a)) with a = −0.5 (Φ(b) = 1 to 1e-37).
    let k = 100;
    let pbr = only(&entry(&[
        ("mu_s", Some("1.0")),
        ("mu_k", Some("{ mean = 0.05, sd = 0.1 }")),
        ("ensemble", Some("100")),
    ]));
    let mu_k: Vec<f64> = pbr.members().unwrap().iter().map(|p| p.mu_k).collect();
    assert!(mu_k.iter().all(|&m| m >= 0.0), "{mu_k:?}");
    let phi_a = phi_by_quadrature(-0.5);
    assert_stratified("truncated mu_k", &mu_k, |x| {
        (phi_by_quadrature((x - 0.05) / 0.1) - phi_a) / (1.0 - phi_a)
    });
    assert_eq!(k, mu_k.len());
    // Sizes: N(0.3, 0.2²) truncated to (0, ∞) keeps every member positive.
    let pbr = only(&entry(&[
        ("width_m", Some("{ mean = 0.3, sd = 0.2 }")),
        ("ensemble", Some("500")),
    ]));
    assert!(pbr
        .members()
        .unwrap()
        .iter()
        .all(|p| p.base_width_m() > 0.0));
}

#[test]
fn members_are_reproducible_for_a_seed_and_differ_between_seeds() {
    let a = uncertain_with(&[("ensemble", Some("50")), ("seed", Some("11"))]);
    let b = uncertain_with(&[("ensemble", Some("50")), ("seed", Some("11"))]);
    let c = uncertain_with(&[("ensemble", Some("50")), ("seed", Some("12"))]);
    assert_eq!(a.members().unwrap(), b.members().unwrap());
    assert_eq!(a.members().unwrap(), a.members().unwrap());
    let (ma, mc) = (a.members().unwrap(), c.members().unwrap());
    assert!(ma
        .iter()
        .zip(&mc)
        .all(|(x, y)| x.base_width_m() != y.base_width_m()));
    // Different ids give different default seeds, hence different ensembles.
    let d = only(&entry(&[
        ("id", Some("\"other\"")),
        ("width_m", Some("{ min = 0.5, max = 0.9 }")),
        ("ensemble", Some("50")),
    ]));
    let e = only(&entry(&[
        ("width_m", Some("{ min = 0.5, max = 0.9 }")),
        ("ensemble", Some("50")),
    ]));
    assert_eq!(d.seed(), default_seed("other"));
    assert_ne!(d.members().unwrap(), e.members().unwrap());
}

#[test]
fn normal_members_have_the_given_mean_and_sd_for_large_k() {
    // K = 10000 members of N(2.0, 0.1²) (height) and N(0.3, 0.02²) (mu_k), truncation
    // negligible (20 and 15 sd away). Owen (1997): the variance of a Latin-hypercube mean is at
    // most K/(K−1) times that of K independent draws, so 5 iid standard errors are a safe
    // bound: sd/√K for the mean, sd/√(2K) for the sample sd (normal case). Bounds: 0.005 and
    // 0.0035 for height, 0.001 and 0.0007 for mu_k (about 3.5 % of sd for the sd).
    let k = 10_000.0;
    let pbr = only(&entry(&[
        ("height_m", Some("{ mean = 2.0, sd = 0.1 }")),
        ("mu_k", Some("{ mean = 0.3, sd = 0.02 }")),
        ("ensemble", Some("10000")),
    ]));
    let members = pbr.members().unwrap();
    assert_eq!(members.len(), 10_000);
    for (name, values, mean, sd) in [
        (
            "height_m",
            members
                .iter()
                .map(|p| 2.0 * p.com_height_m)
                .collect::<Vec<_>>(),
            2.0,
            0.1,
        ),
        (
            "mu_k",
            members.iter().map(|p| p.mu_k).collect::<Vec<_>>(),
            0.3,
            0.02,
        ),
    ] {
        let m = values.iter().sum::<f64>() / k;
        let s = (values.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
        assert!((m - mean).abs() < 5.0 * sd / k.sqrt(), "{name}: mean {m}");
        assert!(
            (s - sd).abs() < 5.0 * sd / (2.0 * k).sqrt(),
            "{name}: sd {s}"
        );
    }
}

#[test]
fn members_with_mu_k_above_mu_s_get_mu_k_equal_to_mu_s() {
    // mu_s ~ U(0.5, 0.7), mu_k ~ U(0.35, 0.75): P(mu_k > mu_s) = (0.75 − E[mu_s])/0.4 = 3/8,
    // so about 37 of 100 members are clipped. The mu_s margin stays stratified; the unclipped
    // mu_k values still fall in distinct strata of U(0.35, 0.75).
    let pbr = only(&entry(&[
        ("mu_s", Some("{ min = 0.5, max = 0.7 }")),
        ("mu_k", Some("{ min = 0.35, max = 0.75 }")),
        ("ensemble", Some("100")),
    ]));
    let members = pbr.members().unwrap();
    assert!(members.iter().all(|p| p.mu_k <= p.mu_s));
    let clipped = members.iter().filter(|p| p.mu_k == p.mu_s).count();
    assert!((10..=65).contains(&clipped), "{clipped} clipped");
    let mu_s: Vec<f64> = members.iter().map(|p| p.mu_s).collect();
    assert_stratified("mu_s", &mu_s, |x| (x - 0.5) / 0.2);
    let mut strata: Vec<usize> = members
        .iter()
        .filter(|p| p.mu_k < p.mu_s)
        .map(|p| ((p.mu_k - 0.35) / 0.4 * 100.0).floor() as usize)
        .collect();
    let n = strata.len();
    strata.sort_unstable();
    strata.dedup();
    assert_eq!(strata.len(), n);
}

// ---------------------------------------------------------------------------------------------
// Projection.

/// The component along `azimuth_deg` of (east, north), through [`Azimuth`].
fn project_horizontal(azimuth_deg: f64, east: f64, north: f64) -> f64 {
    Azimuth::from_degrees(azimuth_deg)
        .unwrap()
        .component(east, north)
}

#[test]
fn projection_matches_sin_cos_at_cardinal_and_general_azimuths() {
    let (east, north) = (3.0, -2.0);
    // 1e-15 relative to |a| ≈ 3.6: sin/cos of the rounded radians are within a few ulp.
    let close = |a: f64, b: f64| (a - b).abs() < 1e-14;
    assert!(close(project_horizontal(0.0, east, north), north));
    assert!(close(project_horizontal(90.0, east, north), east));
    assert!(close(project_horizontal(180.0, east, north), -north));
    assert!(close(project_horizontal(270.0, east, north), -east));
    // 30°: sin = 1/2, cos = √3/2.
    let expected = east * 0.5 + north * 3f64.sqrt() / 2.0;
    assert!(close(project_horizontal(30.0, east, north), expected));
    // 228° (the Rinaldi component): a unit acceleration towards 228° projects to 1, and the
    // projections on two perpendicular axes preserve the horizontal magnitude.
    let az = 228f64.to_radians();
    assert!(close(project_horizontal(228.0, az.sin(), az.cos()), 1.0));
    let along = project_horizontal(228.0, east, north);
    let across = project_horizontal(318.0, east, north);
    assert!(close(along.hypot(across), east.hypot(north)));

    let pbr = only(&entry(&[("azimuth_deg", Some("90"))]));
    assert!(close(pbr.project_horizontal(east, north), east));
}

#[test]
fn a_nominal_mu_k_equal_to_mu_s_up_to_rounding_is_accepted_as_equal() {
    // (0.4 + 0.8)/2 = 0.6000000000000001 in binary floating point: the same as mu_s = 0.6.
    let pbr = only(&entry(&[("mu_k", Some("{ min = 0.4, max = 0.8 }"))]));
    assert_eq!(pbr.nominal().mu_k, 0.6);
    // A real excess is still rejected.
    let text = entry(&[("mu_k", Some("{ min = 0.4, max = 0.81 }"))]);
    assert_eq!(
        toml_error(&text),
        "test.toml:1: pbr[0] (id \"pinnacle-2\"): nominal mu_k = 0.605 exceeds nominal mu_s = 0.6"
    );
}

// ---------------------------------------------------------------------------------------------
// Geometry forms: width/height, half-diagonal/alpha, general body (docs/general-body.md).

type Change = (&'static str, Option<&'static str>);
const NO_WIDTH_HEIGHT: [Change; 2] = [("width_m", None), ("height_m", None)];

#[test]
fn half_diagonal_and_alpha_give_the_same_block_as_width_and_height() {
    let mut changes = NO_WIDTH_HEIGHT.to_vec();
    changes.extend([
        ("half_diagonal_m", Some("1.5")),
        ("alpha_deg", Some("10.0")),
    ]);
    let pbr = only(&entry(&changes));
    let expected = BlockParams::from_r_alpha(1.5, 10f64.to_radians(), 0.6, 0.5, None).unwrap();
    assert_eq!(pbr.nominal(), expected);
    assert!((pbr.nominal().alpha_rad.to_degrees() - 10.0).abs() < 1e-12);
    assert_eq!(pbr.width_m(), None);
}

#[test]
fn a_general_body_entry_is_built_from_its_four_fields_and_samples_them() {
    let mut changes = NO_WIDTH_HEIGHT.to_vec();
    changes.extend([
        ("b_plus_m", Some("0.12")),
        ("b_minus_m", Some("{ min = 0.25, max = 0.35 }")),
        ("h_m", Some("0.9")),
        ("rho_m", Some("{ mean = 0.4, sd = 0.02 }")),
        ("ensemble", Some("20")),
    ]);
    let pbr = only(&entry(&changes));
    let expected = BlockParams::from_body(0.12, 0.3, 0.9, 0.4, 0.6, 0.5, None).unwrap();
    let nominal = pbr.nominal();
    assert!((nominal.b_minus_m - 0.3).abs() < 1e-15);
    assert_eq!(
        (nominal.b_plus_m, nominal.com_height_m, nominal.rho_m),
        (0.12, 0.9, 0.4)
    );
    assert!((nominal.plus.tan_alpha - expected.plus.tan_alpha).abs() < 1e-15);
    let members = pbr.members().unwrap();
    assert_eq!(members.len(), 20);
    // b₋ stratified on [0.25, 0.35]: one member per stratum of width 0.005.
    let mut strata: Vec<usize> = members
        .iter()
        .map(|p| ((p.b_minus_m - 0.25) / 0.005).floor() as usize)
        .collect();
    strata.sort_unstable();
    assert_eq!(strata, (0..20).collect::<Vec<_>>());
    assert!(members
        .iter()
        .all(|p| p.b_plus_m == 0.12 && p.com_height_m == 0.9));
    assert!(members.iter().any(|p| p.rho_m != 0.4));

    // The CSV form loads equal.
    let csv = "id,name,lat,lon,station,azimuth_deg,b_plus_m,b_minus_m_min,b_minus_m_max,h_m,\
               rho_m_mean,rho_m_sd,mu_s,mu_k,source,ensemble\n\
               pinnacle-2,Pinnacle,34.28,-118.48,CI.RRS.00,228.0,0.12,0.25,0.35,0.9,0.4,0.02,0.6,\
               0.5,illustrative,20\n";
    let from_csv = Catalogue::from_csv_str(csv, "x.csv").unwrap();
    assert_eq!(from_csv.pbrs()[0], pbr);
}

#[test]
fn geometry_forms_are_validated_with_the_field_named() {
    let body = |extra: &[(&'static str, Option<&'static str>)]| {
        let mut changes = NO_WIDTH_HEIGHT.to_vec();
        changes.extend([
            ("b_plus_m", Some("0.12")),
            ("b_minus_m", Some("0.3")),
            ("h_m", Some("0.9")),
            ("rho_m", Some("0.4")),
        ]);
        changes.extend_from_slice(extra);
        changes
    };
    let forms = "width_m + height_m, half_diagonal_m + alpha_deg, b_plus_m + b_minus_m + h_m \
                 + rho_m, or mesh";
    let cases: Vec<(Vec<Change>, String)> =
        vec![
        (
            NO_WIDTH_HEIGHT.to_vec(),
            format!("the geometry is missing: give {forms}"),
        ),
        (
            vec![("height_m", None)],
            "height_m is missing: this geometry needs width_m + height_m".to_owned(),
        ),
        (
            vec![("alpha_deg", Some("10"))],
            format!("alpha_deg cannot be combined with width_m: give one geometry, {forms}"),
        ),
        (
            body(&[("rho_m", None)]),
            "rho_m is missing: this geometry needs b_plus_m + b_minus_m + h_m + rho_m".to_owned(),
        ),
        (
            body(&[("h_m", Some("-0.9"))]),
            "h_m = -0.9 must be a finite length > 0 (metres)".to_owned(),
        ),
        (
            body(&[("rho_m", Some("{ min = 0.5, max = 0.4 }"))]),
            "rho_m.min = 0.5 must be less than rho_m.max = 0.4 (use a plain number for a known \
             value)"
                .to_owned(),
        ),
        (
            vec![
                ("width_m", None),
                ("height_m", None),
                ("half_diagonal_m", Some("1.5")),
                ("alpha_deg", Some("90")),
            ],
            "alpha_deg = 90 must be in (0, 90) degrees".to_owned(),
        ),
        (
            // μk above the body's Painlevé bound 2√(c(1 + c)), c = ρ²/R² (here ≈ 0.17).
            body(&[("rho_m", Some("0.1")), ("mu_s", Some("1.2")), ("mu_k", Some("1.1"))]),
            "nominal block rejected".to_owned(),
        ),
    ];
    for (changes, problem) in cases {
        let text = two_entries(&changes);
        let line = header_line(&text, 1);
        let error = toml_error(&text);
        let prefix = format!("test.toml:{line}: pbr[1] (id \"pinnacle-2\"): ");
        assert!(
            error.starts_with(&prefix) && error[prefix.len()..].starts_with(&problem),
            "changes {changes:?}: {error}"
        );
    }
    // The CSV names its columns the same way (sub-fields with '_').
    let csv = "id,name,lat,lon,station,azimuth_deg,b_plus_m,b_minus_m,h_m,rho_m,mu_s,mu_k,source\n\
               p,P,34.28,-118.48,CI.RRS.00,228.0,0.12,0.3,0.9,,0.6,0.5,x\n";
    assert_eq!(
        csv_error(csv),
        "test.csv:2: pbr[0] (id \"p\"): rho_m is missing: this geometry needs b_plus_m + \
         b_minus_m + h_m + rho_m"
    );
}

#[test]
fn members_sized_draws_another_ensemble_size_from_the_same_entry() {
    // `rockwatch fragility --ensemble K` (issue 14 §3): K members of the entry's Latin
    // hypercube, whatever the entry's own `ensemble`; its own K gives exactly `members()`.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/catalogue.toml");
    let catalogue = Catalogue::load(&path).unwrap();
    let pinnacle = catalogue.get("rrs-pinnacle-ensemble").unwrap();
    assert!(pinnacle.has_uncertainty());
    assert_eq!(
        pinnacle.members_sized(pinnacle.ensemble_size()).unwrap(),
        pinnacle.members().unwrap()
    );
    let five = pinnacle.members_sized(5).unwrap();
    assert_eq!(five.len(), 5);
    // Latin hypercube: the 5 widths fall one in each fifth of the 0.60–0.80 m range.
    let mut bins: Vec<usize> = five
        .iter()
        .map(|m| ((m.base_width_m() - 0.60) / 0.04).floor() as usize)
        .collect();
    bins.sort_unstable();
    assert_eq!(bins, vec![0, 1, 2, 3, 4]);
    assert_eq!(pinnacle.members_sized(1).unwrap(), vec![pinnacle.nominal()]);
    let pillar = catalogue.get("rrs-slender-pillar").unwrap();
    assert!(!pillar.has_uncertainty());
}

// ---------------------------------------------------------------------------------------------
// Rocks from meshes.

/// A box 0.4 (x, east) × 0.3 (y, north) × 1.2 (z, up) as an OBJ standing on z = 0.
const BOX_OBJ: &str = "v -0.2 -0.15 0\nv 0.2 -0.15 0\nv 0.2 0.15 0\nv -0.2 0.15 0\n\
                       v -0.2 -0.15 1.2\nv 0.2 -0.15 1.2\nv 0.2 0.15 1.2\nv -0.2 0.15 1.2\n\
                       f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";

/// The mesh entry's TOML with `extra` lines; the mesh at `rocks/box.obj` next to it.
fn mesh_catalogue(dir: &Path, extra: &str) -> PathBuf {
    std::fs::create_dir_all(dir.join("rocks")).unwrap();
    std::fs::write(dir.join("rocks/box.obj"), BOX_OBJ).unwrap();
    let path = dir.join("cat.toml");
    std::fs::write(
        &path,
        format!(
            "[[pbr]]\nid = \"box\"\nname = \"Box\"\nlat = 34.28\nlon = -118.48\n\
             station = \"CI.RRS.00\"\nmesh = \"rocks/box.obj\"\nmu_s = 0.8\nmu_k = 0.6\n\
             source = \"test\"\n{extra}"
        ),
    )
    .unwrap();
    path
}

fn load_error(path: &Path) -> String {
    match Catalogue::load(path) {
        Ok(_) => panic!("{} accepted", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn mesh_entries_give_one_planar_body_per_direction_from_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    // heading 90: the mesh's north (its y axis) points east; true azimuth az is mesh az − 90.
    let path = mesh_catalogue(dir.path(), "azimuths = [0, 90, 45]\nheading_deg = 90.0\n");
    let cat = Catalogue::load(&path).unwrap();
    let pbr = &cat.pbrs()[0];
    assert_eq!(pbr.azimuth_deg(), 0.0);
    let dirs = pbr.directions().unwrap();
    assert_eq!(dirs.len(), 3);
    // True north is mesh azimuth −90 (west-east, the 0.4 m side): b = 0.2; true east is mesh
    // north (the 0.3 m side): b = 0.15. h = 0.6; ρ² from the box's inertia (B² + H²)/12.
    let expect = [(0.2, 0.4), (0.15, 0.3)];
    for (d, (b, side)) in dirs.iter().zip(expect) {
        let block = &d.nominal;
        assert!((block.plus.b_m - b).abs() < 1e-12 && (block.minus.b_m - b).abs() < 1e-12);
        let want = BlockParams::from_body(
            b,
            b,
            0.6,
            ((side * side + 1.44) / 12.0f64).sqrt(),
            0.8,
            0.6,
            None,
        )
        .unwrap();
        assert!((block.alpha_rad - want.alpha_rad).abs() < 1e-12);
        assert!((block.plus.alpha_rad - (b / 0.6f64).atan()).abs() < 1e-12);
        assert!(d.members.is_empty());
    }
    assert_eq!(pbr.nominal(), dirs[0].nominal);
    // The step form, and CSV with the text form, load the same directions.
    let steps = mesh_catalogue(dir.path(), "azimuths = { from = 0, to = 360, step = 90 }\n");
    let cat = Catalogue::load(&steps).unwrap();
    let az: Vec<f64> = cat.pbrs()[0]
        .directions()
        .unwrap()
        .iter()
        .map(|d| d.azimuth.degrees())
        .collect();
    assert_eq!(az, vec![0.0, 90.0, 180.0, 270.0]);
    let csv = dir.path().join("cat.csv");
    std::fs::write(
        &csv,
        "id,name,lat,lon,station,mesh,azimuths,mu_s,mu_k,source\n\
         box,Box,34.28,-118.48,CI.RRS.00,rocks/box.obj,0:360:90,0.8,0.6,test\n",
    )
    .unwrap();
    let from_csv = Catalogue::load(&csv).unwrap();
    assert_eq!(
        from_csv.pbrs()[0].directions().unwrap(),
        cat.pbrs()[0].directions().unwrap()
    );
}

#[test]
fn mesh_heading_and_contact_tolerance_are_sampled_like_the_other_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let path = mesh_catalogue(
        dir.path(),
        "azimuths = [0, 90]\nheading_deg = { min = -20.0, max = 20.0 }\n\
         contact_tolerance_m = { min = 0.001, max = 0.01 }\nensemble = 8\nseed = 5\n",
    );
    let pbr = Catalogue::load(&path).unwrap().pbrs()[0].clone();
    let dirs = pbr.directions().unwrap();
    assert_eq!(dirs.len(), 2);
    // Columns: heading, tolerance (mu_s, mu_k fixed): member i has heading −20 + 40·u_i0.
    let lhs = latin_hypercube_seeded(8, 2, 5);
    for (i, u) in lhs.samples().enumerate() {
        let heading = -20.0 + 40.0 * u[0];
        // North (true 0°) is mesh azimuth −heading: the ray from the box's centre along it
        // leaves its 0.4 × 0.3 base through the nearer side (a box's patch is its base
        // whatever the tolerance).
        let exit = |az_deg: f64| {
            let r = az_deg.to_radians();
            (0.2 / r.sin().abs()).min(0.15 / r.cos().abs())
        };
        let m = &dirs[0].members[i];
        assert!((m.plus.b_m - exit(-heading)).abs() < 1e-12, "member {i}");
        assert!(
            (dirs[1].members[i].plus.b_m - exit(90.0 - heading)).abs() < 1e-12,
            "member {i}"
        );
    }
    // The first direction's members are Pbr::members.
    assert_eq!(pbr.members().unwrap(), dirs[0].members);
}

#[test]
fn a_mesh_entry_without_azimuths_falls_in_every_direction_and_an_open_scan_can_be_capped() {
    let dir = tempfile::tempdir().unwrap();
    // No `azimuths`: every 15° (issue 18 §3), true azimuths from north.
    let path = mesh_catalogue(dir.path(), "");
    let pbr = Catalogue::load(&path).unwrap().pbrs()[0].clone();
    let azimuths: Vec<f64> = pbr
        .directions()
        .unwrap()
        .iter()
        .map(|d| d.azimuth.degrees())
        .collect();
    let every_15: Vec<f64> = (0..24).map(|k| 15.0 * f64::from(k)).collect();
    assert_eq!(azimuths, every_15);
    // The box without its base (a scan from above) is refused, and with cap = true it is the
    // closed box: the same bodies in every direction.
    let open_box = BOX_OBJ.replace("f 1 4 3 2\n", "");
    std::fs::write(dir.path().join("rocks/open.obj"), open_box).unwrap();
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("rocks/box.obj", "rocks/open.obj");
    std::fs::write(&path, &text).unwrap();
    assert!(
        load_error(&path).contains("not a closed"),
        "{}",
        load_error(&path)
    );
    std::fs::write(&path, format!("{text}cap = true\n")).unwrap();
    let capped = Catalogue::load(&path).unwrap().pbrs()[0].clone();
    let cap = capped.mesh().unwrap().cap.clone().expect("capped");
    assert_eq!(cap.loop_vertices, 4);
    assert_eq!(capped.directions().unwrap(), pbr.directions().unwrap());
    // cap on a planar block is refused by name.
    let planar = dir.path().join("planar.toml");
    std::fs::write(
        &planar,
        "[[pbr]]\nid = \"p\"\nname = \"P\"\nlat = 34.28\nlon = -118.48\nstation = \"CI.RRS.00\"\n\
         azimuth_deg = 0.0\nwidth_m = 0.4\nheight_m = 1.2\nmu_s = 0.8\nmu_k = 0.6\n\
         source = \"test\"\ncap = true\n",
    )
    .unwrap();
    assert!(
        load_error(&planar).contains("cap needs mesh"),
        "{}",
        load_error(&planar)
    );
}

#[test]
fn mesh_entry_problems_are_reported_by_field() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("cap = 1\n", "cap"),
        (
            "azimuths = [0]\nazimuth_deg = 10.0\n",
            "azimuth_deg cannot be combined with mesh",
        ),
        (
            "azimuths = [0]\nwidth_m = 1.0\n",
            "width_m cannot be combined with mesh",
        ),
        ("azimuths = [0, 360]\n", "given twice"),
        (
            "azimuths = { from = 0, to = 360, step = 0 }\n",
            "azimuths: azimuth step",
        ),
        ("azimuths = [0]\nup = \"w\"\n", "up: up axis"),
        (
            "azimuths = [0]\ncontact_tolerance_m = 2.0\n",
            "contact_tolerance_m = 2 must be in [0, 1] m",
        ),
        (
            "azimuths = [0]\nensemble = 3\n",
            "no parameter is uncertain",
        ),
    ];
    for (extra, expected) in cases {
        let e = load_error(&mesh_catalogue(dir.path(), extra));
        assert!(
            e.contains("pbr[0] (id \"box\")") && e.contains(expected),
            "{extra:?}: {e}"
        );
    }
    // A missing or open mesh names the file.
    let path = mesh_catalogue(dir.path(), "azimuths = [0]\n");
    std::fs::write(dir.path().join("rocks/box.obj"), "v 0 0 0\n").unwrap();
    let e = load_error(&path);
    assert!(e.contains("mesh:") && e.contains("box.obj"), "{e}");
    let planar = entry(&[("heading_deg", Some("5.0"))]);
    assert!(toml_error(&planar).contains("heading_deg needs mesh"));
    let no_azimuth = entry(&[("azimuth_deg", None)]);
    assert!(toml_error(&no_azimuth).contains("azimuth_deg is missing"));
}

#[test]
fn a_mesh_rock_may_be_integrated_in_3d_and_what_the_3d_model_cannot_take_is_refused() {
    use rockwatch_core::catalogue::RockModel;
    let dir = tempfile::tempdir().unwrap();
    // The default is the planar reduction; model = "2d" says so explicitly.
    for extra in ["", "model = \"2d\"\n"] {
        let cat = Catalogue::load(mesh_catalogue(dir.path(), extra)).unwrap();
        assert_eq!(cat.pbrs()[0].model(), RockModel::Planar);
        assert!(cat.pbrs()[0].rigid_members(1).is_none());
    }
    // model = "3d": the rigid body of the mesh, and the heading and friction of each member
    // drawn as in the planar model (same hypercube: member i has the same heading).
    let path = mesh_catalogue(
        dir.path(),
        "model = \"3d\"\nheading_deg = { min = -10, max = 10 }\nensemble = 5\n",
    );
    let cat = Catalogue::load(&path).unwrap();
    let pbr = &cat.pbrs()[0];
    assert_eq!(pbr.model(), RockModel::Rigid3d);
    let body = pbr.mesh().unwrap().body().expect("a 3-D body");
    // BOX_OBJ's centre of mass is half its height above the resting facet.
    let hull_top = body
        .vertices()
        .iter()
        .map(|v| v.z)
        .fold(f64::NEG_INFINITY, f64::max);
    assert!((hull_top - body.h_m()).abs() < 1e-12);
    let (nominal, members) = pbr.rigid_members(5).unwrap();
    assert_eq!(
        (nominal.heading_deg, nominal.mu_s, nominal.mu_k),
        (0.0, 0.8, 0.6)
    );
    assert_eq!(members.len(), 5);
    let planar = Catalogue::load(mesh_catalogue(
        dir.path(),
        "heading_deg = { min = -10, max = 10 }\nensemble = 5\nazimuths = [0]\n",
    ))
    .unwrap();
    let planar_directions = planar.pbrs()[0].directions().unwrap();
    for (i, m) in members.iter().enumerate() {
        assert!((-10.0..=10.0).contains(&m.heading_deg));
        // Planar member i of heading h has its direction 0 at mesh azimuth −h: the same draw.
        let expected = planar.pbrs()[0]
            .mesh()
            .unwrap()
            .rest()
            .direction_at(-m.heading_deg, 0.0);
        assert_eq!(
            planar_directions[0].members[i],
            expected.block(m.mu_s, m.mu_k, None).unwrap()
        );
    }
    // The engine integrates it as one 3-D rock.
    let spec = rockwatch_core::engine::PbrSpec::from_catalogue(pbr).unwrap();
    let rock = spec.rock_3d.as_ref().expect("3-D spec");
    assert_eq!((rock.nominal, rock.members.len()), (nominal, 5));
    assert!(spec.members.is_empty() && spec.more_directions.is_empty());
    // Its name and position go with it, into its alerts (issue 20 item 10).
    assert_eq!(
        spec.place,
        rockwatch_core::engine::RockPlace {
            name: pbr.name().to_string(),
            lat_deg: Some(pbr.lat_deg()),
            lon_deg: Some(pbr.lon_deg()),
        }
    );
    assert!(!spec.place.name.is_empty());
    // Refused, by field, with the reason.
    let cases = [
        (
            "model = \"4d\"\n",
            "model = \"4d\": expected \"2d\" or \"3d\"",
        ),
        (
            "model = \"3d\"\nrestitution = 0.9\n",
            "restitution is not a parameter of model = \"3d\"",
        ),
        (
            "model = \"3d\"\ncontact_tolerance_m = 0.002\n",
            "contact_tolerance_m belongs to the planar reduction",
        ),
        (
            "model = \"3d\"\nazimuths = [0, 90]\n",
            "azimuths belongs to the planar reduction",
        ),
    ];
    for (extra, expected) in cases {
        let e = load_error(&mesh_catalogue(dir.path(), extra));
        assert!(
            e.contains("pbr[0] (id \"box\")") && e.contains(expected),
            "{extra:?}: {e}"
        );
    }
    let planar = entry(&[("model", Some("\"3d\""))]);
    assert!(
        toml_error(&planar).contains("model = \"3d\" needs mesh"),
        "{}",
        toml_error(&planar)
    );
    // CSV takes the same column.
    let csv = format!(
        "id,name,lat,lon,station,mesh,model,mu_s,mu_k,source\n\
         box,Box,34.28,-118.48,CI.RRS.00,{},3d,0.8,0.6,test\n",
        dir.path().join("rocks/box.obj").display()
    );
    let from_csv = Catalogue::from_csv_str(&csv, "x.csv").unwrap();
    assert_eq!(from_csv.pbrs()[0].model(), RockModel::Rigid3d);
}

// ---------------------------------------------------------------------------------------------
// Issue 20 item 2: every problem of a file in one run; the docs and the parser agree.

/// The problems of a rejected catalogue: one line each (the one problem, or those listed under
/// the count line), and the total.
fn problems(error: &CatalogueError) -> (Vec<String>, usize) {
    match error {
        CatalogueError::Problems { shown, total, .. } => {
            (shown.iter().map(ToString::to_string).collect(), *total)
        }
        other => (vec![other.to_string()], 1),
    }
}

#[test]
fn every_problem_of_a_catalogue_is_reported_in_one_reading() {
    // Entry 0: two fields missing and a latitude out of range; entry 1 valid; entry 2: μk
    // above μs and a bad station; entry 3: entry 0's id again; entry 4: a type error.
    let text = [
        entry(&[
            ("id", Some("\"first\"")),
            ("source", None),
            ("mu_k", None),
            ("lat", Some("95")),
        ]),
        entry(&[("id", Some("\"ok\""))]),
        entry(&[
            ("id", Some("\"third\"")),
            ("mu_k", Some("0.9")),
            ("station", Some("\"ci.rrs.00\"")),
        ]),
        entry(&[("id", Some("\"first\""))]),
        entry(&[("id", Some("\"fifth\"")), ("lon", Some("\"west\""))]),
    ]
    .join("\n");
    let error = Catalogue::from_toml_str(&text, "test.toml").unwrap_err();
    let (lines, total) = problems(&error);
    let at = |n: usize, id: &str| {
        format!(
            "test.toml:{}: pbr[{n}] (id {id:?}): ",
            header_line(&text, n)
        )
    };
    let expected = [
        format!("{}missing field `mu_k`", at(0, "first")),
        format!(
            "{}missing field `source` (required: where the numbers come from, e.g. a survey, a \
             paper, or \"illustrative\" for made-up values)",
            at(0, "first")
        ),
        format!("{}lat = 95 must be in [-90, 90] degrees", at(0, "first")),
        format!("{}mu_k = 0.9 exceeds mu_s = 0.6", at(2, "third")),
        format!(
            "{}id \"first\" is already used by pbr[0] (line 1)",
            at(3, "first")
        ),
        format!(
            "{}lon: invalid type: string \"west\", expected f64",
            at(4, "fifth")
        ),
    ];
    assert_eq!(total, 7, "{error}");
    // (The station's message is the StationId parser's own; its place is checked.)
    assert!(
        lines[3].starts_with(&at(2, "third")) && lines[3].contains("station"),
        "{error}"
    );
    let without_station: Vec<&String> = lines
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != 3)
        .map(|(_, l)| l)
        .collect();
    assert_eq!(
        without_station,
        expected.iter().collect::<Vec<_>>(),
        "{error}"
    );
    let text_of_error = error.to_string();
    assert!(
        text_of_error.starts_with("test.toml: 7 problems in the catalogue:\n  test.toml:"),
        "{text_of_error}"
    );
    assert!(!text_of_error.contains("more"), "{text_of_error}");

    // CSV: a malformed row does not hide the rows after it.
    let csv = format!(
        "{CSV_HEADER}\n{CSV_ROW},extra\n{}\n{}\n",
        CSV_ROW.replace("pinnacle-2", "b").replace(",34.28,", ",,"),
        CSV_ROW
            .replace("pinnacle-2", "c")
            .replace("illustrative", "")
    );
    let error = Catalogue::from_csv_str(&csv, "test.csv").unwrap_err();
    let (lines, total) = problems(&error);
    assert_eq!(total, 3, "{error}");
    assert!(
        lines[0].starts_with("test.csv:2: invalid CSV row:"),
        "{error}"
    );
    assert_eq!(
        lines[1],
        "test.csv:3: pbr[1] (id \"b\"): lat is missing (empty cell)"
    );
    assert_eq!(
        lines[2],
        "test.csv:4: pbr[2] (id \"c\"): source must not be blank (say where the numbers come from)"
    );
}

#[test]
fn problems_beyond_the_bound_are_counted_not_listed() {
    let n = MAX_REPORTED_PROBLEMS + 10;
    let text: Vec<String> = (0..n)
        .map(|i| entry(&[("id", Some(&format!("\"r{i}\"")[..])), ("source", None)]))
        .collect();
    let error = Catalogue::from_toml_str(&text.join("\n"), "test.toml").unwrap_err();
    let (lines, total) = problems(&error);
    assert_eq!((lines.len(), total), (MAX_REPORTED_PROBLEMS, n));
    assert!(
        lines[MAX_REPORTED_PROBLEMS - 1].contains("(id \"r49\")"),
        "{error}"
    );
    let text = error.to_string();
    assert!(
        text.starts_with(&format!("test.toml: {n} problems in the catalogue:\n")),
        "{text}"
    );
    assert!(
        text.ends_with(&format!(
            "\n  … and 10 more (the first {MAX_REPORTED_PROBLEMS} are listed)"
        )),
        "{text}"
    );
    assert_eq!(text.lines().count(), 1 + MAX_REPORTED_PROBLEMS + 1);
}

/// The field table of docs/catalogue.md: (field, required, uncertain).
fn documented_fields() -> Vec<(String, String, String)> {
    let doc = std::fs::read_to_string(repo("docs/catalogue.md")).unwrap();
    doc.lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            (
                cells[1].trim_matches('`').to_owned(),
                cells[2].to_owned(),
                cells[3].to_owned(),
            )
        })
        .collect()
}

/// Issue 20 item 2: the README called `source` optional, the parser required it. The user's
/// reference, docs/catalogue.md, lists exactly the fields the TOML and CSV parsers know, each
/// required one is refused when missing and each optional one is not, and a field documented
/// as uncertain takes a range (the others refuse one by type).
#[test]
fn the_documented_fields_are_exactly_the_parsers() {
    let documented = documented_fields();
    let mut names: Vec<String> = documented.iter().map(|(f, _, _)| f.clone()).collect();
    names.sort();
    // The TOML parser's fields: serde lists them for an unknown one.
    let message = toml_error(&entry(&[("zzz", Some("1"))]));
    let known = message
        .split("expected one of ")
        .nth(1)
        .unwrap_or_else(|| panic!("{message}"));
    let mut toml_fields: Vec<String> = known
        .split(", ")
        .map(|f| f.trim_matches('`').to_owned())
        .collect();
    toml_fields.sort();
    assert_eq!(
        names, toml_fields,
        "docs/catalogue.md against the TOML parser"
    );
    // The CSV parser's columns: its header error lists them.
    let message = csv_error(&format!("{CSV_HEADER},zzz\n{CSV_ROW},1\n"));
    let known = message
        .split("(known: ")
        .nth(1)
        .unwrap_or_else(|| panic!("{message}"));
    let (scalars, uncertain) = known.split_once(", and for P in ").unwrap();
    let uncertain = uncertain.split(": ").next().unwrap();
    let mut csv_fields: Vec<String> = scalars
        .split(", ")
        .chain(uncertain.split(", "))
        .map(str::to_owned)
        .collect();
    csv_fields.sort();
    assert_eq!(
        names, csv_fields,
        "docs/catalogue.md against the CSV parser"
    );

    for (field, required, uncertain) in &documented {
        // Required: refused when missing from a valid planar entry.
        let without = Catalogue::from_toml_str(&entry(&[(field, None)]), "t.toml");
        match required.as_str() {
            "yes" => {
                let message = without.expect_err(field).to_string();
                assert!(
                    message.contains(&format!("missing field `{field}`")),
                    "{message}"
                );
            }
            "planar" => {
                let message = without.expect_err(field).to_string();
                assert!(
                    message.contains(&format!("{field} is missing")),
                    "{message}"
                );
            }
            "geometry" | "no" => {
                if BASE.iter().all(|(k, _)| k != field) {
                    // Not in the valid entry: its absence is fine.
                    assert!(without.is_ok(), "{field}: {:?}", without.err());
                }
            }
            other => panic!("{field}: unknown 'required' value {other:?}"),
        }
        // Uncertain: a range is not a type error.
        let range = Catalogue::from_toml_str(
            &entry(&[(field, Some("{ min = 0.1, max = 0.2 }"))]),
            "t.toml",
        );
        let type_error = range.as_ref().err().is_some_and(|e| {
            let m = e.to_string();
            m.contains("invalid type") || m.contains("did not match any variant")
        });
        match uncertain.as_str() {
            "yes" => assert!(!type_error, "{field}: {:?}", range.err()),
            "no" => assert!(
                type_error,
                "{field} takes a range: {:?}",
                range.map(|c| c.len())
            ),
            other => panic!("{field}: unknown 'uncertain' value {other:?}"),
        }
    }
}
