//! One source of truth for the wire format: the `.msg` files of `msg/pbr_msgs/msg/` and the `.srv`
//! files of `msg/pbr_msgs/srv/` are parsed here and the Rust structs of `rockwatch::ros2::msg` must have the same
//! fields, in the same order, with the same types (CDR is positional), and the same constants;
//! the iceoryx2 alerts carry the same level and mode codes.

use std::collections::BTreeMap;
use std::path::Path;

use rockwatch::iox::PbrAlertIox;
use rockwatch::ros2::msg;
use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{Alert, AlertLevel, SampleUnit};
use serde_reflection::{ContainerFormat, Format, Tracer, TracerConfig};

#[derive(Debug, Default)]
struct MsgFile {
    /// (type, name) in order.
    fields: Vec<(String, String)>,
    /// name → (type, value).
    constants: BTreeMap<String, (String, String)>,
}

/// A minimal parser of the ROS 2 `.msg` grammar used by pbr_msgs: `type name`,
/// `type NAME=value`, `#` comments.
fn parse_msg(name: &str) -> MsgFile {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("msg/pbr_msgs/msg")
        .join(format!("{name}.msg"));
    parse_fields(name, &std::fs::read_to_string(&path).unwrap())
}

/// A `.srv` file of `msg/pbr_msgs/srv/`: the request's fields, a line `---`, the response's.
fn parse_srv(name: &str) -> (MsgFile, MsgFile) {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
        .join("msg/pbr_msgs/srv")
        .join(format!("{name}.srv"));
    let text = std::fs::read_to_string(&path).unwrap();
    let parts: Vec<&str> = text.split("\n---\n").collect();
    assert_eq!(parts.len(), 2, "{name}.srv: one `---` line");
    (
        parse_fields(&format!("{name}_Request"), parts[0]),
        parse_fields(&format!("{name}_Response"), parts[1]),
    )
}

/// The fields and constants of one message's text.
fn parse_fields(name: &str, text: &str) -> MsgFile {
    let mut file = MsgFile::default();
    for line in text.lines() {
        let line = line.split('#').next().unwrap().trim();
        if line.is_empty() {
            continue;
        }
        let (ty, rest) = line.split_once(char::is_whitespace).unwrap();
        let rest = rest.trim();
        if let Some((cname, value)) = rest.split_once('=') {
            file.constants.insert(
                cname.trim().to_string(),
                (ty.to_string(), value.trim().to_string()),
            );
        } else {
            assert!(
                rest.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'),
                "{name}: field {rest:?}"
            );
            file.fields.push((ty.to_string(), rest.to_string()));
        }
    }
    file
}

/// The serde format a ROS 2 field type must have.
fn expected_format(ty: &str) -> Format {
    if let Some(inner) = ty.strip_suffix("[]") {
        return Format::Seq(Box::new(expected_format(inner)));
    }
    if let Some((inner, size)) = ty.strip_suffix(']').and_then(|t| t.split_once('[')) {
        return Format::TupleArray {
            content: Box::new(expected_format(inner)),
            size: size.parse().unwrap(),
        };
    }
    match ty {
        "bool" => Format::Bool,
        "uint8" => Format::U8,
        "uint32" => Format::U32,
        "uint64" => Format::U64,
        "int32" => Format::I32,
        "float32" => Format::F32,
        "float64" => Format::F64,
        "string" => Format::Str,
        "std_msgs/Header" => Format::TypeName("Header".into()),
        "builtin_interfaces/Time" => Format::TypeName("Time".into()),
        other => panic!("type {other} not covered by this test"),
    }
}

fn registry() -> serde_reflection::Registry {
    let mut tracer = Tracer::new(TracerConfig::default());
    tracer.trace_simple_type::<msg::AccelPacket>().unwrap();
    tracer.trace_simple_type::<msg::StationIntensity>().unwrap();
    tracer.trace_simple_type::<msg::PbrState>().unwrap();
    tracer.trace_simple_type::<msg::PbrAlert>().unwrap();
    tracer.trace_simple_type::<msg::IntakeReport>().unwrap();
    tracer.trace_simple_type::<msg::ResetPbrRequest>().unwrap();
    tracer.trace_simple_type::<msg::ResetPbrResponse>().unwrap();
    tracer.registry().unwrap()
}

fn assert_struct_matches(registry: &serde_reflection::Registry, name: &str, file: &MsgFile) {
    let Some(ContainerFormat::Struct(fields)) = registry.get(name) else {
        panic!(
            "{name} is not a struct in the registry: {:?}",
            registry.get(name)
        );
    };
    let rust: Vec<(String, Format)> = fields
        .iter()
        .map(|f| (f.name.clone(), f.value.clone()))
        .collect();
    let msg: Vec<(String, Format)> = file
        .fields
        .iter()
        .map(|(ty, n)| (n.clone(), expected_format(ty)))
        .collect();
    assert_eq!(rust, msg, "{name}: Rust struct vs its .msg/.srv file");
}

#[test]
fn reset_service_structs_have_the_fields_of_the_srv_file_in_order() {
    let registry = registry();
    let (request, response) = parse_srv(msg::RESET_SERVICE_TYPE);
    assert_struct_matches(&registry, "ResetPbrRequest", &request);
    assert_struct_matches(&registry, "ResetPbrResponse", &response);
    // The fields the node and `rockwatch reset --node` rely on, independently of the file.
    let field = |ty: &str, name: &str| (ty.to_string(), name.to_string());
    assert_eq!(request.fields, [field("string", "pbr_id")]);
    assert_eq!(
        response.fields,
        [field("bool", "success"), field("string", "message")]
    );
    assert!(request.constants.is_empty() && response.constants.is_empty());
}

#[test]
fn rust_structs_have_the_fields_of_the_msg_files_in_order() {
    let registry = registry();
    for name in [
        "AccelPacket",
        "StationIntensity",
        "PbrState",
        "PbrAlert",
        "IntakeReport",
    ] {
        assert_struct_matches(&registry, name, &parse_msg(name));
    }
    // std_msgs/Header and builtin_interfaces/Time as defined by ROS 2.
    let header = MsgFile {
        fields: vec![
            ("builtin_interfaces/Time".into(), "stamp".into()),
            ("string".into(), "frame_id".into()),
        ],
        ..MsgFile::default()
    };
    assert_struct_matches(&registry, "Header", &header);
    let time = MsgFile {
        fields: vec![
            ("int32".into(), "sec".into()),
            ("uint32".into(), "nanosec".into()),
        ],
        ..MsgFile::default()
    };
    assert_struct_matches(&registry, "Time", &time);
}

#[test]
fn the_issue_s_required_fields_are_present() {
    // The issue's list, independently of the files (a field must not be dropped from both).
    let required: [(&str, &[&str]); 4] = [
        (
            "AccelPacket",
            &["header", "sample_rate", "sequence", "east", "north", "up"],
        ),
        (
            "StationIntensity",
            &[
                "header",
                "pga",
                "pgv",
                "pgd",
                "cav",
                "arias",
                "asi",
                "d5_95",
                "sa_periods",
                "sa",
            ],
        ),
        (
            "PbrState",
            &[
                "header",
                "pbr_id",
                "station",
                "mode",
                "theta",
                "theta_over_alpha",
                "slide",
                "data_gap",
                "overturn_probability",
            ],
        ),
        (
            "PbrAlert",
            &[
                "header",
                "pbr_id",
                "station",
                "level",
                "mode",
                "theta_over_alpha",
                "slide",
                "overturn_probability",
                "pga",
                "pgv",
                "message",
                "episode",
            ],
        ),
    ];
    for (name, fields) in required {
        let file = parse_msg(name);
        let names: Vec<&str> = file.fields.iter().map(|(_, n)| n.as_str()).collect();
        let positions: Vec<usize> = fields
            .iter()
            .map(|f| {
                names
                    .iter()
                    .position(|n| n == f)
                    .unwrap_or_else(|| panic!("{name}.{f}"))
            })
            .collect();
        assert!(
            positions.windows(2).all(|w| w[0] < w[1]),
            "{name}: order {positions:?}"
        );
    }
}

#[test]
fn mode_and_level_constants_match_the_msg_files() {
    let state = parse_msg("PbrState");
    let expected_modes = [
        ("REST", 0, Mode::Rest),
        ("SLIDE", 1, Mode::Slide),
        ("ROCK", 2, Mode::Rock),
        ("SLIDE_ROCK", 3, Mode::SlideRock),
        ("OVERTURNED", 4, Mode::Overturned),
        ("FLIGHT", 5, Mode::Flight),
    ];
    assert_eq!(state.constants.len(), expected_modes.len());
    for (name, value, mode) in expected_modes {
        assert_eq!(
            state.constants[name],
            ("uint8".to_string(), value.to_string()),
            "PbrState.{name}"
        );
        assert_eq!(msg::mode_code(mode), value, "{mode:?}");
    }
    let alert = parse_msg("PbrAlert");
    let expected_levels = [
        ("MOTION_ONSET", 1, AlertLevel::MotionOnset),
        ("OVERTURN_IMMINENT", 2, AlertLevel::OverturnImminent),
        ("OVERTURNED", 3, AlertLevel::Overturned),
    ];
    assert_eq!(alert.constants.len(), expected_levels.len() + 1);
    // RESET: an operator reset published with the alerts, not an engine level.
    assert_eq!(
        alert.constants["RESET"],
        ("uint8".to_string(), "4".to_string())
    );
    assert_eq!(rockwatch::wire_codes::LEVEL_RESET, 4);
    for (name, value, level) in expected_levels {
        assert_eq!(
            alert.constants[name],
            ("uint8".to_string(), value.to_string()),
            "PbrAlert.{name}"
        );
        assert_eq!(msg::level_code(level), value);
        assert_eq!(msg::level_of_code(value), Some(level));
        // The engine's own numbering agrees (AlertLevel's discriminants).
        assert_eq!(level as u8, value);
    }
    assert_eq!(msg::level_of_code(0), None);
    assert_eq!(msg::level_of_code(4), None);
    // AccelPacket.unit (issue 20 item 15).
    let accel = parse_msg("AccelPacket");
    assert_eq!(accel.constants.len(), 2);
    for (name, value, unit) in [
        ("UNIT_MPS2", 0, SampleUnit::MetresPerSecondSquared),
        ("UNIT_COUNTS", 1, SampleUnit::Counts),
    ] {
        assert_eq!(
            accel.constants[name],
            ("uint8".to_string(), value.to_string()),
            "AccelPacket.{name}"
        );
        assert_eq!(rockwatch::wire_codes::unit_code(unit), value);
        assert_eq!(rockwatch::wire_codes::unit_of_code(value), unit);
    }
    assert_eq!(
        rockwatch::wire_codes::unit_of_code(9),
        SampleUnit::Unknown(9)
    );
}

#[test]
fn iceoryx2_alerts_carry_the_ros2_level_and_mode_codes() {
    let modes = [
        Mode::Rest,
        Mode::Slide,
        Mode::Rock,
        Mode::SlideRock,
        Mode::Overturned,
        Mode::Flight,
    ];
    for level in AlertLevel::ALL {
        for mode in modes {
            let alert = Alert {
                pbr_id: rockwatch_core::engine::PbrId::parse("slender-pillar").unwrap(),
                station: rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap(),
                level,
                episode: 1,
                mode,
                theta_over_alpha: 0.5,
                slide_m: 0.0,
                overturn_probability: 0.0,
                pga_mps2: 1.0,
                pgv_mps: 0.1,
                data_time_ns: 0,
                arrival_ns: 0,
                direction_deg: 0.0,
                lat_deg: Default::default(),
                lon_deg: Default::default(),
                pbr_name: Default::default(),
            };
            let ros = msg::PbrAlert::from(&alert);
            let iox = PbrAlertIox::from_alert(&alert, 0, 0);
            assert_eq!(
                (iox.level, iox.mode),
                (ros.level, ros.mode),
                "{level:?} {mode:?}"
            );
            assert_eq!(iox.alert_level(), msg::level_of_code(ros.level));
            assert_eq!(iox.alert_level(), Some(level));
        }
    }
}
