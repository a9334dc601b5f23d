//! A listener of the node's alerts on `/pbr/alerts` ([`Ros2AlertListener`]): the demo, tools
//! and tests.

use std::time::{Duration, Instant};

use anyhow::{anyhow, Context as _};
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::Subscription;

use super::msg;
use super::names::{IntoNaming, ALERTS_TOPIC};
use super::network::NetworkPlan;
use super::qos::alerts_qos;
use super::session::Ros2Session;

/// A subscriber of `/pbr/alerts` (transient local: receives the history too).
pub struct Ros2AlertListener {
    subscription: Subscription<msg::PbrAlert>,
    poll: Poll,
    events: Events,
    /// Last: the endpoints above are dropped before their participant.
    _session: Ros2Session,
}

impl Ros2AlertListener {
    /// Subscribes `pbr/alerts` as the node `rockwatch_listener` in `naming`'s namespace (the
    /// node's: the topic resolves there, then its remaps).
    pub fn open(plan: &NetworkPlan, naming: impl IntoNaming) -> anyhow::Result<Ros2AlertListener> {
        let mut session =
            Ros2Session::open_client(plan, &naming.into_naming()?, "rockwatch_listener")?;
        let mut subscription =
            session.subscription(ALERTS_TOPIC, msg::PACKAGE, "PbrAlert", alerts_qos())?;
        let poll = Poll::new().context("alert listener poller")?;
        poll.registry()
            .register(&mut subscription, Token(0), Interest::READABLE)
            .context("alert listener registration")?;
        Ok(Ros2AlertListener {
            _session: session,
            subscription,
            poll,
            events: Events::with_capacity(4),
        })
    }

    /// Every alert received within `timeout` (returns as soon as there is at least one).
    pub fn recv(&mut self, timeout: Duration) -> anyhow::Result<Vec<msg::PbrAlert>> {
        let deadline = Instant::now() + timeout;
        let mut out = Vec::new();
        loop {
            while let Some((alert, _)) = self
                .subscription
                .take()
                .map_err(|e| anyhow!("{ALERTS_TOPIC}: {e:?}"))?
            {
                out.push(alert);
            }
            let now = Instant::now();
            if !out.is_empty() || now >= deadline {
                return Ok(out);
            }
            let wait = (deadline - now).min(Duration::from_millis(50));
            let _ = self.poll.poll(&mut self.events, Some(wait));
        }
    }
}
