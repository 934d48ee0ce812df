//! Kinematics, contact, collision, deadlock and station rules on the
//! corridor plant (tests/common), by hand-computed cases.
//!
//! Both units are idle in all of these, so every step costs every AGV
//! 2 × 0.01 on top of what the case is about.

mod common;

use buridan_plant::{Load, Task, BACKWARD, FORWARD, HOLD};
use common::{at, close, corridor, env};

const IDLE: f32 = -0.02;

fn assert_reward(got: f32, want: f32) {
    assert!((got - want).abs() < 1e-6, "reward {got}, want {want}");
}

#[test]
fn dispatcher_sends_each_agv_to_the_nearest_unclaimed_product() {
    let plant = corridor(1, 1, 1000, 10);
    let e = env(&plant, 2);
    // Agent 0 starts on s2 (nearer source B), agent 1 on s1 gets A.
    assert_eq!(e.agvs()[0].task, Task::FetchRaw(1));
    assert_eq!(e.agvs()[1].task, Task::FetchRaw(0));
    assert_eq!(
        (e.agvs()[0].task.goal_code(), e.agvs()[1].task.goal_code()),
        (5, 4)
    );
    // A third AGV would find nothing left: goal 0, route length -1.
    let plant = corridor(1, 0, 1000, 10);
    let e = env(&plant, 2);
    assert_eq!(e.agvs()[1].task, Task::Idle);
    assert_eq!(e.route_length(1), -1.0);
}

#[test]
fn forward_drives_one_metre_per_step_along_the_route() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    e.place_agv(0, at(&plant, "s2", 15.0), 1.0).unwrap();
    e.place_agv(1, at(&plant, "s1", 10.0), 1.0).unwrap();
    close(e.route_length(0), 5.0);
    let mut r = [0.0; 2];
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 16.0);
    close(e.agvs()[0].speed, 1.0);
    close(e.route_length(0), 4.0);
    assert_reward(r[0], IDLE);
    let mut obs = [0.0f32; 11];
    e.write_local_obs(0, &mut obs).unwrap();
    // id, unit A/B status, source A/B counts, x, y, speed, goal, carrying, route.
    assert_eq!(
        obs,
        [0.0, 0.0, 0.0, 1.0, 1.0, 36.0, 0.0, 1.0, 5.0, 0.0, 4.0]
    );
}

#[test]
fn backward_reverses_away_from_the_goal() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    e.place_agv(1, at(&plant, "s1", 10.0), 1.0).unwrap();
    let mut r = [0.0; 2];
    e.step(&[HOLD, BACKWARD], &mut r).unwrap();
    // Agent 1 is bound west for source A: reversing takes it east.
    close(e.agvs()[1].pos.offset, 11.0);
    close(e.agvs()[1].speed, -1.0);
    close(e.route_length(1), 11.0);
}

#[test]
fn reversing_through_a_junction_takes_the_siding() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    // Agent 0, bound east for source B, stands 0.5 m east of m and backs
    // 1 m: 0.5 m to m, then 0.5 m into the siding sd (not s1, ua, ub, sk).
    e.place_agv(0, at(&plant, "s2", 0.5), 1.0).unwrap();
    let mut r = [0.0; 2];
    e.step(&[BACKWARD, HOLD], &mut r).unwrap();
    assert_eq!(e.agvs()[0].pos, at(&plant, "sd", 0.5));
    close(e.route_length(0), 20.5);
    // Forward from there drives back out of the siding towards the goal.
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    assert_eq!(e.agvs()[0].pos, at(&plant, "s2", 0.5));
}

#[test]
fn arrival_loads_and_handling_holds_the_agv_for_two_steps() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    e.place_agv(0, at(&plant, "s2", 18.0), 1.0).unwrap();
    let mut r = [0.0; 2];
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    assert_reward(r[0], IDLE);
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    // Arrived at source B: +0.1 for the pickup.
    assert_reward(r[0], 0.1 + IDLE);
    assert_eq!(e.agvs()[0].task, Task::DropRaw(1));
    assert!(matches!(
        e.agvs()[0].load,
        Load::Raw {
            product: 1,
            created: 0
        }
    ));
    assert_eq!(e.sources()[1].buffer.len(), 0);
    let mut mask = [9u8; 3];
    for _ in 0..2 {
        e.write_mask(0, &mut mask).unwrap();
        assert_eq!(mask, [1, 0, 0]);
        e.step(&[FORWARD, HOLD], &mut r).unwrap();
        assert_eq!(e.agvs()[0].pos, at(&plant, "s2", 20.0));
    }
    e.write_mask(0, &mut mask).unwrap();
    assert_eq!(mask, [1, 1, 0]); // a dead end behind it
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 19.0);
}

#[test]
fn head_on_push_is_a_collision_for_both_and_they_stop_touching() {
    let plant = corridor(1, 1, 1000, 3);
    let mut e = env(&plant, 2);
    // Agent 0 bound east at 2.0, agent 1 bound west at 5.5, on s1.
    e.place_agv(0, at(&plant, "s1", 2.0), 1.0).unwrap();
    e.place_agv(1, at(&plant, "s1", 5.5), -1.0).unwrap();
    let mut r = [0.0; 2];
    e.step(&[FORWARD, FORWARD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 3.0);
    close(e.agvs()[1].pos.offset, 4.5);
    assert_eq!(e.kpis().collisions, 0);
    // 1.5 m apart: agent 0 (lower index) closes to the 1 m contact, then
    // agent 1 cannot move at all; both pushed into an oncoming AGV.
    e.step(&[FORWARD, FORWARD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 3.5);
    close(e.agvs()[1].pos.offset, 4.5);
    close(e.agvs()[0].speed, 0.5);
    close(e.agvs()[1].speed, 0.0);
    assert_reward(r[0], -1.0 + IDLE);
    assert_reward(r[1], -1.0 + IDLE);
    let k = e.kpis();
    assert_eq!((k.collisions, k.blocked_moves), (2, 2));
    assert_eq!(e.waits_for(), vec![Some(1), Some(0)]);
    // Pushing on costs again; holding does not, but the mutual wait goes on.
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    assert_reward(r[0], IDLE); // agent 1 holds: blocked, not a collision
    assert_reward(r[1], IDLE);
    assert_eq!(e.kpis().collisions, 2);
    assert_eq!(e.kpis().deadlock_events, 0); // waited 2 steps
    e.step(&[HOLD, HOLD], &mut r).unwrap();
    // 3 steps of mutual waiting: one deadlock.
    let k = e.kpis();
    assert_eq!((k.deadlock_events, k.deadlock_steps), (1, 1));
    e.step(&[HOLD, HOLD], &mut r).unwrap();
    let k = e.kpis();
    assert_eq!((k.deadlock_events, k.deadlock_steps), (1, 2));
    // One backs off: the cycle is broken.
    e.step(&[BACKWARD, HOLD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 2.5);
    assert_eq!(e.waits_for(), vec![None, None]);
    assert_eq!(e.kpis().deadlock_steps, 2);
}

#[test]
fn driving_into_a_standing_agv_is_blocked_not_a_collision() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    e.place_agv(0, at(&plant, "s1", 4.5), 1.0).unwrap();
    e.place_agv(1, at(&plant, "s1", 6.0), 1.0).unwrap();
    let mut r = [0.0; 2];
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 5.0);
    assert_reward(r[0], IDLE);
    let k = e.kpis();
    assert_eq!((k.collisions, k.blocked_moves), (0, 1));
}

#[test]
fn a_follower_moves_with_the_agv_ahead() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    // Touching, both going east (agent 1 reverses away from its goal).
    e.place_agv(0, at(&plant, "s1", 4.0), 1.0).unwrap();
    e.place_agv(1, at(&plant, "s1", 5.0), -1.0).unwrap();
    let mut r = [0.0; 2];
    e.step(&[FORWARD, BACKWARD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 5.0);
    close(e.agvs()[1].pos.offset, 6.0);
    assert_eq!(e.kpis().blocked_moves, 0);
}

#[test]
fn an_agv_near_a_junction_blocks_the_junction() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    // Agent 1 stands 0.5 m up the unit A spur; agent 0 drives east through
    // m and must stop 1 m (track distance) short of it: 0.5 m before m.
    e.place_agv(1, at(&plant, "ua", 0.5), 1.0).unwrap();
    e.place_agv(0, at(&plant, "s1", 18.8), 1.0).unwrap();
    let mut r = [0.0; 2];
    e.step(&[FORWARD, HOLD], &mut r).unwrap();
    close(e.agvs()[0].pos.offset, 19.5);
    close(e.track_distance(e.agvs()[0].pos, e.agvs()[1].pos), 1.0);
    assert_eq!(e.kpis().blocked_moves, 1);
}

#[test]
fn one_product_from_source_to_sink_with_hand_computed_times() {
    // Only product B: source B (s2 end) -> unit B (10 m spur) -> sink (15 m spur).
    let plant = corridor(0, 1, 1000, 10);
    let mut e = env(&plant, 1);
    e.place_agv(0, at(&plant, "s2", 15.0), 1.0).unwrap();
    let mut r = [0.0];
    let mut events = Vec::new();
    let mut total = 0.0f32;
    for t in 1..=75u32 {
        e.step(&[FORWARD], &mut r).unwrap();
        total += r[0];
        if r[0] > 0.0 {
            events.push((t, (r[0] * 100.0).round() as i32));
        }
    }
    // Pickup at step 5 (5 m), handling 6-7, 30 m to unit B: placed at 37
    // (unit B processes steps 37-46, so only unit A is idle then: +0.1 -
    // 0.01); done at 47 and picked up at 48 (handling 49-50), 25 m to the
    // sink: delivered at step 75.
    assert_eq!(events, vec![(5, 8), (37, 9), (75, 98)]);
    let k = e.kpis();
    assert_eq!((k.pickups, k.placements, k.deliveries), (1, 1, 1));
    assert_eq!(k.mean_lead_time, Some(75.0));
    close(k.throughput_per_hour, 3600.0 / 75.0);
    close(k.unit_utilisation[1], 10.0 / 75.0);
    close(k.unit_utilisation[0], 0.0);
    // 1.2 earned, 0.02 × 75 - 0.01 × 10 idle-unit penalties.
    assert!((total - (1.2 - 1.4)).abs() < 1e-4, "{total}");
    assert!((k.reward - total).abs() < 1e-4);
    assert_eq!(
        e.products_in_plant() as u32 + k.deliveries,
        k.products_created
    );
}

#[test]
fn invalid_actions_and_lengths_are_rejected() {
    let plant = corridor(1, 1, 1000, 10);
    let mut e = env(&plant, 2);
    let mut r = [0.0; 2];
    let err = e.step(&[0, 3], &mut r).unwrap_err();
    assert!(
        err.to_string().contains("action 3 is outside 0..3"),
        "{err}"
    );
    assert!(e.step(&[0], &mut r).is_err());
    assert!(e.place_agv(0, at(&plant, "s1", 25.0), 1.0).is_err());
    e.place_agv(1, at(&plant, "s1", 5.0), 1.0).unwrap();
    assert!(e.place_agv(0, at(&plant, "s1", 5.5), 1.0).is_err());
}

#[test]
fn episodes_end_at_t_max() {
    let plant = corridor(1, 1, 3, 10);
    let mut e = env(&plant, 1);
    let mut r = [0.0];
    assert!(!e.step(&[HOLD], &mut r).unwrap().truncated);
    assert!(!e.step(&[HOLD], &mut r).unwrap().truncated);
    assert!(e.step(&[HOLD], &mut r).unwrap().truncated);
    assert!(e.step(&[HOLD], &mut r).is_err());
    e.reset_next(1);
    assert_eq!((e.time(), e.episode()), (0, 1));
}
