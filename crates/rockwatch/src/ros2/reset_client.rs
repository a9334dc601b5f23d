//! A client of a running node's `/pbr/reset` service ([`Ros2ResetClient`]):
//! `rockwatch reset --node`.

use std::time::{Duration, Instant};

use anyhow::{anyhow, Context as _};
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::{Client, Name, ServiceTypeName};

use super::msg;
use super::names::{IntoNaming, RESET_SERVICE, RESET_SERVICE_MAPPING};
use super::network::NetworkPlan;
use super::qos::service_qos;
use super::security::pad_for_protection;
use super::session::Ros2Session;

/// How often an unanswered reset request is sent again. A request written before the client
/// has matched a server's request reader never reaches that server (services are volatile):
/// with several nodes (a partitioned service, where only the block's owner answers), the
/// owner may match after the first one. Sending again is safe: a reset applies only to a
/// block that has overturned, so a repeat finds it standing ("nothing to reset") and the
/// client keeps the first answer to any of its requests. Longer than a node holds an answer
/// for its client's discovery (`RESET_REPLY_WAIT`), so an answered request is rarely repeated.
pub const RESET_RESEND: Duration = Duration::from_secs(3);

/// Runs `future` on this thread until it completes (true) or `timeout` passes (false).
fn block_on_with_timeout(future: impl std::future::Future<Output = ()>, timeout: Duration) -> bool {
    use futures::future::{select, Either};
    let (tx, rx) = futures::channel::oneshot::channel::<()>();
    // The timer: a thread that completes `rx` after `timeout`. If the future wins, the
    // thread's send fails later and it ends (a CLI's process usually ends first).
    let timer = std::thread::Builder::new()
        .name("rockwatch-timeout".into())
        .spawn(move || {
            std::thread::sleep(timeout);
            let _ = tx.send(());
        });
    if timer.is_err() {
        return false;
    }
    let future = std::pin::pin!(future);
    matches!(
        futures::executor::block_on(select(future, rx)),
        Either::Left(_)
    )
}

/// A client of a running node's `/pbr/reset` service (`pbr_msgs/srv/ResetPbr`), as node
/// `rockwatch_reset` of its own DDS participant: `rockwatch reset --node`.
pub struct Ros2ResetClient {
    client: Client<msg::ResetPbrRequest, msg::ResetPbrResponse>,
    poll: Poll,
    events: Events,
    /// Last: the endpoints above are dropped before their participant.
    session: Ros2Session,
    /// The service's resolved name.
    service: String,
}

impl Ros2ResetClient {
    /// Joins the graph following `plan`, as the node `rockwatch_reset` in `naming`'s
    /// namespace (the node's: the service name `pbr/reset` resolves there, then its remaps).
    pub fn open(plan: &NetworkPlan, naming: impl IntoNaming) -> anyhow::Result<Ros2ResetClient> {
        let mut session =
            Ros2Session::open_client(plan, &naming.into_naming()?, "rockwatch_reset")?;
        let service = session.resolve(RESET_SERVICE)?;
        let name = Name::parse(&service).map_err(|e| anyhow!("service {service}: {e:?}"))?;
        let mut client = session
            .node
            .create_client(
                RESET_SERVICE_MAPPING,
                &name,
                &ServiceTypeName::new(msg::PACKAGE, msg::RESET_SERVICE_TYPE),
                service_qos(),
                service_qos(),
            )
            .map_err(|e| anyhow!("ROS 2 client of {service}: {e:?}"))?;
        let poll = Poll::new().context("reset client poller")?;
        poll.registry()
            .register(&mut client, Token(0), Interest::READABLE)
            .context("reset client registration")?;
        Ok(Ros2ResetClient {
            session,
            service,
            client,
            poll,
            events: Events::with_capacity(4),
        })
    }

    /// Waits up to `timeout` for a server of the service (a matched request reader and
    /// response writer); false if none appeared.
    pub fn wait_for_service(&mut self, timeout: Duration) -> bool {
        block_on_with_timeout(self.client.wait_for_service(&self.session.node), timeout)
    }

    /// Asks for the reset of block `pbr_id` and waits up to `timeout` for the response,
    /// sending the request again every [`RESET_RESEND`] while none has come.
    pub fn reset(
        &mut self,
        pbr_id: &str,
        timeout: Duration,
    ) -> anyhow::Result<msg::ResetPbrResponse> {
        let deadline = Instant::now() + timeout;
        let request = msg::ResetPbrRequest {
            pbr_id: if self.session.plan().security.is_some() {
                pad_for_protection(pbr_id.to_string(), '\0')
            } else {
                pbr_id.to_string()
            },
        };
        let mut ids = Vec::new();
        let mut sent_at = Instant::now();
        loop {
            if ids.is_empty() || sent_at.elapsed() >= RESET_RESEND {
                let id = self
                    .client
                    .send_request(request.clone())
                    .map_err(|e| anyhow!("ROS 2 {}: request not sent: {e:?}", self.service))?;
                ids.push(id);
                sent_at = Instant::now();
            }
            // Responses to other clients' requests share the topic: keep only ours.
            while let Some((rid, response)) = self
                .client
                .receive_response()
                .map_err(|e| anyhow!("ROS 2 {}: bad response: {e:?}", self.service))?
            {
                if ids.contains(&rid) {
                    return Ok(response);
                }
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(anyhow!(
                    "no response from {} within {} s (the node may be overloaded or gone; \
                     the reset may or may not have been applied: see `rockwatch alerts`)",
                    self.service,
                    timeout.as_secs_f64()
                ));
            }
            let wait = (deadline - now).min(Duration::from_millis(50));
            let _ = self.poll.poll(&mut self.events, Some(wait));
        }
    }
}
