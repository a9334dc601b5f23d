//! The node's 3-D view for RViz and Foxglove: `visualization_msgs/MarkerArray` on
//! `pbr/markers` and the rocks' frames on `/tf_static` (docs/ros2.md, "3-D view").
//!
//! - **Frames.** `map`: a local ENU frame (x east, y north, z up, m; REP 103) whose origin is
//!   `[ros2] map_origin = [lat, lon, alt]` (WGS84 degrees and ellipsoidal height in m;
//!   default: the mean position of the node's rocks at altitude 0 — of the whole catalogue's
//!   when the node has a partition), positions projected by
//!   the local tangent plane of `rockwatch_core::geodesy` (WGS84 → ECEF → ENU, exact). Each
//!   rock with a position has the static frame `pbr/<id>` ([`rock_frame`]): its resting base
//!   point (the ground below its centre of mass; the catalogue has no altitude: the origin's
//!   is taken), axes parallel to `map`'s. It is `PbrState.header.frame_id`.
//! - **Markers** (frame `map`; one array is the whole picture: it starts with a DELETEALL —
//!   for a node with a partition, in namespaces suffixed `/p<i>of<N>` and without it):
//!   per rock a TRIANGLE_LIST (ns `pbr`) — its mesh (heading applied; over
//!   [`MAX_DISPLAY_TRIANGLES`] triangles, its bounding box) or, for a planar block, its box
//!   (b₋ + b₊ along its direction, as deep as wide, twice its centre-of-mass height) —
//!   posed by its current state: tilted by θ about its pivot and slid along its direction
//!   (`rockwatch_core::geodesy::RockingPose`: θ > 0 tips it towards the direction's azimuth),
//!   coloured by state ([`RockLook`]); a TEXT_VIEW_FACING label with its id (ns `pbr_label`);
//!   per station with coordinates (`[[station]] lat`, `lon`) a cylinder (ns `station`)
//!   coloured by its health as the dashboard colours it ([`station_color`]: OK blue, WARN
//!   yellow, ERROR red, STALE and NO DATA YET grey) and its id (ns `station_label`). Marker
//!   ids are the rocks' (stations') index in id order.
//! - **When.** Both at start, transient local (a late RViz gets them); the markers again when
//!   a rock's state changes (a state or alert that changes its colour, θ or slide), at most
//!   once per [`MARKER_PERIOD`] (wall clock): the latest state then, never one array per
//!   sample; and when a station's health changes (judged once per status period,
//!   [`Scene::observe_station_health`]). Stamps: the markers carry the data time of the latest state taken in (0 before
//!   any), the transforms the wall-clock time of their publication.
//!
//! Limits: the scene is built at start; a reload (SIGHUP) that adds, moves or removes rocks
//! shows in the view after a restart (the states of kept rocks keep updating it).

use std::time::{Duration, Instant};

use rockwatch_core::catalogue::{Geometry, Pbr};
use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{AlertLevel, StationConfig};
use rockwatch_core::geodesy::{Geodetic, LocalEnu, RockingPose};
use rockwatch_core::partition::Partition;

use super::msg::Header;
pub use super::names::{rock_frame, MAP_FRAME};
use super::viz_msg::{
    ColorRgba, Marker, MarkerArray, Point, Pose, Quaternion, TfMessage, Transform,
    TransformStamped, Vector3, MARKER_CYLINDER, MARKER_DELETEALL, MARKER_TEXT_VIEW_FACING,
    MARKER_TRIANGLE_LIST,
};
use crate::ports::Publication;
use crate::status::{Level, StationStatus};

/// Shortest time between two marker arrays (wall clock): at most 5 per second.
pub const MARKER_PERIOD: Duration = Duration::from_millis(200);

/// Most triangles of a rock's mesh drawn; a larger mesh is drawn as its bounding box.
pub const MAX_DISPLAY_TRIANGLES: usize = 20_000;

/// Most triangles of the whole view (one array: 72 B a triangle, ≈ 7 MB): beyond it the
/// largest meshes are drawn as their bounding boxes (12 triangles) until the view fits.
pub const MAX_SCENE_TRIANGLES: usize = 100_000;

/// A `[ros2] map_origin` or rock position the view refuses.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("[ros2] map_origin = {given:?}: {error}")]
    Origin {
        given: [f64; 3],
        error: rockwatch_core::geodesy::GeodesyError,
    },
}

/// How a rock is drawn: its state as a colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RockLook {
    /// At rest: green.
    Standing,
    /// Moving (rocking, sliding): orange.
    Rocking,
    /// Its station is stale: grey.
    NotMonitored,
    /// Overturned (a state or alert said so; until an operator reset): red.
    Fallen,
}

impl RockLook {
    /// The marker colour (opaque).
    #[must_use]
    pub fn color(self) -> ColorRgba {
        let (r, g, b) = match self {
            RockLook::Standing => (0.20, 0.75, 0.25),
            RockLook::Rocking => (1.00, 0.60, 0.00),
            RockLook::NotMonitored => (0.55, 0.55, 0.55),
            RockLook::Fallen => (0.90, 0.10, 0.10),
        };
        ColorRgba { r, g, b, a: 1.0 }
    }
}

/// One rock of the view.
#[derive(Debug, Clone, PartialEq)]
struct SceneRock {
    id: String,
    /// Resting base point in `map` (m); None without a catalogue position.
    enu: Option<[f64; 3]>,
    /// Triangles at rest (3 points each; m, ENU axes, from the base point).
    points: Vec<Point>,
    /// Height of the drawing (m), for the label.
    height_m: f64,
    /// Per direction: azimuth (degrees), b₊, b₋ (m).
    pivots: Vec<(f64, f64, f64)>,
    look: RockLook,
    theta_rad: f64,
    slide_m: f64,
    direction_deg: f64,
}

/// One station with coordinates.
#[derive(Debug, Clone, PartialEq)]
struct SceneStation {
    id: String,
    enu: [f64; 3],
    /// Its health at the last status ([`Level::NoDataYet`] before the first).
    health: Level,
}

/// A station marker's colour by health: the dashboard's (`web/page.html`, `#map polygon`):
/// OK #3070d0 blue, WARN #e0b000 yellow, ERROR #d02020 red, STALE and NO DATA YET #999 grey.
#[must_use]
pub fn station_color(health: Level) -> ColorRgba {
    let rgb = |hex: u32| ColorRgba {
        r: ((hex >> 16) & 0xff) as f32 / 255.0,
        g: ((hex >> 8) & 0xff) as f32 / 255.0,
        b: (hex & 0xff) as f32 / 255.0,
        a: 1.0,
    };
    match health {
        Level::Ok => rgb(0x3070d0),
        Level::Warn => rgb(0xe0b000),
        Level::Error => rgb(0xd02020),
        Level::Stale | Level::NoDataYet => rgb(0x999999),
    }
}

/// The rocks and stations of the view, their current looks, and whether the markers changed
/// since they were last taken ([`Scene::take_markers`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    frame: LocalEnu,
    rocks: Vec<SceneRock>,
    stations: Vec<SceneStation>,
    /// Data time of the latest state taken in (ns; 0 before any).
    stamp_ns: i64,
    dirty: bool,
    /// The node's partition of a scaled-out service, if any: its markers go in namespaces of
    /// their own (`pbr/p<i>of<N>`…) and no DELETEALL clears the other nodes' markers.
    partition: Option<Partition>,
}

impl Scene {
    /// The view of `pbrs` (the node's own rocks) and `stations` around `origin`
    /// (`[ros2] map_origin`, checked; None: the rocks' mean position at altitude 0). Rocks
    /// and stations without coordinates are left out of the view (the rocks keep their frame
    /// name), said in one log line.
    pub fn new(
        pbrs: &[&Pbr],
        stations: &[StationConfig],
        origin: Option<[f64; 3]>,
    ) -> Result<Scene, SceneError> {
        let origin = match origin {
            Some(given) => Geodetic::new(given[0], given[1], given[2])
                .map_err(|error| SceneError::Origin { given, error })?,
            None => {
                let [lat, lon, _] = Self::mean_origin(pbrs).unwrap_or([0.0; 3]);
                let origin = Geodetic::new(lat, lon, 0.0).unwrap_or(Geodetic {
                    lat_deg: 0.0,
                    lon_deg: 0.0,
                    alt_m: 0.0,
                });
                tracing::info!(
                    "3-D view: map origin {:.6}°, {:.6}°, 0 m, the mean position of the node's \
                     rocks ([ros2] map_origin = [lat, lon, alt] sets it)",
                    origin.lat_deg,
                    origin.lon_deg
                );
                origin
            }
        };
        let frame = LocalEnu::new(origin);
        let mut rocks: Vec<SceneRock> = pbrs.iter().map(|p| scene_rock(p, &frame)).collect();
        rocks.sort_by(|a, b| a.id.cmp(&b.id));
        fit_budget(&mut rocks, MAX_SCENE_TRIANGLES);
        let unplaced: Vec<&str> = rocks
            .iter()
            .filter(|r| r.enu.is_none())
            .map(|r| r.id.as_str())
            .collect();
        if !unplaced.is_empty() {
            tracing::warn!(
                "3-D view: {} rocks without a position are not drawn and have no frame on \
                 /tf_static: {}",
                unplaced.len(),
                unplaced.join(", ")
            );
        }
        let mut stations: Vec<SceneStation> = stations
            .iter()
            .filter_map(|s| {
                let p = Geodetic::new(s.lat?, s.lon?, origin.alt_m).ok()?;
                Some(SceneStation {
                    id: s.id.to_string(),
                    enu: frame.enu(&p),
                    health: Level::NoDataYet,
                })
            })
            .collect();
        stations.sort_by(|a, b| a.id.cmp(&b.id));
        Ok(Scene {
            frame,
            rocks,
            stations,
            stamp_ns: 0,
            dirty: true,
            partition: None,
        })
    }

    /// The mean position of those of `pbrs` that have one, at altitude 0 (`[lat, lon, 0]`,
    /// degrees and m): latitudes averaged, longitudes averaged on the circle (rocks either
    /// side of ±180° average near it, not near 0°). None when none has a position.
    #[must_use]
    pub fn mean_origin(pbrs: &[&Pbr]) -> Option<[f64; 3]> {
        let placed: Vec<(f64, f64)> = pbrs
            .iter()
            .map(|p| (p.lat_deg(), p.lon_deg()))
            .filter(|(lat, lon)| Geodetic::new(*lat, *lon, 0.0).is_ok())
            .collect();
        if placed.is_empty() {
            return None;
        }
        let lat = placed.iter().map(|p| p.0).sum::<f64>() / placed.len() as f64;
        let (sin, cos) = placed.iter().fold((0.0, 0.0), |(s, c), p| {
            let (ps, pc) = p.1.to_radians().sin_cos();
            (s + ps, c + pc)
        });
        Some([lat, sin.atan2(cos).to_degrees(), 0.0])
    }

    /// The view of one node of a scaled-out service (`partition = "i/N"`): the other nodes
    /// publish the same topics, so its markers get namespaces of their own and the arrays no
    /// DELETEALL (which would clear the other nodes' markers in RViz).
    #[must_use]
    pub fn in_partition(mut self, partition: Partition) -> Scene {
        self.partition = Some(partition);
        self
    }

    /// Marker namespace `base`, with the partition's suffix (`pbr/p0of3`) when partitioned.
    fn namespace(&self, base: &str) -> String {
        match self.partition {
            Some(p) => format!("{base}/p{}of{}", p.index(), p.count()),
            None => base.to_string(),
        }
    }

    /// The markers must be sent again (the last array could not be published).
    pub fn mark_dirty(&mut self) {
        self.dirty = true;
    }

    /// The map origin.
    #[must_use]
    pub fn origin(&self) -> Geodetic {
        self.frame.origin()
    }

    /// Marks the rocks in `fallen` (from the journal) fallen, lying in their first direction.
    pub fn set_fallen(&mut self, fallen: &dyn Fn(&str) -> bool) {
        for rock in self.rocks.iter_mut().filter(|r| fallen(&r.id)) {
            rock.look = RockLook::Fallen;
            rock.theta_rad = std::f64::consts::FRAC_PI_2;
            rock.direction_deg = rock.pivots.first().map_or(0.0, |p| p.0);
            self.dirty = true;
        }
    }

    /// Takes in a publication of the node: a state (look, θ, slide, direction), an
    /// overturned alert (fallen; lying along the alert's direction if no state tilted it), a
    /// reset (standing again). Returns whether the view changed.
    pub fn observe(&mut self, publication: &Publication) -> bool {
        let changed = match publication {
            Publication::State(s) => {
                self.stamp_ns = self.stamp_ns.max(s.data_time_ns);
                let look = if s.overturned || s.mode == Mode::Overturned {
                    RockLook::Fallen
                } else if s.not_monitored {
                    RockLook::NotMonitored
                } else if s.mode == Mode::Rest {
                    RockLook::Standing
                } else {
                    RockLook::Rocking
                };
                self.update(s.pbr_id.as_str(), |r| {
                    // A fallen rock stays fallen (and lying) until a reset.
                    if r.look == RockLook::Fallen && look != RockLook::Fallen {
                        return;
                    }
                    r.look = look;
                    if s.theta_rad.is_finite() && s.direction_deg.is_finite() {
                        r.theta_rad = s.theta_rad;
                        r.direction_deg = s.direction_deg;
                    }
                    if s.slide_m.is_finite() {
                        r.slide_m = s.slide_m;
                    }
                })
            }
            Publication::Alert { alert, .. } if alert.level == AlertLevel::Overturned => self
                .update(alert.pbr_id.as_str(), |r| {
                    if r.look != RockLook::Fallen
                        && r.theta_rad.abs() < 1e-9
                        && alert.direction_deg.is_finite()
                    {
                        r.theta_rad = std::f64::consts::FRAC_PI_2.copysign(alert.theta_over_alpha);
                        r.direction_deg = alert.direction_deg;
                    }
                    r.look = RockLook::Fallen;
                }),
            Publication::Reset(reset) => self.update(reset.pbr_id.as_str(), |r| {
                r.look = RockLook::Standing;
                r.theta_rad = 0.0;
                r.slide_m = 0.0;
            }),
            _ => false,
        };
        self.dirty |= changed;
        changed
    }

    /// Takes in the stations' health of a status (id, level; one per status period): a station whose
    /// level changed is drawn in its new colour ([`station_color`]). Returns whether the view
    /// changed. No allocation (the view's stations are sorted by id).
    pub fn observe_station_health<'a>(
        &mut self,
        stations: impl IntoIterator<Item = (&'a str, Level)>,
    ) -> bool {
        let mut changed = false;
        for (id, level) in stations {
            if let Ok(i) = self.stations.binary_search_by(|s| s.id.as_str().cmp(id)) {
                let station = &mut self.stations[i];
                changed |= station.health != level;
                station.health = level;
            }
        }
        self.dirty |= changed;
        changed
    }

    /// Applies `f` to rock `id`; whether its drawing changed.
    fn update(&mut self, id: &str, f: impl FnOnce(&mut SceneRock)) -> bool {
        let Ok(i) = self.rocks.binary_search_by(|r| r.id.as_str().cmp(id)) else {
            return false;
        };
        let rock = &mut self.rocks[i];
        let before = (rock.look, rock.theta_rad, rock.slide_m, rock.direction_deg);
        f(rock);
        before != (rock.look, rock.theta_rad, rock.slide_m, rock.direction_deg)
    }

    /// Whether the markers changed since they were last taken.
    #[must_use]
    pub fn dirty(&self) -> bool {
        self.dirty
    }

    /// The whole marker array now (module doc); the view is clean afterwards.
    pub fn take_markers(&mut self) -> MarkerArray {
        self.dirty = false;
        let header = Header::new(self.stamp_ns, MAP_FRAME);
        let mut clear = Marker::new(
            header.clone(),
            "",
            0,
            0,
            pose([0.0; 3], Quaternion::IDENTITY),
            Vector3::default(),
            RockLook::Standing.color(),
        );
        clear.action = MARKER_DELETEALL;
        let mut markers = match self.partition {
            None => vec![clear],
            // The other nodes' markers stay: this node's replace its own (same ns and id).
            Some(_) => Vec::new(),
        };
        let white = ColorRgba {
            r: 1.0,
            g: 1.0,
            b: 1.0,
            a: 1.0,
        };
        for (i, rock) in self.rocks.iter().enumerate() {
            let Some(enu) = rock.enu else { continue };
            let id = i32::try_from(i).unwrap_or(i32::MAX);
            let (_, b_plus, b_minus) = rock.pivot(rock.direction_deg);
            let p = RockingPose::new(
                rock.direction_deg,
                rock.theta_rad,
                b_plus,
                b_minus,
                rock.slide_m,
            );
            let [x, y, z, w] = p.rotation_xyzw;
            let position = [
                enu[0] + p.translation[0],
                enu[1] + p.translation[1],
                enu[2] + p.translation[2],
            ];
            let mut body = Marker::new(
                header.clone(),
                &self.namespace("pbr"),
                id,
                MARKER_TRIANGLE_LIST,
                pose(position, Quaternion { x, y, z, w }),
                Point {
                    x: 1.0,
                    y: 1.0,
                    z: 1.0,
                },
                rock.look.color(),
            );
            body.points.clone_from(&rock.points);
            markers.push(body);
            let mut label = Marker::new(
                header.clone(),
                &self.namespace("pbr_label"),
                id,
                MARKER_TEXT_VIEW_FACING,
                pose(
                    [enu[0], enu[1], enu[2] + rock.height_m + 0.5],
                    Quaternion::IDENTITY,
                ),
                Point {
                    x: 0.0,
                    y: 0.0,
                    z: 0.4,
                },
                white,
            );
            label.text.clone_from(&rock.id);
            markers.push(label);
        }
        for (i, station) in self.stations.iter().enumerate() {
            let id = i32::try_from(i).unwrap_or(i32::MAX);
            let [e, n, u] = station.enu;
            markers.push(Marker::new(
                header.clone(),
                &self.namespace("station"),
                id,
                MARKER_CYLINDER,
                pose([e, n, u + 0.5], Quaternion::IDENTITY),
                Point {
                    x: 0.6,
                    y: 0.6,
                    z: 1.0,
                },
                station_color(station.health),
            ));
            let mut label = Marker::new(
                header.clone(),
                &self.namespace("station_label"),
                id,
                MARKER_TEXT_VIEW_FACING,
                pose([e, n, u + 1.5], Quaternion::IDENTITY),
                Point {
                    x: 0.0,
                    y: 0.0,
                    z: 0.4,
                },
                white,
            );
            label.text.clone_from(&station.id);
            markers.push(label);
        }
        MarkerArray { markers }
    }

    /// `map` → `pbr/<id>` of every rock with a position, stamped `stamp_ns` (UTC ns).
    #[must_use]
    pub fn transforms(&self, stamp_ns: i64) -> TfMessage {
        TfMessage {
            transforms: self
                .rocks
                .iter()
                .filter_map(|r| {
                    let [x, y, z] = r.enu?;
                    Some(TransformStamped {
                        header: Header::new(stamp_ns, MAP_FRAME),
                        child_frame_id: rock_frame(&r.id),
                        transform: Transform {
                            translation: Point { x, y, z },
                            rotation: Quaternion::IDENTITY,
                        },
                    })
                })
                .collect(),
        }
    }
}

impl SceneRock {
    /// The direction nearest `azimuth_deg` with its pivots (azimuth, b₊, b₋).
    fn pivot(&self, azimuth_deg: f64) -> (f64, f64, f64) {
        let gap = |a: f64| {
            let d = (a - azimuth_deg).rem_euclid(360.0);
            d.min(360.0 - d)
        };
        self.pivots
            .iter()
            .copied()
            .min_by(|a, b| gap(a.0).total_cmp(&gap(b.0)))
            .unwrap_or((azimuth_deg, 0.0, 0.0))
    }
}

fn pose(p: [f64; 3], orientation: Quaternion) -> Pose {
    Pose {
        position: Point {
            x: p[0],
            y: p[1],
            z: p[2],
        },
        orientation,
    }
}

/// The rock's drawing and pivots (module doc).
fn scene_rock(pbr: &Pbr, frame: &LocalEnu) -> SceneRock {
    let origin_alt = frame.origin().alt_m;
    let enu = Geodetic::new(pbr.lat_deg(), pbr.lon_deg(), origin_alt)
        .ok()
        .map(|p| frame.enu(&p));
    let nominal = pbr.nominal();
    let mut pivots = vec![(pbr.azimuth_deg(), nominal.b_plus_m, nominal.b_minus_m)];
    let triangles: Vec<[[f64; 3]; 3]> = match (pbr.mesh(), pbr.geometry()) {
        (Some(mesh), Geometry::Mesh { heading_deg, .. }) => {
            let heading = heading_deg.nominal();
            let rest = mesh.rest();
            pivots = mesh
                .azimuths
                .iter()
                .map(|az| {
                    let body = rest.direction_at(az.degrees() - heading, rest.tolerance_m);
                    (az.degrees(), body.b_plus_m, body.b_minus_m)
                })
                .collect();
            let triangles = mesh.rock().triangles_at_rest(rest, heading);
            if triangles.len() > MAX_DISPLAY_TRIANGLES {
                bounding_box(triangles.iter().flatten().copied())
            } else {
                triangles
            }
        }
        _ => planar_box(
            pbr.azimuth_deg(),
            nominal.b_plus_m,
            nominal.b_minus_m,
            2.0 * nominal.com_height_m,
        ),
    };
    let height_m = triangles
        .iter()
        .flatten()
        .map(|p| p[2])
        .fold(0.0_f64, f64::max);
    SceneRock {
        id: pbr.id().to_string(),
        enu,
        points: triangles
            .iter()
            .flatten()
            .map(|p| Point {
                x: p[0],
                y: p[1],
                z: p[2],
            })
            .collect(),
        height_m,
        pivots,
        look: RockLook::Standing,
        theta_rad: 0.0,
        slide_m: 0.0,
        direction_deg: pbr.azimuth_deg(),
    }
}

/// The 12 outward triangles of a box given by its corners (c[i] for bits i = (x, y, z) of the
/// low (0) or high (1) side of each of three axes, right-handed).
fn box_triangles(c: &[[f64; 3]; 8]) -> Vec<[[f64; 3]; 3]> {
    // Faces as corner indices, counter-clockwise seen from outside.
    const QUADS: [[usize; 4]; 6] = [
        [0, 2, 3, 1], // z low (bottom)
        [4, 5, 7, 6], // z high (top)
        [0, 1, 5, 4], // y low
        [2, 6, 7, 3], // y high
        [0, 4, 6, 2], // x low
        [1, 3, 7, 5], // x high
    ];
    QUADS
        .iter()
        .flat_map(|q| [[c[q[0]], c[q[1]], c[q[2]]], [c[q[0]], c[q[2]], c[q[3]]]])
        .collect()
}

/// A planar block's box: `−b_minus_m..b_plus_m` along the direction `azimuth_deg`, as deep
/// across it as it is wide, `0..height_m` up.
fn planar_box(
    azimuth_deg: f64,
    b_plus_m: f64,
    b_minus_m: f64,
    height_m: f64,
) -> Vec<[[f64; 3]; 3]> {
    let (s, c) = azimuth_deg.to_radians().sin_cos();
    let (along, across) = ([s, c], [c, -s]); // across = along turned 90° clockwise
    let half_depth = 0.5 * (b_plus_m + b_minus_m);
    let corner = |i: usize| {
        let x = if i & 1 == 0 { -b_minus_m } else { b_plus_m };
        let y = if i & 2 == 0 { -half_depth } else { half_depth };
        let z = if i & 4 == 0 { 0.0 } else { height_m };
        // (along, left, up) is right-handed: along × left = up.
        let left = [-across[0], -across[1]];
        [x * along[0] + y * left[0], x * along[1] + y * left[1], z]
    };
    box_triangles(&std::array::from_fn(corner))
}

/// Draws the largest meshes of `rocks` as their bounding boxes until the view has at most
/// `budget` triangles (or every rock is a box); says how many, if any.
fn fit_budget(rocks: &mut [SceneRock], budget: usize) {
    let triangles = |r: &SceneRock| r.points.len() / 3;
    let mut total: usize = rocks.iter().map(triangles).sum();
    if total <= budget {
        return;
    }
    let mut largest: Vec<usize> = (0..rocks.len()).collect();
    largest.sort_by_key(|&i| std::cmp::Reverse(triangles(&rocks[i])));
    let mut boxed = 0;
    for i in largest {
        let n = triangles(&rocks[i]);
        if total <= budget || n <= 12 {
            break;
        }
        let corners = bounding_box(rocks[i].points.iter().map(|p| [p.x, p.y, p.z]));
        rocks[i].points = corners
            .iter()
            .flatten()
            .map(|p| Point {
                x: p[0],
                y: p[1],
                z: p[2],
            })
            .collect();
        total -= n - 12;
        boxed += 1;
    }
    tracing::info!(
        "3-D view: {boxed} meshes drawn as their bounding boxes, to keep the view within \
         {budget} triangles ({total} now)"
    );
}

/// The axis-aligned bounding box of `points`.
fn bounding_box(points: impl Iterator<Item = [f64; 3]>) -> Vec<[[f64; 3]; 3]> {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    box_triangles(&std::array::from_fn(|i| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    }))
}

/// The view's two publishers and its rate limit.
pub(super) struct MarkerPublisher {
    markers: ros2_client::Publisher<MarkerArray>,
    tf_static: ros2_client::Publisher<TfMessage>,
    scene: Option<Scene>,
    last: Option<Instant>,
    errors: u64,
}

impl MarkerPublisher {
    pub(super) fn new(
        markers: ros2_client::Publisher<MarkerArray>,
        tf_static: ros2_client::Publisher<TfMessage>,
    ) -> MarkerPublisher {
        MarkerPublisher {
            markers,
            tf_static,
            scene: None,
            last: None,
            errors: 0,
        }
    }

    /// Starts showing `scene`: its frames on `/tf_static` and its markers, now.
    pub(super) fn show(&mut self, scene: Scene) {
        let transforms = scene.transforms(crate::journal::utc_now_ns());
        if let Err(e) = self.tf_static.publish(transforms) {
            self.failed("/tf_static", &format!("{e:?}"));
        }
        self.scene = Some(scene);
        self.last = None;
        self.tick();
    }

    /// The scene shown, handed over (to a rebuilt participant's publisher).
    pub(super) fn take_scene(&mut self) -> Option<Scene> {
        self.scene.take()
    }

    /// Takes in a publication (see [`Scene::observe`]); the markers go out on the next
    /// [`MarkerPublisher::tick`] that is due.
    pub(super) fn observe(&mut self, publication: &Publication) {
        if let Some(scene) = &mut self.scene {
            scene.observe(publication);
        }
    }

    /// Takes in the stations' health of a status (see [`Scene::observe_station_health`]).
    pub(super) fn observe_station_health(&mut self, stations: &[StationStatus]) {
        if let Some(scene) = &mut self.scene {
            scene.observe_station_health(
                stations
                    .iter()
                    .map(|s| (s.health.station.as_str(), s.level)),
            );
        }
    }

    /// Publishes the markers if they changed and [`MARKER_PERIOD`] has passed since the last
    /// array. Cheap otherwise: call it on every turn of the event loop.
    pub(super) fn tick(&mut self) {
        let Some(scene) = &mut self.scene else { return };
        if !scene.dirty() || self.last.is_some_and(|t| t.elapsed() < MARKER_PERIOD) {
            return;
        }
        self.last = Some(Instant::now());
        let array = scene.take_markers();
        if let Err(e) = self.markers.publish(array) {
            // Sent again at the next tick: the last change (often "fallen") is not lost.
            scene.mark_dirty();
            self.failed("pbr/markers", &format!("{e:?}"));
        }
    }

    fn failed(&mut self, topic: &str, e: &str) {
        self.errors += 1;
        if self.errors.is_power_of_two() {
            tracing::warn!(
                "ROS 2 {topic}: cannot publish ({e}; {} in all)",
                self.errors
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rockwatch_core::catalogue::Catalogue;
    use rockwatch_core::engine::PbrState;

    fn catalogue() -> Catalogue {
        let text = "[[pbr]]\nid = \"b\"\nname = \"b\"\nlat = 34.28\nlon = -118.48\n\
                    station = \"CI.RRS.00\"\nazimuth_deg = 90.0\nwidth_m = 0.30\nheight_m = 1.50\n\
                    mu_s = 0.70\nmu_k = 0.55\nsource = \"test\"\n\n\
                    [[pbr]]\nid = \"a\"\nname = \"a\"\nlat = 34.281\nlon = -118.48\n\
                    station = \"CI.RRS.00\"\nazimuth_deg = 0.0\nwidth_m = 1.0\nheight_m = 1.0\n\
                    mu_s = 0.90\nmu_k = 0.70\nsource = \"test\"\n";
        load(text)
    }

    /// The catalogue `text` (TOML).
    fn load(text: &str) -> Catalogue {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.toml");
        std::fs::write(&path, text).unwrap();
        Catalogue::load(&path).unwrap()
    }

    fn state(id: &str, mode: Mode, theta_rad: f64) -> Publication {
        Publication::State(PbrState {
            pbr_id: rockwatch_core::engine::PbrId::parse(id).unwrap(),
            station: rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap(),
            mode,
            theta_rad,
            theta_over_alpha: 0.0,
            slide_m: 0.0,
            overturned: mode == Mode::Overturned,
            overturn_probability: 0.0,
            data_gap: false,
            data_time_ns: 7,
            not_monitored: false,
            direction_deg: 90.0,
        })
    }

    fn body<'a>(array: &'a MarkerArray, ns: &str, id: i32) -> &'a Marker {
        array
            .markers
            .iter()
            .find(|m| m.ns == ns && m.id == id)
            .unwrap()
    }

    #[test]
    fn the_view_places_tilts_and_colours_each_rock_and_its_frame() {
        let cat = catalogue();
        let pbrs: Vec<&Pbr> = cat.pbrs().iter().collect();
        let mut scene = Scene::new(&pbrs, &[], Some([34.28, -118.48, 100.0])).unwrap();
        // At start: DELETEALL, then per rock (a, b in id order) its body and label.
        let first = scene.take_markers();
        assert_eq!(first.markers.len(), 5);
        assert_eq!(first.markers[0].action, MARKER_DELETEALL);
        assert!(!scene.dirty());
        let b = body(&first, "pbr", 1);
        // b is at the origin: its base point at 0, upright, green, a 12-triangle box.
        assert!(b.pose.position.x.abs() < 1e-9 && b.pose.position.z.abs() < 1e-9);
        assert_eq!(b.pose.orientation, Quaternion::IDENTITY);
        assert_eq!(b.color, RockLook::Standing.color());
        assert_eq!(b.points.len(), 36);
        assert_eq!(body(&first, "pbr_label", 1).text, "b");
        // a is 0.001° north: ≈ 110.9 m (meridian arc at 34.28°).
        let a = body(&first, "pbr", 0);
        assert!((a.pose.position.y - 110.92).abs() < 0.05, "{:?}", a.pose);
        // Frames: map → pbr/a, pbr/b at the same places.
        let tf = scene.transforms(5);
        assert_eq!(tf.transforms.len(), 2);
        assert_eq!(tf.transforms[1].child_frame_id, "pbr/b");
        assert_eq!(tf.transforms[1].header.frame_id, "map");

        // b rocks: θ = 0.1 about its +x pivot (east, b₊ = 0.15 m): a rotation by +θ about
        // z × east = north, the axis (−cos 90°, sin 90°, 0) = (0, 1, 0).
        assert!(scene.observe(&state("b", Mode::Rock, 0.1)));
        assert!(scene.dirty());
        let m = scene.take_markers();
        let b = body(&m, "pbr", 1);
        assert_eq!(b.color, RockLook::Rocking.color());
        let q = b.pose.orientation;
        let half = 0.05_f64;
        assert!((q.y - half.sin()).abs() < 1e-12 && (q.w - half.cos()).abs() < 1e-12);
        assert!(q.x.abs() < 1e-12 && q.z.abs() < 1e-12, "{q:?}");
        // The pivot (0.15, 0, 0) stays put: position = p − R p.
        let want_x = 0.15 - 0.15 * 0.1_f64.cos();
        let want_z = 0.15 * 0.1_f64.sin();
        assert!((b.pose.position.x - want_x).abs() < 1e-12, "{:?}", b.pose);
        assert!((b.pose.position.z - want_z).abs() < 1e-12, "{:?}", b.pose);
        assert_eq!(m.markers[0].header.stamp.to_nanos(), 7);
        // The same state again changes nothing.
        assert!(!scene.observe(&state("b", Mode::Rock, 0.1)));
        // Fallen stays fallen through a later rest state; a reset stands it up.
        scene.observe(&state("b", Mode::Overturned, 1.5));
        scene.observe(&state("b", Mode::Rest, 0.0));
        assert_eq!(
            body(&scene.take_markers(), "pbr", 1).color,
            RockLook::Fallen.color()
        );
        scene.observe(&Publication::Reset(rockwatch_core::engine::ResetEvent {
            pbr_id: rockwatch_core::engine::PbrId::parse("b").unwrap(),
            station: rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap(),
            episode: 1,
            time_ns: 0,
        }));
        let m = scene.take_markers();
        assert_eq!(body(&m, "pbr", 1).color, RockLook::Standing.color());
        assert_eq!(body(&m, "pbr", 1).pose.orientation, Quaternion::IDENTITY);
        // An unknown rock changes nothing.
        assert!(!scene.observe(&state("zz", Mode::Rock, 0.1)));
    }

    #[test]
    fn station_cylinders_take_the_dashboard_s_health_colours_and_change_with_health() {
        let cat = catalogue();
        let pbrs: Vec<&Pbr> = cat.pbrs().iter().collect();
        let placed = |id: &str, lon: Option<f64>| StationConfig {
            lat: Some(34.28),
            lon,
            ..StationConfig::default_for(rockwatch_core::engine::StationId::parse(id).unwrap())
        };
        let stations = [
            placed("CI.RRS.00", Some(-118.479)),
            placed("CI.SYL.00", Some(-118.478)),
            placed("CI.UNP.00", None),
        ];
        let mut scene = Scene::new(&pbrs, &stations, Some([34.28, -118.48, 0.0])).unwrap();
        // The page's colours (web/page.html: #map polygon.OK, .WARN, .ERROR, .STALE).
        let hex = |c: ColorRgba| {
            [c.r, c.g, c.b]
                .map(|v| format!("{:02x}", (v * 255.0).round() as u8))
                .concat()
        };
        let page = include_str!("../web/page.html");
        for (level, css) in [
            (Level::Ok, "#map polygon.OK { fill: #3070d0; }"),
            (Level::Warn, "#map polygon.WARN { fill: #e0b000; }"),
            (Level::Error, "#map polygon.ERROR { fill: #d02020; }"),
        ] {
            assert!(page.contains(css), "{css}");
            assert!(css.contains(&hex(station_color(level))), "{level:?}");
        }
        assert!(page.contains("#map polygon.STALE, #map polygon.NO\\ DATA\\ YET { fill: #999; }"));
        assert_eq!(hex(station_color(Level::Stale)), "999999");
        // At start, before any status: no data yet (grey); the unplaced station is not drawn.
        let colour = |array: &MarkerArray, id: i32| body(array, "station", id).color;
        let first = scene.take_markers();
        assert_eq!(colour(&first, 0), station_color(Level::NoDataYet));
        assert_eq!(colour(&first, 1), station_color(Level::NoDataYet));
        assert!(!first.markers.iter().any(|m| m.ns == "station" && m.id == 2));
        // A status: RRS OK, SYL still no data: the view changes, RRS blue.
        assert!(scene.observe_station_health([
            ("CI.RRS.00", Level::Ok),
            ("CI.SYL.00", Level::NoDataYet),
            ("CI.UNP.00", Level::Ok),
        ]));
        assert!(scene.dirty());
        let m = scene.take_markers();
        assert_eq!(colour(&m, 0), station_color(Level::Ok));
        assert_eq!(colour(&m, 1), station_color(Level::NoDataYet));
        // The same health again: nothing to send.
        assert!(!scene.observe_station_health([("CI.RRS.00", Level::Ok)]));
        assert!(!scene.dirty());
        // RRS late (WARN), then STALE; SYL stale after its grace: each change redraws.
        assert!(scene.observe_station_health([("CI.RRS.00", Level::Warn)]));
        assert_eq!(colour(&scene.take_markers(), 0), station_color(Level::Warn));
        assert!(scene
            .observe_station_health([("CI.RRS.00", Level::Stale), ("CI.SYL.00", Level::Stale)]));
        let m = scene.take_markers();
        assert_eq!(colour(&m, 0), station_color(Level::Stale));
        assert_ne!(colour(&m, 0), station_color(Level::Ok));
        // A station not in the view changes nothing.
        assert!(!scene.observe_station_health([("XX.NONE.00", Level::Error)]));
    }

    #[test]
    fn a_partition_s_markers_have_namespaces_of_their_own_and_no_deleteall() {
        let cat = catalogue();
        let pbrs: Vec<&Pbr> = cat.pbrs().iter().collect();
        let partition = Partition::new(1, 3).unwrap();
        let mut scene = Scene::new(&pbrs, &[], Some([34.28, -118.48, 0.0]))
            .unwrap()
            .in_partition(partition);
        let array = scene.take_markers();
        assert!(array.markers.iter().all(|m| m.action != MARKER_DELETEALL));
        assert_eq!(body(&array, "pbr/p1of3", 0).id, 0);
        assert_eq!(body(&array, "pbr_label/p1of3", 1).text, "b");
        assert!(array.markers.iter().all(|m| m.ns.ends_with("/p1of3")));
        // A failed publication is sent again.
        assert!(!scene.dirty());
        scene.mark_dirty();
        assert!(scene.dirty());
    }

    #[test]
    fn the_largest_meshes_become_boxes_until_the_view_fits_its_budget() {
        let rock = |id: &str, triangles: usize| SceneRock {
            id: id.into(),
            enu: Some([0.0; 3]),
            points: (0..3 * triangles)
                .map(|k| Point {
                    x: k as f64,
                    y: -(k as f64),
                    z: (k % 7) as f64,
                })
                .collect(),
            height_m: 1.0,
            pivots: Vec::new(),
            look: RockLook::Standing,
            theta_rad: 0.0,
            slide_m: 0.0,
            direction_deg: 0.0,
        };
        let mut rocks = vec![rock("a", 30), rock("b", 20), rock("c", 6)];
        fit_budget(&mut rocks, 40);
        let sizes: Vec<usize> = rocks.iter().map(|r| r.points.len() / 3).collect();
        assert_eq!(sizes, [12, 20, 6]);
        // The box spans the mesh's extremes.
        let xs: Vec<f64> = rocks[0].points.iter().map(|p| p.x).collect();
        assert_eq!(xs.iter().copied().fold(f64::INFINITY, f64::min), 0.0);
        assert_eq!(xs.iter().copied().fold(f64::NEG_INFINITY, f64::max), 89.0);
        // Within budget: nothing changes.
        let mut small = vec![rock("a", 10)];
        fit_budget(&mut small, 40);
        assert_eq!(small[0].points.len(), 30);
    }

    #[test]
    fn the_default_origin_averages_longitudes_on_the_circle() {
        let text = "[[pbr]]\nid = \"e\"\nname = \"e\"\nlat = 10.0\nlon = 179.9\n\
                    station = \"XX.A.00\"\nazimuth_deg = 0.0\nwidth_m = 1.0\nheight_m = 1.0\n\
                    mu_s = 0.9\nmu_k = 0.7\nsource = \"test\"\n\n\
                    [[pbr]]\nid = \"w\"\nname = \"w\"\nlat = 20.0\nlon = -179.9\n\
                    station = \"XX.A.00\"\nazimuth_deg = 0.0\nwidth_m = 1.0\nheight_m = 1.0\n\
                    mu_s = 0.9\nmu_k = 0.7\nsource = \"test\"\n";
        let cat = load(text);
        let pbrs: Vec<&Pbr> = cat.pbrs().iter().collect();
        let [lat, lon, alt] = Scene::mean_origin(&pbrs).unwrap();
        assert!((lat - 15.0).abs() < 1e-12 && alt == 0.0);
        assert!((lon.abs() - 180.0).abs() < 1e-9, "{lon}");
        assert_eq!(Scene::mean_origin(&[]), None);
    }

    #[test]
    fn a_bad_origin_is_refused_and_a_planar_box_is_closed_and_outward() {
        let cat = catalogue();
        let pbrs: Vec<&Pbr> = cat.pbrs().iter().collect();
        let e = Scene::new(&pbrs, &[], Some([95.0, 0.0, 0.0])).unwrap_err();
        assert!(e.to_string().contains("latitude 95"), "{e}");
        // Box 0.3 wide along 90° (east), 0.4 deep, 2 m high: outward normals, volume.
        let t = planar_box(90.0, 0.15, 0.15, 2.0);
        let mut volume = 0.0;
        for [p, q, r] in &t {
            // Divergence theorem: V = Σ p·(q × r) / 6 for outward triangles.
            let c = [
                q[1] * r[2] - q[2] * r[1],
                q[2] * r[0] - q[0] * r[2],
                q[0] * r[1] - q[1] * r[0],
            ];
            volume += (p[0] * c[0] + p[1] * c[1] + p[2] * c[2]) / 6.0;
        }
        assert!((volume - 0.3 * 0.3 * 2.0).abs() < 1e-12, "{volume}");
        let east = t.iter().flatten().map(|p| p[0]).fold(0.0_f64, f64::max);
        assert!((east - 0.15).abs() < 1e-12);
    }
}
