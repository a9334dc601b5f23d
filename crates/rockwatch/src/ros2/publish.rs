//! The node's output publishers: alerts on `/pbr/alerts`, block states on `/pbr/state`,
//! station intensity measures on `/pbr/ims`, and the 3-D view (`markers.rs`: `pbr/markers`,
//! `/tf_static`), which follows the states and alerts.

use anyhow::anyhow;

use super::markers::{MarkerPublisher, Scene};
use super::msg;
use super::names::{ALERTS_TOPIC, IMS_TOPIC, MARKERS_TOPIC, STATE_TOPIC, TF_STATIC_TOPIC};
use super::qos::{alerts_qos, output_qos, view_qos};
use super::session::Ros2Session;
use crate::ports::{Publication, Publisher};

/// The node's output publishers (a [`Publisher`]).
pub struct Ros2Publisher {
    alerts: ros2_client::Publisher<msg::PbrAlert>,
    states: ros2_client::Publisher<msg::PbrState>,
    ims: ros2_client::Publisher<msg::StationIntensity>,
    view: MarkerPublisher,
}

impl Ros2Publisher {
    /// Creates the publishers on `session`'s node.
    pub(super) fn open(session: &mut Ros2Session) -> anyhow::Result<Ros2Publisher> {
        Ok(Ros2Publisher {
            alerts: session.publisher(ALERTS_TOPIC, "PbrAlert", alerts_qos())?,
            states: session.publisher(STATE_TOPIC, "PbrState", output_qos())?,
            ims: session.publisher(IMS_TOPIC, "StationIntensity", output_qos())?,
            view: MarkerPublisher::new(
                session.publisher_of(
                    MARKERS_TOPIC,
                    "visualization_msgs",
                    "MarkerArray",
                    view_qos(),
                )?,
                session.publisher_of(TF_STATIC_TOPIC, "tf2_msgs", "TFMessage", view_qos())?,
            ),
        })
    }

    /// Shows `scene` in the 3-D view: its frames on `/tf_static` and its markers, now (and
    /// the markers again as states and alerts change it, see [`Ros2Publisher::tick`]).
    pub fn show(&mut self, scene: Scene) {
        self.view.show(scene);
    }

    /// The scene of the 3-D view, handed over to the publishers of a rebuilt participant.
    pub fn take_scene(&mut self) -> Option<Scene> {
        self.view.take_scene()
    }

    /// Takes in the stations' health of a status: the 3-D view's station markers take its
    /// colours (sent by the next [`Ros2Publisher::tick`] that is due).
    pub fn observe_station_health(&mut self, stations: &[crate::status::StationStatus]) {
        self.view.observe_station_health(stations);
    }

    /// Publishes the markers if the view changed and their rate allows
    /// ([`MARKER_PERIOD`](super::MARKER_PERIOD)); cheap otherwise: call it every turn.
    pub fn tick(&mut self) {
        self.view.tick();
    }
}

impl Publisher for Ros2Publisher {
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()> {
        self.view.observe(publication);
        let result = match publication {
            Publication::Alert {
                alert,
                journal_pending,
                ..
            } => self
                .alerts
                .publish({
                    let mut m = msg::PbrAlert::from(alert);
                    if *journal_pending {
                        m.message.push_str(crate::ports::JOURNAL_PENDING_NOTE);
                    }
                    m
                })
                .map_err(|e| format!("{ALERTS_TOPIC}: {e:?}")),
            Publication::Reset(r) => self
                .alerts
                .publish(msg::PbrAlert::from(r))
                .map_err(|e| format!("{ALERTS_TOPIC}: {e:?}")),
            Publication::State(s) => self
                .states
                .publish(msg::PbrState::from(s))
                .map_err(|e| format!("{STATE_TOPIC}: {e:?}")),
            Publication::Intensity(i) => self
                .ims
                .publish(msg::StationIntensity::from(i))
                .map_err(|e| format!("{IMS_TOPIC}: {e:?}")),
        };
        result.map_err(|e| anyhow!("ROS 2 publish failed: {e}"))
    }
}
