//! The standard ROS 2 messages of the 3-D view (`markers.rs`), as Rust structs for the CDR
//! wire format, in exactly the field order and types of their definitions (Kilted,
//! `visualization_msgs` 5.5.1, `geometry_msgs` 5.5.1, `tf2_msgs`; checked against an rclpy
//! and a Cyclone DDS peer by `tests/ros2_rclpy.rs`):
//! - `geometry_msgs/Point`, `Vector3`: `float64 x, y, z`; `Quaternion`: `float64 x, y, z, w`;
//!   `Pose`: `Point position`, `Quaternion orientation`; `Transform`: `Vector3 translation`,
//!   `Quaternion rotation`; `TransformStamped`: `std_msgs/Header header`,
//!   `string child_frame_id`, `Transform transform`;
//! - `std_msgs/ColorRGBA`: `float32 r, g, b, a`; `builtin_interfaces/Duration`:
//!   `int32 sec`, `uint32 nanosec`;
//! - `tf2_msgs/TFMessage`: `TransformStamped[] transforms`;
//! - `visualization_msgs/Marker` (below), `MarkerArray`: `Marker[] markers`.
//!
//! Units: m, rad (unit quaternions), REP 103.

use serde::{Deserialize, Serialize};

use super::msg::Header;

/// `geometry_msgs/Point` (m).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/Vector3` (same layout as `Point`).
pub type Vector3 = Point;

/// `geometry_msgs/Quaternion` (unit; identity x = y = z = 0, w = 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    pub const IDENTITY: Quaternion = Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}

/// `geometry_msgs/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`: `header.frame_id` the parent frame, `child_frame_id` the
/// child.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    pub transforms: Vec<TransformStamped>,
}

/// `std_msgs/ColorRGBA` (each 0..1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ColorRgba {
    pub r: f32,
    pub g: f32,
    pub b: f32,
    pub a: f32,
}

/// `builtin_interfaces/Duration` (0: forever, for a marker's lifetime).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct DurationMsg {
    pub sec: i32,
    pub nanosec: u32,
}

/// `sensor_msgs/CompressedImage` (a marker's texture; empty here).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    pub header: Header,
    pub format: String,
    pub data: Vec<u8>,
}

/// `visualization_msgs/UVCoordinate`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct UvCoordinate {
    pub u: f32,
    pub v: f32,
}

/// `visualization_msgs/MeshFile` (empty here: meshes go as triangle lists).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    pub filename: String,
    pub data: Vec<u8>,
}

/// `visualization_msgs/Marker` types and actions used.
pub const MARKER_CYLINDER: i32 = 3;
pub const MARKER_TEXT_VIEW_FACING: i32 = 9;
pub const MARKER_TRIANGLE_LIST: i32 = 11;
pub const MARKER_ADD: i32 = 0;
pub const MARKER_DELETEALL: i32 = 3;

/// `visualization_msgs/Marker`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    pub header: Header,
    pub ns: String,
    pub id: i32,
    pub r#type: i32,
    pub action: i32,
    pub pose: Pose,
    /// m (a TRIANGLE_LIST's points are scaled by it: 1).
    pub scale: Vector3,
    pub color: ColorRgba,
    pub lifetime: DurationMsg,
    pub frame_locked: bool,
    /// m, in the marker's pose.
    pub points: Vec<Point>,
    pub colors: Vec<ColorRgba>,
    pub texture_resource: String,
    pub texture: CompressedImage,
    pub uv_coordinates: Vec<UvCoordinate>,
    pub text: String,
    pub mesh_resource: String,
    pub mesh_file: MeshFile,
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// A marker of `type` with the given fields, every other field empty.
    #[must_use]
    pub fn new(
        header: Header,
        ns: &str,
        id: i32,
        r#type: i32,
        pose: Pose,
        scale: Vector3,
        color: ColorRgba,
    ) -> Marker {
        Marker {
            texture: CompressedImage {
                header: header.clone(),
                format: String::new(),
                data: Vec::new(),
            },
            header,
            ns: ns.to_string(),
            id,
            r#type,
            action: MARKER_ADD,
            pose,
            scale,
            color,
            lifetime: DurationMsg::default(),
            frame_locked: false,
            points: Vec::new(),
            colors: Vec::new(),
            texture_resource: String::new(),
            uv_coordinates: Vec::new(),
            text: String::new(),
            mesh_resource: String::new(),
            mesh_file: MeshFile {
                filename: String::new(),
                data: Vec::new(),
            },
            mesh_use_embedded_materials: false,
        }
    }
}

/// `visualization_msgs/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    pub markers: Vec<Marker>,
}

impl ros2_client::Message for TfMessage {}
impl ros2_client::Message for MarkerArray {}
