//! The shore side of the link (`planner shore`): every message of one
//! vehicle, decoded; heartbeats out; link changes; catch-up on (re)connect;
//! commands out.

use std::time::{Duration, Instant};

use zenoh::Wait;
use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::query::ConsolidationMode;
use zenoh::sample::Sample;

use super::encode::{self, Ack, Command, DecodeError, Event, Heartbeat, PlanMsg, Snapshot, State, Status, types};
use super::keys;
use super::monitor::{LinkChange, LinkMonitor, LinkState, heartbeat_period};
use super::session::{self, SessionError, Side};
use auv_platform::clock::mono_now_ns;

/// One message from the vehicle.
#[derive(Clone, Debug, PartialEq)]
pub enum Incoming {
    /// `…/state`.
    State(State),
    /// `…/plan`.
    Plan(PlanMsg),
    /// `…/status`.
    Status(Status),
    /// `…/snapshot`.
    Snapshot(Snapshot),
    /// `…/ack`.
    Ack(Ack),
    /// `…/event`.
    Event(Event),
    /// `…/heartbeat/onboard`.
    Heartbeat(Heartbeat),
}

/// One received message and how it came.
#[derive(Clone, Debug, PartialEq)]
pub struct Received {
    /// What.
    pub msg: Incoming,
    /// The shore's `CLOCK_MONOTONIC` when it was taken off the session, ns.
    pub recv_mono_ns: u64,
    /// It answered the catch-up query (the latest value, perhaps seen before).
    pub catch_up: bool,
}

/// A payload the console could not use.
#[derive(Clone, Debug, PartialEq)]
pub struct Refused {
    /// Its key.
    pub key: String,
    /// Why.
    pub error: String,
}

/// The console's end of the link.
pub struct ShoreLink {
    session: zenoh::Session,
    vehicle: String,
    sub: Subscriber<FifoChannelHandler<Sample>>,
    heartbeat: Publisher<'static>,
    command: Publisher<'static>,
    monitor: LinkMonitor,
    period: Duration,
    last_hb: Option<Instant>,
    hb_seq: u64,
    session_id: u64,
    t: f64,
}

fn zerr(e: impl std::fmt::Display) -> SessionError {
    SessionError::Open(e.to_string())
}

fn decode_sample(vehicle: &str, key: &str, bytes: &[u8]) -> Option<Result<Incoming, DecodeError>> {
    let leaf = keys::leaf(vehicle, key)?;
    Some(match leaf {
        keys::STATE => encode::decode(bytes, types::STATE).map(Incoming::State),
        keys::PLAN => encode::decode(bytes, types::PLAN).map(Incoming::Plan),
        keys::STATUS => encode::decode(bytes, types::STATUS).map(Incoming::Status),
        keys::SNAPSHOT => encode::decode(bytes, types::SNAPSHOT).map(Incoming::Snapshot),
        keys::ACK => encode::decode(bytes, types::ACK).map(Incoming::Ack),
        keys::EVENT => encode::decode(bytes, encode::EVENT_TYPE).map(Incoming::Event),
        keys::HEARTBEAT_ONBOARD => encode::decode(bytes, encode::HEARTBEAT_TYPE).map(Incoming::Heartbeat),
        // Our own keys (heartbeat/shore, command) and any others: not for us.
        _ => return None,
    })
}

impl ShoreLink {
    /// Connects to the bridge at `endpoint` (retrying in the background) for
    /// vehicle `vehicle`; the link is lost after `timeout` of silence.
    pub fn open(
        endpoint: &str,
        vehicle: &str,
        zenoh_config: Option<&std::path::Path>,
        timeout: Duration,
    ) -> Result<Self, SessionError> {
        let session = session::open(Side::Shore, endpoint, zenoh_config)?;
        let sub = session.declare_subscriber(keys::all(vehicle)).wait().map_err(zerr)?;
        let heartbeat = session
            .declare_publisher(keys::key(vehicle, keys::HEARTBEAT_SHORE))
            .wait()
            .map_err(zerr)?;
        let command = session
            .declare_publisher(keys::key(vehicle, keys::COMMAND))
            .wait()
            .map_err(zerr)?;
        let mut s = mono_now_ns() ^ (u64::from(std::process::id()) << 40);
        Ok(Self {
            session,
            vehicle: vehicle.to_string(),
            sub,
            heartbeat,
            command,
            monitor: LinkMonitor::new(timeout),
            period: heartbeat_period(timeout),
            last_hb: None,
            hb_seq: 0,
            session_id: auv_core::rng::splitmix64(&mut s),
            t: 0.0,
        })
    }

    /// The link as the console sees it.
    pub fn monitor(&self) -> &LinkMonitor {
        &self.monitor
    }

    /// The link state now.
    pub fn state(&self) -> LinkState {
        self.monitor.state()
    }

    fn handle(
        &mut self,
        key: &str,
        bytes: &[u8],
        catch_up: bool,
        each: &mut dyn FnMut(Result<Received, Refused>),
        changes: &mut Vec<LinkChange>,
    ) {
        let recv_mono_ns = mono_now_ns();
        let Some(decoded) = decode_sample(&self.vehicle, key, bytes) else {
            return;
        };
        // Anything from the vehicle proves the link.
        changes.extend(self.monitor.heard(Instant::now()));
        match decoded {
            Ok(msg) => {
                if let Incoming::State(s) = &msg {
                    self.t = self.t.max(s.origin.t);
                }
                each(Ok(Received {
                    msg,
                    recv_mono_ns,
                    catch_up,
                }));
            }
            Err(e) => each(Err(Refused {
                key: key.to_string(),
                error: e.to_string(),
            })),
        }
    }

    /// Takes what arrived (waiting at most `wait` for the first message),
    /// sends the heartbeat when due, asks for the latest values when the
    /// link (re)connects, and returns the link changes.
    pub fn poll(&mut self, wait: Duration, each: &mut dyn FnMut(Result<Received, Refused>)) -> Vec<LinkChange> {
        let mut changes = Vec::new();
        let mut first = self.sub.recv_timeout(wait).ok().flatten();
        loop {
            let sample = match first.take() {
                Some(s) => s,
                None => match self.sub.try_recv() {
                    Ok(Some(s)) => s,
                    _ => break,
                },
            };
            let key = sample.key_expr().as_str().to_string();
            let bytes = sample.payload().to_bytes().into_owned();
            self.handle(&key, &bytes, false, each, &mut changes);
        }
        let now = Instant::now();
        if self.last_hb.is_none_or(|h| now.duration_since(h) >= self.period) {
            self.last_hb = Some(now);
            self.hb_seq += 1;
            let hb = Heartbeat::new("shore", self.hb_seq, self.session_id, self.t, self.state().as_str());
            let _ = self.heartbeat.put(encode::encode(&hb)).wait();
        }
        changes.extend(self.monitor.poll(Instant::now()));
        if changes
            .iter()
            .any(|c| matches!(c, LinkChange::Connected | LinkChange::Restored { .. }))
        {
            self.catch_up(each, &mut changes);
        }
        changes
    }

    /// Asks the bridge for the plans it forwarded (the console keeps those
    /// it had not seen) and the latest state, plan, status and snapshot.
    fn catch_up(&mut self, each: &mut dyn FnMut(Result<Received, Refused>), changes: &mut Vec<LinkChange>) {
        let plans = keys::key(&self.vehicle, keys::PLAN_HISTORY);
        for selector in [plans, keys::latest(&self.vehicle)] {
            // Every reply, not Zenoh's default of the latest per key: the
            // history answers many plans on one key.
            let get = self.session.get(selector).consolidation(ConsolidationMode::None);
            let Ok(replies) = get.timeout(Duration::from_secs(2)).wait() else {
                continue;
            };
            while let Ok(reply) = replies.recv() {
                if let Ok(sample) = reply.result() {
                    let key = sample.key_expr().as_str().replace(keys::PLAN_HISTORY, keys::PLAN);
                    let bytes = sample.payload().to_bytes().into_owned();
                    self.handle(&key, &bytes, true, each, changes);
                }
            }
        }
    }

    /// Sends a command (again: the bridge answers a repeat with its ack).
    pub fn send(&self, c: &Command) -> Result<(), SessionError> {
        self.command.put(encode::encode(c)).wait().map_err(zerr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_vehicles_own_onboard_keys_are_decoded() {
        let hb = encode::encode(&Heartbeat::new("onboard", 1, 2, 0.0, "up"));
        assert!(matches!(
            decode_sample("auv1", "auv/auv1/heartbeat/onboard", &hb),
            Some(Ok(Incoming::Heartbeat(_)))
        ));
        assert!(decode_sample("auv1", "auv/auv1/heartbeat/shore", &hb).is_none());
        assert!(decode_sample("auv1", "auv/auv2/heartbeat/onboard", &hb).is_none());
        assert!(matches!(
            decode_sample("auv1", "auv/auv1/plan", &hb),
            Some(Err(DecodeError::Type { .. }))
        ));
    }
}
