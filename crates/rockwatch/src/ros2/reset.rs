//! The server of the operator reset service `pbr/reset` (`pbr_msgs/srv/ResetPbr`, resolved in
//! the node's namespace): requests served by the node's event loop, responses held until the
//! requesting client can receive them ([`HeldServer`]).

use ros2_client::dds::rustdds::mio1::{Registry, Token};

use super::held_server::HeldServer;
use super::input::IntakeLog;
use super::msg;
use super::names::RESET_SERVICE;
use super::security::pad_for_protection;
use super::session::Ros2Session;

pub use super::held_server::{RESET_MATCH_GRACE, RESET_REPLIES_HELD, RESET_REPLY_WAIT};

/// Most reset requests served per turn of the event loop (the rest on the next turn).
pub const RESET_REQUESTS_PER_TURN: usize = 64;

/// The reset server.
pub(super) struct ResetServer {
    server: HeldServer<msg::ResetPbrRequest, msg::ResetPbrResponse>,
    /// DDS Security is on: responses are padded ([`pad_for_protection`]).
    secured: bool,
}

impl ResetServer {
    /// Creates the server of [`RESET_SERVICE`] (resolved in `session`'s namespace) on
    /// `session`'s node.
    pub(super) fn open(session: &mut Ros2Session) -> anyhow::Result<ResetServer> {
        Ok(ResetServer {
            server: HeldServer::open(
                session,
                RESET_SERVICE,
                msg::PACKAGE,
                msg::RESET_SERVICE_TYPE,
            )?,
            secured: session.plan().security.is_some(),
        })
    }

    /// Registers the server with `registry` as `token`, readable (edge-triggered).
    pub(super) fn register(&mut self, registry: &Registry, token: Token) -> std::io::Result<()> {
        self.server.register(registry, token)
    }

    /// Serves up to [`RESET_REQUESTS_PER_TURN`] requests (undecodable ones go to `log`), then
    /// sends the responses that are due. Returns true if the bound was reached.
    pub(super) fn serve(
        &mut self,
        session: &Ros2Session,
        log: &mut IntakeLog,
        handle: &mut impl FnMut(&str) -> Option<msg::ResetPbrResponse>,
    ) -> bool {
        for _ in 0..RESET_REQUESTS_PER_TURN {
            match self.server.receive() {
                Ok(Some((id, request))) => {
                    // A secured client pads the id with NULs (see pad_for_protection).
                    // None: a block another node of the service owns (it answers).
                    let Some(mut response) = handle(request.pbr_id.trim_end_matches('\0')) else {
                        continue;
                    };
                    if self.secured {
                        response.message = pad_for_protection(response.message, ' ');
                    }
                    self.server.reply(id, response);
                }
                Ok(None) => {
                    self.server.send_due(session);
                    return false;
                }
                Err(e) => log.undecodable(&self.server.name, &e),
            }
        }
        self.server.send_due(session);
        true
    }

    /// Responses not sent yet.
    pub(super) fn pending(&self) -> usize {
        self.server.pending()
    }

    /// See [`HeldServer::send_due`].
    pub(super) fn send_due(&mut self, session: &Ros2Session) {
        self.server.send_due(session);
    }

    /// Sends every waiting response now.
    pub(super) fn flush(&mut self) {
        self.server.flush();
    }
}
