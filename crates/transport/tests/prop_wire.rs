//! Property tests of the message validators and of planning on whatever
//! they let through: any message, random or a real one with bits flipped,
//! is either accepted, and then satisfies every documented invariant (and a
//! snapshot can be planned on: any priority vector decodes to a valid
//! route), or rejected with a kind; nothing panics. Plus the sequence guard
//! and the guarded inbox end to end (every message sent is accepted or
//! counted under exactly one kind).

use std::sync::OnceLock;

use auv_core::decode::Decoder;
use auv_core::problem::{MAX_NODES, NodeSet, Problem};
use auv_core::route::Route;
use auv_messages::msg::{
    FromCode, Header, MAX_WIRE_NODES, ObjectiveCode, Plan, PlannerPhase, PlannerStatus, REJECT_KINDS, RejectKind,
    SeqGuard, SnapshotHead, TriggerKind, Validate, VehicleEvent, VehicleMode, VehicleState, WaypointSnapshot, WireEdge,
    boxed_zeroed, route_ids,
};
use auv_messages::network::{fill_problem, find_edge, write_snapshot};
use auv_messages::wire::WireRules;
use auv_transport::faulty::TamperOutbox;
use auv_transport::guard::Guarded;
use auv_transport::ipc::{InProcess, IpcContext, Stamp};
use auv_transport::{IpcOptions, WaitMode, unique_prefix};
use auv_transport::{Outbox, TransportError};
use auv_world::chart::WaterMap;
use auv_world::load::{MissionWorld, ScenarioArgs, load_world};
use proptest::prelude::*;

/// Bytes of the common header.
const HEADER: usize = core::mem::size_of::<Header>();

/// Waypoints of the fixture world.
const N: usize = 16;

struct Fixture {
    world: MissionWorld,
    rules: WireRules,
    /// Real snapshots of epochs 0..8, in their wire form: head and edges.
    snaps: Vec<(Box<SnapshotHead>, Vec<WireEdge>)>,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let args = ScenarioArgs {
            seed: Some(11),
            nodes: Some(N),
            ..Default::default()
        };
        let mut w = load_world(&args).expect("the fixture world loads");
        let rules = WireRules::new(&w);
        let mut snaps = Vec::new();
        for epoch in 0..8 {
            if epoch > 0 {
                w.redraw(epoch);
            }
            let mut s = WaypointSnapshot::new();
            write_snapshot(&w.snapshot(), epoch, &mut s).expect("the world fits a snapshot");
            s.header.seq = epoch + 1;
            s.header.fingerprint = w.fingerprint();
            snaps.push((Box::new(*s.head()), s.edges_in_use().to_vec()));
        }
        Fixture {
            world: load_world(&args).expect("the fixture world loads"),
            rules,
            snaps,
        }
    })
}

/// The message's bytes, writable (`T` is a wire type: integers and floats).
fn bytes_of<T: Copy>(m: &mut T) -> &mut [u8] {
    // SAFETY: message types are plain integers/floats with no padding
    // (checked by msg's layout test), so every byte is initialised and any
    // byte pattern written back is a valid value.
    unsafe { core::slice::from_raw_parts_mut((m as *mut T).cast::<u8>(), core::mem::size_of::<T>()) }
}

/// Flips bit `bit` of byte `at % used` of the message's first `used` bytes.
fn flip<T: Copy>(m: &mut T, flips: &[(usize, u8)], used: usize) {
    let b = bytes_of(m);
    let used = used.clamp(1, b.len());
    for &(at, bit) in flips {
        b[at % used] ^= 1 << (bit % 8);
    }
}

/// Flips bits of a snapshot's wire form where they carry data: the head's
/// scalars and its n nodes, then the edges, as one flat index space.
fn flip_snapshot(head: &mut SnapshotHead, edges: &mut [WireEdge], flips: &[(usize, u8)]) {
    let in_head = core::mem::offset_of!(SnapshotHead, nodes) + head.node_count as usize * 32;
    let used = in_head + edges.len() * 32;
    for &(at, bit) in flips {
        let at = at % used;
        if at < in_head {
            bytes_of(head)[at] ^= 1 << (bit % 8);
        } else {
            let (e, b) = ((at - in_head) / 32, (at - in_head) % 32);
            bytes_of(&mut edges[e])[b] ^= 1 << (bit % 8);
        }
    }
}

fn valid_state(seq: u64) -> VehicleState {
    let mut s = *boxed_zeroed::<VehicleState>();
    s.header.seq = seq;
    s.header.fingerprint = fixture().world.fingerprint();
    s.position = [10.0, 20.0, 5.0];
    s.time_left_s = 1000.0;
    s.to_node = 3;
    s.from_node = 2;
    s.mode = VehicleMode::Travelling as u32;
    s.event = VehicleEvent::Periodic as u32;
    s.route_len = 2;
    s.route[..2].copy_from_slice(&[0, 2]);
    s
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// A real snapshot with bits flipped: accepted ones are sound and plannable.
    #[test]
    fn flipped_snapshots_are_rejected_or_sound_and_plannable(
        which in 0usize..8,
        flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..6),
        prio in proptest::collection::vec(prop_oneof![8 => -50.0f64..50.0, 1 => Just(f64::NAN)], MAX_NODES),
    ) {
        let f = fixture();
        let (mut head, mut edges) = f.snaps[which].clone();
        let mut s = WaypointSnapshot::new();
        s.receive(&head, &edges);
        prop_assert_eq!(s.validate().and_then(|()| f.rules.check_snapshot(&s)), Ok(()));
        flip_snapshot(&mut head, &mut edges, &flips);
        // As a subscriber takes a sample in.
        s.receive(&head, &edges);
        let verdict = s.validate().and_then(|()| f.rules.check_snapshot(&s));
        if verdict.is_err() {
            return Ok(());
        }
        // Accepted: every documented invariant holds.
        let (n, m) = (s.node_count as usize, s.edge_count as usize);
        prop_assert_eq!(n, N);
        prop_assert_eq!(m, edges.len());
        prop_assert!(s.speed_mps.is_finite() && s.speed_mps > 0.0);
        prop_assert!(s.time_available_s.is_finite() && s.time_available_s > 0.0);
        prop_assert!(ObjectiveCode::from_code(s.objective).is_some());
        for w in &s.nodes[..n] {
            prop_assert!(w.x.is_finite() && w.y.is_finite() && w.z.is_finite() && w.prize >= 0.0);
            prop_assert!(f.world.map().is_water(w.x, w.y));
        }
        for e in s.edges_in_use() {
            prop_assert!((e.a as usize) < n && (e.b as usize) < n && e.a != e.b);
            prop_assert!(e.risk > 0.0 && e.priority >= 0.0 && e.task_time_s >= 0.0);
        }
        // Plannable: any priorities decode to a valid route on its edges.
        let mut p: Problem = Problem::new();
        let start = s.start as usize;
        if fill_problem(&s, &mut p, start, NodeSet::EMPTY, s.time_available_s, &[]).is_ok() {
            let mut r = Route::new();
            let e = Decoder::new().decode(&p, &prio, &mut r);
            prop_assert_eq!(p.evaluate(&r), Some(e));
            prop_assert_eq!(r.get(0), start);
            prop_assert_eq!(r.last(), Some(s.goal as usize));
            for k in 1..r.len() {
                prop_assert!(find_edge(&s, r.get(k - 1), r.get(k)).is_some());
            }
        }
    }

    /// Random bytes as a snapshot: validator and world rules never panic.
    #[test]
    fn random_snapshots_never_panic(
        bytes in proptest::collection::vec(any::<u8>(), 0..2048),
        n in 0u32..600,
        m in 0u32..400,
        slice in 0usize..400,
    ) {
        let mut head = boxed_zeroed::<SnapshotHead>();
        let b = bytes_of(&mut *head);
        let k = bytes.len().min(b.len());
        b[..k].copy_from_slice(&bytes[..k]);
        head.node_count = n;
        head.edge_count = m;
        let edges: Vec<WireEdge> = (0..slice)
            .map(|i| {
                let mut e = WireEdge::default();
                let eb = bytes_of(&mut e);
                for (j, x) in eb.iter_mut().enumerate() {
                    *x = bytes.get((i * 32 + j) % bytes.len().max(1)).copied().unwrap_or(0);
                }
                e
            })
            .collect();
        let mut s = WaypointSnapshot::with_capacity(300);
        s.receive(&head, &edges);
        if s.validate().is_ok() {
            prop_assert_eq!(s.edge_count as usize, edges.len());
            prop_assert!(m as usize == slice && slice <= 300 && n as usize <= MAX_WIRE_NODES);
            let _ = fixture().rules.check_snapshot(&s);
        }
    }

    /// A valid vehicle state with bits flipped: rejected, or sound.
    #[test]
    fn flipped_vehicle_states_are_rejected_or_sound(
        flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..6),
    ) {
        let f = fixture();
        let mut s = valid_state(4);
        prop_assert_eq!(s.validate().and_then(|()| f.rules.check_state(&s)), Ok(()));
        flip(&mut s, &flips, usize::MAX);
        if s.validate().and_then(|()| f.rules.check_state(&s)).is_ok() {
            prop_assert!(s.header.seq >= 1 && s.header.mission_time_s >= 0.0);
            prop_assert!(s.position.iter().all(|v| v.is_finite()));
            prop_assert!(s.time_left_s.is_finite() && s.eta_free_s >= 0.0 && s.weight >= 0.0 && s.distance_m >= 0.0);
            prop_assert!(VehicleMode::from_code(s.mode).is_some() && VehicleEvent::from_code(s.event).is_some());
            prop_assert!((s.to_node as usize) < N && (s.from_node as usize) < N);
            let ids = route_ids(&s.route, s.route_len);
            prop_assert!(!ids.is_empty() && ids.len() == s.route_len as usize);
            prop_assert!(ids.iter().all(|&id| (id as usize) < N));
        }
    }

    /// Plans and statuses with bits flipped: rejected, or sound.
    #[test]
    fn flipped_plans_and_statuses_are_rejected_or_sound(
        flips in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..6),
    ) {
        let mut p = *boxed_zeroed::<Plan>();
        p.header.seq = 3;
        p.route_len = 3;
        p.route[..3].copy_from_slice(&[0, 5, 9]);
        prop_assert_eq!(p.validate(), Ok(()));
        flip(&mut p, &flips, usize::MAX);
        if p.validate().is_ok() {
            prop_assert!((1..=MAX_WIRE_NODES).contains(&(p.route_len as usize)));
            prop_assert!(route_ids(&p.route, p.route_len).iter().all(|&id| (id as usize) < MAX_WIRE_NODES));
            prop_assert!(TriggerKind::from_code(p.trigger).is_some());
            prop_assert!(p.feasible <= 1 && p.fallback <= 1 && p.deadline_cut <= 1);
            prop_assert!([p.time_s, p.weight, p.distance_m, p.budget_s].iter().all(|v| v.is_finite()));
        }
        let mut st = *boxed_zeroed::<PlannerStatus>();
        st.header.seq = 1;
        prop_assert_eq!(st.validate(), Ok(()));
        flip(&mut st, &flips, usize::MAX);
        if st.validate().is_ok() {
            prop_assert!(PlannerPhase::from_code(st.phase).is_some());
        }
    }

    /// The sequence guard: per session, accepted numbers strictly rise; a
    /// foreign fingerprint is never accepted; the kind names what happened.
    #[test]
    fn the_sequence_guard_accepts_only_rising_numbers_of_our_scenario(
        msgs in proptest::collection::vec((0u64..3, 0u64..12, any::<bool>()), 1..60),
    ) {
        let mut g = SeqGuard::new(42);
        let mut last: Option<(u64, u64)> = None;
        for (session, seq, foreign) in msgs {
            let h = Header { seq, session, fingerprint: if foreign { 43 } else { 42 }, ..Header::default() };
            let verdict = g.accept(&h);
            let expected = if foreign {
                Err(RejectKind::ForeignScenario)
            } else {
                match last {
                    Some((s, l)) if s == session && l != 0 && seq == l => Err(RejectKind::Repeated),
                    Some((s, l)) if s == session && l != 0 && seq < l => Err(RejectKind::OutOfOrder),
                    _ => Ok(()),
                }
            };
            prop_assert_eq!(verdict, expected);
            if verdict.is_ok() {
                last = Some((session, seq));
            }
            prop_assert_eq!(g.last(), last.unwrap_or((0, 0)));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Through a real (in-process) transport and the guard: every message
    /// sent is either handed on or counted under exactly one kind, and what
    /// is handed on is valid, ours and in sequence.
    #[test]
    fn every_message_through_the_guard_is_accepted_or_counted_once(
        msgs in proptest::collection::vec(
            (any::<bool>(), proptest::collection::vec((any::<usize>(), any::<u8>()), 1..4), 0u8..4),
            1..24,
        ),
    ) {
        let f = fixture();
        let fp = f.world.fingerprint();
        let opts = IpcOptions::new(Some(&unique_prefix("p")), "prop", WaitMode::Spin).unwrap();
        let ctx = IpcContext::<InProcess>::new(&opts, "prop").unwrap();
        let mut out = ctx.outbox::<VehicleState>(Stamp::new(fp)).unwrap();
        let rules = std::sync::Arc::new(f.rules.clone());
        let mut inbox = Guarded::new(ctx.inbox::<VehicleState>().unwrap(), fp, "prop").with_check(rules.state_check());
        let (mut accepted, mut last_seq) = (0u64, 0u64);
        for (good, flips, header_fault) in &msgs {
            let mut tamper = |m: &mut VehicleState| {
                let seq = m.header.seq;
                *m = valid_state(seq);
                m.header.session = 77;
                if !good {
                    // Payload only: a flipped sequence number that happens to
                    // be valid would (rightly) make later good ones stale.
                    let payload: Vec<(usize, u8)> = flips
                        .iter()
                        .map(|&(at, bit)| (HEADER + at % (core::mem::offset_of!(VehicleState, route) + 2 - HEADER), bit))
                        .collect();
                    flip(m, &payload, usize::MAX);
                    match header_fault {
                        1 => m.header.seq = last_seq,
                        2 => m.header.fingerprint ^= 1,
                        _ => {}
                    }
                }
            };
            out.publish_tampered(&mut |_| {}, &mut tamper).unwrap();
            inbox.drain(&mut |m: &VehicleState| {
                assert!(m.validate().is_ok() && rules.check_state(m).is_ok());
                assert_eq!(m.header.fingerprint, fp);
                assert!(m.header.seq > last_seq, "{} after {}", m.header.seq, last_seq);
                last_seq = m.header.seq;
                accepted += 1;
            }).unwrap();
        }
        let rejected = inbox.rejected();
        prop_assert_eq!(accepted + rejected.total(), msgs.len() as u64);
        prop_assert_eq!(rejected.0.len(), REJECT_KINDS);
        let goods = msgs.iter().filter(|(g, _, _)| *g).count() as u64;
        prop_assert!(accepted >= goods, "a good message was refused");
    }

    /// Snapshots through a real (in-process) slice transport and the guard:
    /// each sample carries exactly its edges, every snapshot sent is handed
    /// on intact or counted rejected once, and one whose head claims more
    /// edges than a sample holds is refused by the sender, never sent.
    #[test]
    fn snapshots_through_the_slice_transport_arrive_intact_or_are_counted(
        msgs in proptest::collection::vec((0usize..8, any::<bool>(), proptest::collection::vec((any::<usize>(), any::<u8>()), 1..4), 0u8..3), 1..12),
    ) {
        let f = fixture();
        let fp = f.world.fingerprint();
        let opts = IpcOptions::new(Some(&unique_prefix("p")), "prop", WaitMode::Spin).unwrap();
        let ctx = IpcContext::<InProcess>::new(&opts, "prop").unwrap();
        let mut out = ctx.snapshot_outbox(Stamp::new(fp), N).unwrap();
        let rules = std::sync::Arc::new(f.rules.clone());
        let mut inbox = Guarded::new(ctx.snapshot_inbox().unwrap(), fp, "prop").with_check(rules.snapshot_check());
        let (mut accepted, mut sent) = (0u64, 0u64);
        for (which, good, flips, fault) in &msgs {
            let (head, edges) = &f.snaps[*which];
            let mut fill = |m: &mut WaypointSnapshot| {
                m.receive(head, edges);
            };
            let mut tamper = |m: &mut WaypointSnapshot| {
                if !good {
                    let (mut h, mut e) = (Box::new(*m.head()), m.edges_in_use().to_vec());
                    // Payload only (the header stays in sequence).
                    let payload: Vec<(usize, u8)> = flips.iter().map(|&(at, bit)| (core::mem::size_of::<Header>() + at, bit)).collect();
                    flip_snapshot(&mut h, &mut e, &payload);
                    h.header = m.header;
                    m.receive(&h, &e);
                    if *fault == 1 {
                        // More edges than any sample of this publisher holds.
                        m.edge_count = u32::MAX;
                    }
                }
            };
            match out.publish_tampered(&mut fill, &mut tamper) {
                Ok(_) => sent += 1,
                Err(TransportError::Oversized { len, max, .. }) => {
                    prop_assert!(!good, "a good snapshot was refused by its sender");
                    prop_assert!(len > max);
                }
                Err(e) => panic!("{e}"),
            }
            inbox.drain(&mut |m: &WaypointSnapshot| {
                assert!(m.validate().is_ok() && rules.check_snapshot(m).is_ok());
                if *good {
                    assert_eq!(m.edges_in_use(), &edges[..], "a good snapshot arrives with exactly its edges");
                    assert_eq!(m.nodes[..N], head.nodes[..N]);
                }
                accepted += 1;
            }).unwrap();
        }
        prop_assert_eq!(accepted + inbox.rejected().total(), sent);
        let goods = msgs.iter().filter(|m| m.1).count() as u64;
        prop_assert!(accepted >= goods, "a good snapshot was refused");
        // Publishing through the plain path needs no tamper.
        out.publish(&mut |m: &mut WaypointSnapshot| m.receive(&f.snaps[0].0, &f.snaps[0].1)).unwrap();
    }
}
